// The continuation's view of a CurveProblem: its unknowns and residual divided by the scales of
// ContinuationOptions (unknown_scale, residual_scale), evaluations that refuse non-finite
// output, and the SolveProfile every evaluation and factorisation of one solve is counted in.
#pragma once

#include <Eigen/Dense>
#include <chrono>
#include <string>
#include <utility>

#include "frichb/core/solver/continuation.hpp"
#include "solver/jacobian.hpp"
#include "solver/linear_solver.hpp"

namespace frichb::core {

// Scale vectors resolved to their full sizes (an empty option means all ones).
struct Scaling {
  Eigen::VectorXd unknown;   // n + 1, lambda's last
  Eigen::VectorXd residual;  // n
};

// Resolves the scales of `options` for n equations; false (with `why`) on wrong sizes.
bool make_scaling(const ContinuationOptions& options, Eigen::Index n, Scaling* scaling,
                  std::string* why);

// `lambda` for messages, in the display unit ("291.5 Hz"; "lambda = <value>" with
// 12 significant digits without one).
std::string format_lambda(double lambda, const LambdaDisplay& display);

// Wall seconds since `start`.
double seconds_since(std::chrono::steady_clock::time_point start);

// The problem in scaled variables ys = y / scaling.unknown, es = e / scaling.residual, with
// the linear-solver context of its solve (the kind from `options`, the kept preconditioners).
// Holds references: `problem` and `profile` must outlive it. `profile` may be null (nothing
// counted). Not thread-safe (it counts into the profile); one per solve.
class ScaledProblem {
 public:
  ScaledProblem(const CurveProblem& problem, Scaling scaling, const ContinuationOptions& options,
                SolveProfile* profile)
      : problem_(problem),
        scaling_(std::move(scaling)),
        profile_(profile),
        linear_(options, scaling_.residual.size(), profile, problem.has_jacobian_operator()) {
    display_ = options.lambda_display;
  }

  Eigen::Index equations() const { return scaling_.residual.size(); }
  const Scaling& scaling() const { return scaling_; }
  SolveProfile* profile() const { return profile_; }
  // The context every linear solver of this solve is made from (make_linear_solver).
  LinearSolverContext& linear() const { return linear_; }
  Eigen::VectorXd unscale(const Eigen::VectorXd& ys) const {
    return ys.cwiseProduct(scaling_.unknown);
  }
  Eigen::VectorXd scale(const Eigen::VectorXd& y) const {
    return y.cwiseQuotient(scaling_.unknown);
  }
  // The unscaled lambda of scaled unknowns.
  double lambda_of(const Eigen::VectorXd& ys) const {
    return ys(equations()) * scaling_.unknown(equations());
  }
  // The lambda of scaled unknowns as messages write it (format_lambda).
  std::string describe_lambda(const Eigen::VectorXd& ys) const {
    return format_lambda(lambda_of(ys), display_);
  }

  // The scaled residual `es` (size n) and, when `js` is not null, the scaled n x (n + 1)
  // Jacobian at scaled unknowns `ys`: formed into js's own storage, or as the problem's
  // operator on the matrix-free path (LinearSolverKind::kMatrixFree). False, with `message`,
  // when the problem fails, returns wrong sizes, or returns a non-finite value: NaN never
  // reaches an accepted point (an operator's entries are not checked; its products are, by
  // the solver that uses them).
  bool evaluate(const Eigen::VectorXd& ys, Eigen::VectorXd* es, Jacobian* js,
                std::string* message) const;

 private:
  const CurveProblem& problem_;
  Scaling scaling_;
  SolveProfile* profile_;
  mutable LinearSolverContext linear_;
  LambdaDisplay display_;
};

}  // namespace frichb::core
