// The continuation's linear solvers: GMRES preconditioned by a kept LU, and GMRES on a Jacobian
// operator, against the dense LU.
#include "solver/linear_solver.hpp"

#include <gtest/gtest.h>

#include <complex>
#include <memory>
#include <random>
#include <vector>

#include "frichb/core/numerics/harmonics.hpp"
#include "model/harmonic_jacobian.hpp"
#include "solver/scaled_problem.hpp"

namespace frichb::core {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// A diagonally dominant random matrix (well conditioned, either determinant sign by `sign`).
MatrixXd RandomMatrix(Eigen::Index n, unsigned seed, double sign = 1.0) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  MatrixXd a(n, n);
  for (Eigen::Index j = 0; j < n; ++j)
    for (Eigen::Index i = 0; i < n; ++i) a(i, j) = u(gen);
  a.diagonal().array() += 2.0 * std::sqrt(static_cast<double>(n));
  a.row(0) *= sign;
  return a;
}

// A rows x cols matrix of complex numbers with parts uniform in [-1, 1], drawn from `gen`.
Eigen::MatrixXcd RandomComplex(Eigen::Index rows, Eigen::Index cols, std::mt19937& gen) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXcd m(rows, cols);
  for (Eigen::Index j = 0; j < cols; ++j)
    for (Eigen::Index i = 0; i < rows; ++i) m(i, j) = {u(gen), u(gen)};
  return m;
}

ContinuationOptions Gmres() {
  ContinuationOptions o;
  o.linear_solver = LinearSolverKind::kGmres;
  return o;
}

TEST(LinearSolver, AutoPicksByTheNumberOfEquations) {
  ContinuationOptions o;
  o.gmres_from = 100;
  SolveProfile small_profile, large_profile;
  EXPECT_EQ(LinearSolverContext(o, 99, &small_profile).kind(), LinearSolverKind::kDenseLu);
  EXPECT_EQ(LinearSolverContext(o, 100, &large_profile).kind(), LinearSolverKind::kGmres);
  EXPECT_EQ(small_profile.linear_solver, "dense_lu");
  EXPECT_EQ(large_profile.linear_solver, "gmres");
  EXPECT_NE(large_profile.linear_solver_reason.find("100"), std::string::npos);
  o.linear_solver = LinearSolverKind::kDenseLu;
  EXPECT_EQ(LinearSolverContext(o, 5000, nullptr).kind(), LinearSolverKind::kDenseLu);
}

TEST(LinearSolver, GmresOnAnEarlierFactorisationMeetsItsTolerance) {
  const Eigen::Index n = 200;
  SolveProfile profile;
  LinearSolverContext context(Gmres(), n, &profile);
  const MatrixXd first = RandomMatrix(n, 1);
  // A later matrix: the first with a 5 % perturbation (a Jacobian a few steps on).
  const MatrixXd later = first + 0.05 * RandomMatrix(n, 2) / std::sqrt(static_cast<double>(n));
  const VectorXd b = VectorXd::LinSpaced(n, -1.0, 2.0);
  const auto prepared = make_linear_solver(context);
  prepared->factorise(first);  // no kept LU yet: factorised
  EXPECT_TRUE(prepared->determinant_known());
  EXPECT_EQ(profile.factorisations, 1);
  const auto solver = make_linear_solver(context);
  solver->factorise(later);  // kept LU of `first` preconditions it
  EXPECT_FALSE(solver->determinant_known());
  EXPECT_EQ(profile.factorisations, 1);
  const VectorXd x = solver->solve(b);
  EXPECT_LE((b - later * x).norm(), context.tolerance() * b.norm());
  const VectorXd dense = later.partialPivLu().solve(b);
  EXPECT_LE((x - dense).norm(), 1e-8 * dense.norm());
  EXPECT_EQ(profile.krylov_solves, 1);
  EXPECT_GE(profile.krylov_iterations, 2);
  EXPECT_LE(profile.krylov_iterations, 12);
  EXPECT_EQ(profile.krylov_fallbacks, 0);
  EXPECT_EQ(profile.factorisations, 1);
  // An update is solved to gmres_update_tolerance only, in fewer iterations.
  const long iterations = profile.krylov_iterations;
  const VectorXd update = solver->solve_update(b);
  EXPECT_LE((b - later * update).norm(), context.update_tolerance() * b.norm());
  EXPECT_LT(profile.krylov_iterations - iterations, iterations);
  // The determinant's sign is formed on demand, by a factorisation of the matrix itself.
  EXPECT_EQ(solver->determinant_sign(), 1);
  EXPECT_TRUE(solver->determinant_known());
  EXPECT_EQ(profile.factorisations, 2);
  // The first solver's LU is no longer kept: it iterates now, on the later matrix's LU.
  EXPECT_FALSE(prepared->determinant_known());
  const VectorXd y = prepared->solve(b);
  EXPECT_LE((b - first * y).norm(), context.tolerance() * b.norm());
}

