// The continuation's step controller against its rules written out by hand: growth by
// sqrt(N* / N) at most doubled and clamped, halving after a failure, the fine step after a
// fold and its end, the steep-branch cap and its length, and the resonance-band bound.
#include <gtest/gtest.h>

#include <cmath>

#include "solver/step_controller.hpp"

namespace frichb::core {
namespace {

ContinuationOptions Options() {
  ContinuationOptions o;
  o.initial_step = 0.01;
  o.min_step = 1e-6;
  o.max_step = 0.1;
  o.target_newton_iterations = 4;
  o.turning_point_backtrack = 2;
  o.turning_point_refinement = 0.1;
  o.steep_branch_step_factor = 0.1;
  o.steep_branch_points = 5;
  return o;
}

constexpr double kFarLambda = 1.0;  // no bands: the bands allow any step
constexpr double kTangentLambda = 0.5;

TEST(StepController, GrowsBySqrtOfTargetOverIterationsAtMostDoubledAndClamped) {
  const auto o = Options();
  StepController steps(o);
  EXPECT_EQ(steps.propose(kFarLambda, kTangentLambda, 1.0), 0.01);
  steps.on_accept(0.01, 16.0, false, false);  // 0.01 * sqrt(4 / 16)
  EXPECT_DOUBLE_EQ(steps.propose(kFarLambda, kTangentLambda, 1.0), 0.005);
  steps.on_accept(0.005, 2.0, false, false);  // 0.005 * sqrt(2)
  EXPECT_DOUBLE_EQ(steps.propose(kFarLambda, kTangentLambda, 1.0), 0.005 * std::sqrt(2.0));
  steps.on_accept(0.01, 0.0, false, false);  // 0 iterations count as 1: sqrt(4) = 2, the cap
  EXPECT_DOUBLE_EQ(steps.propose(kFarLambda, kTangentLambda, 1.0), 0.02);
  steps.on_accept(0.08, 1.0, false, false);  // 0.16, clamped to max_step
  EXPECT_DOUBLE_EQ(steps.propose(kFarLambda, kTangentLambda, 1.0), 0.1);
}

TEST(StepController, HalvesAfterAFailureUntilMinStep) {
  const auto o = Options();
  StepController steps(o);
  EXPECT_TRUE(steps.on_reject(0.01));
  EXPECT_DOUBLE_EQ(steps.propose(kFarLambda, kTangentLambda, 1.0), 0.005);
  EXPECT_TRUE(steps.on_reject(1.5e-6));  // halved below min_step: min_step
  EXPECT_DOUBLE_EQ(steps.propose(kFarLambda, kTangentLambda, 1.0), 1e-6);
  EXPECT_FALSE(steps.on_reject(1e-6));  // nothing smaller is left
}

TEST(StepController, RetracesAFoldWithTheFineStepUntilAFoldIsAcceptedOrTheBoundRunsOut) {
  const auto o = Options();
  StepController steps(o);
  steps.on_fold(0.05);
  EXPECT_TRUE(steps.refining());
  EXPECT_DOUBLE_EQ(steps.propose(kFarLambda, kTangentLambda, 1.0), 0.005);
  // Accepted points with few iterations grow the adapted step, but the fine step caps it.
  steps.on_accept(0.005, 1.0, false, false);
  EXPECT_DOUBLE_EQ(steps.propose(kFarLambda, kTangentLambda, 1.0), 0.005);
  steps.on_accept(0.005, 1.0, true, false);  // the fold is accepted: the cap ends
  EXPECT_FALSE(steps.refining());
  EXPECT_DOUBLE_EQ(steps.propose(kFarLambda, kTangentLambda, 1.0), 0.01);

  // Without a fold the cap ends after (backtrack + 2) / refinement = 40 points.
  StepController lost(o);
  lost.on_fold(0.05);
  for (int i = 0; i < 39; ++i) {
    lost.on_accept(0.005, 4.0, false, false);
    ASSERT_TRUE(lost.refining()) << i;
  }
  lost.on_accept(0.005, 4.0, false, false);
  EXPECT_FALSE(lost.refining());
}

TEST(StepController, CapsTheStepOnASteepBranchForTheFollowingPoints) {
  auto o = Options();
  StepController steps(o);
  EXPECT_TRUE(steps.on_accept(0.1, 1.0, false, true));  // adapted 0.1, capped at 0.1 * 0.1
  for (int i = 0; i < 5; ++i) {
    EXPECT_DOUBLE_EQ(steps.propose(kFarLambda, kTangentLambda, 1.0), 0.01) << i;
    steps.on_accept(0.1, 4.0, false, false);
  }
  EXPECT_DOUBLE_EQ(steps.propose(kFarLambda, kTangentLambda, 1.0), 0.1);
  o.steep_branch_control = false;
  StepController uncapped(o);
  EXPECT_FALSE(uncapped.on_accept(0.1, 1.0, false, true));
  EXPECT_DOUBLE_EQ(uncapped.propose(kFarLambda, kTangentLambda, 1.0), 0.1);
}

TEST(StepController, ABandBoundsTheAdvanceInLambdaOverTheTangentsLambdaComponent) {
  auto o = Options();
  o.initial_step = 0.1;
  ContinuationOptions::StepBand band;
  band.centre = 100.0;
  band.step = 0.2;
  band.growth = 0.8;
  band.leaving_growth = 2.0;
  o.step_bands = {band};
  StepController steps(o);
  const double lambda_scale = 10.0, tangent_lambda = 0.5;
  // 1 below the centre, approaching: advance 0.2 + 0.8 * 1 = 1.0 in lambda, 0.1 scaled,
  // over the tangent's lambda component 0.5: a step of 0.2 > 0.1 (the adapted step decides).
  EXPECT_DOUBLE_EQ(steps.propose(99.0, tangent_lambda, lambda_scale), 0.1);
  // At the centre: 0.2 / 10 / 0.5 = 0.04.
  EXPECT_DOUBLE_EQ(steps.propose(100.0, tangent_lambda, lambda_scale), 0.04);
  // 0.125 past it, leaving: (0.2 + 2 * 0.125) / 10 / 0.5 = 0.09; approaching from there
  // (lambda decreasing): (0.2 + 0.8 * 0.125) / 10 / 0.5 = 0.06.
  EXPECT_DOUBLE_EQ(steps.propose(100.125, tangent_lambda, lambda_scale), 0.09);
  EXPECT_DOUBLE_EQ(steps.propose(100.125, -tangent_lambda, lambda_scale), 0.06);
  // Never below min_step.
  o.step_bands[0].step = 1e-12;
  StepController tiny(o);
  EXPECT_DOUBLE_EQ(tiny.propose(100.0, tangent_lambda, lambda_scale), o.min_step);
}

}  // namespace
}  // namespace frichb::core
