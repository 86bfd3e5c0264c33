// Pseudo-arclength continuation: the driver (trace_curve) and the fixed-parameter solve.
// Its units sit beside it in solver/: the scaled view of the problem (scaled_problem), the
// linear-solver seam (linear_solver), the correctors (corrector), the tangents and their
// orientation (tangent), corners and kinks (corners) and the step (step_controller).
#include "frichb/core/solver/continuation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "frichb/core/support/interrupt.hpp"
#include "solver/corners.hpp"
#include "solver/corrector.hpp"
#include "solver/scaled_problem.hpp"
#include "solver/step_controller.hpp"
#include "solver/tangent.hpp"

namespace frichb::core {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kInf = std::numeric_limits<double>::infinity();

bool Fail(std::string* why, const std::string& reason) {
  if (why != nullptr) *why = reason;
  return false;
}

bool PositiveFinite(double v) {
  return std::isfinite(v) && v > 0.0;
}

// Why and how a traced curve ended.
struct Ending {
  TerminationType type;
  std::string reason;
};

// The ending of a trace stopped through its token (support/interrupt.hpp).
Ending interruption(const StopToken& stop) {
  return Ending{TerminationType::kCancelled, stop.reason()};
}

// One traced curve: the driver's state between steps. trace() finds the start point, then
// tries steps from the last point until an Ending: each attempt predicts along the tangent,
// corrects (chord iterations on the kept factorisation, else damped Newton), checks for a
// jump or a corner, steps past a kink after repeated failures, and either undoes the points
// past a fold (turning-point control), lands on lambda_end, rejects the step or accepts the
// point. Not thread-safe; one per call of trace_curve.
class CurveTracer {
 public:
  CurveTracer(const CurveProblem& problem, const ContinuationOptions& options,
              const PointCallback& on_point)
      : raw_problem_(problem),
        options_(options),
        newton_(options.newton),
        on_point_(on_point),
        n_(problem.equation_count()),
        direction_(options.lambda_end > options.lambda_start ? 1.0 : -1.0),
        steps_(options),
        chord_(options.reuse_factorisation_from > 0 && n_ >= options.reuse_factorisation_from) {}

  ContinuationSummary trace(const VectorXd& y_guess);

 private:
  // Correction / step of the last too-long correction beyond which no corner is taken: a turn
  // of at most 89.94 degrees.
  static constexpr double kMaxCornerRatio = 1e3;
  // Failed corrections from one point after which a step past a kink is tried.
  static constexpr int kKinkStepAfterFailures = 4;

  double elapsed() const { return seconds_since(clock_start_); }
  bool emit(const ContinuationPoint& p) {
    summary_.points.push_back(p);
    summary_.points.back().record = raw_problem_.point_record(p.y);
    return !on_point_ || on_point_(summary_.points.back(), summary_.points.size() - 1);
  }
  ContinuationSummary finish(const Ending& ending);
  std::optional<Ending> start(const VectorXd& y_guess);
  std::optional<Ending> limits_reached(long attempt) const;
  std::optional<Ending> attempt_step();
  Correction correct(const ContinuationPoint& last, const VectorXd& predictor);
  bool across_corner(const ContinuationPoint& last, const VectorXd& ys_last,
                     const VectorXd& predictor, double step, Correction* corr);
  void restart_at_fold(double step);
  std::optional<Ending> land_on_end(const ContinuationPoint& last, const ContinuationPoint& p,
                                    const VectorXd& ys_last, double step, std::string* failure);
  std::optional<Ending> accept(const ContinuationPoint& last, const ContinuationPoint& p,
                               const Correction& corr, double step, bool sign_change);
  void forget_failures() {
    failures_here_ = 0;
    kink_reference_.reset();
    corner_repeats_ = 0;  // the corner test starts afresh from the next point
    corner_ratio_ = kInf;
  }

