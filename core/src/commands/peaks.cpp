#include "frichb/core/commands/peaks.hpp"

#include <spdlog/spdlog.h>

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
#include "frichb/core/model/peak_tracking.hpp"
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
      structure_(
          std::make_unique<StructureInstance>(base.structure.plugin, base.structure.values)) {}

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
  entry.model = std::make_unique<HarmonicBalanceModel>(*entry.scene, *structure_);
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

PeaksResult track_peaks(const PeaksOptions& options) {
  const auto started = Clock::now();
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

  // The start: an ordinary run at p = from.
  SceneInput input = options.scene;
  input.overrides.push_back({options.parameter, format_scene_value(options.from)});
  const BoundScene bound = load_bound_scene(input);
  const Scene& scene = bound.scene;
  check_parameter_path(scene, options.parameter);
  const std::size_t k = node_index(scene, options.node);
  result.scene_file = scene.file;
  result.node = scene.output.response[k];
  result.plots = scene.output.plots;
  spdlog::info("{}: the peak of {} at {} = {}", scene.file.string(), result.node, options.parameter,
               format_number(options.from));
  RunOptions run_options;
  run_options.plots = 0;
  run_options.stop = options.stop;
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
  if (!peak.found) {
    result.outcome.status = kExitIncomplete;
    result.outcome.termination = "no_start_peak";
    result.outcome.message = "the run at " + options.parameter + " = " +
                             format_number(options.from) + " has no peak of " + result.node +
                             " to start from (" + peak.why + ")";
    return result;
  }
  result.start_frequency_hz = peak.omega_rad_s / (2 * std::numbers::pi);
  result.start_amplitude_m = peak.amplitude_m;
  result.start_refined = peak.refined;
  if (!peak.refined)
    result.outcome.warnings.push_back(
        "the start peak is the run's highest traced point, not a solved peak: the tracking "
        "starts from it");

  // The peak curve.
  const auto tracking_started = Clock::now();
  SceneParameterModels models(scene, *bound.registry, options.parameter, 0);
  const ContinuationSetup& setup = start.prepared.setup;
  // Scales of the peak curve's arclength: the start peak's amplitude for the harmonics, a
  // tenth of its frequency for w (a frequency sweep's scales weigh the frequency against its
  // resonance's width instead, and would make the peak curve's steps tiny).
  Eigen::VectorXd z_scale =
      Eigen::VectorXd::Constant(n + 1, peak.amplitude_m > 0 ? peak.amplitude_m : setup.u_unit);
  z_scale(n) = 0.1 * peak.omega_rad_s;
  const double lambda_scale = result.logarithmic ? 1.0 : std::abs(options.to - options.from);
  std::vector<Eigen::Index> kept;
  for (std::size_t d : scene.structure.find(result.node)->dofs)
    kept.push_back(start_model.kept_index(d));
  const int samples = std::max(256, 8 * start_model.layout().samples());
  PeakCondition problem(models, kept, start_model.layout().harmonics(), samples, z_scale,
                        result.logarithmic, lambda_scale);
  ContinuationOptions copt = setup.options;
  copt.unknown_scale.resize(n + 2);
  copt.unknown_scale << z_scale, lambda_scale;
  const Eigen::VectorXd r_scale = setup.options.residual_scale.size() == n
                                      ? setup.options.residual_scale
                                      : Eigen::VectorXd::Constant(n, setup.peak);
  copt.residual_scale.resize(n + 1);
  copt.residual_scale << r_scale, setup.peak > 0 ? setup.peak : 1.0;
  copt.lambda_end = problem.lambda(options.to);
  copt.lambda_min = -std::numeric_limits<double>::infinity();
  copt.lambda_max = std::numeric_limits<double>::infinity();
  copt.step_bands.clear();
  copt.lambda_display = {1.0, ""};
  copt.initial_step = 1e-2;
  copt.min_step = 1e-7;
  copt.max_step = 0.1;
  copt.linear_solver = LinearSolverKind::kDenseLu;
  copt.reuse_factorisation_from = 0;
  copt.newton.stop = options.stop;
  // The peak condition is a central difference of the measure: its rounding (about 1e-11 of
  // the amplitude) bounds how closely Newton can place the peak along the response curve.
  copt.newton.residual_tolerance = std::max(copt.newton.residual_tolerance, kPeakResidualTolerance);
  copt.newton.step_tolerance = std::max(copt.newton.step_tolerance, kPeakStepTolerance);

  // Each accepted point's shape (PeakCondition::shape), by its index on the branch.
  std::vector<PeakCondition::PointShape> shapes;
  auto add_point = [&](const Eigen::VectorXd& y, int newton_iterations, int branch,
                       const PeakCondition::PointShape* known) {
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
      const double dp_dlambda = result.logarithmic ? row.parameter : 1.0;
      row.d_frequency_hz_d_parameter = dy(n) / (2 * std::numbers::pi) / dp_dlambda;
      row.d_amplitude_m_d_parameter = problem.directional_amplitude(y, dy) / dp_dlambda;
    }
    result.peaks.push_back(row);
  };

  const double direction = copt.lambda_end > problem.lambda(options.from) ? 1.0 : -1.0;
  Eigen::VectorXd y0(n + 2);
  y0 << peak.y, problem.lambda(options.from);
  std::string ended;  // why the peak curve ended before the range's end ("" when it did not)
  for (int branch = 0;; ++branch) {
    {
      Eigen::VectorXd t;
      if (problem.response_tangent(y0, t, nullptr)) problem.set_reference(t);
    }
    copt.lambda_start = y0(n + 1);
    copt.max_points = std::max(2, options.max_points - static_cast<int>(result.peaks.size()));
    spdlog::info("tracking the peak of {} from {} = {} ({} Hz) to {}", result.node,
                 options.parameter, format_number(problem.parameter(y0(n + 1))),
                 format_number(y0(n) / (2 * std::numbers::pi)), format_number(options.to));
    bool became_minimum = false;
    shapes.clear();
    int short_steps = 0;
    bool stalled = false;
    const ContinuationSummary summary =
        trace_curve(problem, y0, copt, [&](const ContinuationPoint& point, std::size_t index) {
          spdlog::info("  peak {}: {} = {}, {} Hz", result.peaks.size() + index, options.parameter,
                       format_number(problem.parameter(point.y(n + 1))),
                       format_number(point.y(n) / (2 * std::numbers::pi)));
          if (shapes.size() <= index) shapes.resize(index + 1);
          const bool known = problem.shape(point.y, shapes[index], nullptr);
          if (!known) shapes[index] = {std::numeric_limits<double>::quiet_NaN(), {}};
          if (index > 0 && known && shapes[index].curvature > 0) {
            became_minimum = true;
            return false;
          }
          short_steps = index > 0 && point.step < kStalledStep ? short_steps + 1 : 0;
          if (short_steps >= kStalledPoints) {
            stalled = true;
            return false;
          }
          return true;
        });
    result.termination = to_string(summary.termination);
    result.turning_points += summary.turning_points;
    if (options.stop.stop_requested()) {
      result.outcome.status = 128 + options.stop.signal();
      result.outcome.termination = "interrupted";
      result.outcome.message = "stopped by signal " + std::to_string(options.stop.signal());
      return result;
    }
    const std::size_t kept_points = summary.points.size() - (became_minimum ? 1 : 0);
    for (std::size_t i = 0; i < kept_points; ++i)
      add_point(summary.points[i].y, summary.points[i].newton_iterations, branch,
                i < shapes.size() && std::isfinite(shapes[i].curvature) ? &shapes[i] : nullptr);
    if (summary.reached_end() && !became_minimum && !stalled) break;
    if (result.peaks.size() >= static_cast<std::size_t>(options.max_points)) {
      ended = "max_points";
      break;
    }
    // The branch traced ends: its maximum became a minimum (it merged with a valley of the
    // response, a fold of the peak curve), or the continuation could not go on. Jump to the
    // run's peak a little further on.
    const std::string reason =
        became_minimum ? "the traced maximum merged with a valley of the response curve"
        : stalled      ? "the peak curve's steps collapsed (a response with corners: a "
                         "sample-by-sample law)"
                       : "the peak curve could not be continued (" + summary.message + ")";
    if (static_cast<int>(result.jumps.size()) >= kMaxPeakJumps) {
      ended = "too many jumps: " + reason;
      break;
    }
    const Eigen::VectorXd last = kept_points > 0 ? summary.points[kept_points - 1].y : y0;
    double lambda_next = last(n + 1) + direction * kPeakJumpStep * lambda_scale;
    const bool at_end = direction * (lambda_next - copt.lambda_end) >= 0;
    if (at_end) lambda_next = copt.lambda_end;
    const double p_next = problem.parameter(lambda_next);
    spdlog::info("{} at {} = {}: a run at {} for the peak to go on from", reason, options.parameter,
                 format_number(problem.parameter(last(n + 1))), format_number(p_next));
    YAML::Node document = reread_scene_document(scene);
    set_scene_value(document, options.parameter, p_next);
    Scene next_scene = load_scene_variant(document, scene);
    bind_plugins(next_scene, *bound.registry);
    RunOptions quiet = run_options;
    quiet.quiet = true;
    RunResult next = trace_scene(next_scene, quiet);
    if (options.stop.stop_requested()) {
      result.outcome.status = 128 + options.stop.signal();
      result.outcome.termination = "interrupted";
      result.outcome.message = "stopped by signal " + std::to_string(options.stop.signal());
      return result;
    }
    const RunPeak jumped = run_peak(next, k, n);
    if (!jumped.found) {
      ended = reason + ", and the run at " + format_number(p_next) + " has no peak (" + jumped.why +
              ")";
      break;
    }
    PeakJump jump;
    jump.parameter = p_next;
    jump.from_parameter = problem.parameter(last(n + 1));
    jump.from_frequency_hz = last(n) / (2 * std::numbers::pi);
    jump.from_amplitude_m = problem.amplitude(last);
    jump.to_frequency_hz = jumped.omega_rad_s / (2 * std::numbers::pi);
    jump.to_amplitude_m = jumped.amplitude_m;
    jump.reason = reason;
    result.jumps.push_back(jump);
    spdlog::info("  jump to the peak at {} Hz, {} m", format_number(jump.to_frequency_hz),
                 format_number(jump.to_amplitude_m));
    y0.resize(n + 2);
    y0 << jumped.y, lambda_next;
    if (at_end) {
      add_point(y0, 0, branch + 1, nullptr);
      result.termination = "reached_end";
      break;
    }
  }
  if (!result.peaks.empty()) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < result.peaks.size(); ++i)
      if (result.peaks[i].amplitude_m < result.peaks[best].amplitude_m) best = i;
    result.optimum = best;
    result.optimum_at_end = best == 0 || best + 1 == result.peaks.size();
    if (!result.optimum_at_end && !options.stop.stop_requested())
      result.solved_optimum = solve_optimum(problem, copt, result, best);
    if (result.solved_optimum.solved)
      spdlog::info("optimum: {} = {}, {} Hz, {} m ({} probes)", options.parameter,
                   format_number(result.solved_optimum.parameter),
                   format_number(result.solved_optimum.frequency_hz),
                   format_number(result.solved_optimum.amplitude_m), result.solved_optimum.probes);
    else if (!result.optimum_at_end)
      spdlog::warn(
          "{}: the optimum was not solved between the traced points ({}); the lowest "
          "traced point is reported",
          scene.file.string(), result.solved_optimum.message);
  }
  if (!ended.empty()) {
    result.outcome.status = kExitIncomplete;
    result.outcome.termination = result.termination;
    result.outcome.message = "the peak curve ended early: " + ended;
    spdlog::warn("{}: {}", scene.file.string(), result.outcome.message);
  }
  result.tracking_seconds = seconds_since(tracking_started);
  result.wall_seconds = seconds_since(started);
  spdlog::info("{} peaks traced in {} s ({} jumps; start run {} s)", result.peaks.size(),
               format_number(result.tracking_seconds, 3), result.jumps.size(),
               format_number(result.start_seconds, 3));
  return result;
}

}  // namespace frichb::core
