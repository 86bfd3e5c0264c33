#include "frichb/core/solver/continuation.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <functional>
#include <latch>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "frichb/core/support/interrupt.hpp"

namespace frichb::core {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// One scalar equation e(x, lambda) = 0 given by lambdas, for compact test problems.
class ScalarCurve : public CurveProblem {
 public:
  using Residual = std::function<double(double x, double lambda)>;
  using Gradient = std::function<Eigen::Vector2d(double x, double lambda)>;
  using Guard = std::function<bool(double x, double lambda)>;

  ScalarCurve(Residual e, Gradient g, Guard ok = {})
      : e_(std::move(e)), g_(std::move(g)), ok_(std::move(ok)) {}

  Eigen::Index equation_count() const override { return 1; }
  bool evaluate(const VectorXd& y, VectorXd& residual, MatrixXd* jacobian,
                std::string* message) const override {
    ++evaluations;
    if (ok_ && !ok_(y(0), y(1))) {
      if (message != nullptr) *message = "outside the domain";
      return false;
    }
    residual.resize(1);
    residual(0) = e_(y(0), y(1));
    if (jacobian != nullptr) {
      jacobian->resize(1, 2);
      jacobian->row(0) = g_(y(0), y(1)).transpose();
    }
    visited.push_back(y(0));
    return true;
  }

  mutable int evaluations = 0;
  mutable std::vector<double> visited;  // x of each successful evaluation

 private:
  Residual e_;
  Gradient g_;
  Guard ok_;
};

ScalarCurve Circle() {
  return ScalarCurve([](double x, double l) { return x * x + l * l - 1.0; },
                     [](double x, double l) { return Eigen::Vector2d(2.0 * x, 2.0 * l); });
}

// lambda = x^3 - x: folds at x = +-1/sqrt(3). `scale` writes it in x' = scale * x.
ScalarCurve SCurve(double scale = 1.0) {
  return ScalarCurve(
      [scale](double xp, double l) {
        const double x = xp / scale;
        return x * x * x - x - l;
      },
      [scale](double xp, double) {
        const double x = xp / scale;
        return Eigen::Vector2d((3.0 * x * x - 1.0) / scale, -1.0);
      });
}

ScalarCurve Line() {
  return ScalarCurve([](double x, double l) { return x - 2.0 * l; },
                     [](double, double) { return Eigen::Vector2d(1.0, -2.0); });
}

// lambda = ZigzagLambda(x), piecewise linear: x up to x = 0, then -3 x up to x = 1, then
// -3 + 5 (x - 1); two kinks, both folds.
double ZigzagLambda(double x) {
  return x < 0.0 ? x : (x < 1.0 ? -3.0 * x : 5.0 * x - 8.0);
}
double ZigzagSlope(double x) {
  return x < 0.0 ? 1.0 : (x < 1.0 ? -3.0 : 5.0);
}
ScalarCurve Zigzag() {
  return ScalarCurve([](double x, double l) { return ZigzagLambda(x) - l; },
                     [](double x, double) { return Eigen::Vector2d(ZigzagSlope(x), -1.0); });
}

// lambda = StairsLambda(x), piecewise linear with slopes 1, -3, 5, -3, 5 (kinks at x = 0, 0.1,
// 0.3, 0.6).
double StairsLambda(double x) {
  if (x < 0.0) return x;
  if (x < 0.1) return -3.0 * x;
  if (x < 0.3) return -0.3 + 5.0 * (x - 0.1);
  if (x < 0.6) return 0.7 - 3.0 * (x - 0.3);
  return -0.2 + 5.0 * (x - 0.6);
}
double StairsSlope(double x) {
  if (x < 0.0) return 1.0;
  if (x < 0.1) return -3.0;
  if (x < 0.3) return 5.0;
  if (x < 0.6) return -3.0;
  return 5.0;
}
ScalarCurve Stairs() {
  return ScalarCurve([](double x, double l) { return StairsLambda(x) - l; },
                     [](double x, double) { return Eigen::Vector2d(StairsSlope(x), -1.0); });
}

// Real root of x^3 - x - c = 0 for c > 2/(3 sqrt 3), by Cardano (independent of Newton).
double CubicRoot(double c) {
  const double d = std::sqrt(c * c / 4.0 - 1.0 / 27.0);
  return std::cbrt(c / 2.0 + d) + std::cbrt(c / 2.0 - d);
}

int TangentSignChanges(const ContinuationSummary& s) {
  int changes = 0;
  for (std::size_t i = 1; i < s.points.size(); ++i)
    if (s.points[i - 1].tangent(1) * s.points[i].tangent(1) < 0.0) ++changes;
  return changes;
}

ContinuationOptions Sweep(double from, double to) {
  ContinuationOptions o;
  o.lambda_start = from;
  o.lambda_end = to;
  return o;
}

// The unit circle traced once around from (-1, 0) through both folds, stopped by the callback
// when it has closed: a smooth curve with no corner.
ContinuationSummary FullCircle() {
  ContinuationOptions o = Sweep(0.0, 2.0);  // 2 is never reached
  o.max_points = 5000;
  const Eigen::Vector2d start(-1.0, 0.0);
  bool far = false;
  return trace_curve(Circle(), Eigen::Vector2d(-0.9, 0.0), o,
                     [&](const ContinuationPoint& p, std::size_t) {
                       const double d = (p.y - start).norm();
                       if (d > 1.9) far = true;
                       return !(far && d < 0.1);
                     });
}

TEST(Continuation, ClosesACircleThroughBothFolds) {
  const ScalarCurve circle = Circle();
  ContinuationOptions o = Sweep(0.0, 2.0);  // 2 is never reached
  o.max_points = 5000;
  const Eigen::Vector2d start(-1.0, 0.0);
  bool far = false, closed = false;
  const auto summary = trace_curve(circle, Eigen::Vector2d(-0.9, 0.0), o,
                                   [&](const ContinuationPoint& p, std::size_t) {
                                     const double d = (p.y - start).norm();
                                     if (d > 1.9) far = true;
                                     if (far && d < 0.1) closed = true;
                                     return !closed;
                                   });
  EXPECT_TRUE(closed);
  EXPECT_EQ(summary.termination, TerminationType::kCancelled) << summary.message;
  EXPECT_EQ(summary.turning_points, 2);
  EXPECT_EQ(TangentSignChanges(summary), 2);
  double lmax = -2.0, lmin = 2.0;
  for (const auto& p : summary.points) {
    EXPECT_LT(std::abs(p.y.squaredNorm() - 1.0), 1e-8);
    EXPECT_NEAR(p.tangent.norm(), 1.0, 1e-12);
    lmax = std::max(lmax, p.y(1));
    lmin = std::min(lmin, p.y(1));
  }
  EXPECT_NEAR(lmax, 1.0, 1e-3);
  EXPECT_NEAR(lmin, -1.0, 1e-3);
  EXPECT_NEAR(summary.points.front().y(0), -1.0, 1e-12);
  EXPECT_EQ(summary.points.front().step, 0.0);
}

TEST(Continuation, SCurvePassesBothFoldsAndLandsOnEnd) {
  const ScalarCurve curve = SCurve();
  const auto summary = trace_curve(curve, Eigen::Vector2d(-1.5, -2.0), Sweep(-2.0, 2.0));
  ASSERT_EQ(summary.termination, TerminationType::kReachedEnd) << summary.message;
  EXPECT_TRUE(summary.reached_end());
  EXPECT_NEAR(summary.points.back().y(1), 2.0, 1e-12);
  EXPECT_NEAR(summary.points.back().y(0), CubicRoot(2.0), 1e-9);
  EXPECT_NEAR(summary.points.front().y(0), -CubicRoot(2.0), 1e-9);
  EXPECT_EQ(summary.turning_points, 2);
  EXPECT_EQ(TangentSignChanges(summary), 2);
  const double fold = 2.0 / (3.0 * std::sqrt(3.0));
  double lmax = -10.0, lmin = 10.0;
  for (const auto& p : summary.points) {
    const double x = p.y(0);
    EXPECT_LT(std::abs(x * x * x - x - p.y(1)), 1e-9);
    EXPECT_TRUE(p.y.allFinite() && p.tangent.allFinite());
    lmax = std::max(lmax, p.y(1) < 1.0 && x < 0.0 ? p.y(1) : -10.0);
    lmin = std::min(lmin, p.y(1) > -1.0 && x > 0.0 ? p.y(1) : 10.0);
  }
  EXPECT_NEAR(lmax, fold, 1e-2);
  EXPECT_NEAR(lmin, -fold, 1e-2);
  EXPECT_GT(summary.fine_control_restarts, 0);
  EXPECT_GT(summary.total_newton_iterations, 0);
  // The tangent starts along the sweep and ends along it.
  EXPECT_GT(summary.points.front().tangent(1), 0.0);
  EXPECT_GT(summary.points.back().tangent(1), 0.0);
}

TEST(Continuation, TurningPointControlOnlyChangesRestarts) {
  const ScalarCurve curve = SCurve();
  ContinuationOptions o = Sweep(-2.0, 2.0);
  const auto with = trace_curve(curve, Eigen::Vector2d(-1.5, -2.0), o);
  o.turning_point_control = false;
  const auto without = trace_curve(curve, Eigen::Vector2d(-1.5, -2.0), o);
  ASSERT_TRUE(with.reached_end()) << with.message;
  ASSERT_TRUE(without.reached_end()) << without.message;
  EXPECT_GT(with.fine_control_restarts, 0);
  EXPECT_EQ(without.fine_control_restarts, 0);
  EXPECT_EQ(with.turning_points, 2);
  EXPECT_EQ(without.turning_points, 2);
  EXPECT_NEAR(without.points.back().y(1), 2.0, 1e-12);
  // The refined trace resolves the folds more finely.
  EXPECT_GT(with.points.size(), without.points.size());
  const double fold = 2.0 / (3.0 * std::sqrt(3.0));
  auto fold_error = [fold](const ContinuationSummary& s) {
    double lmax = -10.0;
    for (const auto& p : s.points)
      if (p.y(0) < 0.0) lmax = std::max(lmax, p.y(1));
    return fold - lmax;
  };
  EXPECT_LT(fold_error(with), 1e-4);
  EXPECT_LT(fold_error(with), fold_error(without));
}

TEST(Continuation, CloseFoldsAreEachRefinedOnce) {
  // lambda = x^3 - 0.01 x: folds 0.115 apart in x, closer than a long backtrack reaches.
  const ScalarCurve close(
      [](double x, double l) { return x * x * x - 0.01 * x - l; },
      [](double x, double) { return Eigen::Vector2d(3.0 * x * x - 0.01, -1.0); });
  ContinuationOptions o = Sweep(-1.0, 1.0);
  o.turning_point_backtrack = 8;
  const auto summary = trace_curve(close, Eigen::Vector2d(-1.0, -1.0), o);
  ASSERT_TRUE(summary.reached_end()) << summary.message;
  EXPECT_EQ(summary.fine_control_restarts, 2);
  EXPECT_EQ(summary.turning_points, 2);
  EXPECT_EQ(TangentSignChanges(summary), 2);
}

TEST(Continuation, ScalingMakesTinyUnknownsEquivalent) {
  const double s = 1e-9;
  const ScalarCurve plain = SCurve();
  const ScalarCurve tiny = SCurve(s);
  ContinuationOptions o = Sweep(-2.0, 2.0);
  const auto a = trace_curve(plain, Eigen::Vector2d(-1.5, -2.0), o);
  o.unknown_scale = Eigen::Vector2d(s, 1.0);
  const auto b = trace_curve(tiny, Eigen::Vector2d(-1.5 * s, -2.0), o);
  ASSERT_TRUE(a.reached_end()) << a.message;
  ASSERT_TRUE(b.reached_end()) << b.message;
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    EXPECT_NEAR(a.points[i].y(1), b.points[i].y(1), 1e-9) << i;
    EXPECT_NEAR(a.points[i].y(0), b.points[i].y(0) / s, 1e-9) << i;
  }
}

