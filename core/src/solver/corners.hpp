// Corners and kinks of a piecewise-smooth solution curve. A contact sample changing regime
// makes the residual's derivative jump, so a friction branch is piecewise smooth: a correction
// may land across a corner (corner_between), and where a corner turns by more than 90 degrees,
// or a cluster of kinks makes Newton cycle between pieces, the step goes past the kink along the
// next piece's own tangent (step_past_kink). All in scaled variables (ScaledProblem).
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "solver/corrector.hpp"

namespace frichb::core {

// A corrector that lands farther from the predictor than the step either jumped to another
// branch or crossed a corner of this one. It is a corner when the two tangent lines - the last
// point's (y1, v1) and the landed point's (y2, v2) - meet, ahead of the last point and behind
// the landed one, at a point that is itself on the branch: two straight pieces meeting at a
// kink. A jump to another branch has tangent lines that miss each other, or meet away from any
// solution. Lengths are relative to the path through the corner. `min_cosine` bounds the turn.
bool corner_between(const ScaledProblem& problem, const NewtonOptions& newton,
                    const Eigen::VectorXd& y1, const Eigen::VectorXd& v1, const Eigen::VectorXd& y2,
                    const Eigen::VectorXd& v2, double min_cosine);

// Whether the scaled point y lies on the curve already traced: within `tolerance` of one of
// the chords between its last points (scaled, oldest first).
bool on_traced_curve(const Eigen::VectorXd& y, const std::vector<Eigen::VectorXd>& traced,
                     double tolerance);

// What step_past_kink needs of the last point, the same for every step tried from it (so
// evaluated once per point): its residual, the curve's orientation there, sign det [J1; v^T],
// and the curve traced up to it (its last points, scaled). `usable` false: the evaluation
// failed or the orientation is unknown, and no kink step is tried from this point.
struct KinkReference {
  bool usable = false;
  Eigen::VectorXd residual;
  int orientation = 0;
  std::vector<Eigen::VectorXd> traced;
};

KinkReference make_kink_reference(const ScaledProblem& problem,
                                  const std::vector<ContinuationPoint>& points);

// A step past a kink of the branch along the next piece's own tangent, for where the Keller
// corrector along the last tangent v fails at every step: a corner turning by more than 90
// degrees (e.g. a fold that falls on a contact sample changing regime, the lambda component
// of the tangent flipping across the kink) leaves no solution on the hyperplane ahead; a
// cluster of kinks (the micro-folds of a non-smooth force on a time grid) can make Newton
// cycle between pieces on it. At the failed predictor q = y + ds v, past the kink, the
// Jacobian J2 is the next piece's: its null vector v2 is that piece's direction up to sign.
// The sign is the one that keeps the curve's orientation, sign det [J2; w^T] =
// sign det [J1; v^T] (the orientation of a piecewise-smooth solution curve is the same on all
// its pieces; v . v_prev > 0, which orients the tangents between ordinary points, fails past
// a turn of more than 90 degrees, and the other sign walks the branch backwards). The residual
// stays flat along v up to the kink (J1 v = 0) and grows as J2 v past it, so the kink lies at
// y + t v with ds - t = (J2 v) . (e(q) - e(y)) / |J2 v|^2 (clamped to [0, ds]). The step from
// there along w is corrected on the hyperplane normal to w and taken when it converges
// without jumping, does not land on the line of the piece just traced and does not land on
// the curve traced before (reference.traced) - a walk backwards along the branch. On success
// `out` receives the correction and `travel` receives w.
bool step_past_kink(const ScaledProblem& problem, const NewtonOptions& newton,
                    const Eigen::VectorXd& ys_last, const Eigen::VectorXd& v, double step,
                    const KinkReference& reference, Correction* out, Eigen::VectorXd* travel);

}  // namespace frichb::core