  const CurveProblem& raw_problem_;
  const ContinuationOptions& options_;
  const NewtonOptions& newton_;
  const PointCallback& on_point_;
  const Index n_;
  const double direction_;
  const std::chrono::steady_clock::time_point clock_start_ = std::chrono::steady_clock::now();
  ContinuationSummary summary_;
  std::optional<ScaledProblem> problem_;  // once the options are valid
  StepController steps_;
  // Correction / step of the last too-long correction, and how many times in a row it
  // repeated (within 10 %) as the step was halved at this point.
  double corner_ratio_ = kInf;
  int corner_repeats_ = 0;
  int failures_here_ = 0;                        // failed corrections since the last point
  std::optional<KinkReference> kink_reference_;  // of the last point, once a kink step is tried
  std::size_t fold_floor_ = 0;  // restarts never undo an accepted fold (no ping-pong)
  // Chord corrector (ContinuationOptions::reuse_factorisation_from): the factorisation of the
  // Keller matrix at the point of index kept_index_, and the one of a candidate point.
  const bool chord_;
  KellerFactor kept_, candidate_;
  std::size_t kept_index_ = std::numeric_limits<std::size_t>::max();
};

ContinuationSummary CurveTracer::finish(const Ending& ending) {
  summary_.termination = ending.type;
  summary_.message = ending.reason;
  if (!summary_.points.empty())
    summary_.message += " (last point at " +
                        format_lambda(summary_.points.back().y(n_), options_.lambda_display) + ")";
  summary_.turning_points = 0;
  summary_.residual_floor_points = 0;
  summary_.corners = 0;
  summary_.kink_steps = 0;
  summary_.max_condition = 0.0;
  summary_.max_condition_point = 0;
  for (std::size_t i = 0; i < summary_.points.size(); ++i) {
    const auto& point = summary_.points[i];
    summary_.residual_floor_points += point.at_residual_floor;
    summary_.corners += point.passed_corner;
    summary_.kink_steps += point.passed_kink;
    if (point.condition > summary_.max_condition) {
      summary_.max_condition = point.condition;
      summary_.max_condition_point = i;
    }
  }
  for (std::size_t i = 1; i < summary_.points.size(); ++i)
    if (summary_.points[i - 1].tangent(n_) * summary_.points[i].tangent(n_) < 0.0)
      ++summary_.turning_points;
  summary_.wall_seconds = elapsed();
  problem_.reset();  // it counts into summary_.profile, which leaves with the summary
  return std::move(summary_);
}

// Validates the options, then solves at lambda_start (fixed-parameter Newton) and takes the
// first tangent (eq. 4.9); emits the start point.
std::optional<Ending> CurveTracer::start(const VectorXd& y_guess) {
  std::string why;
  if (!options_.IsValid(&why)) return Ending{TerminationType::kInvalidOptions, why};
  Scaling s;
  if (n_ < 1) return Ending{TerminationType::kInvalidOptions, "problem has no equations"};
  if (y_guess.size() != n_ + 1)
    return Ending{TerminationType::kInvalidOptions, "y_guess must have n + 1 entries"};
  if (!make_scaling(options_, n_, &s, &why)) return Ending{TerminationType::kInvalidOptions, why};
  problem_.emplace(raw_problem_, std::move(s), options_, &summary_.profile);

  VectorXd ys0 = problem_->scale(y_guess);
  ys0(n_) = options_.lambda_start / problem_->scaling().unknown(n_);
  const Correction start = newton_correct(*problem_, ys0, newton_);
  summary_.total_newton_iterations += start.iterations;
  if (!start.converged && newton_.stop.stop_requested()) return interruption(newton_.stop);
  if (start.first_evaluation_failed)
    return Ending{TerminationType::kEvaluationFailed, "start point: " + start.message};
  if (!start.converged)
    return Ending{TerminationType::kStartFailed, "start point: " + start.message};
  ContinuationPoint first;
  first.y = problem_->unscale(start.ys);
  first.y(n_) = options_.lambda_start;
  if (!first_tangent(start.js, direction_, problem_->linear(), &first.tangent, &first.condition,
                     &first.orientation))
    return Ending{TerminationType::kStartFailed,
                  "start point: singular e_x, no tangent at " +
                      format_lambda(first.y(n_), options_.lambda_display)};
  first.newton_iterations = start.iterations;
  first.residual_norm = start.residual_norm;
  first.at_residual_floor = start.at_residual_floor;
  if (!emit(first)) return Ending{TerminationType::kCancelled, "cancelled by callback"};
  return std::nullopt;
}

std::optional<Ending> CurveTracer::limits_reached(long attempt) const {
  const long max_attempts = 64L * options_.max_points + 1000L;
  if (summary_.points.size() >= static_cast<std::size_t>(options_.max_points))
    return Ending{TerminationType::kMaxPoints, "max_points reached"};
  if (attempt >= max_attempts)
    return Ending{TerminationType::kMaxPoints, "step attempt budget exhausted"};
  if (elapsed() > options_.max_wall_seconds)
    return Ending{TerminationType::kTimeLimit, "max_wall_seconds elapsed"};
  if (newton_.stop.stop_requested()) return interruption(newton_.stop);
  return std::nullopt;
}

ContinuationSummary CurveTracer::trace(const VectorXd& y_guess) {
  if (auto ending = start(y_guess)) return finish(*ending);
  for (long attempt = 0;; ++attempt) {
    if (auto ending = limits_reached(attempt)) return finish(*ending);
    if (auto ending = attempt_step()) return finish(*ending);
  }
}

// Chord iterations on the factorisation kept from the last point when there is one, full
// Newton from their best iterate when they give up; damped Newton otherwise.
Correction CurveTracer::correct(const ContinuationPoint& last, const VectorXd& predictor) {
  if (!(chord_ && kept_index_ == summary_.points.size() - 1))
    return newton_correct(*problem_, predictor, newton_, &last.tangent, &predictor);
  Correction corr = chord_correct(*problem_, kept_, newton_, last.tangent, predictor,
                                  options_.max_chord_iterations);
  summary_.chord_iterations += corr.chord_iterations;
  if (corr.converged) {
    ++summary_.chord_points;
    return corr;
  }
  ++summary_.chord_fallbacks;
  const int chord_iterations = corr.chord_iterations;
  const VectorXd best = corr.ys;
  corr = newton_correct(*problem_, best, newton_, &last.tangent, &predictor);
  corr.iterations += chord_iterations;
  corr.chord_iterations = chord_iterations;
  return corr;
}

// A correction longer than the step cannot come from the branch's own curvature: the
// corrector has jumped onto another branch - unless the branch has a corner here (a contact
// changing regime, the tangent turning by more than 45 degrees). A corner is recognised at
// once when the tangent lines meet on the branch (corner_between), or when the correction
// shrinks in proportion as the step is halved: once the ratio of correction to step has
// repeated over three halvings the point across it is taken. False (and the correction marked
// as a jump) when it is no corner.
bool CurveTracer::across_corner(const ContinuationPoint& last, const VectorXd& ys_last,
                                const VectorXd& predictor, double step, Correction* corr) {
  const double ratio = (corr->ys - predictor).norm() / step;
  corner_repeats_ = std::abs(ratio / corner_ratio_ - 1.0) < 0.1 ? corner_repeats_ + 1 : 0;
  corner_ratio_ = ratio;
  VectorXd landed_tangent;
  const bool repeated = corner_repeats_ >= 2 && ratio <= kMaxCornerRatio;
  const bool corner =
      repeated || (next_tangent(corr->js, last.tangent, problem_->linear(), &landed_tangent) &&
                   corner_between(*problem_, newton_, ys_last, last.tangent, corr->ys,
                                  landed_tangent, 1.0 / kMaxCornerRatio));
  if (!corner) corr->message = "corrector jumped away from the predictor";
  return corner;
}

// Points kept: at least up to the last accepted fold; the new point is always undone. The
// step controller retraces with the fine step.
void CurveTracer::restart_at_fold(double step) {
  const std::size_t total = summary_.points.size() + 1;
  const auto backtrack = static_cast<std::size_t>(options_.turning_point_backtrack);
  const std::size_t keep =
      std::max(fold_floor_ + 1, total > backtrack ? total - backtrack : std::size_t{1});
  summary_.rejected_steps += static_cast<int>(total - keep);
  summary_.points.resize(keep);
  ++summary_.fine_control_restarts;
  forget_failures();
  steps_.on_fold(step);
}

// The point p passed lambda_end: land exactly on it from the chord between the last two points
// (a fixed-parameter Newton solve), or end at p when land_on_end is off. nullopt, with
// `failure`, when the landing failed (the step is then rejected).
std::optional<Ending> CurveTracer::land_on_end(const ContinuationPoint& last,
                                               const ContinuationPoint& p, const VectorXd& ys_last,
                                               double step, std::string* failure) {
  if (!options_.land_on_end) {
    emit(p);
    return Ending{TerminationType::kReachedEnd, "passed lambda_end"};
  }
  const double t = (options_.lambda_end - last.y(n_)) / (p.y(n_) - last.y(n_));
  VectorXd guess = last.y + t * (p.y - last.y);
  guess(n_) = options_.lambda_end;
  const VectorXd guess_s = problem_->scale(guess);
  const Correction land = newton_correct(*problem_, guess_s, newton_);
  summary_.total_newton_iterations += land.iterations;
  ContinuationPoint end;
  if (land.converged && (land.ys - guess_s).norm() <= step &&
      next_tangent(land.js, p.tangent, problem_->linear(), &end.tangent, &end.condition, nullptr,
                   &end.orientation)) {
    if (keep_orientation(last.orientation, p.tangent, &end, nullptr)) ++summary_.reversed_tangents;
    end.y = problem_->unscale(land.ys);
    end.y(n_) = options_.lambda_end;
    end.newton_iterations = land.iterations;
    end.step = (land.ys - ys_last).norm();
    end.residual_norm = land.residual_norm;
    end.at_residual_floor = land.at_residual_floor;
    emit(end);
    return Ending{TerminationType::kReachedEnd, "reached lambda_end"};
  }
  *failure =
      "landing on lambda_end failed" + (land.message.empty() ? std::string() : ": " + land.message);
  return std::nullopt;
}

// The point is accepted: the step grows by eq. 4.13 (a chord iteration weighs
// kChordIterationWeight), the steep-branch cap starts where the tangent's unknowns jumped, the
// candidate factorisation becomes the kept one, and the point is emitted.
std::optional<Ending> CurveTracer::accept(const ContinuationPoint& last, const ContinuationPoint& p,
                                          const Correction& corr, double step, bool sign_change) {
  forget_failures();
  if (sign_change) fold_floor_ = summary_.points.size();
  const double effective_iterations =
      (corr.iterations - corr.chord_iterations) + kChordIterationWeight * corr.chord_iterations;
  const bool steep =
      p.tangent.head(n_).norm() > options_.steep_branch_alpha * last.tangent.head(n_).norm();
  if (steps_.on_accept(step, effective_iterations, sign_change, steep))
    ++summary_.steep_branch_caps;
  if (chord_) {
    std::swap(kept_, candidate_);
    kept_index_ = summary_.points.size();  // the index p takes
  }
  if (!emit(p)) return Ending{TerminationType::kCancelled, "cancelled by callback"};
  return std::nullopt;
}

std::optional<Ending> CurveTracer::attempt_step() {
  const ContinuationPoint& last = summary_.points.back();
  const double step = steps_.propose(last.y(n_), last.tangent(n_), problem_->scaling().unknown(n_));
  const VectorXd ys_last = problem_->scale(last.y);
  const VectorXd predictor = ys_last + step * last.tangent;
  Correction corr = correct(last, predictor);
  summary_.total_newton_iterations += corr.iterations;
  bool ok = corr.converged;
  bool corner = false;
  if (ok && (corr.ys - predictor).norm() > step) {
    corner = across_corner(last, ys_last, predictor, step, &corr);
    ok = corner;
  }
  // The tangent at the new point is oriented along the direction of travel into it. After a
  // few failed corrections from the last point, each further step is also tried past the kink
  // along the next piece's tangent; its point is taken like any other.
  VectorXd travel = last.tangent;
  bool kink_step = false;
  if (!ok && (failures_here_ + 1 >= kKinkStepAfterFailures || step <= options_.min_step)) {
    Correction across;
    VectorXd across_direction;
    if (!kink_reference_) kink_reference_ = make_kink_reference(*problem_, summary_.points);
    if (step_past_kink(*problem_, newton_, ys_last, last.tangent, step, *kink_reference_, &across,
                       &across_direction)) {
      summary_.total_newton_iterations += across.iterations;
      corr = std::move(across);
      travel = across_direction;
      ok = corner = kink_step = true;
    }
  }
  KellerFactor* keep = chord_ ? &candidate_ : nullptr;
  ContinuationPoint p;
  if (ok && !next_tangent(corr.js, travel, problem_->linear(), &p.tangent, &p.condition, keep,
                          &p.orientation)) {
    ok = false;
    corr.message = "singular bordered Jacobian, no tangent";
  }
  if (ok && keep_orientation(last.orientation, travel, &p, keep)) ++summary_.reversed_tangents;

  bool sign_change = false;
  if (ok) {
    p.y = problem_->unscale(corr.ys);
    const bool past_end = (p.y(n_) - options_.lambda_end) * direction_ >= 0.0;
    if (!past_end && (p.y(n_) < options_.lambda_min || p.y(n_) > options_.lambda_max)) {
      std::ostringstream msg;
      msg << "the curve left the window from "
          << format_lambda(options_.lambda_min, options_.lambda_display) << " to "
          << format_lambda(options_.lambda_max, options_.lambda_display) << " at "
          << format_lambda(p.y(n_), options_.lambda_display);
      return Ending{TerminationType::kLeftBounds, msg.str()};
    }
    p.newton_iterations = corr.iterations;
    p.step = step;
    p.residual_norm = corr.residual_norm;
    p.at_residual_floor = corr.at_residual_floor;
    p.passed_corner = corner;
    p.passed_kink = kink_step;
    sign_change = last.tangent(n_) * p.tangent(n_) < 0.0;
    // A fold at a kink is accepted at once: no finer step gets around it.
    if (sign_change && options_.turning_point_control && !steps_.refining() && !kink_step) {
      restart_at_fold(step);
      return std::nullopt;
    }
    if (past_end) {
      if (auto ending = land_on_end(last, p, ys_last, step, &corr.message)) return ending;
      ok = false;
    }
  }
  if (!ok) {
    ++summary_.rejected_steps;
    ++failures_here_;
    if (steps_.on_reject(step)) return std::nullopt;
    std::ostringstream msg;
    msg << "step below min_step " << options_.min_step << ": " << corr.message;
    return Ending{TerminationType::kStepTooSmall, msg.str()};
  }
  return accept(last, p, corr, step, sign_change);
}

}  // namespace

