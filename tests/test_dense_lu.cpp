// DenseLu: the Newton matrices' factorisation (OpenBLAS LAPACK or Eigen), against an
// independent oracle: solutions against a known x, the reciprocal condition estimate against
// the exact 1-norm condition number from the explicit inverse, and the failure contract.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "frichb/core/numerics/dense_lu.hpp"

namespace {

using frichb::core::DenseLu;

Eigen::MatrixXd TestMatrix(int n, unsigned seed) {
  std::srand(seed);
  Eigen::MatrixXd a = Eigen::MatrixXd::Random(n, n);
  a.diagonal().array() += 0.5;  // nonsymmetric, needs pivoting, well away from singular
  return a;
}

double ExactCondition1(const Eigen::MatrixXd& a) {
  const Eigen::MatrixXd inverse = a.fullPivLu().inverse();
  return a.cwiseAbs().colwise().sum().maxCoeff() * inverse.cwiseAbs().colwise().sum().maxCoeff();
}

TEST(DenseLu, SolvesToRoundingOnBlockedSizes) {
  // Sizes below and above the blocking of LAPACK and Eigen (64 to 256).
  for (int n : {1, 7, 100, 300, 700}) {
    const Eigen::MatrixXd a = TestMatrix(n, 1u + static_cast<unsigned>(n));
    const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(n, -1.0, 2.0);
    const DenseLu lu(a);
    const Eigen::VectorXd solved = lu.solve(a * x);
    const double bound = 1e3 * std::numeric_limits<double>::epsilon() / lu.rcond();
    EXPECT_LT((solved - x).lpNorm<Eigen::Infinity>(), bound * x.lpNorm<Eigen::Infinity>())
        << "n = " << n;
    EXPECT_EQ(lu.size(), n);
  }
}

TEST(DenseLu, ConditionEstimateIsWithinAFactorThreeOfTheExactOne) {
  for (int n : {5, 50, 400}) {
    Eigen::MatrixXd a = TestMatrix(n, 7u * static_cast<unsigned>(n));
    a.row(0) *= 1e-6;  // a badly scaled row: condition about 1e6 x larger
    const double exact = ExactCondition1(a);
    const DenseLu lu(a);
    const double estimate = 1.0 / lu.rcond();
    EXPECT_LE(estimate, exact * (1 + 1e-8)) << "n = " << n;  // estimates bound from below
    EXPECT_GE(estimate, exact / 3.0) << "n = " << n;
  }
}

TEST(DenseLu, DeterminantSignMatchesTheFullPivotingDeterminant) {
  // Against Eigen's full-pivoting determinant (an independent factorisation), on sizes below
  // and above the blocking, with one row negated and two rows swapped in turn.
  for (int n : {1, 2, 9, 100, 200}) {
    Eigen::MatrixXd a = TestMatrix(n, 11u + static_cast<unsigned>(n));
    for (int variant = 0; variant < 3; ++variant) {
      if (variant == 1) a.row(0) *= -1.0;
      if (variant == 2 && n > 1) a.row(0).swap(a.row(n - 1));
      const double det = a.fullPivLu().determinant();
      ASSERT_NE(det, 0.0);
      EXPECT_EQ(DenseLu(a).determinant_sign(), det > 0.0 ? 1 : -1) << "n = " << n;
    }
  }
  Eigen::MatrixXd zero_column = TestMatrix(10, 5u);
  zero_column.col(2).setZero();
  EXPECT_EQ(DenseLu(zero_column).determinant_sign(), 0);
}

TEST(DenseLu, SingularAndNonFiniteMatricesHaveZeroReciprocalCondition) {
  Eigen::MatrixXd singular = TestMatrix(20, 3u);
  singular.col(4) = 2.0 * singular.col(7);  // rank 19, but no zero pivot in exact arithmetic
  const DenseLu lu_singular(singular);
  EXPECT_LT(lu_singular.rcond(), 1e3 * std::numeric_limits<double>::epsilon());

  Eigen::MatrixXd zero_column = TestMatrix(10, 5u);
  zero_column.col(2).setZero();  // exactly singular: a zero pivot
  EXPECT_EQ(DenseLu(zero_column).rcond(), 0.0);
  EXPECT_FALSE(DenseLu(zero_column).solve(Eigen::VectorXd::Ones(10)).allFinite());

  Eigen::MatrixXd with_nan = TestMatrix(10, 6u);
  with_nan(3, 3) = std::numeric_limits<double>::quiet_NaN();
  const DenseLu lu_nan(with_nan);
  EXPECT_EQ(lu_nan.rcond(), 0.0);
  EXPECT_FALSE(lu_nan.solve(Eigen::VectorXd::Ones(10)).allFinite());
}

TEST(DenseLu, WrongSizesAreRefused) {
  EXPECT_THROW(DenseLu(Eigen::MatrixXd::Identity(3, 4)), std::invalid_argument);
  const DenseLu lu(Eigen::MatrixXd::Identity(3, 3));
  EXPECT_THROW(lu.solve(Eigen::VectorXd::Ones(4)), std::invalid_argument);
  EXPECT_EQ(lu.solve(Eigen::Vector3d(1, 2, 3)), Eigen::Vector3d(1, 2, 3));
}

TEST(DenseLu, DescribesItsBackend) {
  const std::string description = frichb::core::dense_solver_description();
#ifdef FRICHB_EXPECT_OPENBLAS
  EXPECT_NE(description.find("OpenBLAS"), std::string::npos) << description;
#endif
  EXPECT_FALSE(description.empty());
}

}  // namespace