TEST(LinearSolver, DeterminantSignAgreesWithTheDenseLu) {
  const Eigen::Index n = 50;
  LinearSolverContext context(Gmres(), n, nullptr);
  const auto solver = make_linear_solver(context);
  solver->factorise(RandomMatrix(n, 3));
  for (const double sign : {1.0, -1.0}) {
    const MatrixXd a = RandomMatrix(n, 4, sign);
    solver->factorise(a);
    DenseLuSolver dense(nullptr);
    dense.factorise(a);
    EXPECT_EQ(solver->determinant_sign(), dense.determinant_sign());
    EXPECT_EQ(dense.determinant_sign(), sign > 0 ? 1 : -1);
  }
}

TEST(LinearSolver, BorderedSystemsKeepTheirOwnPreconditioner) {
  const Eigen::Index n = 80;
  SolveProfile profile;
  LinearSolverContext context(Gmres(), n, &profile);
  const MatrixXd top = RandomMatrix(n + 1, 5).topRows(n);
  const VectorXd row = VectorXd::Ones(n + 1) / std::sqrt(static_cast<double>(n + 1));
  MatrixXd bordered(n + 1, n + 1);
  bordered << top, row.transpose();
  const auto square = make_linear_solver(context);
  square->factorise(top.leftCols(n));
  const auto keller = make_linear_solver(context);
  keller->factorise_bordered(top, row);
  EXPECT_EQ(profile.factorisations, 2);  // one LU kept per size
  const VectorXd e = VectorXd::Unit(n + 1, n);
  const VectorXd t = keller->solve(e);
  EXPECT_LE((bordered * t - e).norm(), 1e-12);
  // A nearby bordered matrix iterates on the kept one.
  const auto next = make_linear_solver(context);
  next->factorise_bordered(top + 1e-3 * MatrixXd::Ones(n, n + 1), row);
  EXPECT_EQ(profile.factorisations, 2);
  MatrixXd next_matrix = bordered;
  next_matrix.topRows(n).array() += 1e-3;
  const VectorXd t_next = next->solve(e);
  EXPECT_LE((next_matrix * t_next - e).norm(), context.tolerance());
  EXPECT_GT(profile.krylov_solves, 0);
  EXPECT_EQ(profile.krylov_fallbacks, 0);
  // The square system's LU was not replaced by the bordered ones.
  EXPECT_TRUE(square->determinant_known());
}

TEST(LinearSolver, AStalledSolveFallsBackToItsOwnFactorisation) {
  const Eigen::Index n = 120;
  ContinuationOptions o = Gmres();
  o.gmres_max_iterations = 3;
  SolveProfile profile;
  LinearSolverContext context(o, n, &profile);
  const auto solver = make_linear_solver(context);
  solver->factorise(RandomMatrix(n, 6));
  // An unrelated matrix: three iterations on the first one's LU do not reach 1e-10.
  const MatrixXd other = RandomMatrix(n, 7, -1.0);
  solver->factorise(other);
  const VectorXd b = VectorXd::Ones(n);
  const VectorXd x = solver->solve(b);
  EXPECT_EQ(profile.krylov_fallbacks, 1);
  EXPECT_EQ(profile.factorisations, 2);
  EXPECT_LE((b - other * x).norm(), 1e-12 * b.norm());
  EXPECT_TRUE(solver->determinant_known());
}