TEST(Continuation, LinearProblemGrowsStepToMax) {
  const ScalarCurve line = Line();
  ContinuationOptions o = Sweep(0.0, 3.0);
  o.target_newton_iterations = 16;  // sqrt(16 / 1) = 4: only the 2x growth cap limits it
  const auto summary = trace_curve(line, Eigen::Vector2d(0.3, 0.0), o);
  ASSERT_TRUE(summary.reached_end()) << summary.message;
  EXPECT_EQ(summary.points.back().y(1), 3.0);
  EXPECT_NEAR(summary.points.back().y(0), 6.0, 1e-12);
  bool hit_max = false;
  for (std::size_t i = 0; i < summary.points.size(); ++i) {
    const auto& p = summary.points[i];
    EXPECT_LE(p.newton_iterations, 1) << i;
    EXPECT_NEAR(p.y(0), 2.0 * p.y(1), 1e-12);
    EXPECT_LE(p.step, o.max_step * (1.0 + 1e-12));
    if (i > 1 && i + 1 < summary.points.size()) {
      EXPECT_GE(p.step, summary.points[i - 1].step);
      EXPECT_LE(p.step, 2.0 * summary.points[i - 1].step * (1.0 + 1e-12));
    }
    if (p.step == o.max_step) hit_max = true;
  }
  EXPECT_TRUE(hit_max);
  EXPECT_EQ(summary.rejected_steps, 0);
  EXPECT_EQ(summary.turning_points, 0);
  // Tangent of x = 2 lambda, swept upwards.
  EXPECT_NEAR(summary.points[1].tangent(0), 2.0 / std::sqrt(5.0), 1e-12);
  EXPECT_NEAR(summary.points[1].tangent(1), 1.0 / std::sqrt(5.0), 1e-12);
}

