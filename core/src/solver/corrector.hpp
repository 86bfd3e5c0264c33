// The continuation's correctors: damped Newton at fixed lambda or on the Keller hyperplane,
// and chord iterations on the factorisation kept from the last point. All in scaled variables
// (ScaledProblem); failure is a result (Correction::converged false, with a message).
#pragma once

#include <Eigen/Dense>
#include <limits>
#include <memory>
#include <string>

#include "solver/linear_solver.hpp"
#include "solver/scaled_problem.hpp"

namespace frichb::core {

// Weight of a chord iteration in the step adaptation (eq. 4.13), against a Newton iteration:
// it contracts less, but costs one residual and two triangular solves instead of a Jacobian
// and a factorisation.
inline constexpr double kChordIterationWeight = 0.5;

struct Correction {
  bool converged = false;
  bool first_evaluation_failed = false;
  int iterations = 0;
  int chord_iterations = 0;  // of them, chord iterations on a kept factorisation
  double residual_norm = std::numeric_limits<double>::infinity();
  bool at_residual_floor = false;  // accepted on the residual alone (NewtonOptions)
  Eigen::VectorXd ys;              // scaled, lambda last
  Jacobian js;                     // scaled full Jacobian at ys
  std::string message;
};

// The factorisation of the Keller matrix A = [J; v_prev^T] at an accepted point, kept for the
// next step's chord iterations, with t = A^-1 e_n (the point's tangent v = t / |t|).
// The next corrector's matrix is B = [J; v^T] = A + e_n d^T with d = v - v_prev; B^-1 comes
// from A's factors by the Sherman-Morrison formula: B^-1 b = x - t (d . x) / (1 + d . t),
// x = A^-1 b (and 1 + d . t = |t| in exact arithmetic). Empty (no solver) until a tangent
// computation fills it.
struct KellerFactor {
  std::unique_ptr<LinearSolver> lu;
  Eigen::VectorXd t;
  Eigen::VectorXd d;
  double denominator = 1.0;
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const {
    const Eigen::VectorXd x = lu->solve_update(b);
    return x - t * (d.dot(x) / denominator);
  }
};

// Damped Newton in scaled variables from `ys0`. Without a tangent, lambda stays fixed and the
// n equations are solved for x; with a tangent v and predictor y1, the Keller system
// [e; v^T (y - y1)] = 0 is solved for all n + 1 unknowns. Memory: besides the problem's own,
// at most three n x (n + 1) Jacobians and one factorisation, each allocated once per call.
Correction newton_correct(const ScaledProblem& problem, const Eigen::VectorXd& ys0,
                          const NewtonOptions& options, const Eigen::VectorXd* tangent = nullptr,
                          const Eigen::VectorXd* predictor = nullptr);

// Keller corrector by chord iterations on `factor` (kept from the last point): each iteration
// costs one residual evaluation (no Jacobian) and two triangular solves. Gives up - not
// converged, ys its best iterate, for newton_correct to take over from there - when the
// residual does not at least halve per iteration (the Jacobian has changed too much: a contact
// changed regime, or the step is long) or after `max_chord` iterations. Converged: the
// Jacobian at the solution is evaluated once (the tangent needs it).
Correction chord_correct(const ScaledProblem& problem, const KellerFactor& factor,
                         const NewtonOptions& options, const Eigen::VectorXd& tangent,
                         const Eigen::VectorXd& predictor, int max_chord);

}  // namespace frichb::core
