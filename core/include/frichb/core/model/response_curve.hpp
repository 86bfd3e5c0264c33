// The forced-response curve of a harmonic-balance model, in stages a program calls in turn
// (frichb run does; so can a study, a Python binding or a program of its own):
//   find_start_point  - the solution at the sweep's start frequency
//   trace_response    - the curve over the sweep (trace_curve; a linear scene is sampled)
//   tabulate_response - amplitudes of the response nodes per point, their solved peaks, the
//                       turning points and the harmonic-truncation check
//   solve_friction_loops - the contacts' periodic traces at requested frequencies
// Units: frequencies in rad/s unless a field says the scene's unit; displacements in m.
// Failure: the trace's end is a result (ContinuationSummary::termination); the other stages
// report what they could not do by leaving it out (and logging a warning). What the model's
// evaluation throws (std::bad_alloc, std::system_error when a contact thread cannot start)
// passes through. Threading: each call reads the model (whose evaluations are not
// thread-safe); one model per thread.
#pragma once

#include <spdlog/spdlog.h>

#include <Eigen/Dense>
#include <complex>
#include <optional>
#include <string>
#include <vector>

#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/solver/continuation.hpp"

namespace frichb::core {

// The solution at options.lambda_start (y: unknowns, lambda last): Newton from the contact-free
// response, and when it cannot get from there (a contact far stiffer than the structure, stuck at
// a tiny fraction of the free motion), from rest, then from the free response scaled by 1e-3 and
// 1e-6. When none converges, the contact-free response itself (trace_curve then reports the
// start's failure). How the start was found is logged at `log_level`. Throws
// std::invalid_argument when the scales of `options` do not fit the model (FixedParameterSolver);
// derive_continuation's always do.
Eigen::VectorXd find_start_point(const HarmonicBalanceModel& model,
                                 const ContinuationOptions& options,
                                 spdlog::level::level_enum log_level = spdlog::level::info);

// The response curve from `start` over the sweep of `options`. A model without contact unknowns
// is linear: its curve is sampled at continuation.step.max of the scene, shortened near each
// resonance as the step bands say (there is nothing to continue). `on_point` as trace_curve's.
ContinuationSummary trace_response(const Scene& scene, const HarmonicBalanceModel& model,
                                   const ContinuationOptions& options, const Eigen::VectorXd& start,
                                   const PointCallback& on_point = {});

// A response node (output.response of the scene) and the kept indices of its DOFs.
struct ResponseNode {
  std::string name;
  std::vector<Eigen::Index> kept;
};

// The complex harmonic amplitudes of a node's DOFs, picked from the kept DOFs' amplitudes
// (HarmonicBalanceModel::kept_response): entry (d, k) is X of the node's DOF d (the order of its
// structure.dofs entry) and the layout's harmonic k (model.layout().harmonics()[k]), m, such
// that the DOF moves as x_d(t) = sum_k Re(X(d, k) exp(i n_k omega t)), that is
// sum_k Re X cos(n_k omega t) - Im X sin(n_k omega t).
Eigen::MatrixXcd node_harmonics(const std::vector<Eigen::VectorXcd>& kept,
                                const ResponseNode& node);

// One contact's harmonics at one point of the curve, in the convention of node_harmonics: entry
// (a, k) is the complex amplitude of the contact's used local component a (t1, t2, n in that
// order, as many as the law uses: ResponseTable::contact_components) and the layout's harmonic
// k, so that the component moves as u_a(t) = sum_k Re(U(a, k) exp(i n_k omega t)).
//   displacement: the relative displacement u = frame . (x_B - x_A) (m), the unknowns of the
//                 harmonic balance;
//   force:        the law's force on u (N), the preload included in the static term (the force
//                 the trace's samples hold, with the trace's Fourier coefficients).
// The force's harmonics are its exact projection on the kept harmonics (AFT, with the kink
// corrections of laws that step along the motion); the force itself has harmonics beyond them.
struct ContactHarmonics {
  Eigen::MatrixXcd displacement;
  Eigen::MatrixXcd force;
  bool periodic = true;  // false: the trace did not settle (its force is that of the last pass)
};

// Every contact's harmonics at the solution y, contacts in the order of model.contacts().
// Traces each contact once (not thread-safe: uses the contacts' tracers). Throws
// std::runtime_error naming the contact when a law fails.
std::vector<ContactHarmonics> contact_harmonics(const HarmonicBalanceModel& model,
                                                const Eigen::VectorXd& y);

// The peak amplitude of one response node (the measure of model/response.hpp): solved along
// the curve beside its highest traced point (model/resonance_peak.hpp), or, where it cannot be
// (the highest point is an end of the curve, a solve fails: logged as a warning), the highest
// traced point itself.
struct NodePeak {
  std::string node;
  double amplitude_m = 0.0;
  double omega_rad_s = 0.0;
  bool refined = false;  // solved, not the highest traced point
  Eigen::VectorXd y;     // the solution at the peak (unknowns, omega last); empty in a study
                         // run in another process (its outcome carries the numbers only)
};

// Turning points of the traced curve (sign changes of the tangent's frequency component) in
// the scene's unit, and the micro-folds among them: turning points within kMicroFoldWidth of
// the sweep span of the next one along the curve. A penalty contact's sampled force is
// piecewise smooth (a sample entering contact bends the residual), and near a fold of a
// lightly damped resonance these bends fold the curve back and forth over a fraction of a
// hertz; the clusters narrow as samples_per_period grows.
inline constexpr double kMicroFoldWidth = 1e-3;
// Relative frequency window within which a real multiplier's crossing of +1 is attributed to a
// fold of the curve (ResponseTable::StabilityChange).
inline constexpr double kFoldWindow = 1e-3;
// Halvings of the chord between two points that locate a bifurcation other than a fold.
inline constexpr int kLocateBisections = 12;
struct TurningPoints {
  std::vector<double> frequencies;
  int micro_folds = 0;         // turning points that belong to a cluster
  double cluster_width = 0.0;  // the clustering distance, in the scene's unit
  double first_cluster = 0.0;  // where the first cluster is
};

// Share of a contact force's energy (over the kept harmonics from 1 up) above which its
// highest kept harmonic is warned about: the force's spectrum is cut where it still matters.
inline constexpr double kHighestHarmonicShare = 0.02;
// At the curve's highest point (of the first response node), the largest share of any contact
// force component's energy that its highest kept harmonic carries. Absent without contacts,
// points, or with fewer than two harmonics.
struct HarmonicTruncation {
  double frequency = 0.0;  // scene's unit
  int highest_harmonic = 0;
  double largest_energy_share = 0.0;
  std::string contact;  // "<name> (<axis>)" of the largest share, empty when none traced
};

// What is read off the traced curve: one row per point (point, frequency_hz, omega_rad_s, per
// node its amplitude and its amplitude per kept harmonic, newton_iterations, step, condition -
// the columns of response.csv, named by `header`), the peaks (one per node; nullopt for a node
// of a curve without points), the turning points and the harmonic truncation.
struct ResponseTable {
  std::vector<ResponseNode> nodes;
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  // node_harmonics of every node at every point: harmonics[point][node], nodes in order.
  std::vector<std::vector<Eigen::MatrixXcd>> harmonics;
  // With output.contact_forces: contact_harmonics at every point, contacts[point][contact], and
  // each contact's used components (0: t1, 1: t2, 2: n); empty otherwise.
  std::vector<std::vector<ContactHarmonics>> contacts;
  std::vector<std::vector<int>> contact_components;
  std::vector<std::optional<NodePeak>> peaks;
  // With output.stability (the table's columns stable and largest_multiplier): per node, its
  // highest traced point that is stable (nullopt: none is), and the bifurcations: the points
  // whose stability differs from the point before them. Empty otherwise.
  struct StablePoint {
    std::size_t point = 0;
    double amplitude_m = 0.0;
    double omega_rad_s = 0.0;
  };
  std::vector<std::optional<StablePoint>> stable_peaks;
  // A bifurcation between points `point - 1` and `point`. A fold: a turning point of the curve
  // there (its multiplier: that of the nearest real crossing of +1 within kFoldWindow of its
  // frequency, else the real one nearest +1 at the two points; its stability: after them).
  // Elsewhere the number of multipliers outside the unit circle changes there, named by the
  // multiplier that crossed (outside the circle at the point with more of them, the nearest it):
  // real and past +1, a branch point (within kFoldWindow of a fold's frequency: that fold's); real
  // and past -1, a period doubling; a complex pair, a Neimark-Sacker bifurcation (a torus: the
  // response turns quasi-periodic).
  // A change other than a fold is then located between the two points by bisection (on the
  // planes across the chord between them, kLocateBisections halvings): where the number of
  // multipliers outside the circle changes, its frequency, each node's amplitude and the
  // multiplier that crossed there (its modulus within the bisection's reach of 1).
  struct LocatedChange {
    double omega_rad_s = 0.0;
    std::vector<double> amplitude_m;  // per node, as `nodes`
    std::complex<double> multiplier;
    double theta = 0.0;       // its place on the chord, 0 at point - 1 and 1 at point
    int nodal_diameter = -1;  // the multiplier's, for a cyclic structure (else -1)
  };
  struct StabilityChange {
    std::size_t point = 0;
    bool stable = false;     // the stability from `point` on
    int unstable_count = 0;  // multipliers outside the circle from `point` on
    std::complex<double> multiplier;
    std::string kind;                      // fold, branch_point, period_doubling or neimark_sacker
    std::optional<LocatedChange> located;  // empty for a fold, or where a solve failed
    int nodal_diameter = -1;               // the multiplier's, for a cyclic structure (else -1)
  };
  std::vector<StabilityChange> stability_changes;
  int unstable_points = 0;
  double stability_seconds = 0.0;  // wall time of the multipliers of every point, s
  TurningPoints turning_points;
  std::optional<HarmonicTruncation> truncation;
};

ResponseTable tabulate_response(const Scene& scene, const HarmonicBalanceModel& model,
                                const ContinuationOptions& options,
                                const ContinuationSummary& summary);

// A contact's periodic trace at a requested frequency where the curve crosses it, solved
// exactly there (a fixed-frequency Newton solve from the curve's chord).
struct FrictionLoop {
  std::size_t contact = 0;  // index in model.contacts()
  double frequency = 0.0;   // as requested, in the scene's unit
  int crossing = 0;         // 1, 2, ...: which crossing of the curve (a folded curve has several)
  ContactTrace trace;
};

// Every crossing of each output.friction_loops_at frequency by the curve, for every contact, in
// that order. A crossing whose Newton solve fails, a contact whose trace fails, and a frequency
// the curve does not reach are logged as warnings and left out.
std::vector<FrictionLoop> solve_friction_loops(const Scene& scene,
                                               const HarmonicBalanceModel& model,
                                               const ContinuationOptions& options,
                                               const ContinuationSummary& summary);
// The same at any frequencies (in the scene's unit), e.g. output.contact_states_at.
std::vector<FrictionLoop> solve_contact_traces(const Scene& scene,
                                               const HarmonicBalanceModel& model,
                                               const ContinuationOptions& options,
                                               const ContinuationSummary& summary,
                                               const std::vector<double>& frequencies);

}  // namespace frichb::core
