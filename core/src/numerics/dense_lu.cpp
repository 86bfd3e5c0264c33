#include "frichb/core/numerics/dense_lu.hpp"

#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>

#ifdef FRICHB_WITH_OPENBLAS
// LAPACK (Fortran) and OpenBLAS entry points; character arguments carry their lengths as
// trailing hidden arguments (gfortran convention).
extern "C" {
void dgetrf_(const int* m, const int* n, double* a, const int* lda, int* ipiv, int* info);
void dgetrs_(const char* trans, const int* n, const int* nrhs, const double* a, const int* lda,
             const int* ipiv, double* b, const int* ldb, int* info, std::size_t trans_length);
void dgecon_(const char* norm, const int* n, const double* a, const int* lda, const double* anorm,
             double* rcond, double* work, int* iwork, int* info, std::size_t norm_length);
void openblas_set_num_threads(int n);
int openblas_get_num_threads(void);
char* openblas_get_config(void);
}
#endif

namespace frichb::core {

namespace {

#ifdef FRICHB_WITH_OPENBLAS
int checked_int(Eigen::Index n) {
  if (n > std::numeric_limits<int>::max())
    throw std::length_error("DenseLu: matrix too large for LAPACK's 32-bit indices");
  return static_cast<int>(n);
}
#endif

}  // namespace

void DenseLu::compute(const Eigen::Ref<const Eigen::MatrixXd>& a) {
  if (a.rows() != a.cols()) throw std::invalid_argument("DenseLu: the matrix is not square");
  factors_ = a;  // no reallocation when the size is unchanged
  factorise_stored();
}

void DenseLu::compute_bordered(const Eigen::Ref<const Eigen::MatrixXd>& top,
                               const Eigen::Ref<const Eigen::VectorXd>& last_row) {
  const Eigen::Index n = top.rows();
  if (top.cols() != n + 1 || last_row.size() != n + 1)
    throw std::invalid_argument("DenseLu: the bordered matrix is not square");
  factors_.resize(n + 1, n + 1);
  factors_.topRows(n) = top;
  factors_.row(n) = last_row.transpose();
  factorise_stored();
}

void DenseLu::factorise_stored() {
  rcond_ = 0.0;
  size_ = factors_.rows();
  if (!factors_.allFinite()) {
    return;
  }
#ifdef FRICHB_WITH_OPENBLAS
  const int n = checked_int(factors_.rows());
  const double anorm = factors_.cwiseAbs().colwise().sum().maxCoeff();  // 1-norm
  pivots_.assign(static_cast<std::size_t>(n), 0);
  int info = 0;
  const int lda = std::max(1, n);
  if (n > 0) dgetrf_(&n, &n, factors_.data(), &lda, pivots_.data(), &info);
  if (info < 0)
    throw std::logic_error("DenseLu: dgetrf rejected argument " + std::to_string(-info));
  if (info > 0 || n == 0) return;  // exactly singular (U(info, info) == 0)
  std::vector<double> work(4 * static_cast<std::size_t>(n));
  std::vector<int> iwork(static_cast<std::size_t>(n));
  dgecon_("1", &n, factors_.data(), &lda, &anorm, &rcond_, work.data(), iwork.data(), &info, 1);
  if (info != 0 || !std::isfinite(rcond_)) rcond_ = 0.0;
#else
  eigen_lu_.compute(factors_);
  rcond_ = eigen_lu_.rcond();
  if (!std::isfinite(rcond_)) rcond_ = 0.0;
#endif
}

int DenseLu::determinant_sign() const {
  if (rcond_ == 0.0 || size_ == 0) return 0;
  int sign = 1;
#ifdef FRICHB_WITH_OPENBLAS
  for (Eigen::Index i = 0; i < size_; ++i) {
    if (pivots_[static_cast<std::size_t>(i)] != i + 1) sign = -sign;
    if (factors_(i, i) < 0.0) sign = -sign;
  }
#else
  sign = static_cast<int>(eigen_lu_.permutationP().determinant());
  for (Eigen::Index i = 0; i < size_; ++i)
    if (eigen_lu_.matrixLU()(i, i) < 0.0) sign = -sign;
#endif
  return sign;
}

Eigen::VectorXd DenseLu::solve(const Eigen::VectorXd& b) const {
  if (b.size() != size_)
    throw std::invalid_argument("DenseLu::solve: right-hand side of the wrong size");
  if (rcond_ == 0.0)  // singular or not factorised: no solution
    return Eigen::VectorXd::Constant(b.size(), std::numeric_limits<double>::quiet_NaN());
#ifdef FRICHB_WITH_OPENBLAS
  Eigen::VectorXd x = b;
  const int n = checked_int(factors_.rows());
  const int one = 1;
  const int lda = std::max(1, n);
  int info = 0;
  dgetrs_("N", &n, &one, factors_.data(), &lda, pivots_.data(), x.data(), &lda, &info, 1);
  return x;
#else
  return eigen_lu_.solve(b);
#endif
}

std::string dense_solver_description() {
#ifdef FRICHB_WITH_OPENBLAS
  return std::string("OpenBLAS (LAPACK dgetrf; ") + openblas_get_config() + ", " +
         std::to_string(openblas_get_num_threads()) + " threads)";
#else
  return "Eigen " + std::to_string(EIGEN_WORLD_VERSION) + "." +
         std::to_string(EIGEN_MAJOR_VERSION) + "." + std::to_string(EIGEN_MINOR_VERSION) +
         " PartialPivLU";
#endif
}

void set_dense_solver_threads(int n) {
#ifdef FRICHB_WITH_OPENBLAS
  openblas_set_num_threads(
      n > 0 ? n : static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
#else
  (void)n;
#endif
}

}  // namespace frichb::core
