#include "frichb/core/numerics/dense_products.hpp"

#include <algorithm>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>

#ifdef FRICHB_WITH_OPENBLAS
// BLAS (Fortran) entry points of OpenBLAS; character arguments carry their lengths as trailing
// hidden arguments (gfortran convention).
extern "C" {
void dgemm_(const char* transa, const char* transb, const int* m, const int* n, const int* k,
            const double* alpha, const double* a, const int* lda, const double* b, const int* ldb,
            const double* beta, double* c, const int* ldc, std::size_t transa_length,
            std::size_t transb_length);
void zgemm_(const char* transa, const char* transb, const int* m, const int* n, const int* k,
            const std::complex<double>* alpha, const std::complex<double>* a, const int* lda,
            const std::complex<double>* b, const int* ldb, const std::complex<double>* beta,
            std::complex<double>* c, const int* ldc, std::size_t transa_length,
            std::size_t transb_length);
}
#endif

namespace frichb::core {
namespace {

// Rows and columns of op(M).
template <class M>
Eigen::Index op_rows(const M& m, MatrixOperation op) {
  return op == MatrixOperation::kNone ? m.rows() : m.cols();
}
template <class M>
Eigen::Index op_cols(const M& m, MatrixOperation op) {
  return op == MatrixOperation::kNone ? m.cols() : m.rows();
}

template <class A, class B, class C>
void check_sizes(const A& a, MatrixOperation op_a, const B& b, MatrixOperation op_b, const C& c) {
  if (op_cols(a, op_a) != op_rows(b, op_b) || c.rows() != op_rows(a, op_a) ||
      c.cols() != op_cols(b, op_b))
    throw std::invalid_argument("multiply: op(A) is " + std::to_string(op_rows(a, op_a)) + " x " +
                                std::to_string(op_cols(a, op_a)) + ", op(B) " +
                                std::to_string(op_rows(b, op_b)) + " x " +
                                std::to_string(op_cols(b, op_b)) + ", C " +
                                std::to_string(c.rows()) + " x " + std::to_string(c.cols()));
}

// Calls f with the expression op(m).
template <class M, class F>
void with_operation(const M& m, MatrixOperation op, F&& f) {
  switch (op) {
    case MatrixOperation::kNone:
      f(m);
      return;
    case MatrixOperation::kTranspose:
      f(m.transpose());
      return;
    case MatrixOperation::kAdjoint:
      f(m.adjoint());
      return;
  }
}

template <class Scalar, class A, class B, class C>
void eigen_multiply(Scalar alpha, const A& a, MatrixOperation op_a, const B& b,
                    MatrixOperation op_b, Scalar beta, C& c) {
  with_operation(a, op_a, [&](const auto& op_a_of_a) {
    with_operation(b, op_b, [&](const auto& op_b_of_b) {
      if (beta == Scalar(0))
        c.noalias() = alpha * (op_a_of_a * op_b_of_b);
      else {
        c *= beta;
        c.noalias() += alpha * (op_a_of_a * op_b_of_b);
      }
    });
  });
}

#ifdef FRICHB_WITH_OPENBLAS
int blas_int(Eigen::Index n) {
  if (n > std::numeric_limits<int>::max())
    throw std::length_error("multiply: matrix too large for BLAS's 32-bit indices");
  return static_cast<int>(n);
}

const char* blas_operation(MatrixOperation op) {
  switch (op) {
    case MatrixOperation::kNone:
      return "N";
    case MatrixOperation::kTranspose:
      return "T";
    case MatrixOperation::kAdjoint:
      return "C";
  }
  return "N";
}

// Leading dimension of a column-major block: its outer stride, at least 1 and its rows.
template <class M>
int leading_dimension(const M& m) {
  return blas_int(std::max<Eigen::Index>({1, m.rows(), m.outerStride()}));
}

// The BLAS call pays off once the product has a few thousand multiply-adds; below that
// Eigen's inlined product is as fast and has no call overhead.
bool worth_blas(Eigen::Index m, Eigen::Index n, Eigen::Index k) {
  return m > 0 && n > 0 && k > 0 && static_cast<double>(m) * n * k >= 32768.0;
}

// gemm of the scalar type: dgemm_ or zgemm_.
void blas_gemm(const char* ta, const char* tb, const int* m, const int* n, const int* k,
               const double* alpha, const double* a, const int* lda, const double* b,
               const int* ldb, const double* beta, double* c, const int* ldc) {
  dgemm_(ta, tb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc, 1, 1);
}
void blas_gemm(const char* ta, const char* tb, const int* m, const int* n, const int* k,
               const std::complex<double>* alpha, const std::complex<double>* a, const int* lda,
               const std::complex<double>* b, const int* ldb, const std::complex<double>* beta,
               std::complex<double>* c, const int* ldc) {
  zgemm_(ta, tb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc, 1, 1);
}
#endif

// C = alpha op(A) op(B) + beta C for either scalar type: BLAS when built with it and the
// product is large enough, Eigen otherwise.
template <class Scalar, class Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>>
void gemm_or_eigen(Scalar alpha, const Eigen::Ref<const Matrix>& a, MatrixOperation op_a,
                   const Eigen::Ref<const Matrix>& b, MatrixOperation op_b, Scalar beta,
                   Eigen::Ref<Matrix>& c) {
  check_sizes(a, op_a, b, op_b, c);
#ifdef FRICHB_WITH_OPENBLAS
  const Eigen::Index k = op_cols(a, op_a);
  if (worth_blas(c.rows(), c.cols(), k)) {
    const int m = blas_int(c.rows()), n = blas_int(c.cols()), kk = blas_int(k);
    const int lda = leading_dimension(a), ldb = leading_dimension(b), ldc = leading_dimension(c);
    blas_gemm(blas_operation(op_a), blas_operation(op_b), &m, &n, &kk, &alpha, a.data(), &lda,
              b.data(), &ldb, &beta, c.data(), &ldc);
    return;
  }
#endif
  eigen_multiply(alpha, a, op_a, b, op_b, beta, c);
}

}  // namespace

void multiply(double alpha, const Eigen::Ref<const Eigen::MatrixXd>& a, MatrixOperation op_a,
              const Eigen::Ref<const Eigen::MatrixXd>& b, MatrixOperation op_b, double beta,
              Eigen::Ref<Eigen::MatrixXd> c) {
  gemm_or_eigen(alpha, a, op_a, b, op_b, beta, c);
}

void multiply(std::complex<double> alpha, const Eigen::Ref<const Eigen::MatrixXcd>& a,
              MatrixOperation op_a, const Eigen::Ref<const Eigen::MatrixXcd>& b,
              MatrixOperation op_b, std::complex<double> beta, Eigen::Ref<Eigen::MatrixXcd> c) {
  gemm_or_eigen(alpha, a, op_a, b, op_b, beta, c);
}

}  // namespace frichb::core