const char* to_string(TerminationType t) {
  switch (t) {
    case TerminationType::kReachedEnd:
      return "reached_end";
    case TerminationType::kMaxPoints:
      return "max_points";
    case TerminationType::kStepTooSmall:
      return "step_too_small";
    case TerminationType::kStartFailed:
      return "start_failed";
    case TerminationType::kEvaluationFailed:
      return "evaluation_failed";
    case TerminationType::kTimeLimit:
      return "time_limit";
    case TerminationType::kLeftBounds:
      return "left_bounds";
    case TerminationType::kCancelled:
      return "cancelled";
    case TerminationType::kInvalidOptions:
      return "invalid_options";
  }
  return "unknown";
}

bool ContinuationOptions::IsValid(std::string* why) const {
  if (!std::isfinite(lambda_start) || !std::isfinite(lambda_end))
    return Fail(why, "lambda_start and lambda_end must be finite");
  if (lambda_start == lambda_end) return Fail(why, "lambda_end must differ from lambda_start");
  if (!PositiveFinite(min_step) || !PositiveFinite(max_step) || !PositiveFinite(initial_step))
    return Fail(why, "initial_step, min_step and max_step must be positive");
  if (min_step > max_step) return Fail(why, "min_step must not exceed max_step");
  if (std::isnan(lambda_min) || std::isnan(lambda_max) || !(lambda_min < lambda_max))
    return Fail(why, "lambda_min must be below lambda_max");
  if (lambda_start < lambda_min || lambda_start > lambda_max || lambda_end < lambda_min ||
      lambda_end > lambda_max)
    return Fail(why, "lambda_start and lambda_end must lie in [lambda_min, lambda_max]");
  if (initial_step < min_step || initial_step > max_step)
    return Fail(why, "initial_step must lie in [min_step, max_step]");
  if (target_newton_iterations < 1) return Fail(why, "target_newton_iterations must be >= 1");
  if (max_points < 1) return Fail(why, "max_points must be >= 1");
  if (!(lambda_display.per_unit > 0.0) || !std::isfinite(lambda_display.per_unit))
    return Fail(why, "lambda_display.per_unit must be finite and positive");
  if (!(max_wall_seconds > 0.0)) return Fail(why, "max_wall_seconds must be positive");
  if (turning_point_control) {
    if (turning_point_backtrack < 1) return Fail(why, "turning_point_backtrack must be >= 1");
    if (!(turning_point_refinement > 0.0 && turning_point_refinement < 1.0))
      return Fail(why, "turning_point_refinement must lie in (0, 1)");
  }
  if (steep_branch_control) {
    if (!(steep_branch_alpha > 1.0) || !std::isfinite(steep_branch_alpha))
      return Fail(why, "steep_branch_alpha must be > 1");
    if (!(steep_branch_step_factor > 0.0 && steep_branch_step_factor <= 1.0))
      return Fail(why, "steep_branch_step_factor must lie in (0, 1]");
    if (steep_branch_points < 0) return Fail(why, "steep_branch_points must be >= 0");
  }
  if (!unknown_scale.allFinite() || (unknown_scale.array() <= 0.0).any())
    return Fail(why, "unknown_scale entries must be positive and finite");
  if (!residual_scale.allFinite() || (residual_scale.array() <= 0.0).any())
    return Fail(why, "residual_scale entries must be positive and finite");
  if (newton.max_iterations < 1) return Fail(why, "newton.max_iterations must be >= 1");
  if (!PositiveFinite(newton.residual_tolerance) || !PositiveFinite(newton.step_tolerance))
    return Fail(why, "newton tolerances must be positive");
  if (reuse_factorisation_from < 0) return Fail(why, "reuse_factorisation_from must be >= 0");
  if (max_chord_iterations < 1) return Fail(why, "max_chord_iterations must be >= 1");
  if (gmres_from < 0) return Fail(why, "gmres_from must be >= 0");
  if (!(gmres_tolerance > 0.0 && gmres_tolerance < 1.0))
    return Fail(why, "gmres_tolerance must lie in (0, 1)");
  if (!(gmres_update_tolerance > 0.0 && gmres_update_tolerance < 1.0))
    return Fail(why, "gmres_update_tolerance must lie in (0, 1)");
  if (gmres_max_iterations < 1) return Fail(why, "gmres_max_iterations must be >= 1");
  if (gmres_refresh_iterations < 0) return Fail(why, "gmres_refresh_iterations must be >= 0");
  if (matrix_free_from < 0) return Fail(why, "matrix_free_from must be >= 0");
  if (matrix_free_dense_limit < 0) return Fail(why, "matrix_free_dense_limit must be >= 0");
  if (newton.max_line_search_halvings < 0)
    return Fail(why, "newton.max_line_search_halvings must be >= 0");
  return true;
}