TEST(Continuation, FailedEvaluationEndsWithStepTooSmall) {
  const ScalarCurve cut([](double x, double l) { return x - l; },
                        [](double, double) { return Eigen::Vector2d(1.0, -1.0); },
                        [](double, double l) { return l <= 0.5; });
  const auto summary = trace_curve(cut, Eigen::Vector2d(0.0, 0.0), Sweep(0.0, 1.0));
  ASSERT_EQ(summary.termination, TerminationType::kStepTooSmall) << summary.message;
  ASSERT_FALSE(summary.points.empty());
  const double last = summary.points.back().y(1);
  EXPECT_LE(last, 0.5);
  EXPECT_GT(last, 0.49);
  EXPECT_GT(summary.rejected_steps, 0);
  // The message quotes lambda at full precision; compare its first five decimals, truncated.
  char text[64];
  std::snprintf(text, sizeof text, "%.5f", std::floor(last * 1e5) / 1e5);
  EXPECT_NE(summary.message.find(text), std::string::npos) << summary.message << " vs " << text;
  EXPECT_NE(summary.message.find("lambda"), std::string::npos);
}

TEST(Continuation, NoSolutionAtStartIsStartFailed) {
  const ScalarCurve none([](double x, double) { return x * x + 1.0; },
                         [](double x, double) { return Eigen::Vector2d(2.0 * x, 0.0); });
  const auto summary = trace_curve(none, Eigen::Vector2d(0.5, 0.0), Sweep(0.0, 1.0));
  EXPECT_EQ(summary.termination, TerminationType::kStartFailed) << summary.message;
  EXPECT_TRUE(summary.points.empty());
  EXPECT_FALSE(summary.message.empty());
}

TEST(Continuation, EvaluationFailureAtStart) {
  const ScalarCurve never([](double x, double l) { return x - l; },
                          [](double, double) { return Eigen::Vector2d(1.0, -1.0); },
                          [](double, double) { return false; });
  const auto summary = trace_curve(never, Eigen::Vector2d(0.0, 0.0), Sweep(0.0, 1.0));
  EXPECT_EQ(summary.termination, TerminationType::kEvaluationFailed) << summary.message;
  EXPECT_NE(summary.message.find("outside the domain"), std::string::npos) << summary.message;
}

TEST(Continuation, InvalidOptionsAreReported) {
  ContinuationOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.min_step = 1.0;
  o.max_step = 0.1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("min_step"), std::string::npos) << why;
  const ScalarCurve line = Line();
  const auto summary = trace_curve(line, Eigen::Vector2d(0.0, 0.0), o);
  EXPECT_EQ(summary.termination, TerminationType::kInvalidOptions);
  EXPECT_FALSE(summary.message.empty());

  ContinuationOptions same;
  same.lambda_end = same.lambda_start;
  EXPECT_FALSE(same.IsValid(&why));

  // Mismatched sizes are only detectable against the problem.
  ContinuationOptions wrong_scale;
  wrong_scale.unknown_scale = Eigen::Vector3d(1.0, 1.0, 1.0);
  EXPECT_EQ(trace_curve(line, Eigen::Vector2d(0.0, 0.0), wrong_scale).termination,
            TerminationType::kInvalidOptions);
  EXPECT_EQ(trace_curve(line, Eigen::Vector3d(0.0, 0.0, 0.0), ContinuationOptions{}).termination,
            TerminationType::kInvalidOptions);
}

TEST(Continuation, DownwardSweepReachesLowerEnd) {
  const ScalarCurve curve = SCurve();
  const auto summary = trace_curve(curve, Eigen::Vector2d(1.5, 2.0), Sweep(2.0, -2.0));
  ASSERT_EQ(summary.termination, TerminationType::kReachedEnd) << summary.message;
  EXPECT_NEAR(summary.points.back().y(1), -2.0, 1e-12);
  EXPECT_NEAR(summary.points.back().y(0), -CubicRoot(2.0), 1e-9);
  EXPECT_EQ(summary.turning_points, 2);
  EXPECT_LT(summary.points.front().tangent(1), 0.0);
  EXPECT_LT(summary.points.back().tangent(1), 0.0);
}

TEST(Continuation, FixedParameterNewtonConvergesQuadratically) {
  const ScalarCurve sq([](double x, double) { return x * x - 2.0; },
                       [](double x, double) { return Eigen::Vector2d(2.0 * x, 0.0); });
  const NewtonResult r = solve_fixed_parameter(sq, Eigen::Vector2d(1.0, 0.7), {});
  ASSERT_TRUE(r.converged) << r.message;
  EXPECT_LE(r.iterations, 6);
  EXPECT_NEAR(r.y(0), std::sqrt(2.0), 1e-12);
  EXPECT_EQ(r.y(1), 0.7);
  EXPECT_LE(r.residual_norm, 1e-9);
  // Error contracts quadratically: e_{k+1} <= e_k^2 (theory: e_k^2 / (2 x_k)).
  std::vector<double> err;
  for (double x : sq.visited) err.push_back(std::abs(x - std::sqrt(2.0)));
  ASSERT_GE(err.size(), 3u);
  for (std::size_t k = 0; k + 1 < err.size() && err[k] > 1e-7; ++k)
    EXPECT_LE(err[k + 1], err[k] * err[k] * (1.0 + 1e-9)) << k;
}

TEST(Continuation, FixedParameterNewtonIsDamped) {
  // Undamped Newton on atan(x) = 0 diverges from |x0| > 1.39.
  const ScalarCurve atan(
      [](double x, double) { return std::atan(x); },
      [](double x, double) { return Eigen::Vector2d(1.0 / (1.0 + x * x), 0.0); });
  const NewtonResult r = solve_fixed_parameter(atan, Eigen::Vector2d(3.0, 0.0), {});
  ASSERT_TRUE(r.converged) << r.message;
  EXPECT_NEAR(r.y(0), 0.0, 1e-12);
  ContinuationOptions no_damping;
  no_damping.newton.max_line_search_halvings = 0;
  EXPECT_FALSE(solve_fixed_parameter(atan, Eigen::Vector2d(3.0, 0.0), no_damping).converged);
}

