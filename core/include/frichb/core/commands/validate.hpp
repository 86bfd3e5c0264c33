// `frichb validate`: every check `frichb run` (and `frichb study`, run by run) makes before its
// first Newton iteration, and what the scene would load. The verb shape: commands/verb.hpp;
// the writer: report/validate_report.hpp.
#pragma once

#include <string>
#include <vector>

#include "frichb/core/commands/verb.hpp"
#include "frichb/core/scene/scene.hpp"

namespace frichb::core {

struct ValidateOptions {
  SceneInput scene;
};

struct ValidationResult {
  Outcome outcome;
  std::filesystem::path scene_file;
  std::string structure, structure_version;  // the provider's name and version
  // One entry per contact ("name (law version)"); a patch once, as its entry's name and its
  // pair count ("tip (patch of 16 node pairs, coupled_3d 1.2.0)").
  std::vector<std::string> contacts;
  std::vector<std::filesystem::path> plugin_files;  // every library the run loads, each once
  std::size_t study_runs = 0;  // runs of the scene's study: section, each checked (0: none)
};

// Loads and binds the scene, checks it as prepare_run does (structure, model, memory,
// continuation setup) and, when it has a study: section, every run of the study. Throws
// SceneError (a study run's error names the run) or PluginError. Writes nothing.
ValidationResult validate_scene(const ValidateOptions& options);

}  // namespace frichb::core
