// One run of a scene, in stages: prepare (build the structure and the model, check them,
// derive the continuation options), find the start point, trace, tabulate, solve the friction
// loops and contact states (model/response_curve.hpp). trace_scene runs them all and returns a
// RunResult; report/run_report.hpp writes it (response.csv, summary.json, friction loops,
// plots). run_scene is the verb `frichb run` (commands/verb.hpp): the scene read from a
// SceneInput, then trace_scene.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "frichb/core/commands/verb.hpp"
#include "frichb/core/model/continuation_setup.hpp"
#include "frichb/core/model/response_curve.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/support/exit_codes.hpp"
#include "frichb/core/support/interrupt.hpp"

namespace frichb::core {

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
  // The call's stop token (support/interrupt.hpp): a stop requested on it ends the trace at
  // its next step and the result's outcome says so (128 + the signal); write_run_folder then
  // refuses to commit.
  StopToken stop;
  // Called on the computing thread after each accepted point of the curve, with its index and
  // frequency in Hz (empty: not called). Must not throw; a caller that wants to end the run
  // requests a stop.
  std::function<void(std::size_t point, double frequency_hz)> on_point;
  // A mistuned disk's run also traces the tuned disk for every blade's amplification
  // (RunResult::mistuning); a caller that needs only the curve turns it off.
  bool compare_with_tuned = true;
};

// A mistuned disk's amplification at one response node of the sector (MistuningComparison,
// in brief).
struct Amplification {
  std::string node;   // the sector's node name
  double factor = 0;  // the worst blade's peak over the tuned peak (0: a peak is missing)
  int worst_blade = -1;
};

// What a run produced, in brief: one row of a study or a convergence study.
struct RunOutcome {
  int exit_code = 4;            // an ExitCode
  std::string termination;      // continuation termination ("reached_end", "max_points", ...),
                                // or "invalid_input" / "internal_error" before any tracing
  std::string message;          // why it ended (or the error)
  std::size_t points = 0;       // points on the response curve
  long unknowns = 0;            // harmonic-balance unknowns (0 when the model was not built)
  std::vector<NodePeak> peaks;  // one per output.response node, in scene order
  // A mistuned disk's (the scene's `mistuning`), per sector response node; empty otherwise.
  std::vector<Amplification> amplification;
  double wall_seconds = 0.0;  // set-up, continuation, post-processing and outputs
  bool wrote_output = false;  // the output folder holds this run's files
};

// The first stage of a run: the structure and the model built (plugin parameters, matrix files,
// DOF indices, frames, sector counts, modal bases), the memory the AFT tables and the Newton
// matrices need checked against the machine's, a static harmonic refused on a structure with a
// rigid-body mode, and the continuation options derived (derive_continuation: scaling, bounds,
// resonance bands). `contact_threads`: threads tracing the contacts within one evaluation (0:
// one per core). Throws SceneError located in the scene (or the file a value came from).
// The model refers to the structure: keep them together (members destroyed model first).
struct PreparedRun {
  std::unique_ptr<StructureModel> structure;
  std::unique_ptr<HarmonicBalanceModel> model;
  ContinuationSetup setup;
  std::vector<std::string> warnings;  // logged as they arose (too few samples per harmonic)
};
PreparedRun prepare_run(const Scene& scene, int contact_threads = 0);

// A Newton matrix whose condition estimate exceeds this has lost 10 of 16 digits: warned.
inline constexpr double kIllConditioned = 1e10;

// What a user can change when the curve ends early, by reason ("" when it reached the end).
std::string suggestion(const ContinuationSummary& summary, const Scene& scene);

// Every check `trace_scene` makes before its first Newton iteration (prepare_run, its
// result dropped). For `frichb validate`.
void check_run_start(const Scene& scene);