TEST(Continuation, NewtonAcceptsTheFloorOfANonSmoothResidual) {
  // e = 1e-3 (x - lambda) + 3e-10 sign(x - lambda) has no root: it jumps from -3e-10 to
  // +3e-10 at x = lambda. Newton then cycles between lambda -+ 3e-7 with |e| = 6e-10 (within
  // the 1e-9 tolerance) and updates of 6e-7 that never shrink, as a friction residual does
  // when one sample switches between stick and slip.
  const double delta = 3e-10;
  const ScalarCurve kink(
      [&](double x, double l) { return 1e-3 * (x - l) + (x > l ? delta : -delta); },
      [](double, double) { return Eigen::Vector2d(1e-3, -1e-3); });
  const NewtonResult r = solve_fixed_parameter(kink, Eigen::Vector2d(1.0, 0.5), {});
  ASSERT_TRUE(r.converged) << r.message;
  EXPECT_TRUE(r.at_residual_floor);
  EXPECT_LE(r.residual_norm, 1e-9);
  EXPECT_NEAR(r.y(0), 0.5, 1e-6);
  ContinuationOptions strict;
  strict.newton.residual_floor_iterations = 1000;  // demand a shrinking update
  EXPECT_FALSE(solve_fixed_parameter(kink, Eigen::Vector2d(1.0, 0.5), strict).converged);
  // A floor above the tolerance is not a solution: refused.
  const ScalarCurve high_floor(
      [&](double x, double l) { return 1e-3 * (x - l) + (x > l ? 10 * delta : -10 * delta); },
      [](double, double) { return Eigen::Vector2d(1e-3, -1e-3); });
  EXPECT_FALSE(solve_fixed_parameter(high_floor, Eigen::Vector2d(1.0, 0.5), {}).converged);
  // Traced, the jump crosses every Keller hyperplane: the residual reverses between the
  // iterates on either side, so the floor brackets the curve and is taken there too.
  const auto traced = trace_curve(kink, Eigen::Vector2d(0.5, 0.5), Sweep(0.5, 1.0));
  ASSERT_TRUE(traced.reached_end()) << traced.message;
  EXPECT_GT(traced.residual_floor_points, 0);
  for (const auto& p : traced.points) EXPECT_NEAR(p.y(0), p.y(1), 1e-6);
  // A smooth problem never needs the floor.
  const ScalarCurve line([](double x, double l) { return x - l; },
                         [](double, double) { return Eigen::Vector2d(1.0, -1.0); });
  EXPECT_FALSE(solve_fixed_parameter(line, Eigen::Vector2d(1.0, 0.5), {}).at_residual_floor);
}

TEST(Continuation, PassesACornerOfTheBranch) {
  // x = 0 up to lambda = 1, then x = 20 (lambda - 1): the tangent turns by 87 degrees, as
  // a friction response does where a contact changes regime. The corrector's distance to the
  // predictor exceeds the step at every step size; it shrinks with the step, so after three
  // halvings the point across the corner is taken.
  const auto g = [](double l) { return l < 1.0 ? 0.0 : 20.0 * (l - 1.0); };
  const ScalarCurve corner(
      [&](double x, double l) { return x - g(l); },
      [](double, double l) { return Eigen::Vector2d(1.0, l < 1.0 ? 0 : -20.0); });
  const auto summary = trace_curve(corner, Eigen::Vector2d(0.0, 0.0), Sweep(0.0, 2.0));
  ASSERT_TRUE(summary.reached_end()) << summary.message;
  EXPECT_GE(summary.corners, 1);
  EXPECT_LE(summary.corners, 2);
  for (const auto& p : summary.points) EXPECT_NEAR(p.y(0), g(p.y(1)), 1e-9);
  EXPECT_NEAR(summary.points.back().y(0), 20.0, 1e-9);
  // The circle has no corner: none is reported.
  const auto circle = FullCircle();
  ASSERT_EQ(circle.termination, TerminationType::kCancelled) << circle.message;
  EXPECT_GT(circle.points.size(), 10u);
  EXPECT_EQ(circle.corners, 0);
}

TEST(Continuation, CornerJustAheadIsRecognisedFromTheTangentLines) {
  // The same 87-degree corner, 5e-7 ahead of the start, with steps of 4e-6 down to 1e-6:
  // the ratio of correction to step (0.88, 0.75, 0.5 times tan 87 degrees) never repeats
  // within 10 %, so the halving test alone ends with step_too_small. The tangent lines of
  // the start point and of the landed point meet at the kink, which is on the branch: the
  // first step is taken across it.
  const double kink = 1.0;
  const auto g = [&](double l) { return l < kink ? 0.0 : 20.0 * (l - kink); };
  const ScalarCurve corner(
      [&](double x, double l) { return x - g(l); },
      [&](double, double l) { return Eigen::Vector2d(1.0, l < kink ? 0 : -20.0); });
  ContinuationOptions o = Sweep(kink - 5e-7, kink + 1e-3);
  o.initial_step = 4e-6;
  o.min_step = 1e-6;
  o.max_step = 1e-4;
  const auto summary = trace_curve(corner, Eigen::Vector2d(0.0, kink - 5e-7), o);
  ASSERT_TRUE(summary.reached_end()) << summary.message;
  EXPECT_EQ(summary.corners, 1);
  EXPECT_EQ(summary.rejected_steps, 0);
  ASSERT_GE(summary.points.size(), 2u);
  EXPECT_TRUE(summary.points[1].passed_corner);
  for (const auto& p : summary.points) EXPECT_NEAR(p.y(0), g(p.y(1)), 1e-12);
  // A point on a parallel branch is not a corner: x = 1e-3 + 20 (lambda - 1) never meets
  // x = 0 at a solution, and the tangent lines' meeting point is off both branches.
  const ScalarCurve two_branches(
      [&](double x, double l) { return l < kink + 1e-6 ? x : x - 1e-3 - 20.0 * (l - kink - 1e-6); },
      [&](double, double l) { return Eigen::Vector2d(1.0, l < kink + 1e-6 ? 0 : -20.0); });
  const auto jumped = trace_curve(two_branches, Eigen::Vector2d(0.0, kink - 5e-7), o);
  EXPECT_EQ(jumped.corners, 0);
  EXPECT_FALSE(jumped.reached_end());
}