TEST(LinearSolver, ASlowSolveRefreshesTheKeptFactorisation) {
  const Eigen::Index n = 120;
  ContinuationOptions o = Gmres();
  o.gmres_refresh_iterations = 2;
  SolveProfile profile;
  LinearSolverContext context(o, n, &profile);
  const auto solver = make_linear_solver(context);
  solver->factorise(RandomMatrix(n, 8));
  const MatrixXd later = RandomMatrix(n, 8) + 0.3 * RandomMatrix(n, 9) / std::sqrt(120.0);
  solver->factorise(later);
  const VectorXd b = VectorXd::Ones(n);
  const VectorXd x = solver->solve(b);
  EXPECT_GT(profile.krylov_iterations, 2);
  EXPECT_EQ(profile.krylov_fallbacks, 0);
  EXPECT_LE((b - later * x).norm(), context.tolerance() * b.norm());
  // More than two iterations: the next matrix is factorised afresh.
  const auto next = make_linear_solver(context);
  next->factorise(later);
  EXPECT_TRUE(next->determinant_known());
  EXPECT_EQ(profile.factorisations, 2);
}

// ---- GMRES on an operator ----

// e_x = a applied as an operator, preconditioned by the LU of `approximation` (that of a
// nearby matrix, or an unrelated one to make GMRES stall).
class MatrixOperator final : public JacobianOperator {
 public:
  MatrixOperator(MatrixXd a, VectorXd g, MatrixXd approximation)
      : a_(std::move(a)), g_(std::move(g)), approximation_(std::move(approximation)) {}
  Eigen::Index rows() const override { return a_.rows(); }
  void apply(const Eigen::Ref<const MatrixXd>& x, Eigen::Ref<MatrixXd> y) const override {
    y.noalias() = a_ * x;
  }
  const VectorXd& parameter_column() const override { return g_; }
  std::unique_ptr<JacobianPreconditioner> make_preconditioner() const override {
    return std::make_unique<Lu>(approximation_);
  }

 private:
  class Lu final : public JacobianPreconditioner {
   public:
    explicit Lu(const MatrixXd& m) : lu_(m) {}
    void solve(const Eigen::Ref<const VectorXd>& b, Eigen::Ref<VectorXd> x) const override {
      x = lu_.solve(b);
    }
    double condition() const override { return 1.0 / lu_.rcond(); }

   private:
    Eigen::PartialPivLU<MatrixXd> lu_;
  };
  MatrixXd a_;
  VectorXd g_;
  MatrixXd approximation_;
};

ContinuationOptions MatrixFree() {
  ContinuationOptions o;
  o.linear_solver = LinearSolverKind::kMatrixFree;
  return o;
}

// Scales far from one, as the continuation's (displacements of 1e-5 m, a frequency of 1e3).
Scaling UnevenScaling(Eigen::Index n) {
  Scaling s;
  s.unknown = VectorXd::LinSpaced(n + 1, 1e-5, 2e-5);
  s.unknown(n) = 1e3;
  s.residual = VectorXd::LinSpaced(n, 1e-5, 3e-5);
  return s;
}

Jacobian OperatorJacobian(const MatrixXd& a, const VectorXd& g, const MatrixXd& approximation,
                          const Scaling& scaling) {
  Jacobian j;
  j.set_operator(std::make_shared<MatrixOperator>(a, g, approximation), scaling);
  return j;
}

TEST(LinearSolver, MatrixFreeNeedsAnOperatorAndAutoPicksItWhereThereIsOne) {
  ContinuationOptions o = MatrixFree();
  SolveProfile profile;
  EXPECT_EQ(LinearSolverContext(o, 10, &profile, false).kind(), LinearSolverKind::kGmres);
  EXPECT_NE(profile.linear_solver_reason.find("no Jacobian operator"), std::string::npos);
  EXPECT_EQ(LinearSolverContext(o, 10, nullptr, true).kind(), LinearSolverKind::kMatrixFree);
  // auto: matrix_free from matrix_free_from where there is an operator, gmres from
  // gmres_from where there is none, dense LU below either.
  o.linear_solver = LinearSolverKind::kAuto;
  o.gmres_from = 100;
  o.matrix_free_from = 50;
  SolveProfile with_operator;
  EXPECT_EQ(LinearSolverContext(o, 50, &with_operator, true).kind(), LinearSolverKind::kMatrixFree);
  EXPECT_NE(with_operator.linear_solver_reason.find("matrix_free_from"), std::string::npos);
  EXPECT_EQ(LinearSolverContext(o, 49, nullptr, true).kind(), LinearSolverKind::kDenseLu);
  EXPECT_EQ(LinearSolverContext(o, 99, nullptr, false).kind(), LinearSolverKind::kDenseLu);
  EXPECT_EQ(LinearSolverContext(o, 100, nullptr, false).kind(), LinearSolverKind::kGmres);
  EXPECT_EQ(LinearSolverContext(o, 5000, nullptr, true).kind(), LinearSolverKind::kMatrixFree);
}

