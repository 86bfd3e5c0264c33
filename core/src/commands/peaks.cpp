#include "frichb/core/commands/peaks.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <stdexcept>
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
  const auto& peak = start.table.peaks.at(k);
  if (!peak || peak->y.size() != n + 1) {
    result.outcome.status = kExitIncomplete;
    result.outcome.termination = "no_start_peak";
    result.outcome.message = "the run at " + options.parameter + " = " +
                             format_number(options.from) + " has no peak of " + result.node +
                             " to start from (" + start.outcome.message + ")";
    return result;
  }
  result.start_frequency_hz = peak->omega_rad_s / (2 * std::numbers::pi);
  result.start_amplitude_m = peak->amplitude_m;
  result.start_refined = peak->refined;
  if (!peak->refined)
    result.outcome.warnings.push_back(
        "the start peak is the run's highest traced point, not a solved peak: the tracking "
        "starts from it");

  // The peak curve.
  const auto tracking_started = Clock::now();
  SceneParameterModels models(scene, *bound.registry, options.parameter, 0);
  const ContinuationSetup& setup = start.prepared.setup;
  // Scales of the peak curve's arclength: the start peak's amplitude for the harmonics, a
  // hundredth of its frequency for w (a frequency sweep's scales weigh the frequency against
  // its resonance's width instead, and would make the peak curve's steps tiny).
  Eigen::VectorXd z_scale =
      Eigen::VectorXd::Constant(n + 1, peak->amplitude_m > 0 ? peak->amplitude_m : setup.u_unit);
  z_scale(n) = 0.1 * peak->omega_rad_s;
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
  copt.lambda_start = problem.lambda(options.from);
  copt.lambda_end = problem.lambda(options.to);
  copt.lambda_min = -std::numeric_limits<double>::infinity();
  copt.lambda_max = std::numeric_limits<double>::infinity();
  copt.step_bands.clear();
  copt.lambda_display = {1.0, ""};
  copt.initial_step = 1e-2;
  copt.min_step = 1e-7;
  copt.max_step = 0.1;
  copt.max_points = options.max_points;
  copt.linear_solver = LinearSolverKind::kDenseLu;
  copt.reuse_factorisation_from = 0;
  copt.newton.stop = options.stop;
  // The peak condition is a central difference of the measure: its rounding (about 1e-11 of
  // the amplitude) bounds how closely Newton can place the peak along the response curve.
  copt.newton.residual_tolerance = std::max(copt.newton.residual_tolerance, kPeakResidualTolerance);
  copt.newton.step_tolerance = std::max(copt.newton.step_tolerance, kPeakStepTolerance);
  Eigen::VectorXd y0(n + 2);
  y0 << peak->y, copt.lambda_start;
  {
    Eigen::VectorXd t;
    std::string why;
    if (problem.response_tangent(y0, t, &why)) problem.set_reference(t);
  }
  spdlog::info("tracking the peak of {} from {} = {} ({} Hz, {} m) to {}", result.node,
               options.parameter, format_number(options.from),
               format_number(result.start_frequency_hz), format_number(result.start_amplitude_m),
               format_number(options.to));
  const ContinuationSummary summary =
      trace_curve(problem, y0, copt, [&](const ContinuationPoint& point, std::size_t index) {
        spdlog::info("  peak {}: {} = {}, {} Hz", index, options.parameter,
                     format_number(problem.parameter(point.y(n + 1))),
                     format_number(point.y(n) / (2 * std::numbers::pi)));
        return true;
      });
  result.termination = to_string(summary.termination);
  result.turning_points = summary.turning_points;
  if (summary.termination == TerminationType::kCancelled && options.stop.stop_requested()) {
    result.outcome.status = 128 + options.stop.signal();
    result.outcome.termination = "interrupted";
    result.outcome.message = "stopped by signal " + std::to_string(options.stop.signal());
    return result;
  }
  for (const ContinuationPoint& point : summary.points) {
    TrackedPeak row;
    const double lambda = point.y(n + 1);
    row.parameter = problem.parameter(lambda);
    row.frequency_hz = point.y(n) / (2 * std::numbers::pi);
    row.amplitude_m = problem.amplitude(point.y);
    row.newton_iterations = point.newton_iterations;
    row.y = point.y;
    row.d_frequency_hz_d_parameter = std::numeric_limits<double>::quiet_NaN();
    row.d_amplitude_m_d_parameter = std::numeric_limits<double>::quiet_NaN();
    Eigen::VectorXd dy;
    if (problem.sensitivity(point.y, dy, nullptr)) {
      const double dp_dlambda = result.logarithmic ? row.parameter : 1.0;
      row.d_frequency_hz_d_parameter = dy(n) / (2 * std::numbers::pi) / dp_dlambda;
      row.d_amplitude_m_d_parameter = problem.directional_amplitude(point.y, dy) / dp_dlambda;
    }
    result.peaks.push_back(row);
  }
  if (!result.peaks.empty()) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < result.peaks.size(); ++i)
      if (result.peaks[i].amplitude_m < result.peaks[best].amplitude_m) best = i;
    result.optimum = best;
    result.optimum_at_end = best == 0 || best + 1 == result.peaks.size();
  }
  if (!summary.reached_end()) {
    result.outcome.status = kExitIncomplete;
    result.outcome.termination = result.termination;
    result.outcome.message = "the peak curve ended early: " + summary.message;
    spdlog::warn("{}: {}", scene.file.string(), result.outcome.message);
  }
  result.tracking_seconds = seconds_since(tracking_started);
  result.wall_seconds = seconds_since(started);
  spdlog::info("{} peaks traced in {} s (start run {} s)", result.peaks.size(),
               format_number(result.tracking_seconds, 3), format_number(result.start_seconds, 3));
  return result;
}

}  // namespace frichb::core
