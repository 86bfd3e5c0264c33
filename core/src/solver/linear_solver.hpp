// The seam between the continuation and its linear algebra: every square system the corrector
// and the tangent solve - the Newton matrix e_x at fixed lambda, the bordered Keller matrix
// [e_y; v^T] - goes through a LinearSolver. make_linear_solver returns a dense one
// (DenseLuSolver); another (an iterative solver on the Jacobian's structure, say) implements the
// same interface and is returned by make_linear_solver without touching the corrector or the
// driver.
#pragma once

#include <Eigen/Dense>
#include <memory>

#include "frichb/core/numerics/dense_lu.hpp"
#include "frichb/core/solver/continuation.hpp"

namespace frichb::core {

// One square system, factorised (or otherwise prepared) once and solved for any number of
// right-hand sides. Refactorising reuses the object's storage. Not thread-safe.
class LinearSolver {
 public:
  virtual ~LinearSolver() = default;
  // Prepares to solve with the square matrix `a`.
  virtual void factorise(const Eigen::Ref<const Eigen::MatrixXd>& a) = 0;
  // Prepares to solve with the bordered matrix [top; last_row^T] (top n x (n + 1)).
  virtual void factorise_bordered(const Eigen::Ref<const Eigen::MatrixXd>& top,
                                  const Eigen::Ref<const Eigen::VectorXd>& last_row) = 0;
  // x with A x = b, for the matrix last prepared.
  virtual Eigen::VectorXd solve(const Eigen::VectorXd& b) const = 0;
  // False when the matrix is singular to working precision (its reciprocal condition estimate
  // is below machine epsilon or not finite); solve() must not be used then.
  virtual bool invertible() const = 0;
  // Estimate of the 1-norm condition number (infinite when the estimate of its reciprocal is 0).
  virtual double condition() const = 0;
  // Sign of the determinant (+1 or -1; 0 when exactly singular): the curve's orientation comes
  // from it.
  virtual int determinant_sign() const = 0;
};

// Dense LU with partial pivoting (numerics/dense_lu: blocked, OpenBLAS when built with it) and
// its reciprocal condition estimate. Factorisations and solves are timed into `profile` (may
// be null), which must outlive the solver.
class DenseLuSolver final : public LinearSolver {
 public:
  explicit DenseLuSolver(SolveProfile* profile) : profile_(profile) {}
  void factorise(const Eigen::Ref<const Eigen::MatrixXd>& a) override;
  void factorise_bordered(const Eigen::Ref<const Eigen::MatrixXd>& top,
                          const Eigen::Ref<const Eigen::VectorXd>& last_row) override;
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const override;
  bool invertible() const override;
  double condition() const override;
  int determinant_sign() const override { return lu_.determinant_sign(); }

 private:
  SolveProfile* profile_;
  DenseLu lu_;
};

// The solver the continuation uses for its systems, counting into `profile` (may be null).
std::unique_ptr<LinearSolver> make_linear_solver(SolveProfile* profile);

}  // namespace frichb::core
