// The scaled Jacobian, formed or as an operator (jacobian.hpp).
#include "solver/jacobian.hpp"

#include "solver/scaled_problem.hpp"

namespace frichb::core {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

VectorXd ScaledPreconditioner::solve(const VectorXd& b) const {
  const Index n = b.size();
  const VectorXd unscaled = b.cwiseProduct(scaling_->residual);
  VectorXd x(n);
  inner_->solve(unscaled, x);
  return x.cwiseQuotient(scaling_->unknown.head(n));
}

std::unique_ptr<ScaledPreconditioner> ScaledPreconditioner::follow(const Jacobian& j) const {
  if (j.op() == nullptr) return nullptr;
  std::unique_ptr<JacobianPreconditioner> inner = inner_->follow(*j.op());
  if (!inner) return nullptr;
  return std::make_unique<ScaledPreconditioner>(std::move(inner), *scaling_);
}

void Jacobian::set_operator(std::shared_ptr<const JacobianOperator> op, const Scaling& scaling) {
  op_ = std::move(op);
  scaling_ = &scaling;
  dense_.resize(0, 0);
}

VectorXd Jacobian::apply_square(const VectorXd& x) const {
  if (!op_) return dense_.leftCols(dense_.rows()) * x;
  const Index n = op_->rows();
  const VectorXd unscaled = x.cwiseProduct(scaling_->unknown.head(n));
  VectorXd y(n);
  op_->apply(unscaled, y);
  return y.cwiseQuotient(scaling_->residual);
}

VectorXd Jacobian::parameter_column() const {
  if (!op_) return dense_.col(dense_.rows());
  const Index n = op_->rows();
  return op_->parameter_column().cwiseQuotient(scaling_->residual) * scaling_->unknown(n);
}

VectorXd Jacobian::apply(const VectorXd& z) const {
  if (!op_) return dense_ * z;
  const Index n = op_->rows();
  return apply_square(z.head(n)) + parameter_column() * z(n);
}

MatrixXd Jacobian::formed() const {
  if (!op_) return dense_;
  const Index n = op_->rows();
  MatrixXd j(n, n + 1);
  op_->form(j.leftCols(n));
  j.leftCols(n) = scaling_->residual.cwiseInverse().asDiagonal() * j.leftCols(n) *
                  scaling_->unknown.head(n).asDiagonal();
  j.col(n) = parameter_column();
  return j;
}

std::unique_ptr<ScaledPreconditioner> Jacobian::make_preconditioner() const {
  if (!op_) return nullptr;
  std::unique_ptr<JacobianPreconditioner> inner = op_->make_preconditioner();
  if (!inner) return nullptr;
  return std::make_unique<ScaledPreconditioner>(std::move(inner), *scaling_);
}

}  // namespace frichb::core