TEST(LinearSolver, MemoryEstimateFollowsThePath) {
  // 1000 contact pairs at H = 5: m = 3000 components, n = 33 000 unknowns, six receptance
  // blocks. The dense paths hold three (n + 1)^2 double matrices (26 GB); the matrix-free path
  // six single-precision complex m x m LUs, one double-precision block, and two GMRES bases of
  // 61 vectors; below matrix_free_dense_limit also the formed matrix and its LU.
  ContinuationOptions o;
  const double n = 33000.0, m = 3000.0;
  EXPECT_DOUBLE_EQ(linear_solver_bytes(o, LinearSolverKind::kDenseLu, 33000, 3000, 6),
                   24.0 * (n + 1) * (n + 1));
  EXPECT_DOUBLE_EQ(linear_solver_bytes(o, LinearSolverKind::kGmres, 33000, 3000, 6),
                   24.0 * (n + 1) * (n + 1));
  const double matrix_free = (6 * 8.0 + 16.0) * m * m + 16.0 * (n + 1) * 61;
  EXPECT_DOUBLE_EQ(linear_solver_bytes(o, LinearSolverKind::kMatrixFree, 33000, 3000, 6),
                   matrix_free);
  EXPECT_LT(matrix_free, 1e9);
  // 300 pairs (9900 unknowns) is below the limit: the formed matrix and its LU count.
  EXPECT_DOUBLE_EQ(linear_solver_bytes(o, LinearSolverKind::kMatrixFree, 9900, 900, 6),
                   64.0 * 900 * 900 + 16.0 * 9901 * 61 + 16.0 * 9901.0 * 9901.0);
}

TEST(LinearSolver, MatrixFreeSolvesSquareAndBorderedSystemsInScaledVariables) {
  const Eigen::Index n = 150;
  const Scaling scaling = UnevenScaling(n);
  SolveProfile profile;
  LinearSolverContext context(MatrixFree(), n, &profile, true);
  const MatrixXd first = RandomMatrix(n, 11, -1.0);
  const MatrixXd later = first + 0.05 * RandomMatrix(n, 12) / std::sqrt(static_cast<double>(n));
  const VectorXd g = VectorXd::LinSpaced(n, 1.0, -1.0);
  // The first point makes the preconditioner; the later one iterates on it.
  const auto at_first = make_linear_solver(context);
  at_first->prepare(OperatorJacobian(first, g, first, scaling));
  EXPECT_EQ(profile.preconditioner_builds, 1);
  const Jacobian j = OperatorJacobian(later, g, later, scaling);
  const MatrixXd formed = j.formed();  // the scaled matrix, oracle
  ASSERT_EQ(formed.cols(), n + 1);
  const auto solver = make_linear_solver(context);
  solver->prepare(j);
  EXPECT_EQ(profile.preconditioner_builds, 1);
  EXPECT_FALSE(solver->determinant_known());
  const VectorXd b = VectorXd::LinSpaced(n, -2.0, 1.0);
  const VectorXd x = solver->solve(b);
  EXPECT_LE((formed.leftCols(n) * x - b).norm(), context.tolerance() * b.norm());
  EXPECT_GT(profile.krylov_iterations, 1);  // the kept preconditioner is not this matrix's
  // The Keller matrix, through the bordered preconditioner.
  const VectorXd row = VectorXd::LinSpaced(n + 1, 0.5, 1.0).normalized();
  MatrixXd bordered(n + 1, n + 1);
  bordered << formed, row.transpose();
  const auto keller = make_linear_solver(context);
  keller->prepare_bordered(j, row);
  const VectorXd e = VectorXd::Unit(n + 1, n);
  const VectorXd t = keller->solve(e);
  EXPECT_LE((bordered * t - e).norm(), context.tolerance());
  EXPECT_EQ(profile.krylov_fallbacks, 0);
  EXPECT_EQ(profile.factorisations, 0);
  // The orientation: the formed matrix's determinant sign.
  const int dense_sign = bordered.partialPivLu().determinant() > 0.0 ? 1 : -1;
  EXPECT_EQ(keller->determinant_sign(), dense_sign);
  EXPECT_EQ(profile.formed_matrices, 1);
  EXPECT_TRUE(keller->determinant_known());
}

