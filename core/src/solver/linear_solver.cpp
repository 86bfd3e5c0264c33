// The continuation's linear solvers (linear_solver.hpp).
#include "solver/linear_solver.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

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

}  // namespace

const char* to_string(LinearSolverKind kind) {
  switch (kind) {
    case LinearSolverKind::kAuto:
      return "auto";
    case LinearSolverKind::kDenseLu:
      return "dense_lu";
    case LinearSolverKind::kGmres:
      return "gmres";
  }
  return "unknown";
}

LinearSolverContext::LinearSolverContext(const ContinuationOptions& options, Eigen::Index n,
                                         SolveProfile* profile)
    : kind_(options.linear_solver),
      profile_(profile),
      tolerance_(options.gmres_tolerance),
      update_tolerance_(options.gmres_update_tolerance),
      max_iterations_(options.gmres_max_iterations),
      refresh_iterations_(options.gmres_refresh_iterations),
      square_size_(n) {
  std::ostringstream why;
  if (kind_ == LinearSolverKind::kAuto) {
    kind_ = n >= options.gmres_from ? LinearSolverKind::kGmres : LinearSolverKind::kDenseLu;
    why << "auto: " << n << " equations, " << (n >= options.gmres_from ? ">= " : "< ")
        << options.gmres_from << " (gmres_from)";
  } else {
    why << "chosen by the scene";
  }
  if (profile_ != nullptr) {
    profile_->linear_solver = to_string(kind_);
    profile_->linear_solver_reason = why.str();
  }
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
  prepare();
}

void GmresSolver::factorise_bordered(const Eigen::Ref<const Eigen::MatrixXd>& top,
                                     const Eigen::Ref<const Eigen::VectorXd>& last_row) {
  const Eigen::Index n = top.rows();
  matrix_.resize(n + 1, n + 1);
  matrix_.topRows(n) = top.leftCols(n + 1);
  matrix_.row(n) = last_row.transpose();
  prepare();
}

// A stale or singular kept LU is replaced by this matrix's; otherwise it is kept.
void GmresSolver::prepare() {
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

// Right-preconditioned GMRES from x = 0: the Krylov basis V of A M^-1 with the Hessenberg
// matrix reduced by Givens rotations as it grows, x = M^-1 V y at the end. The residual the
// rotations give is checked against the true one, b - A x.
bool GmresSolver::iterate(const Eigen::VectorXd& b, double tolerance, Eigen::VectorXd* x) const {
  const DenseLu& m = kept().lu;
  const Eigen::Index n = b.size();
  const int max_k = context_.max_iterations();
  const double beta = b.norm();
  SolveProfile* profile = context_.profile();
  if (profile != nullptr) ++profile->krylov_solves;
  if (beta == 0.0) {
    x->setZero(n);
    return true;
  }
  const double target = tolerance * beta;
  Eigen::MatrixXd v(n, max_k + 1);
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(max_k + 1, max_k);
  Eigen::VectorXd cs(max_k), sn(max_k), g = Eigen::VectorXd::Zero(max_k + 1);
  v.col(0) = b / beta;
  g(0) = beta;
  int k = 0;
  while (k < max_k) {
    Eigen::VectorXd w = matrix_ * m.solve(v.col(k));
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
  *x = m.solve(v.leftCols(k) * y);
  if (!x->allFinite()) return false;
  const double true_residual = (b - matrix_ * *x).norm();
  if (k > context_.refresh_iterations()) kept().stale = true;
  return true_residual <= target;
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

std::unique_ptr<LinearSolver> make_linear_solver(LinearSolverContext& context) {
  if (context.kind() == LinearSolverKind::kGmres) return std::make_unique<GmresSolver>(context);
  return std::make_unique<DenseLuSolver>(context.profile());
}

}  // namespace frichb::core
