#include "frichb/core/commands/peaks.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/model/mistuned_disk.hpp"
#include "frichb/core/model/peak_tracking.hpp"
#include "frichb/core/model/stability.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/support/format.hpp"

namespace frichb::core {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// The path's section must lie outside the structure, which is built once.
void check_parameter_path(const Scene& scene, const std::string& path) {
  if (!path.starts_with("contacts.") && !path.starts_with("contacts[") &&
      !path.starts_with("excitation.") && !path.starts_with("excitation["))
    throw SceneError(scene.file.string(), 0, 0, path,
                     "frichb peaks varies a parameter of a contact (contacts.NAME.params.KEY) or "
                     "of the excitation (excitation.I.amplitude), not '" +
                         path + "'");
}

std::size_t node_index(const Scene& scene, const std::string& node) {
  if (scene.output.response.empty())
    throw SceneError(scene.file.string(), 0, 0, "output.response",
                     "frichb peaks traces the peak of a node of output.response, and it is empty");
  if (node.empty()) return 0;
  for (std::size_t k = 0; k < scene.output.response.size(); ++k)
    if (scene.output.response[k] == node) return k;
  std::string names;
  for (const auto& name : scene.output.response) names += (names.empty() ? "" : ", ") + name;
  throw SceneError(scene.file.string(), 0, 0, "output.response",
                   "--node " + node + " is not among output.response (" + names + ")");
}

// The solved peak of output.response node k of a run, or why there is none.
struct RunPeak {
  bool found = false;
  Eigen::VectorXd y;  // unknowns, w last
  double amplitude_m = 0.0, omega_rad_s = 0.0;
  bool refined = false;
  std::string why;
  std::string note;  // how it was chosen, where that matters (peak_near)
};

RunPeak run_peak(const RunResult& run, std::size_t k, Eigen::Index n) {
  RunPeak peak;
  const auto& p = run.table.peaks.size() > k ? run.table.peaks[k] : std::nullopt;
  if (!p || p->y.size() != n + 1) {
    peak.why = run.outcome.message.empty() ? "no traced point" : run.outcome.message;
    return peak;
  }
  peak.found = true;
  peak.y = p->y;
  peak.amplitude_m = p->amplitude_m;
  peak.omega_rad_s = p->omega_rad_s;
  peak.refined = p->refined;
  return peak;
}

// Node k's amplitude at each point of a run's curve (response.csv's column) and the points'
// frequencies, Hz; empty when the table does not hold one row per point.
struct TabulatedCurve {
  std::vector<double> amplitude_m, frequency_hz;
};

TabulatedCurve tabulated_curve(const RunResult& run, std::size_t k) {
  TabulatedCurve curve;
  const ResponseTable& table = run.table;
  if (k >= table.nodes.size() || table.rows.size() != run.summary.points.size()) return curve;
  const auto& header = table.header;
  const auto amplitude =
      std::find(header.begin(), header.end(), table.nodes[k].name + "_amplitude_m");
  const auto frequency = std::find(header.begin(), header.end(), "frequency_hz");
  if (amplitude == header.end() || frequency == header.end()) return curve;
  const auto a = static_cast<std::size_t>(amplitude - header.begin());
  const auto f = static_cast<std::size_t>(frequency - header.begin());
  for (const auto& row : table.rows) {
    curve.amplitude_m.push_back(row[a]);
    curve.frequency_hz.push_back(row[f]);
  }
  return curve;
}

// The local maxima of a tabulated amplitude along the curve (higher than the point before, not
// lower than the one after; the curve's ends excluded), by point index.
std::vector<std::size_t> local_maxima(const TabulatedCurve& curve) {
  std::vector<std::size_t> maxima;
  const auto& a = curve.amplitude_m;
  for (std::size_t i = 1; i + 1 < a.size(); ++i)
    if (a[i] > a[i - 1] && a[i] >= a[i + 1]) maxima.push_back(i);
  return maxima;
}

// Of `maxima`, the one whose frequency is nearest hz; nullopt when there is none.
std::optional<std::size_t> nearest_maximum(const TabulatedCurve& curve,
                                           const std::vector<std::size_t>& maxima, double hz) {
  std::optional<std::size_t> nearest;
  for (const std::size_t i : maxima)
    if (!nearest ||
        std::abs(curve.frequency_hz[i] - hz) < std::abs(curve.frequency_hz[*nearest] - hz))
      nearest = i;
  return nearest;
}

// The peak solved at lambda (the peak condition at that fixed value) from a point z = (x, w)
// of the response curve beside it.
RunPeak solve_peak_at(const PeakCondition& problem, const ContinuationOptions& options,
                      const Eigen::VectorXd& z, double lambda) {
  const Eigen::Index n = z.size() - 1;
  RunPeak peak;
  Eigen::VectorXd y(n + 2);
  y << z, lambda;
  Eigen::VectorXd t;
  if (problem.response_tangent(y, t, nullptr)) problem.set_reference(t);
  const NewtonResult solved = solve_fixed_parameter(problem, y, options);
  if (!solved.converged) {
    peak.why = "the peak condition did not converge (" + solved.message + ")";
    return peak;
  }
  PeakCondition::PointShape shape;
  if (problem.shape(solved.y, shape, nullptr) && shape.curvature > 0) {
    peak.why = "the stationary point solved there is a valley of the response curve";
    return peak;
  }
  peak.found = true;
  peak.refined = true;
  peak.y = solved.y.head(n + 1);
  peak.amplitude_m = problem.amplitude(solved.y);
  peak.omega_rad_s = solved.y(n);
  return peak;
}

// dA/dlambda along the peak curve at y, or NaN.
double amplitude_slope(const PeakCondition& problem, const Eigen::VectorXd& y) {
  PeakCondition::PointShape shape;
  if (!problem.shape(y, shape, nullptr) || shape.dy_dlambda.size() != y.size())
    return std::numeric_limits<double>::quiet_NaN();
  return problem.directional_amplitude(y, shape.dy_dlambda);
}

// The optimum between the lowest traced point `best` and the neighbour on its branch where the
// amplitude's slope has the other sign: regula falsi (Illinois) in lambda on dA/dlambda, each
// probe the peak condition solved at fixed lambda from the chord between the bracket's ends.
PeaksResult::SolvedOptimum solve_optimum(const PeakCondition& problem,
                                         const ContinuationOptions& options,
                                         const PeaksResult& result, std::size_t best) {
  PeaksResult::SolvedOptimum out;
  const auto& peaks = result.peaks;
  const Eigen::Index last = peaks[best].y.size() - 1;  // lambda
  const double slope_best = peaks[best].d_amplitude_m_d_parameter;
  std::size_t other = best;
  for (const std::size_t i : {best - 1, best + 1}) {
    if (peaks[i].branch != peaks[best].branch) continue;
    const double s = peaks[i].d_amplitude_m_d_parameter;
    // The side where the amplitude falls towards `best`: dA/dp < 0 before it, > 0 after it,
    // with the parameter increasing or decreasing along the curve.
    if (std::isfinite(s) && std::isfinite(slope_best) && s * slope_best < 0) other = i;
  }
  if (other == best) {
    out.message = "no sign change of the amplitude's sensitivity beside the lowest point";
    return out;
  }
  Eigen::VectorXd ya = peaks[best].y, yb = peaks[other].y;
  double sa = amplitude_slope(problem, ya), sb = amplitude_slope(problem, yb);
  if (!(sa * sb < 0)) {
    out.message = "the amplitude's slope does not change sign between the points";
    return out;
  }
  ContinuationOptions fixed = options;
  int kept_side = 0;  // Illinois: halve the slope of a bracket end kept twice
  for (out.probes = 1; out.probes <= kMaxOptimumProbes; ++out.probes) {
    const double f = sa / (sa - sb);
    Eigen::VectorXd guess = (1 - f) * ya + f * yb;
    Eigen::VectorXd t;
    if (problem.response_tangent(guess, t, nullptr)) problem.set_reference(t);
    const NewtonResult solved = solve_fixed_parameter(problem, guess, fixed);
    if (!solved.converged) {
      out.message = "a probe did not converge: " + solved.message;
      return out;
    }
    const double sc = amplitude_slope(problem, solved.y);
    if (!std::isfinite(sc)) {
      out.message = "the amplitude's slope is not defined at a probe";
      return out;
    }
    const double width = std::abs(yb(last) - ya(last));
    const bool done = std::abs(solved.y(last) - (sc * sa < 0 ? yb(last) : ya(last))) <=
                          kOptimumTolerance * options.unknown_scale(last) ||
                      width <= kOptimumTolerance * options.unknown_scale(last) || sc == 0;
    if (sc * sa > 0) {
      ya = solved.y;
      sa = sc;
      if (kept_side == 2) sb /= 2;
      kept_side = 2;
    } else {
      yb = solved.y;
      sb = sc;
      if (kept_side == 1) sa /= 2;
      kept_side = 1;
    }
    if (done) {
      out.solved = true;
      out.parameter = problem.parameter(solved.y(last));
      out.frequency_hz = solved.y(last - 1) / (2 * std::numbers::pi);
      out.amplitude_m = problem.amplitude(solved.y);
      return out;
    }
  }
  out.message = std::to_string(kMaxOptimumProbes) + " probes did not close the bracket";
  return out;
}

}  // namespace

