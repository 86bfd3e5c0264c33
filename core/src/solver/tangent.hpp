// The continuation's tangents (the thesis' eqs. 4.9 and 4.10) and their orientation: the sign
// of det [e_y; v^T], the same on all pieces of a piecewise-smooth curve between branch points.
// All in scaled variables; `js` is the scaled n x (n + 1) Jacobian [e_x e_lambda]. The systems
// are solved by solvers made from `linear` (the solve's LinearSolverContext).
#pragma once

#include <Eigen/Dense>

#include "solver/corrector.hpp"

namespace frichb::core {

// Eq. 4.9: w = e_x^-1 e_lambda, v = direction * (-w, 1) / |(1, w)|. `condition`: estimate of
// the 1-norm condition number of e_x; `orientation` (optional): sign det [e_y; v^T]. False when
// e_x is singular or v is not finite.
bool first_tangent(const Jacobian& js, double direction, LinearSolverContext& linear,
                   Eigen::VectorXd* v, double* condition, int* orientation);

// Eq. 4.10: [A; v_prev^T] v = [0; 1]; the last row keeps v . v_prev > 0, i.e. no reversal.
// `condition` (optional): estimate of the 1-norm condition number of the bordered matrix,
// the Keller corrector's Newton matrix at the point. `keep` (optional): receives the
// factorisation for the next step's chord iterations (its solver is reused when it has one).
// `orientation` (optional): sign det [e_y; v^T], or 0 when the solver did not factorise the
// bordered matrix and the tangent turned from `previous` by less than keep_orientation's angle
// (the point then inherits its predecessor's orientation in keep_orientation); past that
// angle the matrix is factorised for its determinant.
bool next_tangent(const Jacobian& js, const Eigen::VectorXd& previous, LinearSolverContext& linear,
                  Eigen::VectorXd* v, double* condition = nullptr, KellerFactor* keep = nullptr,
                  int* orientation = nullptr);

// Reverses a tangent from next_tangent (and the Sherman-Morrison terms kept with it).
void reverse_tangent(Eigen::VectorXd* v, KellerFactor* keep);

// The tangent oriented along the travel (v . v_prev > 0) is the curve's own direction unless
// the point lies past a fold the step jumped (the corrector landed on a piece that runs back
// towards the last point): that orientation walks the curve backwards. The orientation sign
// det [J; v^T] is the same on all pieces of the curve; where the new point's sign differs
// from `reference` (the last point's) across a turn of more than about 26 degrees from
// `along`, the tangent is reversed and true returned. Below that turn - an ordinary step -
// the travel decides: the sign also changes at a branch point and where the curve runs
// inside a kink surface. A point whose orientation is 0 (not formed, next_tangent) takes
// `reference`. `keep`: the factorisation kept with the tangent (chord corrector).
bool keep_orientation(int reference, const Eigen::VectorXd& along, ContinuationPoint* point,
                      KellerFactor* keep);

}  // namespace frichb::core
