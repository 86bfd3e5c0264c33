// `frichb plugins`, `frichb describe` and `frichb reference`: what the plugins on the search path
// and the core's sections accept. The verb shape: commands/verb.hpp; the writers:
// report/catalog_report.hpp.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "frichb/core/commands/verb.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/scene/scene.hpp"

namespace frichb::core {

// A folder of the plugin search path.
struct SearchFolder {
  std::filesystem::path path;
  bool exists = false;
};

// --- plugins: every plugin on the default search path (Registry::default_search_path).
struct PluginsOptions {};
struct PluginsResult {
  Outcome outcome;
  std::vector<SearchFolder> search_path;
  // Loaded, in name order: each keeps its library loaded (descriptor, schema and file).
  std::vector<std::shared_ptr<const LoadedPlugin>> plugins;
};
// Throws PluginError for a plugin that cannot be loaded (another ABI, a broken descriptor).
PluginsResult list_plugins(const PluginsOptions& options);

// --- describe: one plugin's parameter table, or ("scene") the core sections' tables.
struct DescribeOptions {
  std::string name;  // a plugin name, or "scene"
};
struct DescribeResult {
  Outcome outcome;
  std::shared_ptr<const LoadedPlugin> plugin;  // null for "scene"
  std::vector<CoreSection> sections;           // the scene's and the study's sections ("scene")
};
// Throws PluginError for an unknown name (listing the known ones and the closest).
DescribeResult describe(const DescribeOptions& options);

// --- reference: every schema, for the generated scene reference.
struct ReferenceOptions {};
struct ReferenceResult {
  Outcome outcome;
  std::vector<CoreSection> scene_sections;  // the core's and the study's sections
  std::vector<CoreSection> loop_sections;   // the loop input's
  // Every plugin on the default search path, structure providers first, each in name order.
  std::vector<std::shared_ptr<const LoadedPlugin>> plugins;
};
ReferenceResult scene_reference(const ReferenceOptions& options);

// The core sections and the study's, in the order the reference lists them.
std::vector<CoreSection> scene_sections();

}  // namespace frichb::core