SceneParameterModels::SceneParameterModels(const Scene& base, const Registry& registry,
                                           std::string path, int contact_threads)
    : base_(base),
      registry_(registry),
      path_(std::move(path)),
      threads_(contact_threads),
      structure_(instantiate_structure(base)) {}

SceneParameterModels::~SceneParameterModels() = default;

const HarmonicBalanceModel& SceneParameterModels::at(double p) const {
  ++clock_;
  for (auto& entry : cache_)
    if (entry.p == p) {
      entry.used = clock_;
      return *entry.model;
    }
  Entry entry;
  entry.p = p;
  entry.used = clock_;
  YAML::Node document = reread_scene_document(base_);
  set_scene_value(document, path_, p);
  entry.scene = std::make_unique<Scene>(load_scene_variant(document, base_));
  bind_plugins(*entry.scene, registry_);
  // A contact's parameter changes the contacts' laws only: the structure's reduction (the modal
  // bases, for an FE sector seconds to fetch) is shared with a model already built.
  const bool contact_parameter = path_.rfind("contacts.", 0) == 0;
  entry.model = contact_parameter && !cache_.empty()
                    ? cache_.front().model->with_contact_params(*entry.scene)
                    : std::make_unique<HarmonicBalanceModel>(*entry.scene, *structure_);
  entry.model->set_contact_threads(threads_);
  if (cache_.size() >= kKept) {
    std::size_t oldest = 0;
    for (std::size_t i = 1; i < cache_.size(); ++i)
      if (cache_[i].used < cache_[oldest].used) oldest = i;
    cache_.erase(cache_.begin() + static_cast<std::ptrdiff_t>(oldest));
  }
  cache_.push_back(std::move(entry));
  return *cache_.back().model;
}

