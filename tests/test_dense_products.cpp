// multiply (dense_products.hpp): C = alpha op(A) op(B) + beta C by OpenBLAS gemm or Eigen,
// against a triple loop written out here, for every operation pair, real and complex, on
// column blocks with outer strides, below and above the size where BLAS takes over.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <complex>
#include <stdexcept>

#include "frichb/core/numerics/dense_products.hpp"

namespace {

using frichb::core::MatrixOperation;
using frichb::core::multiply;

template <class M>
typename M::Scalar Entry(const M& m, MatrixOperation op, Eigen::Index i, Eigen::Index j) {
  using std::conj;
  switch (op) {
    case MatrixOperation::kNone:
      return m(i, j);
    case MatrixOperation::kTranspose:
      return m(j, i);
    case MatrixOperation::kAdjoint:
      if constexpr (Eigen::NumTraits<typename M::Scalar>::IsComplex)
        return conj(m(j, i));
      else
        return m(j, i);
  }
  return m(i, j);
}

template <class M, class Scalar>
M Reference(Scalar alpha, const M& a, MatrixOperation op_a, const M& b, MatrixOperation op_b,
            Scalar beta, const M& c) {
  M out = c;
  const Eigen::Index k = op_a == MatrixOperation::kNone ? a.cols() : a.rows();
  for (Eigen::Index i = 0; i < c.rows(); ++i)
    for (Eigen::Index j = 0; j < c.cols(); ++j) {
      Scalar sum(0);
      for (Eigen::Index l = 0; l < k; ++l) sum += Entry(a, op_a, i, l) * Entry(b, op_b, l, j);
      out(i, j) = alpha * sum + beta * c(i, j);
    }
  return out;
}

template <class M>
M Shaped(Eigen::Index rows, Eigen::Index cols, MatrixOperation op) {
  return op == MatrixOperation::kNone ? M::Random(rows, cols) : M::Random(cols, rows);
}

template <class M, class Scalar>
void CheckAllOperations(Scalar alpha, Scalar beta) {
  const MatrixOperation ops[] = {MatrixOperation::kNone, MatrixOperation::kTranspose,
                                 MatrixOperation::kAdjoint};
  // (m, n, k): small products (Eigen inline) and large ones (BLAS when built with it).
  const Eigen::Index sizes[][3] = {{3, 2, 4}, {1, 1, 1}, {70, 50, 60}, {130, 41, 97}};
  for (const auto& s : sizes)
    for (MatrixOperation op_a : ops)
      for (MatrixOperation op_b : ops) {
        const M a = Shaped<M>(s[0], s[2], op_a);
        const M b = Shaped<M>(s[2], s[1], op_b);
        // C is a column block of a wider matrix: its outer stride exceeds its rows.
        M wide = M::Random(s[0] + 3, s[1] + 2);
        const M c0 = wide.block(0, 1, s[0], s[1]);
        const M expected = Reference(alpha, a, op_a, b, op_b, beta, c0);
        const M untouched = wide;
        multiply(alpha, a, op_a, b, op_b, beta, wide.block(0, 1, s[0], s[1]));
        const double scale = 1.0 + expected.cwiseAbs().maxCoeff();
        EXPECT_LT((wide.block(0, 1, s[0], s[1]) - expected).cwiseAbs().maxCoeff(),
                  1e-12 * static_cast<double>(s[2]) * scale)
            << s[0] << "x" << s[1] << "x" << s[2] << " ops " << static_cast<int>(op_a) << ","
            << static_cast<int>(op_b);
        // Nothing outside the block is written.
        EXPECT_EQ(wide.col(0), untouched.col(0));
        EXPECT_EQ(wide.bottomRows(3), untouched.bottomRows(3));
        EXPECT_EQ(wide.rightCols(1), untouched.rightCols(1));
      }
}

TEST(DenseProducts, RealProductsEqualTheTripleLoop) {
  std::srand(7);
  CheckAllOperations<Eigen::MatrixXd>(1.0, 0.0);
  CheckAllOperations<Eigen::MatrixXd>(-0.75, 2.5);
}

TEST(DenseProducts, ComplexProductsEqualTheTripleLoop) {
  std::srand(8);
  CheckAllOperations<Eigen::MatrixXcd>(std::complex<double>(1.0, 0.0),
                                       std::complex<double>(0.0, 0.0));
  CheckAllOperations<Eigen::MatrixXcd>(std::complex<double>(0.3, -1.2),
                                       std::complex<double>(-0.5, 0.25));
}

TEST(DenseProducts, MismatchedSizesThrowBeforeWriting) {
  const Eigen::MatrixXd a = Eigen::MatrixXd::Ones(4, 3), b = Eigen::MatrixXd::Ones(4, 2);
  Eigen::MatrixXd c = Eigen::MatrixXd::Constant(4, 2, 7.0);
  EXPECT_THROW(multiply(1.0, a, MatrixOperation::kNone, b, MatrixOperation::kNone, 0.0, c),
               std::invalid_argument);
  EXPECT_EQ(c, Eigen::MatrixXd::Constant(4, 2, 7.0));
  // With A transposed the inner sizes agree (4), but C must then be 3 x 2.
  EXPECT_THROW(multiply(1.0, a, MatrixOperation::kTranspose, b, MatrixOperation::kNone, 0.0, c),
               std::invalid_argument);
  Eigen::MatrixXd right(3, 2);
  multiply(1.0, a, MatrixOperation::kTranspose, b, MatrixOperation::kNone, 0.0, right);
  EXPECT_EQ(right, Eigen::MatrixXd::Constant(3, 2, 4.0));
}

}  // namespace
