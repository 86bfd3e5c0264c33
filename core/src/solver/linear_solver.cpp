// The continuation's linear solvers (linear_solver.hpp).
#include "solver/linear_solver.hpp"

#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <sstream>
#include <utility>

#include "solver/scaled_problem.hpp"

namespace frichb::core {

namespace {

void account(SolveProfile* profile, std::chrono::steady_clock::time_point start,
             bool factorisation) {
  if (profile == nullptr) return;
  profile->factorisation_seconds += seconds_since(start);
  if (factorisation) ++profile->factorisations;
}

bool invertible_lu(const DenseLu& lu) {
  return std::isfinite(lu.rcond()) && lu.rcond() > std::numeric_limits<double>::epsilon();
}

double condition_of(const DenseLu& lu) {
  return lu.rcond() > 0.0 ? 1.0 / lu.rcond() : std::numeric_limits<double>::infinity();
}

// Right-preconditioned GMRES from x = 0 for A x = b, with products `multiply` (A z) and
// `precondition` (M^-1 z), in its flexible form: the Krylov basis V of A M^-1 with the
// Hessenberg matrix reduced by Givens rotations as it grows, and the preconditioned vectors
// Z = M^-1 V kept, x = Z y at the end. Kept rather than recomputed as M^-1 (V y), so that a
// preconditioner applied with rounding errors of its own (single precision) still gives
// A x = V H y to double precision. At most context.max_iterations();
// counted into the context's profile; a solve of more than refresh_iterations() marks the
// preconditioner for refreshing (*slow). Converged when the true residual |b - A x| is at most
// tolerance |b|.
template <typename Multiply, typename Precondition>
bool right_preconditioned_gmres(const Multiply& multiply, const Precondition& precondition,
                                const Eigen::VectorXd& b, double tolerance,
                                const LinearSolverContext& context, Eigen::VectorXd* x,
                                bool* slow = nullptr) {
  const Eigen::Index n = b.size();
  const int max_k = context.max_iterations();
  const double beta = b.norm();
  SolveProfile* profile = context.profile();
  if (profile != nullptr) ++profile->krylov_solves;
  if (slow != nullptr) *slow = false;
  if (beta == 0.0) {
    x->setZero(n);
    return true;
  }
  const double target = tolerance * beta;
  Eigen::MatrixXd v(n, max_k + 1);
  Eigen::MatrixXd z(n, max_k);
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(max_k + 1, max_k);
  Eigen::VectorXd cs(max_k), sn(max_k), g = Eigen::VectorXd::Zero(max_k + 1);
  v.col(0) = b / beta;
  g(0) = beta;
  int k = 0;
  while (k < max_k) {
    z.col(k) = precondition(v.col(k));
    Eigen::VectorXd w = multiply(z.col(k));
    for (int pass = 0; pass < 2; ++pass) {  // classical Gram-Schmidt, twice
      const Eigen::VectorXd c = v.leftCols(k + 1).transpose() * w;
      w.noalias() -= v.leftCols(k + 1) * c;
      h.col(k).head(k + 1) += c;
    }
    h(k + 1, k) = w.norm();
    if (h(k + 1, k) > 0.0) v.col(k + 1) = w / h(k + 1, k);
    for (int i = 0; i < k; ++i) {
      const double t = cs(i) * h(i, k) + sn(i) * h(i + 1, k);
      h(i + 1, k) = -sn(i) * h(i, k) + cs(i) * h(i + 1, k);
      h(i, k) = t;
    }
    const double r = std::hypot(h(k, k), h(k + 1, k));
    if (!(r > 0.0)) break;
    cs(k) = h(k, k) / r;
    sn(k) = h(k + 1, k) / r;
    h(k, k) = r;
    h(k + 1, k) = 0.0;
    g(k + 1) = -sn(k) * g(k);
    g(k) *= cs(k);
    ++k;
    if (std::abs(g(k)) <= target) break;
  }
  if (profile != nullptr) profile->krylov_iterations += k;
  if (k == 0) return false;
  const Eigen::VectorXd y = h.topLeftCorner(k, k).triangularView<Eigen::Upper>().solve(g.head(k));
  *x = z.leftCols(k) * y;
  if (!x->allFinite()) return false;
  const double true_residual = (b - multiply(*x)).norm();
  if (slow != nullptr) *slow = k > context.refresh_iterations();
  return true_residual <= target;
}

}  // namespace

const char* to_string(LinearSolverKind kind) {
  switch (kind) {
    case LinearSolverKind::kAuto:
      return "auto";
    case LinearSolverKind::kDenseLu:
      return "dense_lu";
    case LinearSolverKind::kGmres:
      return "gmres";
    case LinearSolverKind::kMatrixFree:
      return "matrix_free";
  }
  return "unknown";
}

LinearSolverChoice choose_linear_solver(const ContinuationOptions& options, Eigen::Index n,
                                        bool has_operator) {
  LinearSolverChoice choice;
  std::ostringstream why;
  choice.kind = options.linear_solver;
  if (choice.kind == LinearSolverKind::kAuto) {
    const Eigen::Index from = has_operator ? options.matrix_free_from : options.gmres_from;
    const bool iterative = n >= from;
    choice.kind = !iterative     ? LinearSolverKind::kDenseLu
                  : has_operator ? LinearSolverKind::kMatrixFree
                                 : LinearSolverKind::kGmres;
    why << "auto: " << n << " equations, " << (iterative ? ">= " : "< ") << from
        << (has_operator ? " (matrix_free_from; the model applies its Jacobian as an operator)"
                         : " (gmres_from; the model has no Jacobian operator)");
  } else if (choice.kind == LinearSolverKind::kMatrixFree && !has_operator) {
    choice.kind = LinearSolverKind::kGmres;
    why << "matrix_free chosen by the scene, but the model has no Jacobian operator: gmres";
  } else {
    why << "chosen by the scene";
  }
  choice.reason = why.str();
  return choice;
}

double linear_solver_bytes(const ContinuationOptions& options, LinearSolverKind kind,
                           Eigen::Index n, Eigen::Index components, Eigen::Index harmonics) {
  const auto rows = static_cast<double>(n + 1);
  if (kind != LinearSolverKind::kMatrixFree) return 3.0 * sizeof(double) * rows * rows;
  const auto m = static_cast<double>(components);
  const double preconditioner = (static_cast<double>(harmonics) * sizeof(std::complex<float>) +
                                 sizeof(std::complex<double>)) *
                                m * m;
  const double krylov =
      2.0 * sizeof(double) * rows * static_cast<double>(options.gmres_max_iterations + 1);
  const double formed =
      n + 1 <= options.matrix_free_dense_limit ? 2.0 * sizeof(double) * rows * rows : 0.0;
  return preconditioner + krylov + formed;
}

LinearSolverContext::LinearSolverContext(const ContinuationOptions& options, Eigen::Index n,
                                         SolveProfile* profile, bool has_operator)
    : kind_(LinearSolverKind::kDenseLu),
      profile_(profile),
      tolerance_(options.gmres_tolerance),
      update_tolerance_(options.gmres_update_tolerance),
      max_iterations_(options.gmres_max_iterations),
      refresh_iterations_(options.gmres_refresh_iterations),
      square_size_(n),
      dense_limit_(options.matrix_free_dense_limit) {
  LinearSolverChoice choice = choose_linear_solver(options, n, has_operator);
  kind_ = choice.kind;
  if (profile_ != nullptr) {
    profile_->linear_solver = to_string(kind_);
    profile_->linear_solver_reason = std::move(choice.reason);
  }
}

void LinearSolver::prepare(const Jacobian& j) {
  const Eigen::Index n = j.rows();
  if (!j.is_operator()) {
    factorise(j.dense().leftCols(n));
    return;
  }
  const Eigen::MatrixXd formed = j.formed();
  factorise(formed.leftCols(n));
}

void LinearSolver::prepare_bordered(const Jacobian& j, const Eigen::VectorXd& last_row) {
  if (!j.is_operator()) {
    factorise_bordered(j.dense(), last_row);
    return;
  }
  factorise_bordered(j.formed(), last_row);
}

void DenseLuSolver::factorise(const Eigen::Ref<const Eigen::MatrixXd>& a) {
  const auto start = std::chrono::steady_clock::now();
  lu_.compute(a);
  account(profile_, start, true);
}

void DenseLuSolver::factorise_bordered(const Eigen::Ref<const Eigen::MatrixXd>& top,
                                       const Eigen::Ref<const Eigen::VectorXd>& last_row) {
  const auto start = std::chrono::steady_clock::now();
  lu_.compute_bordered(top, last_row);
  account(profile_, start, true);
}

Eigen::VectorXd DenseLuSolver::solve(const Eigen::VectorXd& b) const {
  const auto start = std::chrono::steady_clock::now();
  Eigen::VectorXd x = lu_.solve(b);
  account(profile_, start, false);
  return x;
}

bool DenseLuSolver::invertible() const {
  return invertible_lu(lu_);
}

double DenseLuSolver::condition() const {
  return condition_of(lu_);
}

void GmresSolver::factorise(const Eigen::Ref<const Eigen::MatrixXd>& a) {
  matrix_ = a;
  keep_or_refactorise();
}

void GmresSolver::factorise_bordered(const Eigen::Ref<const Eigen::MatrixXd>& top,
                                     const Eigen::Ref<const Eigen::VectorXd>& last_row) {
  const Eigen::Index n = top.rows();
  matrix_.resize(n + 1, n + 1);
  matrix_.topRows(n) = top.leftCols(n + 1);
  matrix_.row(n) = last_row.transpose();
  keep_or_refactorise();
}

// A stale or singular kept LU is replaced by this matrix's; otherwise it is kept.
void GmresSolver::keep_or_refactorise() {
  own_generation_ = -1;
  LinearSolverContext::KeptFactor& k = kept();
  if (k.stale || k.lu.size() != matrix_.rows() || !invertible_lu(k.lu)) refactorise();
}

void GmresSolver::refactorise() const {
  LinearSolverContext::KeptFactor& k = kept();
  const auto start = std::chrono::steady_clock::now();
  k.lu.compute(matrix_);
  account(context_.profile(), start, true);
  ++k.generation;
  k.stale = false;
  own_generation_ = k.generation;
}

bool GmresSolver::determinant_known() const {
  return own_generation_ == kept().generation;
}

int GmresSolver::determinant_sign() const {
  if (!determinant_known()) refactorise();
  return kept().lu.determinant_sign();
}

bool GmresSolver::invertible() const {
  return invertible_lu(kept().lu);
}

double GmresSolver::condition() const {
  return condition_of(kept().lu);
}

bool GmresSolver::iterate(const Eigen::VectorXd& b, double tolerance, Eigen::VectorXd* x) const {
  const DenseLu& m = kept().lu;
  bool slow = false;
  const bool converged = right_preconditioned_gmres(
      [&](const Eigen::VectorXd& z) -> Eigen::VectorXd { return matrix_ * z; },
      [&](const Eigen::VectorXd& z) -> Eigen::VectorXd { return m.solve(z); }, b, tolerance,
      context_, x, &slow);
  if (slow) kept().stale = true;
  return converged;
}

Eigen::VectorXd GmresSolver::solve(const Eigen::VectorXd& b) const {
  return solve_to(b, context_.tolerance());
}

Eigen::VectorXd GmresSolver::solve_update(const Eigen::VectorXd& b) const {
  return solve_to(b, context_.update_tolerance());
}

Eigen::VectorXd GmresSolver::solve_to(const Eigen::VectorXd& b, double tolerance) const {
  if (determinant_known()) {
    const auto start = std::chrono::steady_clock::now();
    Eigen::VectorXd x = kept().lu.solve(b);
    account(context_.profile(), start, false);
    return x;
  }
  const auto start = std::chrono::steady_clock::now();
  Eigen::VectorXd x;
  const bool converged = iterate(b, tolerance, &x);
  SolveProfile* profile = context_.profile();
  if (profile != nullptr) profile->krylov_seconds += seconds_since(start);
  if (converged) return x;
  if (profile != nullptr) ++profile->krylov_fallbacks;
  refactorise();
  if (!invertible_lu(kept().lu))
    return Eigen::VectorXd::Constant(b.size(), std::numeric_limits<double>::quiet_NaN());
  const auto direct = std::chrono::steady_clock::now();
  x = kept().lu.solve(b);
  account(profile, direct, false);
  return x;
}

// MatrixFreeSolver. Dense matrices (factorise, or a Jacobian in formed form) go to the dense LU.
void MatrixFreeSolver::factorise(const Eigen::Ref<const Eigen::MatrixXd>& a) {
  const auto start = std::chrono::steady_clock::now();
  dense_.compute(a);
  account(context_.profile(), start, true);
  dense_ready_ = true;
}

void MatrixFreeSolver::factorise_bordered(const Eigen::Ref<const Eigen::MatrixXd>& top,
                                          const Eigen::Ref<const Eigen::VectorXd>& last_row) {
  const auto start = std::chrono::steady_clock::now();
  dense_.compute_bordered(top, last_row);
  account(context_.profile(), start, true);
  dense_ready_ = true;
}

void MatrixFreeSolver::prepare(const Jacobian& j) {
  if (!j.is_operator()) {
    factorise(j.dense().leftCols(j.rows()));
    return;
  }
  prepare_operator(j, nullptr);
}

void MatrixFreeSolver::prepare_bordered(const Jacobian& j, const Eigen::VectorXd& last_row) {
  if (!j.is_operator()) {
    factorise_bordered(j.dense(), last_row);
    return;
  }
  prepare_operator(j, &last_row);
}

void MatrixFreeSolver::prepare_operator(const Jacobian& j, const Eigen::VectorXd* last_row) {
  jacobian_ = j;
  bordered_ = last_row != nullptr;
  if (bordered_) last_row_ = *last_row;
  dense_ready_ = false;
  own_generation_ = -1;
  bordering_generation_ = -1;
  LinearSolverContext::KeptPreconditioner& k = context_.kept_preconditioner();
  if (k.stale || !k.preconditioner || !std::isfinite(k.preconditioner->condition())) {
    refresh_preconditioner();
    return;
  }
  // The kept preconditioner brought to this point where it can follow it (a new generation:
  // the bordering is recomputed; own_generation_ stays unset, since what the preconditioner
  // does not follow is still of the point it was made at).
  std::unique_ptr<ScaledPreconditioner> followed = k.preconditioner->follow(jacobian_);
  if (followed && std::isfinite(followed->condition())) {
    k.preconditioner = std::move(followed);
    ++k.generation;
  }
}

void MatrixFreeSolver::refresh_preconditioner() const {
  LinearSolverContext::KeptPreconditioner& k = context_.kept_preconditioner();
  const auto start = std::chrono::steady_clock::now();
  k.preconditioner = jacobian_.make_preconditioner();
  SolveProfile* profile = context_.profile();
  if (profile != nullptr) {
    ++profile->preconditioner_builds;
    profile->preconditioner_seconds += seconds_since(start);
  }
  ++k.generation;
  k.stale = false;
  own_generation_ = k.generation;
}

bool MatrixFreeSolver::form_dense() const {
  if (dense_ready_) return true;
  const Eigen::Index n = jacobian_.rows();
  if (n > context_.dense_limit()) return false;
  SolveProfile* profile = context_.profile();
  const auto start = std::chrono::steady_clock::now();
  const Eigen::MatrixXd formed = jacobian_.formed();
  if (bordered_)
    dense_.compute_bordered(formed, last_row_);
  else
    dense_.compute(formed.leftCols(n));
  account(profile, start, true);
  if (profile != nullptr) ++profile->formed_matrices;
  dense_ready_ = true;
  return true;
}

Eigen::VectorXd MatrixFreeSolver::multiply(const Eigen::VectorXd& x) const {
  const Eigen::Index n = jacobian_.rows();
  if (!bordered_) return jacobian_.apply_square(x);
  Eigen::VectorXd y(n + 1);
  y.head(n) = jacobian_.apply(x);
  y(n) = last_row_.dot(x);
  return y;
}

// M^-1 b, or for the Keller matrix P^-1 [r; rho] with P = [M, g; v_x^T, v_lambda]:
// x = a - c mu, a = M^-1 r, c = M^-1 g, mu = (rho - v_x . a) / (v_lambda - v_x . c).
Eigen::VectorXd MatrixFreeSolver::precondition(const Eigen::VectorXd& b) const {
  const LinearSolverContext::KeptPreconditioner& k = context_.kept_preconditioner();
  const Eigen::Index n = jacobian_.rows();
  if (!bordered_) return k.preconditioner->solve(b);
  if (bordering_generation_ != k.generation) {
    bordering_solution_ = k.preconditioner->solve(jacobian_.parameter_column());
    bordering_denominator_ = last_row_(n) - last_row_.head(n).dot(bordering_solution_);
    bordering_generation_ = k.generation;
  }
  Eigen::VectorXd x(n + 1);
  x.head(n) = k.preconditioner->solve(b.head(n));
  double mu = 0.0;
  if (bordering_denominator_ != 0.0 && std::isfinite(bordering_denominator_))
    mu = (b(n) - last_row_.head(n).dot(x.head(n))) / bordering_denominator_;
  x.head(n) -= bordering_solution_ * mu;
  x(n) = mu;
  return x;
}

Eigen::VectorXd MatrixFreeSolver::solve(const Eigen::VectorXd& b) const {
  return solve_to(b, context_.tolerance());
}

Eigen::VectorXd MatrixFreeSolver::solve_update(const Eigen::VectorXd& b) const {
  return solve_to(b, context_.update_tolerance());
}

Eigen::VectorXd MatrixFreeSolver::solve_to(const Eigen::VectorXd& b, double tolerance) const {
  SolveProfile* profile = context_.profile();
  failure_.clear();
  if (dense_ready_) {
    const auto start = std::chrono::steady_clock::now();
    Eigen::VectorXd x = dense_.solve(b);
    account(profile, start, false);
    return x;
  }
  Eigen::VectorXd x;
  bool slow = false;
  const auto gmres = [&] {
    const auto start = std::chrono::steady_clock::now();
    const bool converged =
        right_preconditioned_gmres([&](const Eigen::VectorXd& z) { return multiply(z); },
                                   [&](const Eigen::VectorXd& z) { return precondition(z); }, b,
                                   tolerance, context_, &x, &slow);
    if (profile != nullptr) profile->krylov_seconds += seconds_since(start);
    return converged;
  };
  bool converged = gmres();
  if (!converged && own_generation_ != context_.kept_preconditioner().generation) {
    refresh_preconditioner();
    converged = gmres();
  }
  if (slow) context_.kept_preconditioner().stale = true;
  if (converged) return x;
  if (profile != nullptr) ++profile->krylov_fallbacks;
  if (!form_dense() || !invertible_lu(dense_)) {
    std::ostringstream why;
    why << "GMRES did not converge in " << context_.max_iterations() << " iterations, and ";
    if (dense_ready_)
      why << "the formed matrix is singular";
    else
      why << "the matrix of " << jacobian_.rows() << " equations is not formed above "
          << context_.dense_limit() << " (ContinuationOptions::matrix_free_dense_limit)";
    failure_ = why.str();
    return Eigen::VectorXd::Constant(b.size(), std::numeric_limits<double>::quiet_NaN());
  }
  const auto direct = std::chrono::steady_clock::now();
  x = dense_.solve(b);
  account(profile, direct, false);
  return x;
}

bool MatrixFreeSolver::invertible() const {
  if (dense_ready_) return invertible_lu(dense_);
  const auto& p = context_.kept_preconditioner().preconditioner;
  return p && std::isfinite(p->condition()) &&
         p->condition() < 1.0 / std::numeric_limits<double>::epsilon();
}

double MatrixFreeSolver::condition() const {
  if (dense_ready_) return condition_of(dense_);
  const auto& p = context_.kept_preconditioner().preconditioner;
  return p ? p->condition() : std::numeric_limits<double>::infinity();
}

int MatrixFreeSolver::determinant_sign() const {
  if (!form_dense()) return 0;
  return dense_.determinant_sign();
}

std::unique_ptr<LinearSolver> make_linear_solver(LinearSolverContext& context) {
  if (context.kind() == LinearSolverKind::kMatrixFree)
    return std::make_unique<MatrixFreeSolver>(context);
  if (context.kind() == LinearSolverKind::kGmres) return std::make_unique<GmresSolver>(context);
  return std::make_unique<DenseLuSolver>(context.profile());
}

}  // namespace frichb::core
