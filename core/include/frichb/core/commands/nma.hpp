// `frichb nma`: a nonlinear mode of a scene's structure with its contacts, by the extended
// periodic motion concept (model/nonlinear_modes.hpp): the mode's frequency and damping ratio
// against its amplitude, continued in the log of the amplitude from where the contacts stick.
// The verb shape: commands/verb.hpp; the writer: report/nma_report.hpp.
#pragma once

#include <Eigen/Dense>
#include <complex>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
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
  // Excitation levels of the forced responses synthesised from the backbone: multiples of the
  // scene's harmonic-1 excitation (each > 0); empty: none. Each synthesised peak is checked by
  // one harmonic-balance solve of the forced equations at its frequency (SynthesisCheck).
  std::vector<double> synthesise;
  // Also trace each level's full forced response (frichb run's curve over the scene's
  // frequency range) for the synthesis's error at the peak and its cost against it.
  bool against_run = false;
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
  // The work of the scene's harmonic-1 excitation f on the mode's motion per unit a, the
  // synthesis's modal force: p = psi^H Phi^H f - (F_1 / a)^H G F f (N / sqrt(kg)), psi = q / a,
  // F_1 the contact forces at harmonic 1, G F f the excitation's static contact motion through
  // the residual flexibility F (zero without one).
  std::complex<double> modal_force;
  // The response node's harmonic-1 motion (its DOFs, m): the retained modes' Phi q plus the
  // residual flexibility's -F G^H F_1; empty without a response node.
  Eigen::VectorXcd node_motion;
  Eigen::VectorXd y;  // the problem's unknowns (V, w, xi, ln a): NonlinearModeProblem
};

// The forced response to the scene's harmonic-1 excitation times `scale`,
// synthesised from the backbone by single-nonlinear-mode theory: with psi = q / a the mode's
// shape at amplitude a (modal coordinates q), its modal mass m = |psi|^2 (the residual
// flexibility is massless) and modal force p (NmaPoint::modal_force: the excitation's work on
// the mode's physical motion, the residual flexibility's share included), the response at
// frequency W obeys
//   m (w(a)^2 - W^2 + 2 i zeta(a) w(a) W) a = scale p,
// whose largest a over W is where scale |p| / (m a) = 2 zeta w^2 sqrt(1 - zeta^2), at
// W = w sqrt(1 - 2 zeta^2); below that amplitude a is reached at two frequencies,
//   W^2 = w^2 (1 - 2 zeta^2) +- sqrt((scale |p| / (m a))^2 - 4 zeta^2 w^4 (1 - zeta^2)),
// and the mode's phase against the excitation is that of scale p / (m a (w^2 - W^2 + 2 i zeta
// w W)). The response node moves as the mode's motion (NmaPoint::node_motion / a) times that,
// and, in the figures `_with_residual`, also with residual terms: the off-resonant modes as
// linear terms, the linear modes with the contacts at rest other than the one the backbone
// starts from (shapes v_j in modal coordinates), Phi v_j scale v_j^H Phi^H f / (lambda_j - W^2 +
// i W d_j), and the excitation's static motion through the residual flexibility, scale F f.
// Where the contacts stick they leave out only the damping's coupling between the modes and
// the contacts' own static share through F (G F G^H); where the contacts slip they hold the
// off-resonant part only as well as the contacts' tangents at rest do. Accurate near an isolated
// resonance where the mode's shape holds the response; interactions between modes (internal
// resonances) are left out, and the forced motion's shape departs from the free mode's as the
// friction damping grows (docs/validation.md gives the error against it).
struct SynthesisedPeak {
  bool found = false;             // false: the backbone does not hold the peak (message says why)
  double amplitude = 0.0;         // a at the peak, m sqrt(kg)
  double frequency_hz = 0.0;      // W / 2 pi
  double damping_ratio = 0.0;     // zeta(a) there
  double node_amplitude_m = 0.0;  // the response node's harmonic-1 amplitude (its largest
                                  // displacement norm over the period), the mode alone
  // The same with the off-resonant modes' residual terms, and their share of it: |the node's
  // residual terms| / |its synthesised harmonic-1 amplitudes| (complex vectors' norms).
  double node_amplitude_with_residual_m = 0.0, residual_share = 0.0;
  std::string message;
};
// One point of a synthesised response curve.
struct SynthesisedPoint {
  double frequency_hz = 0.0;  // W / 2 pi
  double amplitude = 0.0;     // the mode's a, m sqrt(kg)
  // The response node's harmonic-1 amplitude, m: the mode alone, and with the off-resonant
  // modes' residual terms.
  double node_amplitude_m = 0.0, node_amplitude_with_residual_m = 0.0;
};

