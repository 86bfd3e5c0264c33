// Studies: a scene run over a grid or list of values of any of its numeric scalars.
//
//   study:
//     sweep:
//       - {path: contacts.shroud.params.normal_load, values: [0, 5, 10, 25]}
//       - {path: excitation.0.amplitude, from: 1, to: 100, count: 5, spacing: log}
//       - {path: contacts.shroud.params.gap, values: [1e-4, 0, 0]}
//       - {path: contacts.shroud.params.normal_load, values: [0, 5, 10], with_previous: true}
//     combine: grid        # every combination (first sweep slowest); zip: i-th with i-th
//                          # (with_previous: that sweep is zipped with the one before it
//                          # and the pair is one axis of the grid)
//     parallel: auto       # threads per process: auto (every core), serial, or a count
//
// A path addresses a key of the scene as written: map keys separated by '.', list entries by
// their index (`excitation.0.amplitude`, or `excitation[0].amplitude`, which YAML's flow
// style `{path: ...}` needs quoted), and an entry of `contacts` by its name (`contacts.shroud`
// is the contact named shroud). The last key may be absent from the scene (its default is then
// overridden), and may index a number list (`structure.params.masses.1`).
//
// Every run is validated before any computes: a value out of its key's range is an error
// naming the study entry and the run. Runs are independent and deterministic: the same run
// gives the same files whether it ran alone, on a thread, or on another MPI rank. The verb
// shape: commands/verb.hpp; the writer of the index: report/study_report.hpp; each run is
// written by the request's RunWriter into runs/NNNN/ (as `frichb run`).
#pragma once

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/commands/verb.hpp"
#include "frichb/core/scene/scene.hpp"

namespace frichb::core {

// The processes of a study: one (serial) by default; MPI ranks when the program was started
// by mpirun (core/app). Every member runs the same study; rank 0 writes the index.
class StudyCommunicator {
 public:
  virtual ~StudyCommunicator() = default;
  virtual int rank() const { return 0; }
  virtual int size() const { return 1; }
  // Rank 0 receives every rank's text in rank order; the other ranks receive nothing.
  virtual std::vector<std::string> gather(const std::string& text) { return {text}; }
  // Every rank receives rank 0's text.
  virtual std::string broadcast(const std::string& text) { return text; }
};

struct SweepSpec {
  std::string path;            // as written
  std::vector<double> values;  // the values, generated when given as from/to/count
  bool with_previous = false;  // varies together with the previous sweep (same length)
  bool log_spacing = false;    // generated with `spacing: log`
  std::string name;            // short name and unit for plots (sweep_quantity)
  std::string unit;
};

// The short name and unit of a swept key, for plot axes and legends: the name is the path's
// last key (`normal_load`; an entry of a number list as `masses[1]`), the unit the one the
// schema validating the key gives (a contact's law for contacts.<name>.params.<key>, the
// structure's provider for structure.params.<key>, the core's section schemas otherwise); ""
// when dimensionless, unknown (a scene variable) or the plugin is not bound.
struct SweepQuantity {
  std::string name;
  std::string unit;
};
SweepQuantity sweep_quantity(const Scene& scene, const std::string& path);

struct StudySpec {
  std::vector<SweepSpec> sweeps;
  bool zip = false;  // false: grid (cartesian product, the first sweep varying slowest)
  int threads = 0;   // 0: one per core
  std::string node;  // node whose curves are overlaid and peaks plotted

