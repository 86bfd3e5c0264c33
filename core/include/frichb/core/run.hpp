// One run of a scene: validate, build the reduced model, trace the response curve, post-
// process, and write response.csv, summary.json, friction loops and plots.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "frichb/core/exit_codes.hpp"

namespace frichb::core {

struct RunRequest {
  std::filesystem::path scene_file;
  std::filesystem::path output_directory;  // empty: out/<scene name>
  bool validate_only = false;
};

// Runs the request; logs through spdlog; returns an ExitCode. Never throws.
int run_scene(const RunRequest& request);

struct Scene;

struct RunOptions {
  // Routine progress (setup, points, outputs written) at debug level instead of info: for
  // the members of a study, whose progress the study reports. Warnings and errors stay.
  bool quiet = false;
  // Overrides the scene's output.plots when set to 0 or 1 (-1: the scene decides).
  int plots = -1;
  // Merged into summary.json under "study" when not null (the run's place in a study).
  nlohmann::json study_context;
  // Threads tracing the contacts within one evaluation (0: one per core); a study running
  // several scenes at once gives each the cores it leaves.
  int contact_threads = 0;
};

// The peak amplitude of one response node. The highest point of the traced curve is refined
// by a golden-section search over the frequency between its two neighbours (each probe a
// fixed-frequency Newton solve), unless the curve turns there or a probe fails.
struct NodePeak {
  std::string node;
  double amplitude_m = 0.0;
  double omega_rad_s = 0.0;
  bool refined = false;
};

// What a run produced, for callers that run many scenes (studies, convergence reports).
struct RunOutcome {
  int exit_code = 4;            // an ExitCode
  std::string termination;      // continuation termination ("reached_end", "max_points", ...),
                                // or "invalid_input" / "internal_error" before any tracing
  std::string message;          // why it ended (or the error)
  std::size_t points = 0;       // points on the response curve
  std::vector<NodePeak> peaks;  // one per output.response node, in scene order
  double wall_seconds = 0.0;    // set-up, continuation, post-processing and outputs
  bool wrote_output = false;    // the output folder holds this run's files
};

// Runs a bound scene (load_bound_scene or load_scene + bind_plugins) and writes its outputs
// into `output_directory` (staged: nothing is left there if the run fails before writing).
// Never throws. Safe to call concurrently from several threads on different Scene objects
// (each call creates its own structure and contact-law instances).
RunOutcome run_bound_scene(const Scene& scene, const std::filesystem::path& output_directory,
                           const RunOptions& options = {});

// Every check `run_bound_scene` makes before its first Newton iteration: the structure and
// the model built (plugin parameters, matrix files, DOF indices, frames, sector counts, modal
// bases), the contact-free response over the sweep, the memory the scene needs. Throws
// SceneError located in the scene (or the file a value came from). For `frichb validate`.
void check_run_start(const Scene& scene);

}  // namespace frichb::core