// A synthesised peak checked by one harmonic-balance solve of the forced equations (the
// scene's, its harmonic-1 excitation scaled) at the peak's frequency, started from the
// backbone's motion at the peak put in the excitation's phase.
struct SynthesisCheck {
  bool converged = false;
  // The response node's amplitude there (frichb run's measure: all harmonics, the largest
  // norm over the period), m, and the synthesis's error against it (synthesised / solved - 1),
  // the mode alone and with the residual terms.
  double node_amplitude_m = 0.0, error = 0.0, error_with_residual = 0.0;
  int newton_iterations = 0;
  double seconds = 0.0;
  std::string message;  // why it did not converge
};

// The full forced response of a level (frichb run's curve and its solved peak) against the
// synthesised peak.
struct FullRunComparison {
  bool found = false;  // the run's peak was solved (not an end of its curve)
  double frequency_hz = 0.0, node_amplitude_m = 0.0;
  // synthesised / full - 1: the peak's amplitude (mode alone and with the residual terms) and
  // its frequency.
  double amplitude_error = 0.0, amplitude_error_with_residual = 0.0, frequency_error = 0.0;
  int points = 0;  // of the run's curve
  double seconds = 0.0;
  std::string termination, message;
};

struct SynthesisedResponse {
  double scale = 1.0;  // of the scene's harmonic-1 excitation
  SynthesisedPeak peak;
  // In order along the curve: the flank below the peak's frequency (a rising), the peak, the
  // flank above it (a falling; frequencies ascend on both unless a strongly softening backbone
  // folds a flank), over the backbone below the peak (8 points per interval,
  // interpolated as the peak is) down to a tenth of the peak's a, and within
  // synthesis_band_hz.
  // Empty without a peak.
  std::vector<SynthesisedPoint> curve;
  SynthesisCheck check;                   // when the peak was found
  std::optional<FullRunComparison> full;  // NmaOptions::against_run
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
  // For the synthesis: the scene's excitation at harmonic 1 projected on the retained modes,
  // Phi^H f (N / sqrt(kg)), and the response node (the first of output.response; empty without
  // one) with the modes at its DOFs (node DOFs x modes, m per m sqrt(kg)).
  Eigen::VectorXcd modal_excitation;
  std::string node;
  Eigen::MatrixXcd node_modes;
  // The excitation's static motion of the response node through the residual flexibility,
  // (F f) at its DOFs (m; zero without a residual flexibility): a residual term.
  Eigen::VectorXcd node_flexible_excitation;
  // The linear modes with the contacts at rest (NonlinearModeProblem::rest_modes), for the
  // off-resonant modes' residual terms: their stiffness (rad^2/s^2) and modal damping (rad/s),
  // their shapes in the retained modes' coordinates (columns), and the one the backbone starts
  // from (left out of the terms).
  Eigen::VectorXd rest_stiffness, rest_damping;
  Eigen::MatrixXcd rest_shapes;
  Eigen::Index rest_mode = 0;
  // The forced responses synthesised at NmaOptions::synthesise, in that order, and the time
  // they took (the synthesis, the checks, the full runs), s.
  std::vector<SynthesisedResponse> syntheses;
  double synthesis_seconds = 0.0, check_seconds = 0.0, full_run_seconds = 0.0;
};

// `scale` > 0 multiplies the scene's excitation. The peak is the first amplitude, going up the
// backbone, where the condition above is met, between two traced points (interpolated in ln a).
SynthesisedPeak synthesise_peak(const NmaResult& result, double scale);

// The frequencies (Hz) within which a synthesised curve is drawn: between the midpoints to the
// neighbouring linear modes with the contacts at rest (0 and infinity where there is none),
// where the mode rather than its neighbours makes the response.
std::pair<double, double> synthesis_band_hz(const NmaResult& result);
// The curve and the peak of a level (no check): pure, from the result's backbone.
SynthesisedResponse synthesise_response(const NmaResult& result, double scale);
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