  // The axes of the grid: consecutive sweeps that vary together (all of them with zip; a
  // sweep and the following ones marked with_previous otherwise), as indices into sweeps.
  std::vector<std::vector<std::size_t>> axes() const;
};

// One run of a study: its values (one per sweep) and its scene, bound to plugins.
struct StudyRun {
  std::size_t index = 0;
  std::string id;  // "0000", "0001", ... (the folder under runs/)
  std::vector<double> values;
  Scene scene;
};

// Parses and checks scene.root["study"] (throws SceneError naming file:line:col and key).
StudySpec load_study(const Scene& scene);

// Builds every run of the study: the scene re-read from its file, each value set, loaded and
// bound to plugins from `registry`, and each contact law instantiated once (so a value its
// law refuses is caught here). Throws SceneError naming the study entry and the run.
std::vector<StudyRun> prepare_study_runs(const Scene& scene, const StudySpec& study,
                                         const Registry& registry);

struct StudyRequest {
  SceneInput scene;
  int threads = -1;  // -1: the scene's study.parallel
  // Called once, on rank 0, after every rank has validated the study and before any run:
  // returns the folder the runs are written into (the command line stages the output folder
  // and returns its runs/). Required.
  std::function<std::filesystem::path()> stage_runs;
  // Writes each run into <runs folder>/NNNN as it finishes (report/run_report.hpp's
  // write_run_folder). Required.
  RunWriter write_run;
  // The call's stop token (support/interrupt.hpp): a stop ends the runs under way at their next
  // step, starts no other, and the result's outcome says so (128 + the signal).
  StopToken stop;
};

// One run of a study in the index.
struct StudyRunRow {
  std::string id;              // "0000", ...: its folder under runs/
  std::vector<double> values;  // one per sweep
  RunOutcome outcome;
};

struct StudyResult {
  // completed; kExitIncomplete (termination "runs_incomplete") when a run ended before the end
  // of its sweep or failed (its row says why); kExitInvalidInput when a rank could not
  // validate the study, or the code of a runs folder that could not be staged (logged, no
  // rows); 128 + signal when interrupted (no rows).
  Outcome outcome;
  bool leader = true;  // this process holds the rows (rank 0); the other ranks hold none
  std::filesystem::path scene_file;
  std::string scene_name;
  FrequencyUnit unit = FrequencyUnit::kHz;  // of the scene's sweep
  std::vector<std::string> response;        // the scene's output.response nodes
  // A mistuned disk's study: the sector's response nodes, whose amplification each run gives
  // (RunOutcome::amplification) and the study sums up (amplification_statistics).
  std::vector<std::string> mistuned_nodes;
  bool plots = true;                                        // the scene's output.plots
  bool stability = false;                                   // the scene's output.stability
  AmplitudeAxis amplitude_axis = AmplitudeAxis::automatic;  // the scene's output.amplitude_axis
  StudySpec study;
  std::vector<StudyRunRow> runs;  // by run index
  int processes = 1;
  int threads = 1;  // per process
  int failed_runs = 0;
  // The run with the lowest peak of study.node among those that reached the end of their
  // sweep (runs.size() when none did), and that peak, m.
  std::size_t optimum = 0;
  double optimum_amplitude_m = 0.0;
  double wall_seconds = 0.0;
};

// The amplification factors of a mistuned disk's study at one sector node, over the runs that
// reached the end of their sweep with a tuned peak and a blade's peak: their count, mean, 95th and
// 99th percentiles (linear interpolation between order statistics, as numpy's default), the largest
// and the run that gave it (runs.size() when none).
struct AmplificationStatistics {
  std::string node;
  std::size_t count = 0;
  double mean = 0, p95 = 0, p99 = 0, largest = 0;
  std::size_t worst_run = 0;
};
std::vector<AmplificationStatistics> amplification_statistics(const StudyResult& result);

// Runs the study of a scene on `communicator`'s processes (run i on rank i mod size, each
// rank's share on its threads), every run handed to request.write_run as it ends; rank 0
// gathers the rows. Never throws: a study that does not validate on some rank logs why and
// is refused on every rank.
StudyResult run_study(const StudyRequest& request, StudyCommunicator& communicator);

// The core section schemas of `study` (for the generated scene reference).
std::vector<CoreSection> study_schemas();

}  // namespace frichb::core
