// `frichb convergence`: how much accuracy each harmonic-balance setting buys for its cost.
//
// The scene is run at every combination of kept harmonics H, samples per period N (with
// N >= 2H + 1) and trace oversampling o. Each run's peak amplitude and peak frequency (of
// the first output.response node, refined as in `frichb run`) are compared with those of
// the finest setting (largest H, N and o) and, for a scene without cyclic symmetry, with
// the time-integration reference (simulate_in_time at the finest setting's peak
// frequency). Runs are serial by default so that their wall times are comparable.
//
// The verb shape: commands/verb.hpp; the writer: report/convergence_report.hpp. Each
// setting's run is handed, as it finishes, to the request's RunWriter (the command line
// writes it into DIR/runs/H<H>_N<N>_o<o>/).
#pragma once

#include <cmath>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/commands/verb.hpp"
#include "frichb/core/scene/scene.hpp"

namespace frichb::core {

struct ConvergenceRequest {
  SceneInput scene;
  std::vector<int> harmonics = {1, 3, 5, 7, 10, 15};  // largest kept harmonic H
  std::vector<int> samples = {64, 128, 256, 512, 1024, 2048};
  std::vector<int> oversampling = {1, 4};
  bool time_integration = true;  // compare with simulate_in_time (plain structures)
  int timesim_steps_per_period = 8000;
  // Called once the request and the scene are valid, before the first setting: the folder
  // each setting's run is written into (<folder>/<setting id>), by write_run. Either empty:
  // the runs are not written.
  std::function<std::filesystem::path()> stage_runs;
  RunWriter write_run;
  // The call's stop token (support/interrupt.hpp): a stop ends the setting under way at its
  // next step (and the time integration after its period), starts no other, and the result's
  // outcome says so (128 + the signal).
  StopToken stop;
};

// One harmonic-balance setting: largest kept harmonic H (the kept ones follow the scene's
// pattern: odd only, from 0, or from 1), samples per period N and trace oversampling o.
struct ConvergenceSetting {
  int max_harmonic = 0, samples = 0, oversampling = 1;
  std::vector<int> harmonics;
  std::string id;  // "H<H>_N<N>_o<o>"
};

// A setting's run and its relative errors (NaN where there is nothing to compare).
struct ConvergenceRow {
  ConvergenceSetting setting;
  RunOutcome outcome;
  double amplitude_m = NAN;                             // peak amplitude of the node
  double frequency_hz = NAN;                            // at the peak
  double amplitude_error = NAN, frequency_error = NAN;  // against the reference (0 for it)
  double amplitude_error_vs_timesim = NAN;              // against the time integration
};

// The time-integration reference at the reference setting's peak frequency.
struct ConvergenceTimesim {
  bool run = false;  // false: not asked, a cyclic scene, no peak, or it failed (warned)
  double frequency_hz = NAN;
  double amplitude_m = NAN;  // of the node, over the last period integrated
  bool periodic = false;
  int periods = 0;
  int steps_per_period = 0;
  double wall_seconds = 0.0;
  // The amplitude the settings are compared with: NaN unless the response became periodic.
  double compared() const { return run && periodic ? amplitude_m : NAN; }
};

struct ConvergenceResult {
  // kExitIncomplete (termination "settings_incomplete") when a setting's curve ended early
  // (its row says why); 128 + signal when interrupted between settings.
  Outcome outcome;
  std::filesystem::path scene_file;
  std::string scene_name;
  std::string node;                  // the first output.response node
  std::vector<ConvergenceRow> rows;  // coarse to fine; the reference (the finest) last
  ConvergenceTimesim timesim;
  int incomplete_settings = 0;
  std::vector<int> oversampling;  // the factors run, ascending (one plot series each)
  bool plots = true;              // the scene's output.plots
};

// Runs the scene at every valid setting, serially, and the time-integration reference.
// Throws SceneError or PluginError for a scene it cannot load, and SceneError for a request
// without a valid finest setting or a scene without a response node. Each setting's run is
// handed to request.write_run (when set) into <request.stage_runs()>/<setting id>; a setting
// the scene refuses is a row with termination invalid_input.
ConvergenceResult study_convergence(const ConvergenceRequest& request);

}  // namespace frichb::core
