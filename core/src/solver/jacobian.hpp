// The scaled Jacobian Js = [e_x e_lambda] (n x (n + 1)) the continuation carries from an
// evaluation to its solves: formed (a dense matrix), or a problem's JacobianOperator seen
// through the scales, Js = diag(1 / residual_scale) J diag(unknown_scale), which is never formed
// unless a solve needs a factorisation.
#pragma once

#include <Eigen/Dense>
#include <memory>

#include "frichb/core/solver/continuation.hpp"

namespace frichb::core {

struct Scaling;
class Jacobian;

// The preconditioner of a scaled operator: Ms^-1 b = diag(1 / unknown_scale) M^-1 diag(
// residual_scale) b. Holds a reference to the scales, which must outlive it.
class ScaledPreconditioner {
 public:
  ScaledPreconditioner(std::unique_ptr<JacobianPreconditioner> inner, const Scaling& scaling)
      : inner_(std::move(inner)), scaling_(&scaling) {}
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;
  double condition() const { return inner_->condition(); }
  // JacobianPreconditioner::follow through the same scales; null when it cannot follow.
  std::unique_ptr<ScaledPreconditioner> follow(const Jacobian& j) const;

 private:
  std::unique_ptr<JacobianPreconditioner> inner_;
  const Scaling* scaling_;
};

class Jacobian {
 public:
  Eigen::Index rows() const { return op_ ? op_->rows() : dense_.rows(); }
  bool is_operator() const { return op_ != nullptr; }
  // The formed matrix (empty in operator form); ScaledProblem::evaluate writes it.
  Eigen::MatrixXd& dense() { return dense_; }
  const Eigen::MatrixXd& dense() const { return dense_; }
  // Operator form: `op` (unscaled) seen through `scaling`, which must outlive this object and
  // its copies. Releases the formed matrix's storage.
  void set_operator(std::shared_ptr<const JacobianOperator> op, const Scaling& scaling);

  // Js z for z of size n + 1, and Js_x x (the first n columns) for x of size n.
  Eigen::VectorXd apply(const Eigen::VectorXd& z) const;
  Eigen::VectorXd apply_square(const Eigen::VectorXd& x) const;
  // The scaled e_lambda (size n).
  Eigen::VectorXd parameter_column() const;
  // The scaled matrix formed (n x (n + 1)): dense() itself, or the operator applied to the
  // identity (n products in one block).
  Eigen::MatrixXd formed() const;
  // The operator's preconditioner in scaled variables (operator form only).
  std::unique_ptr<ScaledPreconditioner> make_preconditioner() const;
  // The unscaled operator (null in formed form).
  const JacobianOperator* op() const { return op_.get(); }

  void swap(Jacobian& other) noexcept {
    dense_.swap(other.dense_);
    op_.swap(other.op_);
    std::swap(scaling_, other.scaling_);
  }

 private:
  Eigen::MatrixXd dense_;
  std::shared_ptr<const JacobianOperator> op_;
  const Scaling* scaling_ = nullptr;
};

}  // namespace frichb::core
