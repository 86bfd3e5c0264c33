// The continuation's tangents and their orientation (tangent.hpp).
#include "solver/tangent.hpp"

#include <cmath>

namespace frichb::core {

using Eigen::Index;
using Eigen::VectorXd;

namespace {
// The cosine between a new tangent and the direction of travel below which the orientation is
// checked (keep_orientation): a turn of more than about 26 degrees.
constexpr double kKeepOrientationCosine = 0.9;
}  // namespace

bool first_tangent(const Jacobian& js, double direction, LinearSolverContext& linear, VectorXd* v,
                   double* condition, int* orientation) {
  const Index n = js.rows();
  const std::unique_ptr<LinearSolver> lu = make_linear_solver(linear);
  lu->prepare(js);
  *condition = lu->condition();
  if (!lu->invertible()) return false;
  const VectorXd w = lu->solve(js.parameter_column());
  VectorXd t(n + 1);
  t.head(n) = -w;
  t(n) = 1.0;
  *v = direction * t / t.norm();
  // det [e_x e_lambda; v^T] = det e_x (1 + w . w) direction / |(1, w)|.
  if (orientation != nullptr)
    *orientation = direction > 0 ? lu->determinant_sign() : -lu->determinant_sign();
  return v->allFinite();
}

bool next_tangent(const Jacobian& js, const VectorXd& previous, LinearSolverContext& linear,
                  VectorXd* v, double* condition, KellerFactor* keep, int* orientation) {
  const Index n = js.rows();
  KellerFactor local;
  KellerFactor& f = keep != nullptr ? *keep : local;
  if (!f.lu) f.lu = make_linear_solver(linear);
  f.lu->prepare_bordered(js, previous);
  if (condition != nullptr) *condition = f.lu->condition();
  if (!f.lu->invertible()) return false;
  f.t = f.lu->solve(VectorXd::Unit(n + 1, n));
  *v = f.t / f.t.norm();
  if (!v->allFinite()) return false;
  // [J; v^T] = [J; p^T] + e_n (v - p)^T has determinant det [J; p^T] |t| (v . t = |t|).
  if (orientation != nullptr)
    *orientation = f.lu->determinant_known() || v->dot(previous) < kKeepOrientationCosine
                       ? f.lu->determinant_sign()
                       : 0;
  f.d = *v - previous;
  f.denominator = 1.0 + f.d.dot(f.t);
  return std::isfinite(f.denominator) && std::abs(f.denominator) > 0.0;
}

void reverse_tangent(VectorXd* v, KellerFactor* keep) {
  if (keep != nullptr) {
    const VectorXd bordering = *v - keep->d;  // the row p the factorised matrix was bordered by
    keep->d = -*v - bordering;
    keep->denominator = 1.0 + keep->d.dot(keep->t);
  }
  *v = -*v;
}

bool keep_orientation(int reference, const VectorXd& along, ContinuationPoint* point,
                      KellerFactor* keep) {
  if (point->orientation == 0) {
    point->orientation = reference;
    return false;
  }
  if (reference == 0 || point->orientation == reference ||
      point->tangent.dot(along) >= kKeepOrientationCosine)
    return false;
  reverse_tangent(&point->tangent, keep);
  point->orientation = reference;
  return true;
}

}  // namespace frichb::core
