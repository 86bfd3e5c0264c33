// One run of a scene, in stages: prepare (build the structure and the model, check them,
// derive the continuation options), find the start point, trace, tabulate, solve the friction
// loops (model/response_curve.hpp), report (report/run_report.hpp). run_bound_scene runs them
// all and writes response.csv, summary.json, friction loops and plots; a program that wants the
// results in memory calls prepare_run and the stages itself.
#pragma once

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "frichb/core/model/continuation_setup.hpp"
#include "frichb/core/model/response_curve.hpp"
#include "frichb/core/support/exit_codes.hpp"

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

// The first stage of a run: the structure and the model built (plugin parameters, matrix files,
// DOF indices, frames, sector counts, modal bases), the memory the AFT tables and the Newton
// matrices need checked against the machine's, a static harmonic refused on a structure with a
// rigid-body mode, and the continuation options derived (derive_continuation: scaling, bounds,
// resonance bands). `contact_threads`: threads tracing the contacts within one evaluation (0:
// one per core). Throws SceneError located in the scene (or the file a value came from).
// The model refers to the structure: keep them together (members destroyed model first).
struct PreparedRun {
  std::unique_ptr<StructureInstance> structure;
  std::unique_ptr<HarmonicBalanceModel> model;
  ContinuationSetup setup;
};
PreparedRun prepare_run(const Scene& scene, int contact_threads = 0);

// Every check `run_bound_scene` makes before its first Newton iteration (prepare_run, its
// result dropped). For `frichb validate`.
void check_run_start(const Scene& scene);

}  // namespace frichb::core
