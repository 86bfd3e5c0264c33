// One run of a scene: validate, build the reduced model, trace the response curve, post-
// process, and write response.csv, summary.json, friction loops and plots.
#pragma once

#include <filesystem>
#include <string>

namespace frichb::core {

// Exit codes of the command-line program (docs/getting-started.md).
enum ExitCode : int {
  kExitOk = 0,
  kExitUsage = 1,         // bad command line
  kExitInvalidInput = 2,  // bad scene, unknown plugin, plugin of another ABI, missing file
  kExitIncomplete = 3,    // the curve ended before the sweep's end (outputs written)
  kExitInternal = 4,      // unexpected failure
};

struct RunRequest {
  std::filesystem::path scene_file;
  std::filesystem::path output_directory;  // empty: out/<scene name>
  bool validate_only = false;
};

// Runs the request; logs through spdlog; returns an ExitCode. Never throws.
int run_scene(const RunRequest& request);

const char* version();

}  // namespace frichb::core