namespace {

// The continuation of the peak curve: the run's options, with the peak curve's scales, the
// parameter's range and no frequency bounds or bands.
ContinuationOptions peak_curve_options(const ContinuationSetup& setup,
                                       const Eigen::VectorXd& z_scale, double lambda_scale,
                                       double lambda_end, const StopToken& stop) {
  const Eigen::Index n = z_scale.size() - 1;
  ContinuationOptions copt = setup.options;
  copt.unknown_scale.resize(n + 2);
  copt.unknown_scale << z_scale, lambda_scale;
  const Eigen::VectorXd r_scale = setup.options.residual_scale.size() == n
                                      ? setup.options.residual_scale
                                      : Eigen::VectorXd::Constant(n, setup.peak);
  copt.residual_scale.resize(n + 1);
  copt.residual_scale << r_scale, setup.peak > 0 ? setup.peak : 1.0;
  copt.lambda_end = lambda_end;
  copt.lambda_min = -std::numeric_limits<double>::infinity();
  copt.lambda_max = std::numeric_limits<double>::infinity();
  copt.step_bands.clear();
  copt.lambda_display = {1.0, ""};
  copt.initial_step = 1e-2;
  copt.min_step = 1e-7;
  copt.max_step = 0.1;
  copt.linear_solver = LinearSolverKind::kDenseLu;
  copt.reuse_factorisation_from = 0;
  copt.newton.stop = stop;
  // The peak condition is a central difference of the measure: its rounding (about 1e-11 of
  // the amplitude) bounds how closely Newton can place the peak along the response curve.
  copt.newton.residual_tolerance = std::max(copt.newton.residual_tolerance, kPeakResidualTolerance);
  copt.newton.step_tolerance = std::max(copt.newton.step_tolerance, kPeakStepTolerance);
  return copt;
}

// A point of the peak curve as reported, its sensitivities from `known` (or computed).
// With `stability` (the scene's output.stability), the point's Floquet multipliers.
TrackedPeak tracked_peak(const PeakCondition& problem, const Eigen::VectorXd& y,
                         int newton_iterations, int branch, const PeakCondition::PointShape* known,
                         const ParameterModels* stability) {
  const Eigen::Index n = y.size() - 2;
  TrackedPeak row;
  row.parameter = problem.parameter(y(n + 1));
  row.frequency_hz = y(n) / (2 * std::numbers::pi);
  row.amplitude_m = problem.amplitude(y);
  row.newton_iterations = newton_iterations;
  row.branch = branch;
  row.y = y;
  row.d_frequency_hz_d_parameter = std::numeric_limits<double>::quiet_NaN();
  row.d_amplitude_m_d_parameter = std::numeric_limits<double>::quiet_NaN();
  PeakCondition::PointShape computed;
  const PeakCondition::PointShape* shape = known;
  if (shape == nullptr && problem.shape(y, computed, nullptr)) shape = &computed;
  if (shape != nullptr && shape->dy_dlambda.size() == n + 2) {
    const Eigen::VectorXd& dy = shape->dy_dlambda;
    const double dp_dlambda = problem.logarithmic() ? row.parameter : 1.0;
    row.d_frequency_hz_d_parameter = dy(n) / (2 * std::numbers::pi) / dp_dlambda;
    row.d_amplitude_m_d_parameter = problem.directional_amplitude(y, dy) / dp_dlambda;
  }
  row.largest_multiplier = std::numeric_limits<double>::quiet_NaN();
  if (stability != nullptr) {
    const FloquetMultipliers floquet =
        floquet_multipliers(stability->at(row.parameter), y.head(n + 1));
    if (floquet.failure.empty()) {
      row.stable = floquet.stable();
      row.largest_multiplier = floquet.largest_modulus;
    }
  }
  return row;
}

// One branch of the peak curve from y0, ended early where its maximum turns into a minimum
// or its steps stall; each accepted point's shape kept by its index.
struct Branch {
  ContinuationSummary summary;
  std::vector<PeakCondition::PointShape> shapes;
  bool became_minimum = false;
  bool stalled = false;
  // The points that are peaks (a point where the maximum had turned is not).
  std::size_t peaks() const { return summary.points.size() - (became_minimum ? 1 : 0); }
  std::string end_reason() const {
    if (became_minimum) return "the traced maximum merged with a valley of the response curve";
    if (stalled)
      return "the peak curve's steps collapsed (a response with corners, as a sample-by-sample "
             "law gives, or a kink of the peak curve where a contact starts to stick)";
    return "the peak curve could not be continued (" + summary.message + ")";
  }
};

Branch trace_branch(const PeakCondition& problem, const ContinuationOptions& copt,
                    const Eigen::VectorXd& y0, std::size_t first_index,
                    const std::string& parameter, const char* label = "peak") {
  const Eigen::Index n = y0.size() - 2;
  Branch branch;
  int short_steps = 0;
  branch.summary =
      trace_curve(problem, y0, copt, [&](const ContinuationPoint& point, std::size_t index) {
        spdlog::info("  {} {}: {} = {}, {} Hz", label, first_index + index, parameter,
                     format_number(problem.parameter(point.y(n + 1))),
                     format_number(point.y(n) / (2 * std::numbers::pi)));
        auto& shapes = branch.shapes;
        if (shapes.size() <= index) shapes.resize(index + 1);
        const bool known = problem.shape(point.y, shapes[index], nullptr);
        if (!known) shapes[index] = {std::numeric_limits<double>::quiet_NaN(), {}};
        if (index > 0 && known && shapes[index].curvature > 0) {
          branch.became_minimum = true;
          return false;
        }
        short_steps = index > 0 && point.step < kStalledStep ? short_steps + 1 : 0;
        if (short_steps >= kStalledPoints) {
          branch.stalled = true;
          return false;
        }
        return true;
      });
  return branch;
}

// A run of `scene` with the parameter at p.
RunResult run_with_parameter(const Scene& scene, const Registry& registry,
                             const std::string& parameter, double p, RunOptions run_options) {
  YAML::Node document = reread_scene_document(scene);
  set_scene_value(document, parameter, p);
  Scene variant = load_scene_variant(document, scene);
  bind_plugins(variant, registry);
  run_options.quiet = true;
  return trace_scene(variant, run_options);
}

// The peak of node k of a run at lambda nearest hz: the run's own solved peak where it is the
// local maximum of the run's curve nearest hz (or the curve has none), else that local maximum
// solved at lambda; where that solve fails (a response with corners), the run's own peak, with
// a note that says so.
RunPeak peak_near(const RunResult& run, std::size_t k, const PeakCondition& problem,
                  const ContinuationOptions& options, double lambda, double hz) {
  const Eigen::Index n = problem.equation_count() - 1;
  const TabulatedCurve curve = tabulated_curve(run, k);
  const std::vector<std::size_t> maxima = local_maxima(curve);
  const auto nearest = nearest_maximum(curve, maxima, hz);
  RunPeak own = run_peak(run, k, n);
  if (!nearest ||
      (own.found &&
       nearest_maximum(curve, maxima, own.omega_rad_s / (2 * std::numbers::pi)) == nearest))
    return own;
  RunPeak solved = solve_peak_at(problem, options, run.summary.points[*nearest].y, lambda);
  if (solved.found || !own.found) return solved;
  own.note = "the run's peak nearest " + format_number(hz) + " Hz (" +
             format_number(curve.frequency_hz[*nearest]) + " Hz) was not solved (" + solved.why +
             "): its highest peak instead";
  return own;
}

// What a run at lambda says of the traced peak there (frequency hz): the highest of its curve's
// other local maxima (all but the one nearest hz), and whether it is higher than that one.
struct RunCheck {
  double lambda = 0.0;
  std::size_t first_peak = 0;  // PeaksResult::peaks' index of the traced point at lambda
  bool other_highest = false;
  Eigen::VectorXd other_z;  // the other's point of the run's curve (empty: no other maximum)
  double other_hz = 0.0;
};

RunCheck check_run(const RunResult& run, std::size_t k, double lambda, double hz,
                   std::size_t first_peak) {
  RunCheck check;
  check.lambda = lambda;
  check.first_peak = first_peak;
  const TabulatedCurve curve = tabulated_curve(run, k);
  const std::vector<std::size_t> maxima = local_maxima(curve);
  const auto mine = nearest_maximum(curve, maxima, hz);
  if (!mine) return check;
  const auto& a = curve.amplitude_m;
  std::size_t other = *mine;
  for (const std::size_t i : maxima)
    if (i != *mine && (other == *mine || a[i] > a[other])) other = i;
  if (other == *mine) return check;
  check.other_highest = a[other] > a[*mine];
  check.other_z = run.summary.points[other].y;
  check.other_hz = curve.frequency_hz[other];
  return check;
}

// y at lambda on the polyline through `points` (its first segment that spans lambda).
std::optional<Eigen::VectorXd> polyline_at(const std::vector<Eigen::VectorXd>& points,
                                           double lambda) {
  for (std::size_t i = 0; i + 1 < points.size(); ++i) {
    const Eigen::Index l = points[i].size() - 1;
    const double a = points[i](l), b = points[i + 1](l);
    if ((lambda - a) * (lambda - b) > 0 || a == b) continue;
    const double f = (lambda - a) / (b - a);
    return Eigen::VectorXd((1 - f) * points[i] + f * points[i + 1]);
  }
  return std::nullopt;
}

// The two peaks solved at lambda from their guesses: the other's amplitude minus the traced
// one's, or why not.
struct ExchangeProbe {
  RunPeak traced, other;
  double difference = 0.0;
  std::string why;
};

ExchangeProbe probe_exchange(const PeakCondition& problem, const ContinuationOptions& options,
                             const Eigen::VectorXd& traced_guess,
                             const Eigen::VectorXd& other_guess, double lambda) {
  const Eigen::Index n = traced_guess.size() - 2;
  ExchangeProbe probe;
  probe.traced = solve_peak_at(problem, options, traced_guess.head(n + 1), lambda);
  probe.other = solve_peak_at(problem, options, other_guess.head(n + 1), lambda);
  if (!probe.traced.found || !probe.other.found)
    probe.why = probe.traced.found ? probe.other.why : probe.traced.why;
  else if (std::abs(probe.other.omega_rad_s - probe.traced.omega_rad_s) <=
           1e-6 * probe.traced.omega_rad_s)
    probe.why = "the two peaks' solves met at one peak";
  probe.difference = probe.other.amplitude_m - probe.traced.amplitude_m;
  return probe;
}

// The crossing of the two peaks' amplitudes between the traced points j and j + 1 (differences
// da and db of opposite signs): regula falsi (Illinois) in lambda.
void solve_exchange(const PeakCondition& problem, const ContinuationOptions& options,
                    const std::vector<Eigen::VectorXd>& other_points, Eigen::VectorXd ta,
                    Eigen::VectorXd tb, double da, double db, PeakExchange& exchange) {
  const Eigen::Index last = ta.size() - 1;
  Eigen::VectorXd oa = *polyline_at(other_points, ta(last));
  Eigen::VectorXd ob = *polyline_at(other_points, tb(last));
  int kept_side = 0;
  for (int step = 1; step <= kMaxExchangeSteps; ++step) {
    const double f = da / (da - db);
    const double lambda = (1 - f) * ta(last) + f * tb(last);
    const ExchangeProbe probe =
        probe_exchange(problem, options, (1 - f) * ta + f * tb, (1 - f) * oa + f * ob, lambda);
    if (!probe.why.empty()) {
      exchange.message = "a step of the crossing's solve failed: " + probe.why;
      return;
    }
    Eigen::VectorXd tc(last + 1), oc(last + 1);
    tc << probe.traced.y, lambda;
    oc << probe.other.y, lambda;
    if (std::abs(probe.difference) <= kExchangeTolerance * probe.traced.amplitude_m) {
      exchange.located = true;
      exchange.parameter = problem.parameter(lambda);
      exchange.amplitude_m = probe.traced.amplitude_m;
      exchange.frequency_hz = probe.traced.omega_rad_s / (2 * std::numbers::pi);
      exchange.other_frequency_hz = probe.other.omega_rad_s / (2 * std::numbers::pi);
      return;
    }
    if (probe.difference * da > 0) {
      ta = tc, oa = oc, da = probe.difference;
      if (kept_side == 2) db /= 2;
      kept_side = 2;
    } else {
      tb = tc, ob = oc, db = probe.difference;
      if (kept_side == 1) da /= 2;
      kept_side = 1;
    }
  }
  exchange.message = std::to_string(kMaxExchangeSteps) + " steps did not meet the tolerance";
}

// The exchange between the runs a and b (one has the other peak highest, the other not): the
// other peak solved at the run where it is the highest and continued towards the other run,
// the difference of the amplitudes at the traced points between them, and its zero solved.
PeakExchange locate_exchange(const PeakCondition& problem, const ContinuationOptions& options,
                             const PeaksResult& result, const RunCheck& a, const RunCheck& b) {
  PeakExchange exchange;
  exchange.overtaken = b.other_highest;
  exchange.bracket_from = problem.parameter(a.lambda);
  exchange.bracket_to = problem.parameter(b.lambda);
  exchange.parameter = exchange.bracket_to;
  if (a.first_peak >= result.peaks.size()) {
    exchange.message = "no traced point at the bracket's start (its branch did not start)";
    return exchange;
  }
  const RunCheck& side = b.other_highest ? b : a;
  exchange.other_frequency_hz = side.other_hz;
  const RunPeak other = solve_peak_at(problem, options, side.other_z, side.lambda);
  if (!other.found) {
    exchange.message = "the other peak was not solved at " +
                       format_number(problem.parameter(side.lambda)) + ": " + other.why;
    return exchange;
  }
  ContinuationOptions along = options;
  along.lambda_start = side.lambda;
  along.lambda_end = b.other_highest ? a.lambda : b.lambda;
  const Eigen::Index n = other.y.size() - 1;
  Eigen::VectorXd y0(n + 2);
  y0 << other.y, side.lambda;
  Eigen::VectorXd t;
  if (problem.response_tangent(y0, t, nullptr)) problem.set_reference(t);
  const Branch branch = trace_branch(problem, along, y0, 0, result.parameter, "other peak");
  std::vector<Eigen::VectorXd> other_points;
  for (std::size_t i = 0; i < branch.peaks(); ++i)
    other_points.push_back(branch.summary.points[i].y);
  // The amplitudes' difference at the traced points between the runs, and its sign change.
  std::optional<std::size_t> previous;
  double previous_difference = 0.0;
  const int on_branch = result.peaks[a.first_peak].branch;
  for (std::size_t j = a.first_peak; j <= b.first_peak && j < result.peaks.size(); ++j) {
    const TrackedPeak& traced = result.peaks[j];
    if (traced.branch != on_branch) break;
    const auto at = polyline_at(other_points, traced.y(n + 1));
    if (!at) continue;
    const double difference = problem.amplitude(*at) - traced.amplitude_m;
    if (previous && difference * previous_difference <= 0) {
      solve_exchange(problem, options, other_points, result.peaks[*previous].y, traced.y,
                     previous_difference, difference, exchange);
      return exchange;
    }
    previous = j;
    previous_difference = difference;
  }
  exchange.message =
      "the crossing lies where one of the two peaks was not traced (the other peak's "
      "continuation: " +
      std::string(branch.summary.reached_end() ? "reached the run" : branch.end_reason()) + ")";
  return exchange;
}

bool interrupted(PeaksResult& result, const StopToken& stop) {
  if (!stop.stop_requested()) return false;
  result.outcome.status = 128 + stop.signal();
  result.outcome.termination = "interrupted";
  result.outcome.message = "stopped by signal " + std::to_string(stop.signal());
  return true;
}

// The lowest traced point, and the optimum solved beside it.
void find_optimum(PeaksResult& result, const PeakCondition& problem,
                  const ContinuationOptions& copt, const StopToken& stop, const std::string& file) {
  if (result.peaks.empty()) return;
  std::size_t best = 0;
  for (std::size_t i = 1; i < result.peaks.size(); ++i)
    if (result.peaks[i].amplitude_m < result.peaks[best].amplitude_m) best = i;
  result.optimum = best;
  result.optimum_at_end = best == 0 || best + 1 == result.peaks.size();
  if (result.optimum_at_end || stop.stop_requested()) return;
  result.solved_optimum = solve_optimum(problem, copt, result, best);
  const auto& solved = result.solved_optimum;
  if (solved.solved)
    spdlog::info("optimum: {} = {}, {} Hz, {} m ({} probes)", result.parameter,
                 format_number(solved.parameter), format_number(solved.frequency_hz),
                 format_number(solved.amplitude_m), solved.probes);
  else
    spdlog::warn(
        "{}: the optimum was not solved between the traced points ({}); the lowest traced "
        "point is reported",
        file, solved.message);
}

// mu / f and 1 / f of the normalised chart: the varied contact's `mu` and the scene's one
// excitation amplitude f.
void normalisation(const Scene& scene, const std::string& path, PeaksResult& result) {
  const auto refuse = [&](const std::string& why) {
    throw SceneError(scene.file.string(), 0, 0, path, "--normalise: " + why);
  };
  const std::string prefix = "contacts.", suffix = ".params.normal_load";
  if (!path.starts_with(prefix) || !path.ends_with(suffix) ||
      path.size() <= prefix.size() + suffix.size())
    refuse(
        "the chart's variable is mu N0 / f: vary a contact's normal load "
        "(contacts.NAME.params.normal_load)");
  const std::string name = path.substr(prefix.size(), path.size() - prefix.size() - suffix.size());
  const ContactSpec* contact = nullptr;
  for (const auto& c : scene.contacts)
    if (c.name == name) contact = &c;
  if (contact == nullptr) refuse("no contact named '" + name + "'");
  const nlohmann::json values = contact->values.to_json(contact->plugin->schema());
  if (!values.contains("mu") || !values["mu"].is_number())
    refuse("law '" + contact->law + "' has no friction coefficient mu");
  if (scene.excitation.size() != 1 || !(std::abs(scene.excitation[0].amplitude) > 0))
    refuse("f is the excitation's amplitude: the scene needs exactly one excitation, not zero");
  const double f = std::abs(scene.excitation[0].amplitude);
  result.mu_over_force = values["mu"].get<double>() / f;
  result.per_force = 1.0 / f;
}

// The result with the range checked and its axis decided.
PeaksResult checked_range(const PeaksOptions& options) {
  if (!(std::isfinite(options.from) && std::isfinite(options.to) && options.from != options.to))
    throw std::invalid_argument("the parameter's range needs two different finite values");
  PeaksResult result;
  result.parameter = options.parameter;
  result.from = options.from;
  result.to = options.to;
  const double lo = std::min(options.from, options.to), hi = std::max(options.from, options.to);
  result.logarithmic = options.logarithmic.value_or(lo > 0 && hi >= 10 * lo);
  if (result.logarithmic && !(lo > 0))
    throw std::invalid_argument("a logarithmic parameter axis needs a range above 0");
  return result;
}

// What the steps of track_peaks share once the start run is done.
struct Tracking {
  const PeaksOptions& options;
  const Scene& scene;
  const Registry& registry;
  RunOptions run_options;
  std::size_t k = 0;
  Eigen::Index n = 0;
  const PeakCondition& problem;
  ContinuationOptions copt;
  const ParameterModels* stability = nullptr;  // the models, with output.stability
  std::vector<RunCheck> checks;                // the runs made, in the parameter's order
  bool end_checked = false;                    // a jump's run was made at the range's end
};

// The branches of the peak curve from y0 and the jumps between them; false when a stop ended
// them. `ended` says why the curve ended before the range's end ("" when it did not).
bool trace_branches(Tracking& t, PeaksResult& result, Eigen::VectorXd y0, std::string& ended) {
  const PeakCondition& problem = t.problem;
  ContinuationOptions& copt = t.copt;
  const Eigen::Index n = t.n;
  const double direction = copt.lambda_end > y0(n + 1) ? 1.0 : -1.0;
  const double lambda_scale = copt.unknown_scale(n + 1);
  for (int b = 0;; ++b) {
    Eigen::VectorXd tangent;
    if (problem.response_tangent(y0, tangent, nullptr)) problem.set_reference(tangent);
    copt.lambda_start = y0(n + 1);
    copt.max_points = std::max(2, t.options.max_points - static_cast<int>(result.peaks.size()));
    spdlog::info("tracking the peak of {} from {} = {} ({} Hz) to {}", result.node,
                 t.options.parameter, format_number(problem.parameter(y0(n + 1))),
                 format_number(y0(n) / (2 * std::numbers::pi)), format_number(t.options.to));
    const Branch branch = trace_branch(problem, copt, y0, result.peaks.size(), t.options.parameter);
    result.termination = to_string(branch.summary.termination);
    result.turning_points += branch.summary.turning_points;
    if (interrupted(result, t.options.stop)) return false;
    const auto& points = branch.summary.points;
    for (std::size_t i = 0; i < branch.peaks(); ++i) {
      const auto& shape = branch.shapes;
      const bool known = i < shape.size() && std::isfinite(shape[i].curvature);
      result.peaks.push_back(tracked_peak(problem, points[i].y, points[i].newton_iterations, b,
                                          known ? &shape[i] : nullptr, t.stability));
    }
    if (branch.summary.reached_end() && !branch.became_minimum && !branch.stalled) return true;
    if (result.peaks.size() >= static_cast<std::size_t>(t.options.max_points)) {
      ended = "max_points";
      return true;
    }
    // The branch ends: jump to the peak of a run a little further on nearest the branch's last.
    const std::string reason = branch.end_reason();
    if (static_cast<int>(result.jumps.size()) >= kMaxPeakJumps) {
      ended = "too many jumps: " + reason;
      return true;
    }
    const Eigen::VectorXd last = branch.peaks() > 0 ? points[branch.peaks() - 1].y : y0;
    double lambda_next = last(n + 1) + direction * kPeakJumpStep * lambda_scale;
    const bool at_end = direction * (lambda_next - copt.lambda_end) >= 0;
    if (at_end) lambda_next = copt.lambda_end;
    PeakJump jump;
    jump.from_parameter = problem.parameter(last(n + 1));
    jump.parameter = problem.parameter(lambda_next);
    jump.from_frequency_hz = last(n) / (2 * std::numbers::pi);
    jump.from_amplitude_m = problem.amplitude(last);
    spdlog::info("{} at {} = {}: a run at {} for the peak to go on from", reason,
                 t.options.parameter, format_number(jump.from_parameter),
                 format_number(jump.parameter));
    const RunResult run =
        run_with_parameter(t.scene, t.registry, t.options.parameter, jump.parameter, t.run_options);
    if (interrupted(result, t.options.stop)) return false;
    const RunPeak jumped = peak_near(run, t.k, problem, copt, lambda_next, jump.from_frequency_hz);
    if (!jumped.found) {
      ended = reason + ", and the run at " + format_number(jump.parameter) + " has no peak (" +
              jumped.why + ")";
      return true;
    }
    jump.to_frequency_hz = jumped.omega_rad_s / (2 * std::numbers::pi);
    jump.to_amplitude_m = jumped.amplitude_m;
    jump.reason = jumped.note.empty() ? reason : reason + "; " + jumped.note;
    result.jumps.push_back(jump);
    spdlog::info("  jump to the peak at {} Hz, {} m", format_number(jump.to_frequency_hz),
                 format_number(jump.to_amplitude_m));
    t.checks.push_back(check_run(run, t.k, lambda_next, jump.to_frequency_hz, result.peaks.size()));
    y0 << jumped.y, lambda_next;
    if (at_end) {
      result.peaks.push_back(tracked_peak(problem, y0, 0, b + 1, nullptr, t.stability));
      result.termination = "reached_end";
      t.end_checked = true;
      return true;
    }
  }
}

// The run at the range's end: its peak nearest the last traced one, and its other peaks.
void check_range_end(Tracking& t, PeaksResult& result) {
  if (t.end_checked || result.peaks.empty()) return;
  const TrackedPeak& last = result.peaks.back();
  const double lambda = last.y(t.n + 1);
  spdlog::info("a run at {} = {} for the peaks there", t.options.parameter,
               format_number(last.parameter));
  const RunResult run =
      run_with_parameter(t.scene, t.registry, t.options.parameter, last.parameter, t.run_options);
  if (t.options.stop.stop_requested()) return;
  const RunPeak peak = peak_near(run, t.k, t.problem, t.copt, lambda, last.frequency_hz);
  if (peak.found) {
    result.end_run.made = true;
    result.end_run.frequency_hz = peak.omega_rad_s / (2 * std::numbers::pi);
    result.end_run.amplitude_m = peak.amplitude_m;
  }
  t.checks.push_back(check_run(run, t.k, lambda, last.frequency_hz, result.peaks.size() - 1));
}

// Runs at PeaksOptions::check_runs traced points between the range's ends (those nearest equal
// steps of lambda, the points of the runs already made excepted), for the exchanges between
// them; the checks then in the order of the peak curve.
void check_between(Tracking& t, PeaksResult& result) {
  const auto& peaks = result.peaks;
  const int runs = t.options.check_runs;
  if (runs <= 0 || peaks.size() < 3) return;
  const double first = peaks.front().y(t.n + 1), last = peaks.back().y(t.n + 1);
  std::vector<bool> checked(peaks.size(), false);
  for (const RunCheck& c : t.checks) checked[std::min(c.first_peak, peaks.size() - 1)] = true;
  for (int r = 1; r <= runs; ++r) {
    const double target = first + (last - first) * r / (runs + 1);
    std::size_t nearest = 0;
    for (std::size_t j = 1; j < peaks.size(); ++j)
      if (std::abs(peaks[j].y(t.n + 1) - target) < std::abs(peaks[nearest].y(t.n + 1) - target))
        nearest = j;
    if (checked[nearest]) continue;
    checked[nearest] = true;
    const TrackedPeak& p = peaks[nearest];
    spdlog::info("a run at {} = {} for the peaks there", t.options.parameter,
                 format_number(p.parameter));
    const RunResult run =
        run_with_parameter(t.scene, t.registry, t.options.parameter, p.parameter, t.run_options);
    if (t.options.stop.stop_requested()) return;
    t.checks.push_back(check_run(run, t.k, p.y(t.n + 1), p.frequency_hz, nearest));
  }
  std::stable_sort(t.checks.begin(), t.checks.end(), [](const RunCheck& a, const RunCheck& b) {
    return a.first_peak < b.first_peak;
  });
}

// The exchanges between the runs made: where the highest of the others changes side.
void find_exchanges(Tracking& t, PeaksResult& result) {
  for (std::size_t i = 0; i + 1 < t.checks.size(); ++i) {
    if (t.checks[i].other_highest == t.checks[i + 1].other_highest) continue;
    if (t.options.stop.stop_requested()) return;
    result.exchanges.push_back(
        locate_exchange(t.problem, t.copt, result, t.checks[i], t.checks[i + 1]));
    const PeakExchange& e = result.exchanges.back();
    if (e.located)
      spdlog::info("the peak at {} Hz {} the traced one at {} = {} ({} m)",
                   format_number(e.other_frequency_hz), e.overtaken ? "overtakes" : "falls below",
                   t.options.parameter, format_number(e.parameter), format_number(e.amplitude_m));
    else
      spdlog::warn("the peak at {} Hz {} the traced one between {} = {} and {} ({})",
                   format_number(e.other_frequency_hz), e.overtaken ? "overtakes" : "falls below",
                   t.options.parameter, format_number(e.bracket_from), format_number(e.bracket_to),
                   e.message);
  }
}

// The start run's local maximum nearest PeaksOptions::near_hz, by point index; nullopt without
// near_hz. Throws nothing: a curve without a local maximum gives nullopt with `why`.
std::optional<std::size_t> start_near(const RunResult& start, std::size_t k,
                                      const PeaksOptions& options, std::string& why) {
  if (!options.near_hz) return std::nullopt;
  const TabulatedCurve curve = tabulated_curve(start, k);
  const auto nearest = nearest_maximum(curve, local_maxima(curve), *options.near_hz);
  if (!nearest) why = "the run's curve has no local maximum of the amplitude";
  return nearest;
}

void no_start_peak(PeaksResult& result, const PeaksOptions& options, const std::string& why) {
  result.outcome.status = kExitIncomplete;
  result.outcome.termination = "no_start_peak";
  result.outcome.message =
      "the run at " + options.parameter + " = " + format_number(options.from) + " has no peak of " +
      result.node +
      (options.near_hz ? " near " + format_number(*options.near_hz) + " Hz" : std::string()) +
      " to start from (" + why + ")";
}

}  // namespace