TEST(LinearSolver, MatrixFreeStallRetriesItsOwnPreconditionerThenFormsTheMatrix) {
  const Eigen::Index n = 120;
  const Scaling scaling = UnevenScaling(n);
  ContinuationOptions o = MatrixFree();
  o.gmres_max_iterations = 3;
  const MatrixXd a = RandomMatrix(n, 13);
  const MatrixXd unrelated = RandomMatrix(n, 14, -1.0);
  const VectorXd g = VectorXd::Ones(n);
  const VectorXd b = VectorXd::LinSpaced(n, 1.0, 3.0);
  {
    // Kept from an unrelated point: three iterations stall, this point's own (exact) one solves.
    SolveProfile profile;
    LinearSolverContext context(o, n, &profile, true);
    make_linear_solver(context)->prepare(OperatorJacobian(unrelated, g, unrelated, scaling));
    const Jacobian j = OperatorJacobian(a, g, a, scaling);
    const auto solver = make_linear_solver(context);
    solver->prepare(j);
    const VectorXd x = solver->solve(b);
    EXPECT_EQ(profile.preconditioner_builds, 2);
    EXPECT_EQ(profile.krylov_fallbacks, 0);
    EXPECT_LE((j.formed().leftCols(n) * x - b).norm(), context.tolerance() * b.norm());
  }
  {
    // A preconditioner that never fits: the matrix is formed and factorised.
    SolveProfile profile;
    LinearSolverContext context(o, n, &profile, true);
    const Jacobian j = OperatorJacobian(a, g, unrelated, scaling);
    const auto solver = make_linear_solver(context);
    solver->prepare(j);
    const VectorXd x = solver->solve(b);
    EXPECT_EQ(profile.krylov_fallbacks, 1);
    EXPECT_EQ(profile.formed_matrices, 1);
    EXPECT_LE((j.formed().leftCols(n) * x - b).norm(), 1e-12 * b.norm());
  }
  {
    // ... unless it has more equations than matrix_free_dense_limit: no solution.
    o.matrix_free_dense_limit = n - 1;
    SolveProfile profile;
    LinearSolverContext context(o, n, &profile, true);
    const auto solver = make_linear_solver(context);
    solver->prepare(OperatorJacobian(a, g, unrelated, scaling));
    EXPECT_FALSE(solver->solve(b).allFinite());
    EXPECT_NE(solver->failure().find("matrix_free_dense_limit"), std::string::npos)
        << solver->failure();
    EXPECT_EQ(solver->determinant_sign(), 0);
    EXPECT_EQ(profile.formed_matrices, 0);
  }
}

