// The seam between the continuation and its linear algebra: every square system the corrector
// and the tangent solve - the Newton matrix e_x at fixed lambda, the bordered Keller matrix
// [e_y; v^T] - goes through a LinearSolver made by make_linear_solver from the solve's
// LinearSolverContext: a dense LU of every matrix (DenseLuSolver), GMRES preconditioned by
// the LU of an earlier matrix that the context keeps between systems (GmresSolver), or GMRES on
// the problem's Jacobian operator preconditioned by the operator's own approximate inverse,
// also kept between systems (MatrixFreeSolver).
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <string>

#include "frichb/core/numerics/dense_lu.hpp"
#include "frichb/core/solver/continuation.hpp"
#include "solver/jacobian.hpp"

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
  // Prepares to solve with e_x of the scaled Jacobian `j`, or with the Keller matrix
  // [j; last_row^T]. A solver that works on matrices forms an operator's (Jacobian::formed).
  virtual void prepare(const Jacobian& j);
  virtual void prepare_bordered(const Jacobian& j, const Eigen::VectorXd& last_row);
  // x with A x = b, for the matrix last prepared; non-finite entries when it cannot be solved.
  virtual Eigen::VectorXd solve(const Eigen::VectorXd& b) const = 0;
  // A Newton or chord update: x with A x = b to the accuracy an update needs (an iterative
  // solver stops at ContinuationOptions::gmres_update_tolerance); the same as solve() for a
  // direct one.
  virtual Eigen::VectorXd solve_update(const Eigen::VectorXd& b) const { return solve(b); }
  // False when the matrix is singular to working precision (its reciprocal condition estimate
  // is below machine epsilon or not finite); solve() must not be used then. For a solver that
  // does not factorise every matrix, of the factorised matrix it works from.
  virtual bool invertible() const = 0;
  // Estimate of the 1-norm condition number (infinite when the estimate of its reciprocal is
  // 0), of the factorised matrix the solver works from.
  virtual double condition() const = 0;
  // True when the prepared matrix itself is factorised, so that determinant_sign() is free.
  virtual bool determinant_known() const = 0;
  // Sign of the determinant of the prepared matrix (+1 or -1; 0 when exactly singular): the
  // curve's orientation comes from it. Factorises the matrix when determinant_known() is false.
  virtual int determinant_sign() const = 0;
  // Why the last solve gave no solution (empty when it did, or when there is nothing to add).
  virtual std::string failure() const { return {}; }
};

// What the linear solvers of one solve (a curve, a fixed-parameter Newton) share: the kind,
// the GMRES settings, the LUs kept as preconditioners (one per size: the n x n Newton matrix
// and the (n + 1) x (n + 1) Keller matrix), and the SolveProfile every factorisation and
// solve is counted in (may be null; must outlive the context). Not thread-safe; one per solve.
class LinearSolverContext {
 public:
  // `options.linear_solver` resolved for n equations: kAuto becomes kMatrixFree from
  // options.matrix_free_from equations on where `has_operator` (the problem's
  // has_jacobian_operator()), kGmres from options.gmres_from on where not, kDenseLu below.
  // Writes the choice and its reason into the profile. kMatrixFree chosen by the scene
  // without an operator becomes kGmres, and the reason says so.
  LinearSolverContext(const ContinuationOptions& options, Eigen::Index n, SolveProfile* profile,
                      bool has_operator = false);

  LinearSolverKind kind() const { return kind_; }
  SolveProfile* profile() const { return profile_; }
  double tolerance() const { return tolerance_; }
  double update_tolerance() const { return update_tolerance_; }
  int max_iterations() const { return max_iterations_; }
  int refresh_iterations() const { return refresh_iterations_; }

  // An LU kept to precondition the systems of one size. `generation` counts its
  // factorisations, so that a solver knows whether the LU is still that of its own matrix.
  struct KeptFactor {
    DenseLu lu;
    long generation = 0;
    bool stale = true;  // refactorise at the next matrix of this size (none yet, or too slow)
  };
  KeptFactor& kept(Eigen::Index size) { return size == square_size_ ? square_ : bordered_; }
  // The operator preconditioner kept for the matrix-free path (shared by both sizes: the
  // bordered system is preconditioned through it, MatrixFreeSolver).
  struct KeptPreconditioner {
    std::shared_ptr<const ScaledPreconditioner> preconditioner;
    long generation = 0;
    bool stale = true;
  };
  KeptPreconditioner& kept_preconditioner() { return kept_preconditioner_; }
  Eigen::Index dense_limit() const { return dense_limit_; }

 private:
  LinearSolverKind kind_;
  SolveProfile* profile_;
  double tolerance_;
  double update_tolerance_;
  int max_iterations_;
  int refresh_iterations_;
  Eigen::Index square_size_ = 0;
  Eigen::Index dense_limit_ = 0;
  KeptFactor square_, bordered_;
  KeptPreconditioner kept_preconditioner_;
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
  bool determinant_known() const override { return true; }
  int determinant_sign() const override { return lu_.determinant_sign(); }

