// The continuation's linear solvers (linear_solver.hpp).
#include "solver/linear_solver.hpp"

#include <chrono>
#include <cmath>
#include <limits>

#include "solver/scaled_problem.hpp"

namespace frichb::core {

namespace {

void account(SolveProfile* profile, std::chrono::steady_clock::time_point start,
             bool factorisation) {
  if (profile == nullptr) return;
  profile->factorisation_seconds += seconds_since(start);
  if (factorisation) ++profile->factorisations;
}

}  // namespace

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
  return std::isfinite(lu_.rcond()) && lu_.rcond() > std::numeric_limits<double>::epsilon();
}

double DenseLuSolver::condition() const {
  return lu_.rcond() > 0.0 ? 1.0 / lu_.rcond() : std::numeric_limits<double>::infinity();
}

std::unique_ptr<LinearSolver> make_linear_solver(SolveProfile* profile) {
  return std::make_unique<DenseLuSolver>(profile);
}

}  // namespace frichb::core