TEST(Continuation, PassesFoldsAtCornersSharperThan90Degrees) {
  // lambda = f(x), piecewise linear: x up to x = 0, then -3 x up to x = 1, then -3 + 5 (x - 1).
  // Both kinks are folds: the tangent turns by 116.6 degrees at x = 0 and by 142.1 degrees at
  // x = 1, so no Keller hyperplane ahead of a point before a kink meets the branch and the
  // corrector fails at every step; the branch goes on along the next piece's tangent, taken
  // from the Jacobian past the kink. The curve reaches lambda = 1 at x = 1.8.
  const auto f = ZigzagLambda;
  const ScalarCurve zigzag = Zigzag();
  const auto summary = trace_curve(zigzag, Eigen::Vector2d(-1.0, -1.0), Sweep(-1.0, 1.0));
  ASSERT_TRUE(summary.reached_end()) << summary.message;
  EXPECT_EQ(summary.kink_steps, 2);
  EXPECT_EQ(summary.turning_points, 2);
  EXPECT_EQ(TangentSignChanges(summary), 2);
  EXPECT_NEAR(summary.points.back().y(0), 1.8, 1e-12);
  EXPECT_DOUBLE_EQ(summary.points.back().y(1), 1.0);
  double lowest = 0.0;
  for (const auto& p : summary.points) {
    EXPECT_NEAR(p.y(1), f(p.y(0)), 1e-12);
    lowest = std::min(lowest, p.y(1));
  }
  // The branch was followed down the middle piece to its lower fold at (1, -3), not cut short.
  EXPECT_LT(lowest, -2.9);
  // Smooth curves never take that step.
  const auto s_curve = trace_curve(SCurve(), Eigen::Vector2d(-2.0, -6.0), Sweep(-6.0, 6.0));
  ASSERT_TRUE(s_curve.reached_end()) << s_curve.message;
  EXPECT_EQ(s_curve.turning_points, 2);
  EXPECT_EQ(s_curve.kink_steps, 0);
  const auto circle = FullCircle();
  ASSERT_EQ(circle.termination, TerminationType::kCancelled) << circle.message;
  EXPECT_EQ(circle.turning_points, 2);
  EXPECT_EQ(circle.kink_steps, 0);
}

TEST(Continuation, KeepsTheOrientationWhereAStepLandsPastAFold) {
  // lambda = f(x), piecewise linear with slopes 1, -3, 5, -3, 5 (kinks at x = 0, 0.1, 0.3,
  // 0.6), traced from x = -0.001 with a first step of 0.5. Its predictor lies over the fourth
  // piece, and its Keller hyperplane crosses that piece at x = 0.4475: Newton lands there in
  // one iteration, three folds beyond the start. The curve runs on towards larger x, but the
  // tangent oriented along the travel (v . v_prev > 0) points the other way (a turn of
  // 116.6 degrees), and the curve would be walked backwards down to lambda_min. The
  // orientation sign det [e_y; v^T] tells them apart: the tangent is reversed, the fold
  // control retraces the folds with fine steps, and the curve reaches lambda = 1 at x = 0.84.
  const auto f = StairsLambda;
  const ScalarCurve stairs = Stairs();
  ContinuationOptions o = Sweep(-0.001, 1.0);
  o.initial_step = 0.5;
  o.max_step = 0.5;
  o.lambda_min = -2.0;
  // The curve climbed to its end: every point on it, with the start's orientation, and x
  // growing along the points (never walked backwards).
  const auto expect_climbed = [&](const ContinuationSummary& summary) {
    ASSERT_TRUE(summary.reached_end()) << summary.message;
    EXPECT_GE(summary.reversed_tangents, 1);
    EXPECT_NEAR(summary.points.back().y(0), 0.84, 1e-12);
    for (std::size_t i = 0; i < summary.points.size(); ++i) {
      const auto& p = summary.points[i];
      EXPECT_NEAR(p.y(1), f(p.y(0)), 1e-12);
      EXPECT_EQ(p.orientation, summary.points.front().orientation) << "point " << i;
      if (i > 0) {
        EXPECT_GT(p.y(0), summary.points[i - 1].y(0)) << "point " << i;
      }
    }
  };
  const auto summary = trace_curve(stairs, Eigen::Vector2d(-0.001, -0.001), o);
  expect_climbed(summary);
  EXPECT_EQ(summary.turning_points, 4);
  // The same without the fold control (the reversed point is kept, not retraced) and with
  // the chord corrector, whose kept factorisation follows the reversed tangent; the end
  // point keeps the orientation too.
  o.turning_point_control = false;
  o.reuse_factorisation_from = 1;
  const auto plain = trace_curve(stairs, Eigen::Vector2d(-0.001, -0.001), o);
  expect_climbed(plain);
  EXPECT_GT(plain.chord_points, 0);
  // Ordinary curves never need the reversal.
  const auto circle = FullCircle();
  ASSERT_EQ(circle.termination, TerminationType::kCancelled) << circle.message;
  EXPECT_EQ(circle.reversed_tangents, 0);
  const auto s_curve = trace_curve(SCurve(), Eigen::Vector2d(-2.0, -6.0), Sweep(-6.0, 6.0));
  ASSERT_TRUE(s_curve.reached_end()) << s_curve.message;
  EXPECT_EQ(s_curve.reversed_tangents, 0);
}

TEST(Continuation, GmresTracesTheSameFoldAndKinkCurvesAsTheDenseLu) {
  // The folds of the S-curve and the circle, the kinks of the zigzag (steps past them) and the
  // stairs (a tangent reversed by the orientation): GMRES on the kept factorisation of an
  // earlier matrix, with the orientation inherited where no determinant is formed, gives the
  // dense path's points, folds, kink steps and reversals.
  const ScalarCurve zigzag = Zigzag();
  const ScalarCurve stairs = Stairs();
  ContinuationOptions stairs_options = Sweep(-0.001, 1.0);
  stairs_options.initial_step = 0.5;
  stairs_options.max_step = 0.5;
  stairs_options.lambda_min = -2.0;
  struct Case {
    const char* name;
    const CurveProblem* problem;
    Eigen::Vector2d guess;
    ContinuationOptions options;
  };
  const ScalarCurve s_curve = SCurve();
  const std::vector<Case> cases = {
      {"S-curve", &s_curve, Eigen::Vector2d(-2.0, -6.0), Sweep(-6.0, 6.0)},
      {"zigzag", &zigzag, Eigen::Vector2d(-1.0, -1.0), Sweep(-1.0, 1.0)},
      {"stairs", &stairs, Eigen::Vector2d(-0.001, -0.001), stairs_options},
  };
  for (const auto& c : cases) {
    for (const Eigen::Index chord_from : {Eigen::Index{0}, Eigen::Index{1}}) {
      SCOPED_TRACE(std::string(c.name) + (chord_from > 0 ? ", chord corrector" : ""));
      ContinuationOptions dense_options = c.options;
      dense_options.reuse_factorisation_from = chord_from;
      dense_options.linear_solver = LinearSolverKind::kDenseLu;
      ContinuationOptions gmres_options = dense_options;
      gmres_options.linear_solver = LinearSolverKind::kGmres;
      const auto dense = trace_curve(*c.problem, c.guess, dense_options);
      const auto gmres = trace_curve(*c.problem, c.guess, gmres_options);
      ASSERT_TRUE(dense.reached_end()) << dense.message;
      ASSERT_TRUE(gmres.reached_end()) << gmres.message;
      EXPECT_EQ(dense.profile.linear_solver, "dense_lu");
      EXPECT_EQ(gmres.profile.linear_solver, "gmres");
      EXPECT_GT(gmres.profile.krylov_solves, 0);
      EXPECT_LT(gmres.profile.factorisations, dense.profile.factorisations);
      ASSERT_EQ(gmres.points.size(), dense.points.size());
      EXPECT_EQ(gmres.turning_points, dense.turning_points);
      EXPECT_EQ(gmres.kink_steps, dense.kink_steps);
      EXPECT_EQ(gmres.reversed_tangents, dense.reversed_tangents);
      for (std::size_t i = 0; i < dense.points.size(); ++i) {
        EXPECT_LE((gmres.points[i].y - dense.points[i].y).norm(), 1e-9) << "point " << i;
        EXPECT_EQ(gmres.points[i].orientation, dense.points[i].orientation) << "point " << i;
      }
    }
  }
}