namespace {

// One fixed-parameter Newton solve on `scaled` from the unscaled guess.
NewtonResult solve_scaled_fixed(const ScaledProblem& scaled, const VectorXd& y_guess,
                                const NewtonOptions& newton) {
  NewtonResult result;
  const Index n = scaled.equations();
  const Correction core = newton_correct(scaled, scaled.scale(y_guess), newton);
  result.converged = core.converged;
  result.iterations = core.iterations;
  result.residual_norm = core.residual_norm;
  result.at_residual_floor = core.at_residual_floor;
  result.y = scaled.unscale(core.ys);
  result.y(n) = y_guess(n);  // unscaling must not perturb the fixed parameter
  result.message = core.message;
  return result;
}

}  // namespace

NewtonResult solve_fixed_parameter(const CurveProblem& problem, const VectorXd& y_guess,
                                   const ContinuationOptions& options) {
  NewtonResult result;
  result.y = y_guess;
  const Index n = problem.equation_count();
  Scaling s;
  if (y_guess.size() != n + 1) {
    result.message = "y_guess must have n + 1 entries";
    return result;
  }
  if (!make_scaling(options, n, &s, &result.message)) return result;
  SolveProfile profile;
  const ScaledProblem scaled(problem, std::move(s), options, &profile);
  result = solve_scaled_fixed(scaled, y_guess, options.newton);
  result.profile = std::move(profile);
  return result;
}

