// Dense matrix products C = alpha op(A) op(B) + beta C, the level-3 BLAS operation (gemm), for
// the large products of an evaluation: the receptances at the contacts, P diag(1/z) P^T.
//
// Backend: OpenBLAS dgemm/zgemm when FricHB is built with it (blocked, vectorised for the
// running CPU, multithreaded; bounded by set_dense_solver_threads), else Eigen's product.
// Only level-3 routines are called (Eigen's own EIGEN_USE_BLAS mapping, which also sends
// matrix-vector products to BLAS, is not used; see docs/performance.md).
//
// Layout: column-major matrices or column blocks of them (unit inner stride, any outer
// stride), the same for A, B and C. C must not alias A or B.
// Threading: reentrant; OpenBLAS may run one product on several threads.
// Failure: mismatched sizes throw std::invalid_argument before anything is written.
#pragma once

#include <Eigen/Dense>
#include <complex>

namespace frichb::core {

// op(M): M, its transpose, or its conjugate transpose (the transpose for real matrices).
enum class MatrixOperation { kNone, kTranspose, kAdjoint };

void multiply(double alpha, const Eigen::Ref<const Eigen::MatrixXd>& a, MatrixOperation op_a,
              const Eigen::Ref<const Eigen::MatrixXd>& b, MatrixOperation op_b, double beta,
              Eigen::Ref<Eigen::MatrixXd> c);

void multiply(std::complex<double> alpha, const Eigen::Ref<const Eigen::MatrixXcd>& a,
              MatrixOperation op_a, const Eigen::Ref<const Eigen::MatrixXcd>& b,
              MatrixOperation op_b, std::complex<double> beta, Eigen::Ref<Eigen::MatrixXcd> c);

}  // namespace frichb::core