TEST(Continuation, RefusesAResidualFloorPastAFold) {
  // The zigzag of PassesFoldsAtCornersSharperThan90Degrees with its residual scaled by 1e-4
  // (as a scaled friction residual can be), from 1e-5 before its first fold with steps of
  // 1e-6: the Keller hyperplanes just past the fold miss the curve by less than the 1e-9
  // tolerance times the slope, so Newton finds a residual floor below the tolerance there.
  // Taken as a point, it is off the curve, and the curve is walked into the region past the
  // fold until the floor exceeds the tolerance (step_too_small). Refused, the step is
  // shortened and the fold passed along the next piece.
  const double scale = 1e-4;
  const ScalarCurve zigzag(
      [&](double x, double l) { return scale * (ZigzagLambda(x) - l); },
      [&](double x, double) { return Eigen::Vector2d(scale * ZigzagSlope(x), -scale); });
  ContinuationOptions o = Sweep(-1e-5, 1.0);
  o.initial_step = 1e-6;
  o.min_step = 1e-7;
  const auto summary = trace_curve(zigzag, Eigen::Vector2d(-1e-5, -1e-5), o);
  ASSERT_TRUE(summary.reached_end()) << summary.message;
  EXPECT_EQ(summary.residual_floor_points, 0);
  EXPECT_EQ(summary.kink_steps, 2);
  EXPECT_NEAR(summary.points.back().y(0), 1.8, 1e-12);
  for (const auto& p : summary.points) EXPECT_NEAR(p.y(1), ZigzagLambda(p.y(0)), 1e-12);
  // The fixed-lambda solve still accepts a floor within the tolerance
  // (NewtonAcceptsTheFloorOfANonSmoothResidual).
}

TEST(Continuation, EndsWhereTheCurveLeavesTheLambdaBounds) {
  // The unit circle from (-0.6, -0.8) towards lambda = 2, never reached: over the top fold
  // and back down, the curve leaves lambda >= -0.9 on its way to the bottom fold.
  ContinuationOptions o = Sweep(-0.8, 2.0);
  o.lambda_min = -0.9;
  const auto summary = trace_curve(Circle(), Eigen::Vector2d(-0.6, -0.8), o);
  EXPECT_EQ(summary.termination, TerminationType::kLeftBounds) << summary.message;
  EXPECT_STREQ(to_string(summary.termination), "left_bounds");
  ASSERT_FALSE(summary.points.empty());
  for (const auto& p : summary.points) EXPECT_GE(p.y(1), -0.9);
  EXPECT_GT(summary.points.back().y(0), 0.0);  // on the far side of the circle
  // A sweep down to lambda_end = lambda_min lands on it instead.
  ContinuationOptions down = Sweep(0.5, 0.0);
  down.lambda_min = 0.0;
  const auto line = trace_curve(Line(), Eigen::Vector2d(1.0, 0.5), down);
  ASSERT_TRUE(line.reached_end()) << line.message;
  EXPECT_DOUBLE_EQ(line.points.back().y(1), 0.0);
  // A start outside the bounds is refused.
  ContinuationOptions outside = Sweep(-0.95, 2.0);
  outside.lambda_min = -0.9;
  EXPECT_EQ(trace_curve(Circle(), Eigen::Vector2d(-0.3, -0.95), outside).termination,
            TerminationType::kInvalidOptions);
}

TEST(Continuation, EachPointCarriesTheConditionOfItsNewtonMatrix) {
  // e = a x - lambda: the bordered Newton matrix [a, -1; v^T] at every point, with the unit
  // tangent v = (1, a) / |(1, a)|, has 1-norm condition number |A|_1 |A^-1|_1 computed
  // here from the explicit inverse; the start point's e_x = a has condition 1.
  for (const double a : {1.0, 1e-3, 1e6}) {
    const ScalarCurve line([a](double x, double l) { return a * x - l; },
                           [a](double, double) { return Eigen::Vector2d(a, -1.0); });
    ContinuationOptions o = Sweep(0.0, 1.0);
    o.max_step = 1e4;  // the line is 1 / a long
    const auto summary = trace_curve(line, Eigen::Vector2d(0.0, 0.0), o);
    ASSERT_TRUE(summary.reached_end()) << summary.message;
    EXPECT_DOUBLE_EQ(summary.points.front().condition, 1.0);
    Eigen::Matrix2d bordered;
    const Eigen::Vector2d v = Eigen::Vector2d(1.0, a).normalized();
    bordered << a, -1.0, v(0), v(1);
    const auto norm1 = [](const Eigen::Matrix2d& m) {
      return m.cwiseAbs().colwise().sum().maxCoeff();
    };
    const double exact = norm1(bordered) * norm1(bordered.inverse());
    for (std::size_t i = 1; i < summary.points.size(); ++i) {
      // The estimate bounds the condition from below, within a small factor.
      EXPECT_LE(summary.points[i].condition, exact * (1 + 1e-9)) << a;
      EXPECT_GE(summary.points[i].condition, exact / 3.0) << a;
    }
    EXPECT_GE(summary.max_condition, exact / 3.0);
    EXPECT_LT(summary.max_condition_point, summary.points.size());
  }
}

TEST(Continuation, SteepBranchCapsTheFollowingSteps) {
  // x = 0.01 lambda + tanh(50 (lambda - 0.5)): flat, then nearly vertical.
  const ScalarCurve steep(
      [](double x, double l) { return x - 0.01 * l - std::tanh(50.0 * (l - 0.5)); },
      [](double, double l) {
        const double t = std::tanh(50.0 * (l - 0.5));
        return Eigen::Vector2d(1.0, -0.01 - 50.0 * (1.0 - t * t));
      });
  ContinuationOptions o = Sweep(0.0, 1.0);
  const auto summary = trace_curve(steep, Eigen::Vector2d(0.0, 0.0), o);
  ASSERT_TRUE(summary.reached_end()) << summary.message;
  EXPECT_EQ(summary.steep_branch_caps, 1);
  std::size_t jumps = 0;
  for (std::size_t i = 1; i < summary.points.size(); ++i) {
    const double vx = std::abs(summary.points[i].tangent(0));
    if (vx <= o.steep_branch_alpha * std::abs(summary.points[i - 1].tangent(0))) continue;
    ++jumps;
    for (std::size_t k = i + 1; k <= i + static_cast<std::size_t>(o.steep_branch_points); ++k) {
      ASSERT_LT(k, summary.points.size());
      EXPECT_LE(summary.points[k].step, o.steep_branch_step_factor * o.max_step * (1 + 1e-12));
    }
  }
  EXPECT_EQ(jumps, 1u);
  o.steep_branch_control = false;
  EXPECT_EQ(trace_curve(steep, Eigen::Vector2d(0.0, 0.0), o).steep_branch_caps, 0);
}

