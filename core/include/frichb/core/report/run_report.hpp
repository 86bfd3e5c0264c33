// The report of a response-curve run: response.csv, the friction loops (loops/*.csv, their
// force harmonics, plots), the contact states, response.png and summary.json, from a RunResult
// (commands/run.hpp). One place decides what each file holds, for frichb run and for every
// verb that runs scenes (study members, convergence runs) through it.
//
// Units: summary.json and the CSV columns say theirs (frequency in the scene's unit where a key
// has no suffix; _hz, _rad_s, _m, _N, _J otherwise). Failure: writes throw OutputError
// (support/output.hpp); nothing else is thrown. Threading: reads its inputs; one report per
// output folder.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/model/continuation_setup.hpp"
#include "frichb/core/model/response_curve.hpp"
#include "frichb/core/support/output.hpp"

namespace frichb::core {

// The top-level names write_run writes: the output folder's managed names.
std::vector<std::string> run_outputs();
// Writes every file of the run into the staged folder `out` (the caller commits), and logs
// the run's outputs at info level (debug when result.options.quiet).
void write_run(const RunResult& result, StagedOutput& out);
// write_run into `folder`, staged and committed: the RunWriter of study and convergence
// members.
void write_run_folder(const RunResult& result, const std::filesystem::path& folder);
// run_member with write_run_folder: trace a bound scene and write it into `folder`. Never
// throws.
RunOutcome run_bound_scene(const Scene& scene, const std::filesystem::path& folder,
                           const RunOptions& options = {});

// Everything a run's report reads. References: the caller keeps them alive during the calls.
struct RunRecord {
  const Scene& scene;
  const HarmonicBalanceModel& model;
  const ContinuationSetup& setup;
  const ContinuationSummary& summary;
  const ResponseTable& table;
  const std::vector<FrictionLoop>& loops;
};

// Writes response.csv, every friction loop (loops/<contact>_<frequency><unit>_<crossing>.csv
// and _harmonics.csv) and, when `plots`, their gnuplot scripts and PNGs and response.png into
// `out`. Returns the friction_loops entries of summary.json (file names relative to the
// output folder, energy per cycle, force harmonic amplitudes).
nlohmann::json write_curve_files(StagedOutput& out, const RunRecord& run, bool plots);

// A friction loop's summary.json entry without its files: contact, frequency, crossing, force
// harmonic amplitudes per axis, dissipated energy per cycle, trace passes (write_curve_files
// adds `file` and `harmonics_file`).
nlohmann::json friction_loop_entry(const RunRecord& run, const FrictionLoop& loop);

// Writes, for each crossing of each output.contact_states_at frequency (the traces of
// solve_contact_traces, every contact of a crossing in a row), contact_states/<frequency><unit>_
// <crossing>.csv: per contact its scene entry, name, sides, the place of a patch pair on its
// face (m, along its tangents from the face's centroid) and area (m^2), and its shares of the
// period stuck, slipping and open (slip_shares); with `plots`, a plot of each patch's face
// coloured by the share stuck. Returns the contact_states entries of summary.json.
nlohmann::json write_contact_states(StagedOutput& out, const RunRecord& run,
                                    const std::vector<FrictionLoop>& states, bool plots);

// The summary.json document of a run: termination and suggestion, curve statistics, the
// profile, resonance bands, peaks, scaling, plugins, the validated scene, `friction_loops`
// (from write_curve_files), `timing` (wall_time_s), and `study_context` under "study" when
// not null. Command-line overrides are recorded with their types.
nlohmann::json run_summary(const RunRecord& run, const nlohmann::json& friction_loops,
                           const nlohmann::json& timing, const nlohmann::json& study_context);
// summary.json's `mistuning` section of a mistuned disk's run: the deviations, per response
// node every blade's peak, the tuned peak, the amplification and the worst blade, and how the
// tuned run ended.
nlohmann::json mistuning_json(const MistuningComparison& mistuning);

}  // namespace frichb::core