struct FixedParameterSolver::State {
  State(const CurveProblem& problem, Scaling scaling, const ContinuationOptions& options)
      : newton(options.newton), scaled(problem, std::move(scaling), options, &profile) {}
  NewtonOptions newton;
  SolveProfile profile;
  ScaledProblem scaled;  // counts into `profile` (declared after it)
};

FixedParameterSolver::FixedParameterSolver(const CurveProblem& problem,
                                           const ContinuationOptions& options) {
  Scaling s;
  std::string why;
  if (!make_scaling(options, problem.equation_count(), &s, &why))
    throw std::invalid_argument("fixed-parameter solver: " + why);
  state_ = std::make_unique<State>(problem, std::move(s), options);
}

FixedParameterSolver::~FixedParameterSolver() = default;

NewtonResult FixedParameterSolver::solve(const VectorXd& y_guess) {
  if (y_guess.size() != state_->scaled.equations() + 1) {
    NewtonResult result;
    result.y = y_guess;
    result.message = "y_guess must have n + 1 entries";
    return result;
  }
  return solve_scaled_fixed(state_->scaled, y_guess, state_->newton);
}

const SolveProfile& FixedParameterSolver::profile() const {
  return state_->profile;
}

// A chord's points serve derivatives along the curve (a flat peak's location): solved to this
// share of the continuation's tolerances, most often one Newton iteration more, but not below
// the floor (near the residual's rounding) unless the continuation's tolerance already is.
constexpr double kChordToleranceShare = 1e-3;
constexpr double kChordToleranceFloor = 1e-12;

