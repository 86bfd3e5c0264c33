// Dense LU factorisation with partial pivoting of the continuation's Newton and tangent
// matrices, with the reciprocal condition number estimate (1-norm, LAPACK dgecon).
//
// Backend: LAPACK dgetrf/dgetrs/dgecon from OpenBLAS when FricHB is built with it (CMake finds
// Debian's libopenblas-dev; blocked, vectorised for the running CPU, multithreaded), else
// Eigen's PartialPivLU. Both give the same factors up to rounding (same pivoting rule).
//
// Threading: an object is used by one thread. OpenBLAS itself may run a factorisation on
// several threads; set_dense_solver_threads bounds them. The bound is process-wide (OpenBLAS
// keeps one): OpenBLAS's default (every core, or OPENBLAS_NUM_THREADS) until a program sets
// it; `frichb study` sets it once per process to the cores each of its runs gets (1 for one
// scene per core); a program running several verbs at once sets it once, before them.
// Failure: factorising a matrix with a non-finite entry gives rcond() == 0; a singular matrix
// gives rcond() == 0 (exactly singular) or a tiny estimate. solve() on such a matrix returns
// non-finite entries rather than throwing; callers test invertible() first.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

namespace frichb::core {

class DenseLu {
 public:
  DenseLu() = default;
  // Factorises the square matrix a (copied; a is not modified).
  explicit DenseLu(const Eigen::Ref<const Eigen::MatrixXd>& a) { compute(a); }
  // Factorises a, copied into storage kept from the previous factorisation of the same size:
  // one object refactorised over and over allocates once.
  void compute(const Eigen::Ref<const Eigen::MatrixXd>& a);
  // Factorises the bordered matrix [top; last_row^T] ((n + 1) x (n + 1), top n x (n + 1)),
  // formed directly in the factor storage.
  void compute_bordered(const Eigen::Ref<const Eigen::MatrixXd>& top,
                        const Eigen::Ref<const Eigen::VectorXd>& last_row);
  // Reciprocal condition number estimate in the 1-norm, in [0, 1]; 0 when singular.
  double rcond() const { return rcond_; }
  // Sign of det(A): +1 or -1, from the factors (the row interchanges and the signs of U's
  // diagonal); 0 when A is singular or not factorised.
  int determinant_sign() const;
  // Solves A x = b.
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;
  Eigen::Index size() const { return size_; }

 private:
  void factorise_stored();  // factorises factors_ in place (it holds the matrix on entry)

  Eigen::MatrixXd factors_;  // L (unit diagonal, below) and U (on and above), LAPACK layout
  std::vector<int> pivots_;  // 1-based row interchanges (LAPACK ipiv)
  Eigen::PartialPivLU<Eigen::MatrixXd> eigen_lu_;  // the Eigen backend
  double rcond_ = 0.0;
  Eigen::Index size_ = 0;
};

// The backend in use, e.g. "OpenBLAS 0.3.21 (LAPACK dgetrf, 2 threads)" or "Eigen 3.4".
std::string dense_solver_description();
// Bounds the threads of one factorisation (OpenBLAS); no effect with Eigen. n <= 0: all cores.
void set_dense_solver_threads(int n);

}  // namespace frichb::core
