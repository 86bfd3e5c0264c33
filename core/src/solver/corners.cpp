// Corners and kinks of a piecewise-smooth solution curve (corners.hpp).
#include "solver/corners.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace frichb::core {

using Eigen::VectorXd;

bool corner_between(const ScaledProblem& problem, const NewtonOptions& newton, const VectorXd& y1,
                    const VectorXd& v1, const VectorXd& y2, const VectorXd& v2, double min_cosine) {
  constexpr double kRelativeTolerance = 0.05;
  const double c = v1.dot(v2);
  if (c < min_cosine || 1.0 - c * c < 1e-8) return false;  // too sharp, or parallel lines
  // Closest points y1 + a v1 and y2 + b v2 of the two lines.
  const VectorXd w = y1 - y2;
  const double d = v1.dot(w), f = v2.dot(w);
  const double a = (c * f - d) / (1.0 - c * c);
  const double b = f + a * c;
  const double path = a - b;
  if (!(a >= 0.0 && b <= 0.0 && path > 0.0)) return false;
  const VectorXd p1 = y1 + a * v1, p2 = y2 + b * v2;
  if ((p1 - p2).norm() > kRelativeTolerance * path) return false;
  // The kink estimate must lie on the branch: corrected on the hyperplane through it
  // normal to the bisector of the two tangents, it moves by a small part of the path.
  const VectorXd kink = 0.5 * (p1 + p2);
  const VectorXd bisector = (v1 - v2).norm() > 1e-12 ? VectorXd((v1 - v2).normalized()) : v1;
  const Correction onto = newton_correct(problem, kink, newton, &bisector, &kink);
  return onto.converged && (onto.ys - kink).norm() <= kRelativeTolerance * path;
}

bool on_traced_curve(const VectorXd& y, const std::vector<VectorXd>& traced, double tolerance) {
  for (std::size_t i = 1; i < traced.size(); ++i) {
    const VectorXd chord = traced[i] - traced[i - 1];
    const double length_squared = chord.squaredNorm();
    const double along = length_squared > 0.0
                             ? std::clamp((y - traced[i - 1]).dot(chord) / length_squared, 0.0, 1.0)
                             : 0.0;
    if ((y - traced[i - 1] - along * chord).norm() <= tolerance) return true;
  }
  return false;
}

KinkReference make_kink_reference(const ScaledProblem& problem,
                                  const std::vector<ContinuationPoint>& points) {
  constexpr std::size_t kTracedPoints = 64;  // the curve a kink step must not land on
  KinkReference ref;
  const ContinuationPoint& last = points.back();
  const VectorXd ys_last = problem.scale(last.y);
  std::string message;
  if (!problem.evaluate(ys_last, &ref.residual, nullptr, &message)) return ref;
  ref.orientation = last.orientation;  // sign det [J; v^T], kept with the point
  for (std::size_t i = points.size() > kTracedPoints ? points.size() - kTracedPoints : 0;
       i < points.size(); ++i)
    ref.traced.push_back(problem.scale(points[i].y));
  ref.usable = ref.orientation != 0;
  return ref;
}

bool step_past_kink(const ScaledProblem& problem, const NewtonOptions& newton,
                    const VectorXd& ys_last, const VectorXd& v, double step,
                    const KinkReference& reference, Correction* out, VectorXd* travel) {
  constexpr double kMinSineToOldPiece = 0.25;  // within ~14 degrees of +-v: the old piece
  constexpr double kOnTracedCurve = 0.05;      // of the step taken: on a chord traced before
  if (!reference.usable) return false;
  const VectorXd q = ys_last + step * v;
  VectorXd e_q;
  Jacobian j_q;
  std::string message;
  if (!problem.evaluate(q, &e_q, &j_q, &message)) return false;
  const std::unique_ptr<LinearSolver> past = make_linear_solver(problem.linear());
  past->prepare_bordered(j_q, v);
  if (!past->invertible()) return false;
  // [J2; v^T] t = e_n: J2 t = 0, and det [J2; t^T] has the sign of det [J2; v^T] (t . t > 0).
  const VectorXd t = past->solve(VectorXd::Unit(v.size(), v.size() - 1));
  if (!t.allFinite() || t.norm() == 0.0) return false;
  const VectorXd direction =
      (past->determinant_sign() == reference.orientation ? 1.0 : -1.0) * t / t.norm();
  const VectorXd growth = j_q.apply(v);  // J2 v
  const double growth_squared = growth.squaredNorm();
  double beyond =
      growth_squared > 0.0 ? growth.dot(e_q - reference.residual) / growth_squared : 0.0;
  if (!std::isfinite(beyond)) beyond = 0.0;
  const VectorXd kink = ys_last + (step - std::clamp(beyond, 0.0, step)) * v;
  const VectorXd predictor = kink + step * direction;
  Correction corr = newton_correct(problem, predictor, newton, &direction, &predictor);
  if (!corr.converged || (corr.ys - predictor).norm() > step) return false;
  const VectorXd d = corr.ys - ys_last;
  if ((d - d.dot(v) * v).norm() < kMinSineToOldPiece * d.norm()) return false;
  // Nor back onto the pieces traced before it (a walk backwards along the branch).
  if (on_traced_curve(corr.ys, reference.traced, kOnTracedCurve * d.norm())) return false;
  *out = std::move(corr);
  *travel = direction;
  return true;
}

}  // namespace frichb::core