struct ChordSolver::State {
  State(const CurveProblem& curve, Scaling scaling, const ContinuationOptions& options)
      : problem(curve),
        newton(options.newton),
        scaled(curve, std::move(scaling), options, &profile) {
    newton.floor_on_hyperplane = true;
    for (double* tolerance : {&newton.residual_tolerance, &newton.step_tolerance})
      *tolerance =
          std::min(*tolerance, std::max(kChordToleranceShare * *tolerance, kChordToleranceFloor));
  }
  const CurveProblem& problem;
  NewtonOptions newton;
  SolveProfile profile;
  ScaledProblem scaled;  // counts into `profile` (declared after it)
};

ChordSolver::ChordSolver(const CurveProblem& problem, const ContinuationOptions& options)
    : equations_(problem.equation_count()) {
  Scaling s;
  std::string why;
  if (!make_scaling(options, equations_, &s, &why))
    throw std::invalid_argument("chord solver: " + why);
  state_ = std::make_unique<State>(problem, std::move(s), options);
}

ChordSolver::~ChordSolver() = default;

double ChordSolver::theta(const VectorXd& a, const VectorXd& b, const VectorXd& y) const {
  const ScaledProblem& scaled = state_->scaled;
  const VectorXd d = scaled.scale(b) - scaled.scale(a);
  return d.dot(scaled.scale(y) - scaled.scale(a)) / d.squaredNorm();
}