TEST(Continuation, NanAtStartIsAnEvaluationFailure) {
  const ScalarCurve nan_everywhere(
      [](double, double) { return std::numeric_limits<double>::quiet_NaN(); },
      [](double, double) { return Eigen::Vector2d(1.0, -1.0); });
  const auto summary = trace_curve(nan_everywhere, Eigen::Vector2d(0.0, 0.0), Sweep(0.0, 1.0));
  EXPECT_EQ(summary.termination, TerminationType::kEvaluationFailed) << summary.message;
  EXPECT_TRUE(summary.points.empty());
}

TEST(Continuation, NanResidualNeverEntersAPoint) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const ScalarCurve bad([nan](double x, double l) { return l > 1.0 ? nan : x - l; },
                        [](double, double) { return Eigen::Vector2d(1.0, -1.0); });
  const ScalarCurve bad_jacobian(
      [](double x, double l) { return x - l; },
      [](double, double l) {
        return Eigen::Vector2d(1.0, l > 1.0 ? std::numeric_limits<double>::infinity() : -1.0);
      });
  for (const ScalarCurve* problem : {&bad, &bad_jacobian}) {
    const auto summary = trace_curve(*problem, Eigen::Vector2d(0.0, 0.0), Sweep(0.0, 2.0));
    EXPECT_EQ(summary.termination, TerminationType::kStepTooSmall) << summary.message;
    EXPECT_FALSE(summary.message.empty());
    ASSERT_FALSE(summary.points.empty());
    for (const auto& p : summary.points) {
      EXPECT_TRUE(p.y.allFinite());
      EXPECT_TRUE(p.tangent.allFinite());
      EXPECT_TRUE(std::isfinite(p.residual_norm));
      EXPECT_TRUE(std::isfinite(p.step));
      EXPECT_LE(p.y(1), 1.0);
    }
  }
}

// n coupled hardening springs under a load growing with lambda:
//   e(x, lambda) = K x + g x.^3 - lambda b,
// K tridiagonal (2 on the diagonal, -1 beside it, a chain held at both ends).
class SpringChain : public CurveProblem {
 public:
  explicit SpringChain(Eigen::Index n, double g = 1.0) : n_(n), g_(g) {}
  Eigen::Index equation_count() const override { return n_; }
  bool evaluate(const VectorXd& y, VectorXd& residual, MatrixXd* jacobian,
                std::string*) const override {
    const VectorXd x = y.head(n_);
    const double lambda = y(n_);
    residual = Stiffness() * x + g_ * x.array().cube().matrix() - lambda * Load();
    if (jacobian != nullptr) {
      jacobian->resize(n_, n_ + 1);
      jacobian->leftCols(n_) = Stiffness();
      jacobian->leftCols(n_).diagonal() += 3.0 * g_ * x.array().square().matrix();
      jacobian->col(n_) = -Load();
      ++jacobians;
    }
    return true;
  }
  MatrixXd Stiffness() const {
    MatrixXd k = MatrixXd::Zero(n_, n_);
    for (Eigen::Index i = 0; i < n_; ++i) {
      k(i, i) = 2.0;
      if (i > 0) k(i, i - 1) = k(i - 1, i) = -1.0;
    }
    return k;
  }
  VectorXd Load() const { return VectorXd::LinSpaced(n_, 1.0, 2.0); }
  mutable int jacobians = 0;

 private:
  Eigen::Index n_;
  double g_;
};

TEST(Continuation, ChordCorrectorSolvesTheSameEquationsWithFewerFactorisations) {
  const SpringChain chain(30);
  ContinuationOptions o = Sweep(0.0, 40.0);
  o.max_step = 0.5;
  o.reuse_factorisation_from = 0;  // never: Newton at every step
  const auto newton = trace_curve(chain, VectorXd::Zero(31), o);
  const int newton_jacobians = chain.jacobians;
  o.reuse_factorisation_from = 1;  // always
  chain.jacobians = 0;
  const auto chord = trace_curve(chain, VectorXd::Zero(31), o);
  ASSERT_TRUE(newton.reached_end()) << newton.message;
  ASSERT_TRUE(chord.reached_end()) << chord.message;
  EXPECT_EQ(newton.chord_points, 0);
  EXPECT_GT(chord.chord_points, static_cast<int>(chord.points.size()) / 2);
  EXPECT_LT(chord.profile.factorisations, newton.profile.factorisations);
  EXPECT_LT(chain.jacobians, newton_jacobians);
  EXPECT_GT(chord.profile.residual_only_evaluations, 0);
  // Every point solves e = 0 (checked here, not by the solver's own norm), and both curves
  // end on the same solution at lambda = 40.
  for (const auto& p : chord.points) {
    VectorXd e;
    ASSERT_TRUE(chain.evaluate(p.y, e, nullptr, nullptr));
    EXPECT_LT(e.lpNorm<Eigen::Infinity>(), 1e-8 * (1.0 + 2.0 * p.y(30)));
  }
  EXPECT_NEAR(chord.points.back().y(30), 40.0, 1e-12);
  EXPECT_LT((chord.points.back().y - newton.points.back().y).lpNorm<Eigen::Infinity>(), 1e-9);
}

TEST(Continuation, ChordCorrectorPassesTheFoldsOfTheSCurve) {
  // One equation: the chord is used from the second step on, and gives way to Newton near
  // the folds, where the Jacobian changes fastest.
  const ScalarCurve curve = SCurve();
  ContinuationOptions o = Sweep(-2.0, 2.0);
  o.reuse_factorisation_from = 1;
  const auto summary = trace_curve(curve, Eigen::Vector2d(-1.5, -2.0), o);
  ASSERT_TRUE(summary.reached_end()) << summary.message;
  EXPECT_EQ(summary.turning_points, 2);
  EXPECT_GT(summary.chord_points, 0);
  EXPECT_NEAR(summary.points.back().y(0), CubicRoot(2.0), 1e-9);
  for (const auto& p : summary.points) {
    const double x = p.y(0);
    EXPECT_LT(std::abs(x * x * x - x - p.y(1)), 1e-9);
  }
  o.reuse_factorisation_from = -1;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  o.reuse_factorisation_from = 0;
  o.max_chord_iterations = 0;
  EXPECT_FALSE(o.IsValid(&why));
}