 private:
  SolveProfile* profile_;
  DenseLu lu_;
};

// GMRES (right-preconditioned, no restart, classical Gram-Schmidt applied twice) on a copy of
// the prepared matrix, preconditioned by the context's kept LU of that size. The kept LU is
// refactorised from the prepared matrix when it is stale or singular, when a solve does not
// converge (ContinuationOptions::gmres_*; a singular matrix then gives non-finite entries),
// and by determinant_sign() when it is not that of the prepared matrix. Refactorising
// replaces the LU every solver of that size in the context works from. Converged solves satisfy
// |b - A x|_2 <= tolerance |b|_2 (gmres_tolerance, or gmres_update_tolerance for an update),
// checked on the true residual. Holds a reference to the
// context, which must outlive it.
class GmresSolver final : public LinearSolver {
 public:
  explicit GmresSolver(LinearSolverContext& context) : context_(context) {}
  void factorise(const Eigen::Ref<const Eigen::MatrixXd>& a) override;
  void factorise_bordered(const Eigen::Ref<const Eigen::MatrixXd>& top,
                          const Eigen::Ref<const Eigen::VectorXd>& last_row) override;
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const override;
  Eigen::VectorXd solve_update(const Eigen::VectorXd& b) const override;
  bool invertible() const override;
  double condition() const override;
  bool determinant_known() const override;
  int determinant_sign() const override;

 private:
  LinearSolverContext::KeptFactor& kept() const { return context_.kept(matrix_.rows()); }
  void keep_or_refactorise();
  void refactorise() const;  // the kept LU becomes that of matrix_
  bool iterate(const Eigen::VectorXd& b, double tolerance, Eigen::VectorXd* x) const;
  Eigen::VectorXd solve_to(const Eigen::VectorXd& b, double tolerance) const;

  LinearSolverContext& context_;
  Eigen::MatrixXd matrix_;
  mutable long own_generation_ = -1;  // the kept LU's generation when it was matrix_'s
};

// GMRES on the scaled Jacobian operator (Jacobian in operator form): products cost what the
// operator's structure allows and nothing is formed. Preconditioned by the context's kept
// operator preconditioner (M of an earlier point; the Keller matrix through the bordering
// [M, g; v_x^T, v_lambda] with this matrix's g = e_lambda), brought to each new point where it
// can follow it (JacobianPreconditioner::follow), made afresh when stale and marked stale
// after a solve of more than gmres_refresh_iterations iterations. A solve that has not
// converged in gmres_max_iterations is repeated with this point's own preconditioner; if that
// fails too, the matrix is formed and factorised when it has at most
// matrix_free_dense_limit equations (counted in krylov_fallbacks), else the solution is
// non-finite. invertible() and condition() are of the preconditioner; determinant_sign()
// forms and factorises the matrix (0 above the limit). Given a dense Jacobian it behaves as
// DenseLuSolver. Holds a reference to the context, which must outlive it.
class MatrixFreeSolver final : public LinearSolver {
 public:
  explicit MatrixFreeSolver(LinearSolverContext& context) : context_(context) {}
  void factorise(const Eigen::Ref<const Eigen::MatrixXd>& a) override;
  void factorise_bordered(const Eigen::Ref<const Eigen::MatrixXd>& top,
                          const Eigen::Ref<const Eigen::VectorXd>& last_row) override;
  void prepare(const Jacobian& j) override;
  void prepare_bordered(const Jacobian& j, const Eigen::VectorXd& last_row) override;
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const override;
  Eigen::VectorXd solve_update(const Eigen::VectorXd& b) const override;
  bool invertible() const override;
  double condition() const override;
  bool determinant_known() const override { return dense_ready_; }
  int determinant_sign() const override;
  std::string failure() const override { return failure_; }

 private:
  void prepare_operator(const Jacobian& j, const Eigen::VectorXd* last_row);
  void refresh_preconditioner() const;  // the kept preconditioner becomes this point's
  bool form_dense() const;              // dense_ becomes the LU of this matrix, if it fits
  Eigen::VectorXd multiply(const Eigen::VectorXd& x) const;
  Eigen::VectorXd precondition(const Eigen::VectorXd& b) const;
  Eigen::VectorXd solve_to(const Eigen::VectorXd& b, double tolerance) const;

  LinearSolverContext& context_;
  Jacobian jacobian_;  // operator form (shares the operator)
  bool bordered_ = false;
  Eigen::VectorXd last_row_;
  // The bordering of the kept preconditioner: b = M^-1 g and v_lambda - v_x . b.
  mutable Eigen::VectorXd bordering_solution_;
  mutable double bordering_denominator_ = 1.0;
  mutable long bordering_generation_ = -1;
  mutable long own_generation_ = -1;  // the kept preconditioner's generation when it was made here
  mutable DenseLu dense_;
  mutable bool dense_ready_ = false;
  mutable std::string failure_;
};

// The solver for one system of the solve that owns `context`.
std::unique_ptr<LinearSolver> make_linear_solver(LinearSolverContext& context);

}  // namespace frichb::core
