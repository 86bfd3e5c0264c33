// The continuation's scaled view of a problem (scaled_problem.hpp).
#include "solver/scaled_problem.hpp"

#include <chrono>
#include <sstream>

namespace frichb::core {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

bool make_scaling(const ContinuationOptions& options, Index n, Scaling* scaling, std::string* why) {
  scaling->unknown =
      options.unknown_scale.size() == 0 ? VectorXd::Ones(n + 1) : options.unknown_scale;
  scaling->residual =
      options.residual_scale.size() == 0 ? VectorXd::Ones(n) : options.residual_scale;
  const char* wrong = scaling->unknown.size() != n + 1 ? "unknown_scale must have n + 1 entries"
                      : scaling->residual.size() != n  ? "residual_scale must have n entries"
                                                       : nullptr;
  if (wrong != nullptr && why != nullptr) *why = wrong;
  return wrong == nullptr;
}

std::string format_lambda(double lambda, const LambdaDisplay& display) {
  std::ostringstream out;
  out.precision(12);
  if (display.unit.empty())
    out << "lambda = " << lambda;
  else
    out << lambda / display.per_unit << " " << display.unit;
  return out.str();
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

bool ScaledProblem::evaluate(const VectorXd& ys, VectorXd* es, Jacobian* js,
                             std::string* message) const {
  const Index n = equations();
  const VectorXd y = ys.cwiseProduct(scaling_.unknown);
  VectorXd e(n);
  const bool as_operator = js != nullptr && linear_.kind() == LinearSolverKind::kMatrixFree;
  MatrixXd* formed = js != nullptr && !as_operator ? &js->dense() : nullptr;
  std::shared_ptr<const JacobianOperator> op;
  if (formed != nullptr) formed->resize(n, n + 1);
  std::string why;
  const auto start = std::chrono::steady_clock::now();
  const bool evaluated = as_operator ? problem_.evaluate_operator(y, e, &op, &why)
                                     : problem_.evaluate(y, e, formed, &why);
  if (profile_ != nullptr) {
    ++profile_->evaluations;
    profile_->evaluation_seconds += seconds_since(start);
    if (js == nullptr) ++profile_->residual_only_evaluations;
  }
  if (!evaluated) {
    *message =
        "evaluation failed at " + format_lambda(y(n), display_) + (why.empty() ? "" : ": " + why);
    return false;
  }
  if (e.size() != n || (formed != nullptr && (formed->rows() != n || formed->cols() != n + 1)) ||
      (as_operator && (!op || op->rows() != n || op->parameter_column().size() != n))) {
    *message = "evaluate() returned wrongly sized residual or Jacobian";
    return false;
  }
  if (!e.allFinite() || (formed != nullptr && !formed->allFinite()) ||
      (as_operator && !op->parameter_column().allFinite())) {
    *message = "non-finite residual or Jacobian at " + format_lambda(y(n), display_);
    return false;
  }
  *es = e.cwiseQuotient(scaling_.residual);
  if (as_operator) {
    js->set_operator(std::move(op), scaling_);
  } else if (formed != nullptr) {
    // Rows by the residual scales and columns by the unknown scales, in one pass.
    const VectorXd inverse_residual_scale = scaling_.residual.cwiseInverse();
    for (Index c = 0; c <= n; ++c)
      formed->col(c) = formed->col(c).cwiseProduct(inverse_residual_scale) * scaling_.unknown(c);
  }
  return true;
}

}  // namespace frichb::core