TEST(Continuation, BudgetsAndCancellationStopTheTrace) {
  const ScalarCurve curve = SCurve();
  ContinuationOptions o = Sweep(-2.0, 2.0);
  o.max_points = 5;
  auto summary = trace_curve(curve, Eigen::Vector2d(-1.5, -2.0), o);
  EXPECT_EQ(summary.termination, TerminationType::kMaxPoints);
  EXPECT_EQ(summary.points.size(), 5u);

  o = Sweep(-2.0, 2.0);
  o.max_wall_seconds = 1e-12;
  summary = trace_curve(curve, Eigen::Vector2d(-1.5, -2.0), o);
  EXPECT_EQ(summary.termination, TerminationType::kTimeLimit);
  EXPECT_GE(summary.points.size(), 1u);

  o = Sweep(-2.0, 2.0);
  std::size_t calls = 0;
  summary = trace_curve(curve, Eigen::Vector2d(-1.5, -2.0), o,
                        [&](const ContinuationPoint&, std::size_t index) {
                          ++calls;
                          return index < 3;
                        });
  EXPECT_EQ(summary.termination, TerminationType::kCancelled);
  EXPECT_EQ(summary.points.size(), 4u);
  EXPECT_EQ(calls, 4u);
  EXPECT_STREQ(to_string(TerminationType::kReachedEnd), "reached_end");
  EXPECT_STREQ(to_string(TerminationType::kStepTooSmall), "step_too_small");
}

// A stop requested on the call's token ends a fixed-parameter Newton solve at its next
// iteration (unconverged, saying why) and a trace at its next step (cancelled); the same calls
// with a token of their own converge.
TEST(Continuation, AStopStopsNewtonSolvesAndTraces) {
  const ScalarCurve sq([](double x, double) { return x * x - 2.0; },
                       [](double x, double) { return Eigen::Vector2d(2.0 * x, 0.0); });
  ContinuationOptions stopped_options = Sweep(-2.0, 2.0);
  const StopSource source;
  stopped_options.newton.stop = source.token();
  source.request_stop(SIGINT);
  const NewtonResult stopped =
      solve_fixed_parameter(sq, Eigen::Vector2d(1.0, 0.7), stopped_options);
  const ScalarCurve curve = SCurve();
  const ContinuationSummary cut = trace_curve(curve, Eigen::Vector2d(-1.5, -2.0), stopped_options);
  EXPECT_FALSE(stopped.converged);
  EXPECT_EQ(stopped.iterations, 0);
  EXPECT_NE(stopped.message.find("interrupted by signal " + std::to_string(SIGINT)),
            std::string::npos)
      << stopped.message;
  EXPECT_EQ(cut.termination, TerminationType::kCancelled);
  EXPECT_NE(cut.message.find("interrupted"), std::string::npos) << cut.message;
  EXPECT_TRUE(solve_fixed_parameter(sq, Eigen::Vector2d(1.0, 0.7), {}).converged);
  EXPECT_TRUE(trace_curve(curve, Eigen::Vector2d(-1.5, -2.0), Sweep(-2.0, 2.0)).reached_end());
}

// Tokens are per call: a trace whose token is stopped (as by a SIGTERM) at its fourth point ends
// there, cancelled, while a trace running beside it on another thread, with a token of its own,
// reaches its end with the points it gives alone.
TEST(Continuation, AStopEndsItsOwnCallOnly) {
  const Eigen::Vector2d y0(-1.5, -2.0);
  const ContinuationSummary alone = trace_curve(SCurve(), y0, Sweep(-2.0, 2.0));
  ASSERT_TRUE(alone.reached_end());
  ASSERT_GT(alone.points.size(), 8u);
  const StopSource stopping, running_source;
  ContinuationOptions stopped_options = Sweep(-2.0, 2.0);
  stopped_options.newton.stop = stopping.token();
  ContinuationOptions running_options = Sweep(-2.0, 2.0);
  running_options.newton.stop = running_source.token();
  ContinuationSummary cut, beside;
  {
    std::latch start(2);
    std::jthread stopped([&] {
      const ScalarCurve curve = SCurve();
      start.arrive_and_wait();
      cut = trace_curve(curve, y0, stopped_options, [&](const ContinuationPoint&, std::size_t i) {
        if (i == 3) stopping.request_stop(SIGTERM);
        return true;
      });
    });
    std::jthread running([&] {
      const ScalarCurve curve = SCurve();
      start.arrive_and_wait();
      beside = trace_curve(curve, y0, running_options);
    });
  }
  EXPECT_EQ(cut.termination, TerminationType::kCancelled);
  EXPECT_EQ(cut.points.size(), 4u);
  EXPECT_NE(cut.message.find("interrupted by signal " + std::to_string(SIGTERM)), std::string::npos)
      << cut.message;
  EXPECT_FALSE(running_source.stop_requested());
  ASSERT_TRUE(beside.reached_end()) << beside.message;
  ASSERT_EQ(beside.points.size(), alone.points.size());
  for (std::size_t i = 0; i < alone.points.size(); ++i)
    EXPECT_EQ(beside.points[i].y, alone.points[i].y) << "point " << i;
}

// Solves one after another on one FixedParameterSolver give what separate solves give, and
// their profile counts all of them.
TEST(Continuation, FixedParameterSolverSolvesAsSeparateSolves) {
  const ScalarCurve cubic([](double x, double l) { return x * x * x + x - l; },
                          [](double x, double) { return Eigen::Vector2d(3 * x * x + 1, -1.0); });
  const ContinuationOptions options;
  FixedParameterSolver solver(cubic, options);
  long evaluations = 0;
  for (const double lambda : {-3.0, -0.5, 0.0, 2.0, 10.0}) {
    const NewtonResult shared = solver.solve(Eigen::Vector2d(0.3, lambda));
    const NewtonResult alone = solve_fixed_parameter(cubic, Eigen::Vector2d(0.3, lambda), options);
    ASSERT_TRUE(shared.converged) << shared.message;
    EXPECT_EQ(shared.y, alone.y);
    EXPECT_EQ(shared.iterations, alone.iterations);
    EXPECT_EQ(shared.y(1), lambda);
    EXPECT_NEAR(std::pow(shared.y(0), 3) + shared.y(0), lambda, 1e-9 * (1 + std::abs(lambda)));
    evaluations += alone.profile.evaluations;
  }
  EXPECT_EQ(solver.profile().evaluations, evaluations);
  EXPECT_FALSE(solver.solve(Eigen::Vector3d(0.0, 0.0, 1.0)).converged);  // wrong size
}

}  // namespace
}  // namespace frichb::core