PeaksResult track_peaks(const PeaksOptions& options) {
  const auto started = Clock::now();
  PeaksResult result = checked_range(options);
  if (options.near_hz && !(std::isfinite(*options.near_hz) && *options.near_hz > 0))
    throw std::invalid_argument("--near takes a frequency above 0 Hz");
  result.near_hz = options.near_hz;

  // The start: an ordinary run at p = from.
  SceneInput input = options.scene;
  input.overrides.push_back({options.parameter, format_scene_value(options.from)});
  const BoundScene bound = load_bound_scene(input);
  const Scene& scene = bound.scene;
  check_parameter_path(scene, options.parameter);
  const std::size_t k = node_index(scene, options.node);
  if (options.normalise) normalisation(scene, options.parameter, result);
  result.scene_file = scene.file;
  result.node = scene.output.response[k];
  result.plots = scene.output.plots;
  spdlog::info("{}: the peak of {} at {} = {}", scene.file.string(), result.node, options.parameter,
               format_number(options.from));
  RunOptions run_options;
  run_options.plots = 0;
  run_options.stop = options.stop;
  run_options.compare_with_tuned = false;  // the peaks need the curves alone
  RunResult start = trace_scene(scene, run_options);
  result.start_seconds = seconds_since(started);
  result.outcome.warnings = start.outcome.warnings;
  if (start.outcome.status >= 128) {
    result.outcome = start.outcome;
    return result;
  }
  const HarmonicBalanceModel& start_model = *start.prepared.model;
  const Eigen::Index n = start_model.equation_count();
  result.unknowns = static_cast<long>(n);
  RunPeak peak = run_peak(start, k, n);
  std::string why = peak.why;
  const std::optional<std::size_t> near_point = start_near(start, k, options, why);
  if (options.near_hz ? !near_point : !peak.found) {
    no_start_peak(result, options, why);
    return result;
  }
  // The peak curve. Scales of its arclength: the start peak's amplitude for the harmonics, a
  // tenth of its frequency for w (a frequency sweep's scales weigh the frequency against its
  // resonance's width instead, and would make the peak curve's steps tiny).
  const auto tracking_started = Clock::now();
  const TabulatedCurve start_curve = tabulated_curve(start, k);
  const double amplitude = near_point ? start_curve.amplitude_m[*near_point] : peak.amplitude_m;
  const double omega =
      near_point ? 2 * std::numbers::pi * start_curve.frequency_hz[*near_point] : peak.omega_rad_s;
  SceneParameterModels models(scene, *bound.registry, options.parameter, 0);
  Eigen::VectorXd z_scale =
      Eigen::VectorXd::Constant(n + 1, amplitude > 0 ? amplitude : start.prepared.setup.u_unit);
  z_scale(n) = 0.1 * omega;
  const double lambda_scale = result.logarithmic ? 1.0 : std::abs(options.to - options.from);
  std::vector<Eigen::Index> kept;
  for (std::size_t d : scene.structure.find(result.node)->dofs)
    kept.push_back(start_model.kept_index(d));
  const PeakCondition problem(models, kept, start_model.layout().harmonics(),
                              std::max(256, 8 * start_model.layout().samples()), z_scale,
                              result.logarithmic, lambda_scale);
  Tracking t{.options = options,
             .scene = scene,
             .registry = *bound.registry,
             .run_options = run_options,
             .k = k,
             .n = n,
             .problem = problem,
             .copt = peak_curve_options(start.prepared.setup, z_scale, lambda_scale,
                                        problem.lambda(options.to), options.stop),
             .stability = scene.output.stability ? &models : nullptr,
             .checks = {},
             .end_checked = false};
  const double lambda_from = problem.lambda(options.from);
  if (near_point) {
    peak = solve_peak_at(problem, t.copt, start.summary.points[*near_point].y, lambda_from);
    if (!peak.found) {
      no_start_peak(result, options, peak.why);
      return result;
    }
  }
  result.start_frequency_hz = peak.omega_rad_s / (2 * std::numbers::pi);
  result.start_amplitude_m = peak.amplitude_m;
  result.start_refined = peak.refined;
  if (!peak.refined)
    result.outcome.warnings.push_back(
        "the start peak is the run's highest traced point, not a solved peak: the tracking "
        "starts from it");
  t.checks.push_back(check_run(start, k, lambda_from, result.start_frequency_hz, 0));
  Eigen::VectorXd y0(n + 2);
  y0 << peak.y, lambda_from;
  std::string ended;
  if (!trace_branches(t, result, y0, ended)) return result;
  if (ended.empty()) check_range_end(t, result);
  check_between(t, result);
  find_exchanges(t, result);
  find_optimum(result, problem, t.copt, options.stop, scene.file.string());
  if (interrupted(result, options.stop)) return result;
  if (!ended.empty()) {
    result.outcome.status = kExitIncomplete;
    result.outcome.termination = result.termination;
    result.outcome.message = "the peak curve ended early: " + ended;
    spdlog::warn("{}: {}", scene.file.string(), result.outcome.message);
  }
  result.tracking_seconds = seconds_since(tracking_started);
  result.wall_seconds = seconds_since(started);
  spdlog::info("{} peaks traced in {} s ({} jumps, {} exchanges; start run {} s)",
               result.peaks.size(), format_number(result.tracking_seconds, 3), result.jumps.size(),
               result.exchanges.size(), format_number(result.start_seconds, 3));
  return result;
}

}  // namespace frichb::core
