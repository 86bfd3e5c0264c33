#include "frichb/core/commands/catalog.hpp"

#include "frichb/core/commands/loop.hpp"
#include "frichb/core/commands/study.hpp"

namespace frichb::core {

namespace {

std::vector<std::shared_ptr<const LoadedPlugin>> every_plugin(const Registry& registry) {
  std::vector<std::shared_ptr<const LoadedPlugin>> plugins;
  for (const auto& name : registry.names()) plugins.push_back(registry.load_any(name));
  return plugins;
}

}  // namespace

std::vector<CoreSection> scene_sections() {
  auto sections = core_schemas();
  for (auto& section : study_schemas()) sections.push_back(std::move(section));
  return sections;
}

PluginsResult list_plugins(const PluginsOptions& /*options*/) {
  const Registry registry(Registry::default_search_path());
  PluginsResult result;
  for (const auto& folder : registry.search_path()) {
    std::error_code ec;
    result.search_path.push_back({folder, std::filesystem::is_directory(folder, ec)});
  }
  result.plugins = every_plugin(registry);
  return result;
}

DescribeResult describe(const DescribeOptions& options) {
  DescribeResult result;
  if (options.name == "scene") {
    result.sections = scene_sections();
    return result;
  }
  const Registry registry(Registry::default_search_path());
  result.plugin = registry.load_any(options.name);
  return result;
}

ReferenceResult scene_reference(const ReferenceOptions& /*options*/) {
  ReferenceResult result;
  result.scene_sections = scene_sections();
  result.loop_sections = loop_schemas();
  const Registry registry(Registry::default_search_path());
  const auto plugins = every_plugin(registry);
  for (const auto kind : {FRICHB_KIND_STRUCTURE, FRICHB_KIND_CONTACT_LAW})
    for (const auto& plugin : plugins)
      if (plugin->kind() == kind) result.plugins.push_back(plugin);
  return result;
}

}  // namespace frichb::core
