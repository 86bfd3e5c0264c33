#include "frichb/core/commands/nma.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>

#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/model/mistuned_disk.hpp"
#include "frichb/core/model/nonlinear_modes.hpp"
#include "frichb/core/plugin_host/periodic_trace.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/plugin_host/schema.hpp"
#include "frichb/core/scene/plugin_checks.hpp"
#include "frichb/core/solver/continuation.hpp"
#include "frichb/core/support/format.hpp"
#include "nma_synthesis.hpp"

namespace frichb::core {

namespace {

// The default range: the amplitudes at which the start mode's largest contact motion is
// kLowestMotion and kHighestMotion (m).
constexpr double kLowestMotion = 1e-9, kHighestMotion = 1e-3;
// Continuation steps in the scaled unknowns (ln a's scale is 1: a step of 0.25 is 28 % in a).
constexpr double kInitialStep = 0.05, kMaxStep = 0.25, kMinStep = 1e-7;

double seconds_since(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// The largest amplitude over the contact components of harmonic k's coefficients in `u`.
double largest_motion(const HarmonicBalanceModel& model, const Eigen::VectorXd& u, std::size_t k) {
  const int c = model.layout().coefficient_count();
  const int ci = model.layout().cos_index(k), si = model.layout().sin_index(k);
  double largest = 0.0;
  for (int a = 0; a < model.component_count(); ++a)
    largest = std::max(largest, std::hypot(u(a * c + ci), u(a * c + si)));
  return largest;
}

// The point's quantities at the backbone's y: the contacts traced at the motion.
// `node`: the kept indices of the response node's DOFs (empty without one); `excitation`: the
// scene's harmonic-1 excitation on the retained modes.
NmaPoint describe(const NonlinearModeProblem& problem, const ContinuationPoint& p,
                  const std::vector<Eigen::Index>& node, const Eigen::VectorXcd& excitation) {
  const HarmonicBalanceModel& model = problem.model();
  const Eigen::Index n = problem.harmonic_unknowns();
  const Eigen::VectorXd z = problem.balance_point(p.y);
  NmaPoint point;
  point.y = p.y;
  point.amplitude = std::exp(p.y(n + 2));
  point.frequency_hz = p.y(n) / (2 * std::numbers::pi);
  point.xi = p.y(n + 1);
  point.damping_ratio = point.xi / (2 * p.y(n));
  point.newton_iterations = p.newton_iterations;
  double samples = 0.0;
  for (std::size_t i = 0; i < model.contacts().size(); ++i) {
    ContactTrace trace;
    std::string error;
    if (!model.trace_contact(i, z, trace, &error))
      throw std::runtime_error("contact " + model.contacts()[i].name + ": " + error);
    point.contact_energy_j += trace.energy_per_cycle;
    const SlipShares shares = slip_shares(trace, model.contacts()[i].tracer->components());
    const auto count = static_cast<double>(trace.force.rows());
    point.stuck += shares.stuck * count;
    point.slipping += shares.slipping * count;
    point.open += shares.open * count;
    samples += count;
  }
  if (samples > 0) {
    point.stuck /= samples;
    point.slipping /= samples;
    point.open /= samples;
  }
  point.contact_motion_m = largest_motion(model, z, problem.first_harmonic());
  const auto& h = model.layout().harmonics();
  double first = 0.0, higher = 0.0;
  for (std::size_t k = 0; k < h.size(); ++k) {
    if (h[k] == 0) continue;
    const int c = model.layout().coefficient_count();
    const int ci = model.layout().cos_index(k), si = model.layout().sin_index(k);
    for (int a = 0; a < model.component_count(); ++a) {
      const double squared = z(a * c + ci) * z(a * c + ci) + z(a * c + si) * z(a * c + si);
      (h[k] == 1 ? first : higher) += squared;
    }
  }
  point.higher_harmonics = first + higher > 0 ? std::sqrt(higher / (first + higher)) : 0.0;
  // One evaluation at z keeps the contact forces there for every mode's coordinate.
  Eigen::VectorXd residual;
  std::string message;
  if (!model.evaluate_autonomous(z, point.xi, residual, nullptr, &message))
    throw std::runtime_error("the backbone's point: " + message);
  const auto modes = model.contact_modes(problem.first_harmonic()).cols();
  point.modal_coordinates.resize(modes);
  const std::size_t k1 = problem.first_harmonic();
  for (Eigen::Index r = 0; r < modes; ++r)
    point.modal_coordinates(r) = model.modal_coordinate(z, point.xi, k1, r);
  // The synthesis's modal force and the node's motion, the residual flexibility's share in
  // each: the contact forces' static motion -F G^H F_1 and the excitation's G F f.
  const Eigen::VectorXcd forces = model.contact_force_amplitudes(z, k1);
  point.modal_force = (point.modal_coordinates / point.amplitude).dot(excitation) -
                      (forces / point.amplitude).dot(model.excitation_flexible_motion(k1));
  if (!node.empty()) {
    const int index = model.receptance_forms()[k1].harmonic_index;
    const ReducedStructure::Basis& basis = model.structure().basis(index);
    const Eigen::VectorXcd flexible =
        model.structure().residual_response(index, -(model.gather(k1).adjoint() * forces));
    point.node_motion = basis.rows(node, Eigen::all) * point.modal_coordinates + flexible(node);
  }
  return point;
}

void check_range(const NmaOptions& options) {
  if (options.mode < 1) throw std::invalid_argument("the mode is counted from 1");
  if (options.from.has_value() != options.to.has_value() ||
      (options.from &&
       !(*options.from > 0 && *options.to > *options.from && std::isfinite(*options.to))))
    throw std::invalid_argument("the amplitude range needs 0 < from < to, both finite");
}

// Refuses a mode the structure does not retain at harmonic 1's harmonic index.
void check_mode_retained(const std::string& file, const HarmonicBalanceModel& model, int mode) {
  for (const auto& form : model.receptance_forms())
    if (form.harmonic == 1 &&
        static_cast<std::size_t>(mode) > model.structure().mode_count(form.harmonic_index))
      throw SceneError(file, 0, 0, "--mode",
                       "mode " + std::to_string(mode) + ": the structure retains " +
                           std::to_string(model.structure().mode_count(form.harmonic_index)) +
                           " modes at harmonic index " + std::to_string(form.harmonic_index));
}

// The result's facts about the structure: the harmonic index, the mode's frequency without
// contacts, the excitation on the retained modes and the response node's modes.
void describe_structure(const Scene& scene, const HarmonicBalanceModel& model,
                        const NonlinearModeProblem& problem, NmaResult& result) {
  const std::size_t k1 = problem.first_harmonic();
  result.harmonic_index = model.receptance_forms()[k1].harmonic_index;
  result.free_frequency_hz =
      model.structure().natural_frequencies(result.harmonic_index)(result.mode - 1) /
      (2 * std::numbers::pi);
  const ReducedStructure::Basis& basis = model.structure().basis(result.harmonic_index);
  result.modal_excitation = basis.rows.adjoint() * model.excitation(k1);
  if (scene.output.response.empty()) return;
  result.node = scene.output.response.front();
  const Eigen::VectorXcd flexible =
      model.structure().residual_response(result.harmonic_index, model.excitation(k1));
  for (const auto& node : scene.structure.nodes)
    if (node.name == result.node) {
      const auto dofs = static_cast<Eigen::Index>(node.dofs.size());
      result.node_modes.resize(dofs, basis.rows.cols());
      result.node_flexible_excitation.resize(dofs);
      for (Eigen::Index d = 0; d < dofs; ++d) {
        const Eigen::Index kept = model.kept_index(node.dofs[static_cast<std::size_t>(d)]);
        result.node_modes.row(d) = basis.rows.row(kept);
        result.node_flexible_excitation(d) = flexible(kept);
      }
    }
}

// Ends the computation early as a result: kExitIncomplete with `termination` and `message`.
void end_early(NmaResult& result, const std::string& file, const std::string& termination,
               const std::string& message) {
  result.outcome.status = kExitIncomplete;
  result.outcome.termination = result.termination = termination;
  result.outcome.message = message;
  spdlog::warn("{}: {}", file, message);
}

void warn(NmaResult& result, const std::string& file, const std::string& warning) {
  spdlog::warn("{}: {}", file, warning);
  result.outcome.warnings.push_back(warning);
}

// A stop requested: the outcome says so (true), else false.
bool stopped(const NmaOptions& options, NmaResult& result) {
  if (!options.stop.stop_requested()) return false;
  result.outcome.status = options.stop.exit_code();
  result.outcome.termination = "interrupted";
  result.outcome.message = options.stop.reason();
  return true;
}

// The continuation's scales: V by its largest entry (m per m sqrt(kg)), harmonic 0's unknowns
// (m) by `static_scale`, w by the start frequency w0, xi by 1 % of it, ln a by 1.
void set_scales(ContinuationOptions& copt, const NonlinearModeProblem& problem,
                double per_amplitude, double static_scale, double w0) {
  const Eigen::Index n = problem.harmonic_unknowns();
  const Eigen::ArrayXd dynamic = problem.dynamic_unknowns().array();
  copt.unknown_scale.resize(n + 3);
  copt.unknown_scale.head(n) =
      (dynamic > 0).select(per_amplitude, Eigen::ArrayXd::Constant(n, static_scale)).matrix();
  copt.unknown_scale(n) = w0;
  copt.unknown_scale(n + 1) = 1e-2 * w0;
  copt.unknown_scale(n + 2) = 1.0;
  copt.residual_scale.resize(n + 2);
  copt.residual_scale.head(n) = copt.unknown_scale.head(n);
  copt.residual_scale(n) = copt.residual_scale(n + 1) = 1.0;
}

// The backbone's first point, at a = from, and the continuation's options.
struct BackboneStart {
  Eigen::VectorXd y;
  ContinuationOptions options;
};

// The start: the linear mode with the contacts at rest, the amplitude range (the default from
// the contact motion), the scales, the solve at `from`. nullopt where the start fails or a
// stop ends it (the outcome says which).
std::optional<BackboneStart> start_backbone(const NonlinearModeProblem& problem,
                                            const NmaOptions& options, const std::string& file,
                                            NmaResult& result) {
  const HarmonicBalanceModel& model = problem.model();
  const Eigen::Index n = problem.harmonic_unknowns();
  Eigen::VectorXd guess;
  try {
    guess = problem.linear_guess(1.0);
  } catch (const std::runtime_error& e) {
    end_early(result, file, "start_failed", e.what());
    return std::nullopt;
  }
  result.start_frequency_hz = guess(n) / (2 * std::numbers::pi);
  const NonlinearModeProblem::RestModes rest = problem.rest_modes();
  result.rest_stiffness = rest.stiffness;
  result.rest_damping = rest.damping;
  result.rest_shapes = rest.shapes;
  result.rest_mode = rest.chosen;
  const double per_amplitude =
      largest_motion(model, guess.head(n), problem.first_harmonic());  // m per m sqrt(kg)
  if (!(per_amplitude > 0))
    throw SceneError(file, 0, 0, "contacts",
                     "mode " + std::to_string(options.mode) + " does not move the contacts");
  result.default_range = !options.from.has_value();
  result.from = options.from.value_or(kLowestMotion / per_amplitude);
  result.to = options.to.value_or(kHighestMotion / per_amplitude);
  spdlog::info(
      "{}: mode {} ({} Hz without contacts, {} Hz with the contacts at rest), amplitude "
      "{} to {} m sqrt(kg)",
      file, options.mode, format_number(result.free_frequency_hz, 6),
      format_number(result.start_frequency_hz, 6), format_number(result.from, 4),
      format_number(result.to, 4));

  // Harmonic 0's unknowns are first scaled by the largest amplitude's motion (a contact that
  // opens moves its mean by about its motion; at small amplitudes the static unknowns are
  // those at rest).
  BackboneStart start;
  ContinuationOptions& copt = start.options;
  const double w0 = guess(n);
  set_scales(copt, problem, per_amplitude, per_amplitude * result.to, w0);
  copt.lambda_start = std::log(result.from);
  copt.lambda_end = std::log(result.to);
  copt.initial_step = kInitialStep;
  copt.max_step = kMaxStep;
  copt.min_step = kMinStep;
  copt.max_points = options.max_points;
  copt.max_wall_seconds = 1e9;
  copt.newton.stop = options.stop;
  guess(n + 2) = copt.lambda_start;
  const NewtonResult solved = solve_fixed_parameter(problem, guess, copt);
  if (stopped(options, result)) return std::nullopt;
  if (!solved.converged) {
    std::string message = "the mode did not converge at a = " + format_number(result.from, 4) +
                          " m sqrt(kg): " + solved.message;
    if (std::abs(result.start_frequency_hz / result.free_frequency_hz - 1) < 1e-12)
      message +=
          " (the contacts carry no stiffness on this mode at rest, open or without a "
          "preload: its start is the free mode, where the equations condensed to the contacts "
          "leave the motion undetermined)";
    end_early(result, file, "start_failed", message);
    return std::nullopt;
  }
  // Harmonic 0's scale: what the start holds (a static load's motion) if larger.
  const Eigen::ArrayXd dynamic = problem.dynamic_unknowns().array();
  set_scales(copt, problem, per_amplitude,
             std::max(per_amplitude * result.to,
                      (solved.y.head(n).array() * (1 - dynamic)).abs().maxCoeff()),
             w0);
  start.y = solved.y;
  return start;
}

// Refinement of the traced backbone (refine_backbone): neighbours whose damping ratios differ
// by more than kRefineDamping of the larger, or whose frequencies by more than kRefineFrequency,
// get a point between them, down to kRefineSmallest in ln a and at most kRefinePoints points
// (and options.max_points in all).
// A change in the damping ratio below kRefineDampingFloor is none (a backbone without
// structural damping is stuck at zero to rounding).
constexpr double kRefineDamping = 0.05, kRefineFrequency = 1e-3, kRefineSmallest = 1e-4;
constexpr double kRefineDampingFloor = 1e-6;
constexpr std::size_t kRefinePoints = 400;

bool needs_point_between(const NmaPoint& p0, const NmaPoint& p1) {
  const double gap = std::log(p1.amplitude / p0.amplitude);
  if (!(gap > kRefineSmallest)) return false;
  const double change = std::abs(p1.damping_ratio - p0.damping_ratio);
  return (change > kRefineDampingFloor &&
          change >
              kRefineDamping * std::max(std::abs(p0.damping_ratio), std::abs(p1.damping_ratio))) ||
         std::abs(p1.frequency_hz - p0.frequency_hz) >
             kRefineFrequency * std::min(p0.frequency_hz, p1.frequency_hz);
}

// The continuation steps in the arclength of the scaled unknowns and does not see where the
// damping ratio turns sharply: where a contact starts to slip (a kink: the dissipated energy
// grows from zero with the motion beyond the stick limit) a step can go from stuck to well
// into slip. The synthesis interpolates between points, so such intervals get points between
// them, solved at fixed amplitude (the midpoint in ln a, from the neighbours' mean), until the
// change is resolved. Returns the points added; an interval whose point does not converge is
// left as it is (counted in `unsolved`).
std::size_t refine_backbone(const NonlinearModeProblem& problem, const ContinuationOptions& copt,
                            const std::vector<Eigen::Index>& node, const NmaOptions& options,
                            NmaResult& result, std::size_t& unsolved) {
  const Eigen::Index n = problem.harmonic_unknowns();
  std::vector<NmaPoint>& points = result.points;
  const std::size_t traced = points.size();
  const auto most = static_cast<std::size_t>(std::max(0, options.max_points));
  const std::size_t limit = std::min(kRefinePoints, most > traced ? most - traced : 0);
  std::size_t added = 0;
  for (std::size_t i = 1; i < points.size();) {
    if (options.stop.stop_requested()) break;
    if (added == limit) {
      for (std::size_t j = i; j < points.size(); ++j)
        if (needs_point_between(points[j - 1], points[j])) {
          warn(result, result.scene_file.string(),
               "the backbone's refinement stopped at " + std::to_string(added) +
                   " added points (its limit): it is coarser above a = " +
                   format_number(points[j - 1].amplitude, 4) + " m sqrt(kg)");
          break;
        }
      break;
    }
    if (!needs_point_between(points[i - 1], points[i])) {
      ++i;
      continue;
    }
    Eigen::VectorXd guess = 0.5 * (points[i - 1].y + points[i].y);
    guess(n + 2) = 0.5 * (std::log(points[i - 1].amplitude) + std::log(points[i].amplitude));
    const NewtonResult solved = solve_fixed_parameter(problem, guess, copt);
    if (!solved.converged) {
      ++unsolved;
      ++i;
      continue;
    }
    ContinuationPoint point;
    point.y = solved.y;
    point.newton_iterations = solved.iterations;
    points.insert(points.begin() + static_cast<std::ptrdiff_t>(i),
                  describe(problem, point, node, result.modal_excitation));
    ++added;
  }
  return added;
}

// Continues the backbone from the start to `to`, describing each point into result.points.
void trace_backbone(const NonlinearModeProblem& problem, const BackboneStart& start,
                    const std::vector<Eigen::Index>& node, const NmaOptions& options,
                    const std::string& file, NmaResult& result) {
  std::string undescribed;  // why a point could not be described (its contacts' trace)
  const ContinuationSummary summary = trace_curve(
      problem, start.y, start.options, [&](const ContinuationPoint& p, std::size_t index) {
        try {
          result.points.push_back(describe(problem, p, node, result.modal_excitation));
        } catch (const std::runtime_error& e) {
          undescribed = e.what();
          return false;
        }
        const NmaPoint& last = result.points.back();
        if (index % 10 == 0)
          spdlog::info("  a = {} m sqrt(kg): {} Hz, damping ratio {}, {} % slipping",
                       format_number(last.amplitude, 4), format_number(last.frequency_hz, 7),
                       format_number(last.damping_ratio, 4), format_number(100 * last.slipping, 3));
        return !options.stop.stop_requested();
      });
  result.termination = to_string(summary.termination);
  if (stopped(options, result)) return;
  if (undescribed.empty()) {
    std::size_t unsolved = 0;
    try {
      const std::size_t added =
          refine_backbone(problem, start.options, node, options, result, unsolved);
      if (added > 0)
        spdlog::info("{}: {} points added where the damping ratio or the frequency turns sharply",
                     file, added);
    } catch (const std::runtime_error& e) {
      warn(result, file, std::string("the backbone's refinement stopped: ") + e.what());
    }
    if (unsolved > 0)
      warn(result, file,
           std::to_string(unsolved) +
               " points between traced ones did not converge: the backbone is coarser there");
    if (stopped(options, result)) return;
  }
  if (!summary.reached_end())
    end_early(result, file, result.termination,
              "the backbone ended early: " +
                  (undescribed.empty() ? summary.message : "a point's contacts: " + undescribed));
}

// The harmonic-balance solve at a synthesised peak; what it throws becomes its message.
void check_level(const Scene& scene, const NonlinearModeProblem& problem, const NmaOptions& options,
                 NmaResult& result, SynthesisedResponse& response) {
  const std::string level = "excitation x " + format_number(response.scale, 6);
  try {
    response.check =
        check_synthesised_peak(scene, problem.model(), problem, result, response, options.stop);
  } catch (const std::exception& e) {
    response.check = SynthesisCheck{};
    response.check.message = e.what();
  }
  result.check_seconds += response.check.seconds;
  if (options.stop.stop_requested()) return;
  if (!response.check.converged) {
    warn(result, scene.file.string(), level + ": " + response.check.message);
    return;
  }
  spdlog::info(
      "{}: synthesised peak {} m at {} Hz (damping ratio {}); the harmonic balance there: {} m "
      "({:+.2e})",
      level, format_number(response.peak.node_amplitude_with_residual_m, 6),
      format_number(response.peak.frequency_hz, 7), format_number(response.peak.damping_ratio, 4),
      format_number(response.check.node_amplitude_m, 6), response.check.error_with_residual);
}

// The full run of a level; what it throws becomes its message.
void run_level(const Scene& scene, const NmaOptions& options, NmaResult& result,
               SynthesisedResponse& response) {
  const std::string level = "excitation x " + format_number(response.scale, 6);
  try {
    const BoundScene scaled = with_excitation_scaled(options.scene, scene, response.scale);
    response.full = compare_with_full_run(scaled.scene, response, options.stop);
  } catch (const std::exception& e) {
    response.full = FullRunComparison{};
    response.full->message = e.what();
  }
  result.full_run_seconds += response.full->seconds;
  if (options.stop.stop_requested()) return;
  if (!response.full->found) {
    warn(result, scene.file.string(), level + ": full run: " + response.full->message);
    return;
  }
  spdlog::info(
      "{}: the full run's peak {} m at {} Hz ({} points, {} s): synthesis {:+.2e} in amplitude, "
      "{:+.2e} in frequency",
      level, format_number(response.full->node_amplitude_m, 6),
      format_number(response.full->frequency_hz, 7), response.full->points,
      format_number(response.full->seconds, 3), response.full->amplitude_error_with_residual,
      response.full->frequency_error);
}

// The forced responses at options.synthesise: each synthesised, its peak checked by one
// harmonic-balance solve, and (options.against_run) the full run traced. A stop ends them
// (the outcome says so).
void synthesise_levels(const Scene& scene, const NonlinearModeProblem& problem,
                       const NmaOptions& options, NmaResult& result) {
  for (const double scale : options.synthesise) {
    if (stopped(options, result)) return;
    const auto synthesising = std::chrono::steady_clock::now();
    SynthesisedResponse& response =
        result.syntheses.emplace_back(synthesise_response(result, scale));
    result.synthesis_seconds += seconds_since(synthesising);
    if (!response.peak.found) {
      warn(result, scene.file.string(),
           "excitation x " + format_number(scale, 6) +
               ": no synthesised peak: " + response.peak.message);
      continue;
    }
    check_level(scene, problem, options, result, response);
    if (options.against_run && !options.stop.stop_requested())
      run_level(scene, options, result, response);
  }
  stopped(options, result);
}

}  // namespace

NmaResult compute_nonlinear_modes(const NmaOptions& options) {
  const auto started = std::chrono::steady_clock::now();
  check_range(options);
  const BoundScene bound = load_bound_scene(options.scene);
  const Scene& scene = bound.scene;
  const std::string file = scene.file.string();
  const auto instance = instantiate_structure(scene);
  StructureModel& structure = *instance;
  check_scene_against_plugins(scene, structure);
  const HarmonicBalanceModel model(scene, structure);
  check_mode_retained(file, model, options.mode);
  NmaResult result;
  result.scene_file = scene.file;
  result.plots = scene.output.plots;
  result.mode = options.mode;
  result.harmonics = scene.harmonic_balance.harmonics;
  result.unknowns = static_cast<long>(model.equation_count());
  std::unique_ptr<NonlinearModeProblem> made;
  try {
    made = std::make_unique<NonlinearModeProblem>(model, options.mode - 1);
  } catch (const std::invalid_argument& e) {
    throw SceneError(file, 0, 0, "harmonic_balance", e.what());
  }
  const NonlinearModeProblem& problem = *made;
  describe_structure(scene, model, problem, result);
  const std::optional<BackboneStart> start = start_backbone(problem, options, file, result);
  std::vector<Eigen::Index> node;  // the response node's kept DOFs
  if (!result.node.empty())
    for (std::size_t d : scene.structure.find(result.node)->dofs)
      node.push_back(model.kept_index(d));
  if (start) trace_backbone(problem, *start, node, options, file, result);
  result.wall_seconds = seconds_since(started);
  if (!start || result.outcome.termination == "interrupted") return result;
  spdlog::info("{}: {} points of the backbone in {} s", file, result.points.size(),
               format_number(result.wall_seconds, 3));
  synthesise_levels(scene, problem, options, result);
  return result;
}

}  // namespace frichb::core