ChordPoint ChordSolver::solve(const VectorXd& a, const VectorXd& b, double theta,
                              const VectorXd& guess) {
  ChordPoint out;
  out.y = guess;
  const Index n = equations_;
  if (a.size() != n + 1 || b.size() != n + 1 || guess.size() != n + 1) {
    out.message = "a, b and the guess must have n + 1 entries";
    return out;
  }
  const ScaledProblem& scaled = state_->scaled;
  const VectorXd as = scaled.scale(a);
  const VectorXd d = scaled.scale(b) - as;
  const double length = d.norm();
  if (!(length > 0) || !std::isfinite(length)) {
    out.message = "the chord's ends coincide";
    return out;
  }
  if (n == 0) {
    out.converged = true;
    out.y = a + theta * (b - a);
    out.velocity = b - a;
    return out;
  }
  const VectorXd normal = d / length;
  const VectorXd through = as + theta * d;
  const Correction corr =
      newton_correct(scaled, scaled.scale(guess), state_->newton, &normal, &through);
  out.iterations = corr.iterations;
  out.residual_norm = corr.residual_norm;
  out.y = scaled.unscale(corr.ys);
  if (!corr.converged) {
    out.message = corr.message;
    return out;
  }
  VectorXd v;
  if (!next_tangent(corr.js, normal, scaled.linear(), &v)) {
    out.message = "singular bordered Jacobian at " + scaled.describe_lambda(corr.ys);
    return out;
  }
  // v is the unit tangent with v . normal > 0; dy/dtheta projects on the chord as d does.
  out.velocity = scaled.unscale(v * (length / v.dot(normal)));
  out.record = state_->problem.point_record(out.y);
  out.converged = true;
  return out;
}

const SolveProfile& ChordSolver::profile() const {
  return state_->profile;
}

double ContinuationOptions::band_advance(double lambda, double direction) const {
  double limit = std::numeric_limits<double>::infinity();
  for (const auto& band : step_bands) {
    const bool approaching = direction * (band.centre - lambda) > 0;
    limit = std::min(limit, band.step + (approaching ? band.growth : band.leaving_growth) *
                                            std::abs(lambda - band.centre));
  }
  return limit;
}

ContinuationSummary trace_curve(const CurveProblem& problem, const VectorXd& y_guess,
                                const ContinuationOptions& options, const PointCallback& on_point) {
  CurveTracer tracer(problem, options, on_point);
  return tracer.trace(y_guess);
}

}  // namespace frichb::core