// A mistuned disk's run (the scene's `mistuning`, docs/mistuning.md): each response node's peak
// on every blade against the tuned disk's, the tuned disk traced by its cyclic sector (the
// scene without `mistuning`, MistuningSpec::tuned) over the same sweep.
struct BladePeaks {
  std::string node;                  // the sector's node name (blade j's is node@j)
  std::vector<double> amplitude_m;   // per blade; 0 where the blade's curve has no peak
  std::vector<double> frequency_hz;  // per blade; 0 where it has none
  // Per blade: the peak was solved (not the highest traced point, NodePeak::refined).
  std::vector<bool> solved;
  double tuned_amplitude_m = 0, tuned_frequency_hz = 0;  // 0: the tuned curve has no peak
  // The worst blade's peak over the tuned peak (0 when either is missing), and that blade (-1).
  double amplification = 0;
  int worst_blade = -1;
};
struct MistuningComparison {
  std::vector<double> deviations;  // blade j's stiffness factor is 1 + deviations[j]
  std::vector<BladePeaks> nodes;   // in output.response order
  std::string tuned_termination;   // the tuned curve's ("reached_end", "max_points", ...)
  std::size_t tuned_points = 0;
  double tuned_seconds = 0;  // wall time of the tuned run
};

// The results of one run, as report/run_report.hpp writes them. Move-only (it owns the model).
struct RunResult {
  // completed when the curve reached the end of the sweep; kExitIncomplete with the
  // continuation's termination ("max_points", "step_too_small", ...) and message when it
  // ended early (its results are written all the same); 128 + signal, termination
  // "interrupted", when a stop on options.stop ended it (nothing to write).
  Outcome outcome;
  // The scene and its plugins when run_scene read them (null when the caller's scene was
  // traced: the caller keeps it alive while the result lives).
  std::shared_ptr<const BoundScene> bound;
  const Scene* scene = nullptr;      // the scene traced
  RunOptions options;                // as run
  PreparedRun prepared;              // structure, model, continuation setup
  ContinuationSummary summary;       // the curve's points and how it ended
  ResponseTable table;               // response.csv's rows, the peaks, turning points
  std::vector<FrictionLoop> loops;   // at output.friction_loops_at, every crossing
  std::vector<FrictionLoop> states;  // at output.contact_states_at, every crossing
  std::vector<NodePeak> peaks;       // of the output.response nodes that have one, in order
  std::optional<MistuningComparison> mistuning;  // a mistuned disk's, against the tuned one
  // Wall-clock times, s: set-up, continuation, peaks and loops, and the whole call.
  double setup_seconds = 0.0, continuation_seconds = 0.0, post_seconds = 0.0, wall_seconds = 0.0;
};

// Runs every stage on a bound scene (load_bound_scene, or load_scene + bind_plugins): logs
// progress (at debug level when options.quiet), writes nothing. Throws SceneError (located in
// the scene) for a scene prepare_run refuses, std::runtime_error for a failure of the model
// or a plugin. Safe to call concurrently from several threads on different Scene objects
// (each call creates its own structure and contact-law instances).
RunResult trace_scene(const Scene& scene, const RunOptions& options = {});

// `frichb run`: the scene read from `scene` (load_bound_scene), then trace_scene. Throws as
// both.
RunResult run_scene(const SceneInput& scene, const RunOptions& options = {});

// Writes a run's results into a folder: report/run_report.hpp's write_run_folder, handed down
// by the caller of a verb that runs many scenes (the verbs compute, the report writes).
using RunWriter = std::function<void(const RunResult& result, const std::filesystem::path& folder)>;

// One member of a study or a convergence study: trace_scene, then `write` into `folder`
// unless a stop ended it. Never throws: a scene prepare_run refuses is termination
// "invalid_input" (exit code 2), a folder that cannot be written "output_error" (2 or 5), any
// other failure "internal_error" (4), each logged at error level.
RunOutcome run_member(const Scene& scene, const std::filesystem::path& folder,
                      const RunOptions& options, const RunWriter& write);

}  // namespace frichb::core
