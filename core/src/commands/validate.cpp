#include "frichb/core/commands/validate.hpp"

#include <algorithm>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/commands/study.hpp"

namespace frichb::core {

ValidationResult validate_scene(const ValidateOptions& options) {
  const BoundScene bound = load_bound_scene(options.scene);
  const Scene& scene = bound.scene;
  ValidationResult result;
  result.scene_file = scene.file;
  if (scene.root["study"]) {
    const auto runs = prepare_study_runs(scene, load_study(scene), *bound.registry);
    for (const auto& run : runs) {
      try {
        check_run_start(run.scene);
      } catch (const SceneError& e) {
        throw SceneError(e.file(), e.line(), e.column(), e.key_path(),
                         e.message() + " (study run " + run.id + ")");
      }
    }
    result.study_runs = runs.size();
  }
  check_run_start(scene);
  result.structure = scene.structure.plugin->name();
  result.structure_version = scene.structure.plugin->descriptor().version;
  const ContactPatch* listed_patch = nullptr;
  for (const auto& c : scene.contacts) {
    if (c.patch && c.patch.get() == listed_patch) continue;
    listed_patch = c.patch.get();
    const std::string name = c.patch ? c.name.substr(0, c.name.rfind('.')) + " (patch of " +
                                           std::to_string(c.patch->pairs.size()) + " node pairs, "
                                     : c.name + " (";
    result.contacts.push_back(name + c.plugin->name() + " " + c.plugin->descriptor().version + ")");
  }
  // Loading a plugin runs its code: the files the run loads, each once.
  result.plugin_files = {scene.structure.plugin->file()};
  for (const auto& c : scene.contacts)
    if (std::find(result.plugin_files.begin(), result.plugin_files.end(), c.plugin->file()) ==
        result.plugin_files.end())
      result.plugin_files.push_back(c.plugin->file());
  return result;
}

}  // namespace frichb::core
