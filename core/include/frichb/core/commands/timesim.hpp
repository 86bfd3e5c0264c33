// `frichb timesim`: the time-integration reference of a scene without cyclic symmetry, at one
// excitation frequency, with the same contact-law plugins stepping the contacts.
//
// The structure is integrated in its modal coordinates q (x = Phi q at the kept DOFs, all the
// provider's modes; no residual flexibility), q'' + C q' + diag(w^2) q = Phi^T (f_ext - G^T f),
// by velocity Verlet with the contact forces of each new position, from rest, until the
// response repeats from one period to the next (relative 1e-8, three periods in a row) or
// `max_periods`. Use it to check a harmonic-balance result; it is far slower.
//
// Two entry points: simulate_in_time() integrates an already loaded and bound Scene and
// returns the result (no files, no logging); integrate_scene() is the verb (commands/verb.hpp):
// it loads the scene of a SceneInput and calls simulate_in_time(). report/timesim_report.hpp
// writes its result.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "frichb/core/commands/verb.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/support/interrupt.hpp"

namespace frichb::core {

struct TimesimOptions {
  double frequency_hz = 0.0;    // excitation frequency f, Hz; must be finite and > 0
  int steps_per_period = 4000;  // time steps per excitation period T = 1/f; >= 1
  int max_periods = 3000;       // periods integrated at most before giving up; >= 1
  // The call's stop token (support/interrupt.hpp), polled after every period: a stop ends the
  // integration there and the result's outcome says so (128 + the signal).
  StopToken stop;
};

// One response node (scene.output.response) over the last integrated period.
struct TimesimNodeResult {
  std::string node;  // name in structure.dofs
  // Maximum over the period of the Euclidean norm of the node's displacement, m.
  double amplitude_m = 0.0;
  // Maximum over the node's DOFs of (max - min) / 2 over the period, m.
  double half_peak_to_peak_m = 0.0;
  // Amplitude of each harmonic of TimesimResult::harmonics (same index), m: the DFT of the
  // period's samples, 2 |c_n| for n > 0 and |c_0| for n = 0, combined over the node's DOFs
  // as sqrt(sum of squares).
  std::vector<double> harmonic_amplitudes_m;
  // samples_m[d][s]: displacement of the node's DOF d (order of structure.dofs) at
  // TimesimResult::time_s[s], m.
  std::vector<std::vector<double>> samples_m;
};

struct TimesimResult {
  // completed, or kExitIncomplete with termination "not_periodic" when max_periods passed.
  Outcome outcome;
  std::filesystem::path scene_file;
  TimesimOptions options;     // as integrated
  bool periodic = false;      // the response repeated (relative 1e-8, three periods in a row)
  int periods = 0;            // periods integrated (max_periods when not periodic)
  double wall_seconds = 0.0;  // wall-clock time of the whole call, s
  // The scene's kept temporal harmonics (scene.harmonic_balance.harmonics, ascending), in the
  // order of TimesimNodeResult::harmonic_amplitudes_m.
  std::vector<int> harmonics;
  // Sample times of the last period, s: (s + 1) T / steps_per_period for s = 0..steps - 1,
  // measured from the period's start (the excitation has the same phase as at t = 0).
  std::vector<double> time_s;
  std::vector<TimesimNodeResult> nodes;  // in the order of scene.output.response
};

// Integrates a bound scene (load_scene + bind_plugins: plugins loaded, params validated) of a
// plain structure (no cyclic symmetry) at options.frequency_hz. The scene is only read. Each
// call makes its own StructureInstance from scene.structure.plugin/values and its own
// contact-law instances from scene.contacts[i].plugin/values; nothing is written or logged.
//
// Returns normally also when max_periods passed without a periodic response (periodic =
// false; the result then holds the last period integrated). Throws:
//  - SceneError for a scene it cannot integrate: a cyclic scene (key path "cyclic"), a
//    provider/scene mismatch or bad DOF found while building the model;
//  - std::invalid_argument for options out of range or a scene whose plugins are not bound;
//  - std::runtime_error (PluginError included) when a plugin fails, the provider's modes are
//    complex, or the integration diverges (non-finite state); what() says which.
//
// Threading: safe to call concurrently on different Scene objects (e.g. loaded separately,
// even with the same Registry): the calls share no mutable state apart from FFTW planning,
// which the core serializes. This relies on the plugins' create() building independent
// instances, as the shipped plugins do (fe_sector's disk cache is written atomically).
// Concurrent calls on the same Scene object are not promised to be safe: building the model
// may take a non-const handle on the scene's shared YAML tree (to locate an error).
TimesimResult simulate_in_time(const Scene& scene, const TimesimOptions& options);

struct TimesimRequest {
  SceneInput scene;
  TimesimOptions integration;
};

// load_bound_scene + simulate_in_time. Throws as simulate_in_time, and SceneError or
// PluginError for a scene it cannot load. Logs the periods integrated.
TimesimResult integrate_scene(const TimesimRequest& request);

}  // namespace frichb::core
