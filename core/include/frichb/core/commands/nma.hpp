// `frichb nma`: a nonlinear mode of a scene's structure with its contacts, by the extended
// periodic motion concept (model/nonlinear_modes.hpp): the mode's frequency and damping ratio
// against its amplitude, continued in the log of the amplitude from where the contacts stick.
// The verb shape: commands/verb.hpp; the writer: report/nma_report.hpp.
#pragma once

#include <Eigen/Dense>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "frichb/core/commands/verb.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/support/interrupt.hpp"

namespace frichb::core {

struct NmaOptions {
  SceneInput scene;
  // The mode: 1 for the structure's lowest retained mode at harmonic 1 (for a cyclic scene, of
  // the harmonic index the scene's engine order excites), ascending frequency.
  int mode = 1;
  // The range of the mode's amplitude a (its fundamental modal coordinate, m sqrt(kg): the
  // modes are mass-normalised), from < to, both > 0. nullopt: the amplitudes at which the
  // start mode's largest contact motion is 1 nm and 1 mm (six decades, from stuck to well
  // beyond macroslip for contacts whose stick limit lies between).
  std::optional<double> from, to;
  int max_points = 500;
  // The call's stop token: a stop ends the continuation at its next step (outcome 128 +
  // signal, nothing to write).
  StopToken stop;
};

// One point of the backbone.
struct NmaPoint {
  double amplitude = 0.0;      // a, m sqrt(kg)
  double frequency_hz = 0.0;   // the mode's frequency w / 2 pi at a
  double damping_ratio = 0.0;  // xi / (2 w): structural damping and friction together
  double xi = 0.0;             // the damping shift, rad/s
  // The energy the contacts dissipate per cycle at a, J (the closed integral of f . du).
  double contact_energy_j = 0.0;
  // The shares of the contacts' samples (all contacts together, each sample once) stuck,
  // slipping and open (periodic_trace.hpp's slip_shares), summing to 1.
  double stuck = 0.0, slipping = 0.0, open = 0.0;
  // The largest amplitude of a contact component's relative motion at harmonic 1, m.
  double contact_motion_m = 0.0;
  // The contacts' relative motion in harmonics n >= 2 against n >= 1:
  // sqrt(sum_{n>=2} |U_n|^2 / sum_{n>=1} |U_n|^2).
  double higher_harmonics = 0.0;
  int newton_iterations = 0;
  // The retained modes' modal coordinates at harmonic 1 (complex amplitudes, m sqrt(kg); mode
  // K's is a): the mode's shape at this amplitude, for the forced response's synthesis.
  Eigen::VectorXcd modal_coordinates;
  Eigen::VectorXd y;  // the problem's unknowns (V, w, xi, ln a): NonlinearModeProblem
};

struct NmaResult {
  Outcome outcome;
  std::filesystem::path scene_file;
  bool plots = true;  // the scene's output.plots
  int mode = 1;
  int harmonic_index = 0;  // the structure's harmonic index of harmonic 1
  // The mode's natural frequency without contacts (the structure's), and the undamped natural
  // frequency of the start: the structure's retained modes with each contact's tangent at
  // rest (the stuck contacts), Hz.
  double free_frequency_hz = 0.0, start_frequency_hz = 0.0;
  double from = 0.0, to = 0.0;  // the amplitude range traced, m sqrt(kg)
  bool default_range = false;   // chosen from the contact motion (NmaOptions::from/to unset)
  long unknowns = 0;            // harmonic-balance unknowns
  std::vector<int> harmonics;
  std::vector<NmaPoint> points;  // from `from`, in the order traced
  std::string termination;       // the continuation's (solver/continuation.hpp's words)
  double wall_seconds = 0.0;
  // For synthesise_peak: the scene's excitation at harmonic 1 projected on the retained modes,
  // Phi^H f (N / sqrt(kg)), and the response node (the first of output.response; empty without
  // one) with the modes at its DOFs (node DOFs x modes, m per m sqrt(kg)).
  Eigen::VectorXcd modal_excitation;
  std::string node;
  Eigen::MatrixXcd node_modes;
};

// The peak of the forced response to the scene's harmonic-1 excitation times `scale`,
// synthesised from the backbone by single-nonlinear-mode theory: with psi = q / a the mode's
// shape at amplitude a (modal coordinates q), its modal mass m = |psi|^2 and modal force
// p = psi^H Phi^H f, the response at frequency W obeys
//   m (w(a)^2 - W^2 + 2 i zeta(a) w(a) W) a = scale p,
// whose largest a over W is where scale |p| / (m a) = 2 zeta w^2 sqrt(1 - zeta^2), at
// W = w sqrt(1 - 2 zeta^2). Accurate near an isolated resonance where the mode's shape holds
// the response; the off-resonant modes, and interactions between modes, are left out.
struct SynthesisedPeak {
  bool found = false;             // false: the backbone does not hold the peak (message says why)
  double amplitude = 0.0;         // a at the peak, m sqrt(kg)
  double frequency_hz = 0.0;      // W / 2 pi
  double damping_ratio = 0.0;     // zeta(a) there
  double node_amplitude_m = 0.0;  // the response node's harmonic-1 amplitude (its largest
                                  // displacement norm over the period)
  std::string message;
};
// `scale` > 0 multiplies the scene's excitation. The peak is the first amplitude, going up the
// backbone, where the condition above is met, between two traced points (interpolated in ln a).
SynthesisedPeak synthesise_peak(const NmaResult& result, double scale);
// The excitation scale whose synthesised peak lies at point `index` of the backbone (inverse of
// synthesise_peak at the traced points).
double excitation_scale_at(const NmaResult& result, std::size_t index);

// The nonlinear mode of a loaded scene. Throws SceneError for a mode the structure does not
// have or a scene the formulation cannot take (harmonic 1 not kept, non-diagonal modal
// damping), naming the file; std::invalid_argument for a range that is not 0 < from < to;
// PluginError where a plugin fails. A continuation that ends before `to` is a result
// (kExitIncomplete, with why).
NmaResult compute_nonlinear_modes(const NmaOptions& options);

}  // namespace frichb::core