// The harmonic-balance Jacobian operator at 600 contact components (200 three-component
// contacts, harmonics 0 to 2), where its products and preconditioner solves spread the
// harmonics over threads: with two threads they give the very numbers one thread gives, and
// the product is the formed matrix's.
TEST(LinearSolver, HarmonicJacobianOnThreadsGivesTheSameNumbers) {
  constexpr int kContacts = 200, kComponents = 3 * kContacts;
  const HarmonicLayout layout({0, 1, 2}, 16);
  const int c = layout.coefficient_count();
  const Eigen::Index n = static_cast<Eigen::Index>(kComponents) * c;
  std::mt19937 gen(5);
  const auto random_complex = [&](Eigen::Index rows, Eigen::Index cols) {
    return RandomComplex(rows, cols, gen);
  };
  std::vector<HarmonicReceptance> receptances;
  for (std::size_t k = 0; k < layout.harmonics().size(); ++k) {
    HarmonicReceptance r;
    r.harmonic = layout.harmonics()[k];
    r.cos_index = layout.cos_index(k);
    r.sin_index = layout.sin_index(k);
    r.formed = 1e-3 * random_complex(kComponents, kComponents);
    if (r.harmonic == 0) r.formed.imag().setZero();
    receptances.push_back(std::move(r));
  }
  std::vector<ContactTangent> tangents;
  for (int i = 0; i < kContacts; ++i) {
    ContactTangent t;
    t.first = static_cast<Eigen::Index>(3 * i) * c;
    t.block = 10.0 * MatrixXd::Random(3 * c, 3 * c);
    tangents.push_back(std::move(t));
  }
  const VectorXd column = VectorXd::Random(n);
  const HarmonicJacobian one(c, kComponents, receptances, tangents, column, 1);
  const HarmonicJacobian two(c, kComponents, receptances, tangents, column, 2);
  const MatrixXd x = MatrixXd::Random(n, 2);
  MatrixXd y_one(n, 2), y_two(n, 2);
  one.apply(x, y_one);
  two.apply(x, y_two);
  EXPECT_EQ(y_one, y_two);
  MatrixXd formed(n, n);
  one.form(formed);
  EXPECT_LT((formed * x - y_one).cwiseAbs().maxCoeff(), 1e-10 * y_one.cwiseAbs().maxCoeff());
  const auto m_one = one.make_preconditioner();
  const auto m_two = two.make_preconditioner();
  VectorXd s_one(n), s_two(n);
  m_one->solve(x.col(0), s_one);
  m_two->solve(x.col(0), s_two);
  EXPECT_EQ(s_one, s_two);
  EXPECT_TRUE(s_one.allFinite());
}

// A harmonic-balance Jacobian with modal receptances Rc = P diag(inv_z) P^H + F (harmonics 0
// to 3, real at harmonic 0; 20 three-component contacts, 4 modes) and tangents that do not vary
// over the period, where the harmonic-decoupled preconditioner is the inverse itself; `shift` moves
// the frequency: inv_z of the harmonics above 0 changes, P, F and the tangents do not.
struct ModalJacobianCase {
  static constexpr int kContacts = 20, kComponents = 3 * kContacts, kModes = 4;
  HarmonicLayout layout{{0, 1, 2, 3}, 16};
  int c = layout.coefficient_count();
  Eigen::Index n = static_cast<Eigen::Index>(kComponents) * c;
  std::vector<Eigen::MatrixXcd> projected, flexibility;
  std::vector<ContactTangent> tangents;
  VectorXd column;

  explicit ModalJacobianCase(bool with_flexibility) {
    std::mt19937 gen(11);
    const auto random_complex = [&](Eigen::Index rows, Eigen::Index cols) {
      return RandomComplex(rows, cols, gen);
    };
    for (std::size_t k = 0; k < layout.harmonics().size(); ++k) {
      // Harmonic 0 real (no cyclic phase), as a nodal diameter 0 gives it.
      projected.push_back(0.3 * random_complex(kComponents, kModes));
      Eigen::MatrixXcd g = random_complex(kComponents, kComponents);
      if (layout.harmonics()[k] == 0) {
        projected.back().imag().setZero();
        g.imag().setZero();
      }
      flexibility.push_back(with_flexibility ? Eigen::MatrixXcd(2e-3 * g * g.adjoint())
                                             : Eigen::MatrixXcd());
    }
    for (int i = 0; i < kContacts; ++i) {
      const MatrixXd d0 = 3.0 * MatrixXd::Random(3, 3) + 4.0 * MatrixXd::Identity(3, 3);
      ContactTangent t;
      t.first = static_cast<Eigen::Index>(3 * i) * c;
      t.block = MatrixXd::Zero(3 * c, 3 * c);  // d0 on every coefficient
      for (int b = 0; b < 3; ++b)
        for (int e = 0; e < 3; ++e)
          t.block.block(b * c, e * c, c, c).diagonal().setConstant(d0(b, e));
      tangents.push_back(std::move(t));
    }
    column = VectorXd::Random(n);
  }

