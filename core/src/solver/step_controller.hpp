// The arclength step of the continuation (trace_curve): what step to try from a point, how it
// shrinks after a failed correction and grows after an accepted point, and the caps that keep
// it short where a long step would lose the curve's shape or step over part of it.
#pragma once

#include "frichb/core/solver/continuation.hpp"

namespace frichb::core {

// Steps are in the continuation's scaled units (ContinuationOptions::unknown_scale,
// lambda_scale). The controller reads `options` (it must outlive the controller) and owns only
// its own state. Not thread-safe; one per traced curve.
//
// The step tried from a point is the smallest of:
//   - the adapted step: after an accepted point, step * sqrt(target / iterations), at most
//     doubled and within [min_step, max_step] (a chord iteration counts half); after a failed
//     correction, half the step tried;
//   - on a steep branch (the tangent's unknowns grew by more than steep_branch_alpha), for the
//     next steep_branch_points points: steep_branch_step_factor * max_step;
//   - while retracing towards a fold that a step passed (turning_point_control): the fine step,
//     turning_point_refinement times the step that passed it, until a fold is accepted or
//     (turning_point_backtrack + 2) / turning_point_refinement points have been taken;
//   - near a linear resonance: the advance in lambda its band allows (step_bands), over the
//     tangent's lambda component;
// and never below min_step.
class StepController {
 public:
  explicit StepController(const ContinuationOptions& options);

  // The step to try from a point at `lambda` (unscaled) whose unit tangent has the scaled
  // lambda component `tangent_lambda`; `lambda_scale` is the scale of lambda.
  double propose(double lambda, double tangent_lambda, double lambda_scale) const;
  // The correction from `step` failed. False when `step` was already min_step: no smaller
  // step is left.
  bool on_reject(double step);
  // A step passed a fold and its points are undone: retrace with the fine step.
  void on_fold(double step);
  // A point was accepted from `step` after `effective_iterations` corrector iterations.
  // `passed_fold`: the tangent's lambda component changed sign. `steep`: the tangent's
  // unknowns grew by more than steep_branch_alpha. True when the steep-branch cap started.
  bool on_accept(double step, double effective_iterations, bool passed_fold, bool steep);

  // Retracing towards a fold with the fine step (folds found then are accepted at once).
  bool refining() const { return refining_; }

 private:
  const ContinuationOptions& options_;
  double step_;              // the adapted step
  int steep_left_ = 0;       // points still under the steep-branch cap
  bool refining_ = false;    // retracing towards a fold with the fine step
  int refine_left_ = 0;      // bound on that retrace in case the fold vanishes
  double refine_cap_ = 0.0;  // the fine step
};

}  // namespace frichb::core
