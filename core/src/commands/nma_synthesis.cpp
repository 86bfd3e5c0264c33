// The forced response synthesised from a nonlinear mode (commands/nma.hpp) and its checks
// (nma_synthesis.hpp).
#include "nma_synthesis.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/model/continuation_setup.hpp"
#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/model/response.hpp"
#include "frichb/core/solver/continuation.hpp"

namespace frichb::core {

namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;
// The synthesised curve: points per interval of the backbone, and how far below the peak's
// amplitude a it goes (its flanks down to a tenth of the peak's a).
constexpr int kCurveSubdivisions = 8;
constexpr double kCurveDepth = 0.1;

double seconds_since(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// The mode's shape psi = q / a at a point, its modal mass |psi|^2 and force, and the node's
// motion per unit a.
struct ShapeAt {
  Eigen::VectorXcd psi, node;
  double mass = 0.0;
  std::complex<double> force;
};
ShapeAt shape_at(const NmaPoint& p) {
  ShapeAt shape;
  shape.psi = p.modal_coordinates / p.amplitude;
  shape.node = p.node_motion / p.amplitude;
  shape.mass = shape.psi.squaredNorm();
  shape.force = p.modal_force;
  return shape;
}

// The largest norm over the period of a node's motion with complex amplitudes c:
// max |Re(c e^{i t})|^2 = (|c|^2 + |c^T c|) / 2.
double largest_norm(const Eigen::VectorXcd& c) {
  return std::sqrt(0.5 * (c.squaredNorm() + std::abs(c.cwiseProduct(c).sum())));
}

// The backbone between points i - 1 and i at t in [0, 1] (ln a, w, zeta and psi linear in t).
struct BackboneAt {
  double amplitude = 0.0, w = 0.0, zeta = 0.0;
  ShapeAt shape;
};
BackboneAt backbone_at(const NmaResult& result, std::size_t i, double t) {
  const NmaPoint &p0 = result.points[i - 1], &p1 = result.points[i];
  const auto blend = [t](double x0, double x1) { return x0 + t * (x1 - x0); };
  BackboneAt at;
  at.amplitude = std::exp(blend(std::log(p0.amplitude), std::log(p1.amplitude)));
  at.w = kTwoPi * blend(p0.frequency_hz, p1.frequency_hz);
  at.zeta = blend(p0.damping_ratio, p1.damping_ratio);
  const ShapeAt s0 = shape_at(p0), s1 = shape_at(p1);
  at.shape.psi = (1 - t) * s0.psi + t * s1.psi;
  at.shape.node = (1 - t) * s0.node + t * s1.node;
  at.shape.mass = at.shape.psi.squaredNorm();
  at.shape.force = (1 - t) * s0.force + t * s1.force;
  return at;
}

// The mode's complex amplitude a e^{i theta} at W: scale p / (m (w^2 - W^2 + 2 i zeta w W)).
std::complex<double> modal_response(double scale, const BackboneAt& at, double big_w) {
  const std::complex<double> impedance(at.w * at.w - big_w * big_w, 2 * at.zeta * at.w * big_w);
  return scale * at.shape.force / (at.shape.mass * impedance);
}

// The response node's harmonic-1 amplitudes: the mode alone, and the off-resonant modes'
// residual terms at W.
struct NodeMotion {
  Eigen::VectorXcd mode, residual;
};
// `modal`: the mode's complex amplitude a e^{i theta}. The residual terms: the other linear
// modes with the contacts at rest, and the excitation's static motion of the node through the
// residual flexibility.
NodeMotion node_motion(const NmaResult& result, double scale, const BackboneAt& at, double big_w,
                       std::complex<double> modal_amplitude) {
  NodeMotion motion;
  if (result.node_modes.size() == 0) return motion;
  motion.mode = at.shape.node * modal_amplitude;
  Eigen::VectorXcd modal = Eigen::VectorXcd::Zero(result.modal_excitation.size());
  for (Eigen::Index j = 0; j < result.rest_stiffness.size(); ++j) {
    if (j == result.rest_mode) continue;
    const Eigen::VectorXcd v = result.rest_shapes.col(j);
    modal += v * (scale * v.dot(result.modal_excitation) /
                  std::complex<double>(result.rest_stiffness(j) - big_w * big_w,
                                       big_w * result.rest_damping(j)));
  }
  motion.residual = result.node_modes * modal + scale * result.node_flexible_excitation;
  return motion;
}

// Where the synthesised peak lies: between points index - 1 and index, at t.
struct PeakBracket {
  std::size_t index = 0;
  double t = 0.0;
};
std::optional<PeakBracket> find_peak(const NmaResult& result, double scale) {
  // g = ln(scale / excitation_scale_at) falls through 0 at the peak (the excitation a point's
  // amplitude needs grows along the backbone); linear in t where the needed excitation is a
  // power of a (a linear mode's is proportional to it), as ln a is. A point without damping
  // (zeta <= 0: friction alone while the contacts stick, zero to rounding) needs no excitation:
  // its g is infinite, and a peak right after it is put at the next point.
  const auto g = [&](std::size_t i) {
    const double needed = excitation_scale_at(result, i);
    return needed > 0 ? std::log(scale / needed) : std::numeric_limits<double>::infinity();
  };
  for (std::size_t i = 1; i < result.points.size(); ++i) {
    const double before = g(i - 1), after = g(i);
    if (!(before > 0 && after <= 0)) continue;
    return PeakBracket{i, std::isinf(before) ? 1.0 : before / (before - after)};
  }
  return std::nullopt;
}

// The two frequencies (rad/s, ascending) at which the mode reaches the point's amplitude under
// `scale`, or nullopt where it does not (above the peak) or neither is real; a lower one that is
// not real is 0.
std::optional<std::pair<double, double>> frequencies_reaching(double scale, const BackboneAt& at) {
  const double w2 = at.w * at.w, zeta2 = at.zeta * at.zeta;
  const double reach = scale * std::abs(at.shape.force) / (at.shape.mass * at.amplitude);
  const double discriminant = reach * reach - 4 * zeta2 * w2 * w2 * (1 - zeta2);
  if (!(discriminant >= 0)) return std::nullopt;
  const double centre = w2 * (1 - 2 * zeta2), half = std::sqrt(discriminant);
  if (!(centre + half > 0)) return std::nullopt;
  return std::pair{std::sqrt(std::max(0.0, centre - half)), std::sqrt(centre + half)};
}

SynthesisedPoint curve_point(const NmaResult& result, double scale, const BackboneAt& at,
                             double big_w) {
  const NodeMotion motion = node_motion(result, scale, at, big_w, modal_response(scale, at, big_w));
  SynthesisedPoint point;
  point.frequency_hz = big_w / kTwoPi;
  point.amplitude = at.amplitude;
  if (motion.mode.size() > 0) {
    point.node_amplitude_m = largest_norm(motion.mode);
    point.node_amplitude_with_residual_m = largest_norm(motion.mode + motion.residual);
  }
  return point;
}

// The node's amplitude (frichb run's measure) at the harmonic-balance solution z = [U; w].
double node_amplitude(const HarmonicBalanceModel& model, const Scene& scene,
                      const std::string& node, const Eigen::VectorXd& z) {
  std::vector<Eigen::Index> kept;
  for (std::size_t d : scene.structure.find(node)->dofs) kept.push_back(model.kept_index(d));
  AmplitudeSampler sampler(model.layout().harmonics(), std::max(256, 8 * model.layout().samples()));
  return sampler.peak_amplitude(model.kept_response(z), kept);
}

}  // namespace

double excitation_scale_at(const NmaResult& result, std::size_t index) {
  const NmaPoint& p = result.points.at(index);
  const ShapeAt shape = shape_at(p);
  const double w = kTwoPi * p.frequency_hz, zeta = p.damping_ratio;
  return 2 * zeta * w * w * std::sqrt(1 - zeta * zeta) * shape.mass * p.amplitude /
         std::abs(shape.force);
}

SynthesisedPeak synthesise_peak(const NmaResult& result, double scale) {
  SynthesisedPeak peak;
  if (!(scale > 0)) throw std::invalid_argument("synthesise_peak: the scale must be > 0");
  if (result.modal_excitation.size() == 0 || result.modal_excitation.norm() == 0) {
    peak.message = "the scene has no excitation at harmonic 1";
    return peak;
  }
  const std::optional<PeakBracket> bracket = find_peak(result, scale);
  if (!bracket) {
    peak.message = "the peak lies outside the traced amplitudes";
    return peak;
  }
  const BackboneAt at = backbone_at(result, bracket->index, bracket->t);
  peak.amplitude = at.amplitude;
  peak.damping_ratio = at.zeta;
  if (!(2 * at.zeta * at.zeta < 1)) {
    peak.message = "the damping ratio at the peak is above 1 / sqrt(2): no resonance peak";
    return peak;
  }
  const double big_w = at.w * std::sqrt(1 - 2 * at.zeta * at.zeta);
  peak.frequency_hz = big_w / kTwoPi;
  // The interpolated amplitude in the phase of the response there.
  const NodeMotion motion =
      node_motion(result, scale, at, big_w,
                  std::polar(at.amplitude, std::arg(modal_response(scale, at, big_w))));
  if (motion.mode.size() > 0) {
    peak.node_amplitude_m = largest_norm(motion.mode);
    peak.node_amplitude_with_residual_m = largest_norm(motion.mode + motion.residual);
    const double total = (motion.mode + motion.residual).norm();
    peak.residual_share = total > 0 ? motion.residual.norm() / total : 0.0;
  }
  peak.found = true;
  return peak;
}

std::pair<double, double> synthesis_band_hz(const NmaResult& result) {
  std::pair<double, double> band{0.0, std::numeric_limits<double>::infinity()};
  const Eigen::Index j = result.rest_mode, count = result.rest_stiffness.size();
  if (j >= count) return band;
  const auto hz = [&](Eigen::Index i) {
    return std::sqrt(std::max(0.0, result.rest_stiffness(i))) / kTwoPi;
  };
  if (j > 0) band.first = 0.5 * (hz(j - 1) + hz(j));
  if (j + 1 < count) band.second = 0.5 * (hz(j) + hz(j + 1));
  return band;
}

SynthesisedResponse synthesise_response(const NmaResult& result, double scale) {
  SynthesisedResponse response;
  response.scale = scale;
  response.peak = synthesise_peak(result, scale);
  if (!response.peak.found) return response;
  const PeakBracket bracket = *find_peak(result, scale);
  const std::pair<double, double> band = synthesis_band_hz(result);
  const double smallest = response.peak.amplitude * kCurveDepth;
  std::vector<SynthesisedPoint> below, above;
  // The backbone below the peak, kCurveSubdivisions points per interval.
  for (std::size_t i = 1; i <= bracket.index; ++i)
    for (int j = 0; j < kCurveSubdivisions; ++j) {
      const double t = static_cast<double>(j) / kCurveSubdivisions;
      if (i == bracket.index && t >= bracket.t) break;
      const BackboneAt at = backbone_at(result, i, t);
      if (at.amplitude < smallest) continue;
      const auto reach = frequencies_reaching(scale, at);
      if (!reach) continue;
      const auto inside = [&band](double w) {
        return w > 0 && w / kTwoPi >= band.first && w / kTwoPi <= band.second;
      };
      if (inside(reach->first)) below.push_back(curve_point(result, scale, at, reach->first));
      if (inside(reach->second)) above.push_back(curve_point(result, scale, at, reach->second));
    }
  const BackboneAt at = backbone_at(result, bracket.index, bracket.t);
  response.curve = std::move(below);
  response.curve.push_back(curve_point(result, scale, at, kTwoPi * response.peak.frequency_hz));
  response.curve.insert(response.curve.end(), above.rbegin(), above.rend());
  return response;
}

BoundScene with_excitation_scaled(const SceneInput& input, const Scene& scene, double scale) {
  SceneInput scaled = input;
  for (std::size_t i = 0; i < scene.excitation.size(); ++i)
    if (scene.excitation[i].harmonic == 1)
      scaled.overrides.push_back({"excitation." + std::to_string(i) + ".amplitude",
                                  format_scene_value(scale * scene.excitation[i].amplitude)});
  BoundScene bound = load_bound_scene(scaled);
  // The overrides address the scene's excitation list entry by entry.
  for (std::size_t i = 0; i < scene.excitation.size(); ++i)
    if (bound.scene.excitation.size() != scene.excitation.size() ||
        (scene.excitation[i].harmonic == 1 &&
         std::abs(bound.scene.excitation[i].amplitude - scale * scene.excitation[i].amplitude) >
             1e-12 * std::abs(scale * scene.excitation[i].amplitude)))
      throw std::logic_error("with_excitation_scaled: the excitation entries did not scale");
  return bound;
}

SynthesisCheck check_synthesised_peak(const Scene& scene, const HarmonicBalanceModel& base,
                                      const NonlinearModeProblem& problem, const NmaResult& result,
                                      const SynthesisedResponse& response, const StopToken& stop) {
  const auto started = std::chrono::steady_clock::now();
  SynthesisCheck check;
  const std::unique_ptr<HarmonicBalanceModel> scaled =
      base.with_excitation_scaled(scene, 1, response.scale);
  const HarmonicBalanceModel& model = *scaled;
  const PeakBracket bracket = *find_peak(result, response.scale);
  const BackboneAt at = backbone_at(result, bracket.index, bracket.t);
  const double big_w = kTwoPi * response.peak.frequency_hz;
  // The backbone's unknowns at the peak, its harmonics n >= 1 turned by n theta: the free
  // motion shifted in time into the excitation's phase.
  const Eigen::VectorXd& y0 = result.points[bracket.index - 1].y;
  const Eigen::VectorXd& y1 = result.points[bracket.index].y;
  Eigen::VectorXd y = (1 - bracket.t) * y0 + bracket.t * y1;
  const Eigen::Index n = problem.harmonic_unknowns();
  y(n + 2) = std::log(at.amplitude);
  Eigen::VectorXd z = problem.balance_point(y);
  const double theta = std::arg(modal_response(response.scale, at, big_w));
  const HarmonicLayout& layout = model.layout();
  const int c = layout.coefficient_count();
  for (std::size_t k = 0; k < layout.harmonics().size(); ++k) {
    const int h = layout.harmonics()[k];
    if (h == 0) continue;
    const std::complex<double> turn = std::polar(1.0, h * theta);
    const int ci = layout.cos_index(k), si = layout.sin_index(k);
    for (int a = 0; a < model.component_count(); ++a) {
      // X = c - i s turned: X e^{i h theta}.
      const std::complex<double> x = std::complex<double>(z(a * c + ci), -z(a * c + si)) * turn;
      z(a * c + ci) = x.real();
      z(a * c + si) = -x.imag();
    }
  }
  z(n) = big_w;
  ContinuationOptions options = derive_continuation(scene, model).options;
  options.newton.stop = stop;
  const NewtonResult solved = solve_fixed_parameter(model, z, options);
  check.newton_iterations = solved.iterations;
  if (!solved.converged) {
    check.message = "the harmonic-balance solve at " + std::to_string(response.peak.frequency_hz) +
                    " Hz did not converge: " + solved.message;
  } else {
    check.converged = true;
    check.node_amplitude_m = node_amplitude(model, scene, result.node, solved.y);
    check.error = response.peak.node_amplitude_m / check.node_amplitude_m - 1;
    check.error_with_residual =
        response.peak.node_amplitude_with_residual_m / check.node_amplitude_m - 1;
  }
  check.seconds = seconds_since(started);
  return check;
}

FullRunComparison compare_with_full_run(const Scene& scaled, const SynthesisedResponse& response,
                                        const StopToken& stop) {
  FullRunComparison full;
  RunOptions options;
  options.quiet = true;
  options.plots = 0;
  options.stop = stop;
  const RunResult run = trace_scene(scaled, options);
  full.seconds = run.wall_seconds;
  full.points = static_cast<int>(run.summary.points.size());
  full.termination = run.outcome.termination;
  if (run.table.peaks.empty() || !run.table.peaks.front()) {
    full.message = "the run has no peak at the response node";
    return full;
  }
  const NodePeak& peak = *run.table.peaks.front();
  full.frequency_hz = peak.omega_rad_s / kTwoPi;
  full.node_amplitude_m = peak.amplitude_m;
  full.amplitude_error = response.peak.node_amplitude_m / peak.amplitude_m - 1;
  full.amplitude_error_with_residual =
      response.peak.node_amplitude_with_residual_m / peak.amplitude_m - 1;
  full.frequency_error = response.peak.frequency_hz / full.frequency_hz - 1;
  full.found = peak.refined;
  if (!peak.refined)
    full.message = "the run's highest point is an end of its curve (" + run.outcome.termination +
                   "): the peak lies outside the scene's frequency range or was not solved";
  return full;
}

}  // namespace frichb::core