  // The modal dynamic compliances 1 / (w_r^2 - W^2 + i W c_r) at W = harmonic x (1 + shift).
  std::shared_ptr<HarmonicJacobian> at(double shift) const {
    std::vector<HarmonicReceptance> receptances;
    for (std::size_t k = 0; k < layout.harmonics().size(); ++k) {
      HarmonicReceptance r;
      r.harmonic = layout.harmonics()[k];
      r.cos_index = layout.cos_index(k);
      r.sin_index = layout.sin_index(k);
      r.projected = &projected[k];
      r.flexibility = flexibility[k].size() ? &flexibility[k] : nullptr;
      r.inv_z.resize(kModes);
      const double w = r.harmonic * (1.0 + shift);
      for (int q = 0; q < kModes; ++q) {
        const double wr = 0.8 + 0.6 * q;
        r.inv_z(q) = 1.0 / std::complex<double>(wr * wr - w * w, 0.05 * w);
      }
      receptances.push_back(std::move(r));
    }
    return std::make_shared<HarmonicJacobian>(c, kComponents, receptances, tangents, column);
  }
};

// |M^-1 J x - x| / |x|: how far the preconditioner is from the inverse of e_x.
double PreconditionerError(const JacobianPreconditioner& m, const JacobianOperator& op,
                           const VectorXd& x) {
  MatrixXd jx(x.size(), 1);
  op.apply(x, jx);
  VectorXd back(x.size());
  m.solve(jx.col(0), back);
  return (back - x).norm() / x.norm();
}

// With time-invariant tangents the harmonic-decoupled preconditioner is e_x's inverse (to its
// single-precision factors), with and without a residual flexibility; one made at an earlier
// frequency is not, and the same one followed to the new frequency is again.
TEST(LinearSolver, TheModalPreconditionerFollowsTheFrequency) {
  for (const bool with_flexibility : {true, false}) {
    SCOPED_TRACE(with_flexibility ? "with F" : "modes only");
    const ModalJacobianCase modal(with_flexibility);
    const auto here = modal.at(0.0);
    const auto later = modal.at(0.04);
    const VectorXd x = VectorXd::Random(modal.n);
    const auto made = here->make_preconditioner();
    EXPECT_LT(PreconditionerError(*made, *here, x), 1e-5);
    EXPECT_GT(PreconditionerError(*made, *later, x), 1e-2);
    const auto followed = made->follow(*later);
    ASSERT_NE(followed, nullptr);
    EXPECT_LT(PreconditionerError(*followed, *later, x), 1e-5);
    EXPECT_LT(PreconditionerError(*later->make_preconditioner(), *later, x), 1e-5);
    EXPECT_TRUE(std::isfinite(followed->condition()));
  }
  // Receptances of another model (other P): nothing to follow.
  const ModalJacobianCase one(true), other(true);
  EXPECT_EQ(one.at(0.0)->make_preconditioner()->follow(*other.at(0.0)), nullptr);
}

// The matrix-free solver follows its kept preconditioner from point to point: a Newton matrix
// at a new frequency is solved in the iterations of an exact preconditioner, with no new one.
TEST(LinearSolver, MatrixFreeFollowsTheKeptPreconditionerToTheNextPoint) {
  const ModalJacobianCase modal(true);
  const Scaling scaling = UnevenScaling(modal.n);
  ContinuationOptions o = MatrixFree();
  SolveProfile profile;
  LinearSolverContext context(o, modal.n, &profile, true);
  const VectorXd b = VectorXd::Random(modal.n);
  for (const double shift : {0.0, 0.02, 0.04}) {
    Jacobian j;
    j.set_operator(modal.at(shift), scaling);
    const auto solver = make_linear_solver(context);
    solver->prepare(j);
    const int before = profile.krylov_iterations;
    const VectorXd x = solver->solve(b);
    EXPECT_LE((j.apply_square(x) - b).norm(), context.tolerance() * b.norm());
    // Single-precision factors: a few iterations to 1e-10.
    EXPECT_LE(profile.krylov_iterations - before, 3) << "shift " << shift;
  }
  EXPECT_EQ(profile.preconditioner_builds, 1);
}

}  // namespace
}  // namespace frichb::core
