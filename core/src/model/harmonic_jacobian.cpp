// The harmonic-balance Jacobian as an operator, and its harmonic-decoupled preconditioner
// (harmonic_jacobian.hpp).
#include "model/harmonic_jacobian.hpp"

#include <algorithm>
#include <complex>
#include <limits>
#include <utility>
#include <vector>

#include "frichb/core/support/threads.hpp"

namespace frichb::core {

using Eigen::Index;
using Eigen::MatrixXcd;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

const std::complex<double> kImaginaryUnit(0.0, 1.0);

// From this many contact components on, the kept harmonics of a product or a preconditioner
// solve go to threads: each harmonic then streams at least m^2 / 2 complex numbers (the
// residual flexibility's lower triangle, or the preconditioner's LU in single precision:
// 2.9 MB at m = 600, some 0.3 ms), against tens of microseconds to start a thread.
constexpr int kThreadedComponents = 600;

// work(k) for k in [0, count), spread over up to `threads` threads (this one included; k goes
// to thread k mod threads). The first exception a thread throws is rethrown here once all
// have ended.
template <typename Work>
void for_each_harmonic(std::size_t count, int threads, const Work& work) {
  const std::size_t t =
      std::min<std::size_t>(static_cast<std::size_t>(std::max(1, threads)), count);
  run_on_threads(t, [&](std::size_t i) {
    for (std::size_t k = i; k < count; k += t) work(k);
  });
}

// Rows a * c + cos - i (a * c + sin) of x as the m x k complex amplitudes of harmonic r.
MatrixXcd gather_harmonic(const HarmonicReceptance& r, int coefficients, int components,
                          const Eigen::Ref<const MatrixXd>& x) {
  MatrixXcd z(components, x.cols());
  for (int a = 0; a < components; ++a) {
    const Index row = static_cast<Index>(a) * coefficients;
    if (r.harmonic > 0)
      z.row(a) = x.row(row + r.cos_index).cast<std::complex<double>>() -
                 kImaginaryUnit * x.row(row + r.sin_index);
    else
      z.row(a) = x.row(row + r.cos_index).cast<std::complex<double>>();
  }
  return z;
}

// y's rows of harmonic r += the real coefficients of the amplitudes w (m x k).
void scatter_harmonic(const HarmonicReceptance& r, int coefficients, int components,
                      const MatrixXcd& w, Eigen::Ref<MatrixXd> y) {
  for (int a = 0; a < components; ++a) {
    const Index row = static_cast<Index>(a) * coefficients;
    y.row(row + r.cos_index) += w.row(a).real();
    if (r.harmonic > 0) y.row(row + r.sin_index) -= w.row(a).imag();
  }
}

// I + Rc_n D0 of every kept harmonic, LU-factorised (complex, partial pivoting) in single
// precision: a preconditioner needs no more digits than its approximation has, and each GMRES
// iteration streams these factors from memory (half the bytes of double precision).
using PreconditionerFactor = Eigen::PartialPivLU<Eigen::MatrixXcf>;

class HarmonicDecoupledPreconditioner final : public JacobianPreconditioner {
 public:
  HarmonicDecoupledPreconditioner(int coefficients, int components,
                                  std::vector<HarmonicReceptance> layout,
                                  std::vector<PreconditionerFactor> factors, int threads)
      : coefficients_(coefficients),
        components_(components),
        threads_(threads),
        layout_(std::move(layout)),
        factors_(std::move(factors)) {
    condition_ = 1.0;
    for (const auto& f : factors_) {
      const double rcond = f.rcond();
      condition_ =
          std::max(condition_, rcond > 0.0 ? 1.0 / rcond : std::numeric_limits<double>::infinity());
      if (!std::isfinite(rcond)) condition_ = std::numeric_limits<double>::infinity();
    }
  }

  // Each harmonic writes its own rows of x: the harmonics may run on threads.
  void solve(const Eigen::Ref<const VectorXd>& b, Eigen::Ref<VectorXd> x) const override {
    x.setZero();
    for_each_harmonic(layout_.size(), threads_, [&](std::size_t k) {
      const MatrixXcd rhs = gather_harmonic(layout_[k], coefficients_, components_, b);
      MatrixXcd solution(rhs.rows(), rhs.cols());
      if (rhs.cols() == 1)
        solution.col(0) =
            factors_[k].solve(rhs.col(0).cast<std::complex<float>>()).cast<std::complex<double>>();
      else
        solution = factors_[k].solve(rhs.cast<std::complex<float>>()).cast<std::complex<double>>();
      if (layout_[k].harmonic == 0) solution.imag().setZero();
      scatter_harmonic(layout_[k], coefficients_, components_, solution, x);
    });
  }
  double condition() const override { return condition_; }

 private:
  int coefficients_;
  int components_;
  int threads_;
  std::vector<HarmonicReceptance> layout_;  // harmonic and indices only
  std::vector<PreconditionerFactor> factors_;
  double condition_ = 1.0;
};

}  // namespace

void HarmonicReceptance::apply(const MatrixXcd& x, MatrixXcd& y) const {
  y.resize(x.rows(), x.cols());
  if (x.cols() == 1) {
    // One vector: matrix-vector products (a matrix product would pack Rc or F every call).
    if (projected == nullptr) {
      y.col(0).noalias() = formed * x.col(0);
      return;
    }
    const Eigen::VectorXcd modal = inv_z.cwiseProduct(projected->adjoint() * x.col(0));
    y.col(0).noalias() = *projected * modal;
    // F = G F0 G^H is Hermitian: its lower triangle is read once (half the bytes).
    if (flexibility != nullptr && flexibility->size() > 0)
      y.col(0).noalias() += flexibility->selfadjointView<Eigen::Lower>() * x.col(0);
    return;
  }
  if (projected == nullptr) {
    y.noalias() = formed * x;
    return;
  }
  const MatrixXcd modal = inv_z.asDiagonal() * (projected->adjoint() * x);
  y.noalias() = *projected * modal;
  if (flexibility != nullptr && flexibility->size() > 0) y.noalias() += *flexibility * x;
}

MatrixXcd HarmonicReceptance::matrix() const {
  if (projected == nullptr) return formed;
  MatrixXcd rc = (*projected * inv_z.asDiagonal()) * projected->adjoint();
  if (flexibility != nullptr && flexibility->size() > 0) rc += *flexibility;
  return rc;
}

HarmonicJacobian::HarmonicJacobian(int coefficients, int components,
                                   std::vector<HarmonicReceptance> receptances,
                                   std::vector<ContactTangent> tangents, VectorXd parameter_column,
                                   int threads)
    : coefficients_(coefficients),
      components_(components),
      threads_(components >= kThreadedComponents ? std::max(1, threads) : 1),
      receptances_(std::move(receptances)),
      tangents_(std::move(tangents)),
      parameter_column_(std::move(parameter_column)) {}

void HarmonicJacobian::apply(const Eigen::Ref<const MatrixXd>& x, Eigen::Ref<MatrixXd> y) const {
  // D x, contact by contact.
  MatrixXd dx(x.rows(), x.cols());
  for (const ContactTangent& t : tangents_) {
    const Index p = t.block.rows();
    dx.middleRows(t.first, p).noalias() = t.block * x.middleRows(t.first, p);
  }
  y = x;
  // Each harmonic writes its own rows of y: the harmonics may run on threads.
  for_each_harmonic(receptances_.size(), threads_, [&](std::size_t k) {
    const HarmonicReceptance& r = receptances_[k];
    MatrixXcd w;
    r.apply(gather_harmonic(r, coefficients_, components_, dx), w);
    if (r.harmonic == 0) w.imag().setZero();
    scatter_harmonic(r, coefficients_, components_, w, y);
  });
}

void HarmonicJacobian::form(Eigen::Ref<MatrixXd> out) const {
  out.setZero();
  MatrixXcd force_block, product;
  for (const HarmonicReceptance& r : receptances_) {
    const MatrixXcd rc = r.matrix();
    for (const ContactTangent& t : tangents_) {
      const Index p = t.block.rows();
      const Index d = p / coefficients_;
      force_block.resize(d, p);
      for (Index b = 0; b < d; ++b) {
        const Index row = b * coefficients_;
        if (r.harmonic > 0)
          force_block.row(b) = t.block.row(row + r.cos_index).cast<std::complex<double>>() -
                               kImaginaryUnit * t.block.row(row + r.sin_index);
        else
          force_block.row(b) = t.block.row(row + r.cos_index).cast<std::complex<double>>();
      }
      product.noalias() = rc.middleCols(t.first / coefficients_, d) * force_block;
      scatter_harmonic(r, coefficients_, components_, product, out.middleCols(t.first, p));
    }
  }
  out.diagonal().array() += 1.0;
}

std::unique_ptr<JacobianPreconditioner> HarmonicJacobian::make_preconditioner() const {
  // D0 of each contact, d x d: the static-static block, or the mean of the cos-cos and
  // sin-sin blocks of the first kept harmonic (both equal the time-averaged tangent plus or
  // minus half its 2n-th cosine coefficient).
  if (receptances_.empty()) return nullptr;
  const auto with_static =
      std::find_if(receptances_.begin(), receptances_.end(),
                   [](const HarmonicReceptance& r) { return r.harmonic == 0; });
  const HarmonicReceptance& basis =
      with_static != receptances_.end() ? *with_static : receptances_.front();
  MatrixXd mean = MatrixXd::Zero(components_, components_);
  for (const ContactTangent& t : tangents_) {
    const Index d = t.block.rows() / coefficients_;
    const Index first = t.first / coefficients_;
    for (Index b = 0; b < d; ++b)
      for (Index e = 0; e < d; ++e) {
        const Index rb = b * coefficients_, re = e * coefficients_;
        mean(first + b, first + e) =
            basis.harmonic == 0 ? t.block(rb + basis.cos_index, re + basis.cos_index)
                                : 0.5 * (t.block(rb + basis.cos_index, re + basis.cos_index) +
                                         t.block(rb + basis.sin_index, re + basis.sin_index));
      }
  }
  std::vector<HarmonicReceptance> layout;
  std::vector<PreconditionerFactor> factors;
  for (const HarmonicReceptance& r : receptances_) {
    MatrixXcd rc = r.matrix();
    if (r.harmonic == 0) rc.imag().setZero();
    MatrixXcd m = MatrixXcd::Identity(components_, components_);
    // Rc D0 contact by contact (D0 is block diagonal).
    for (const ContactTangent& t : tangents_) {
      const Index d = t.block.rows() / coefficients_;
      const Index first = t.first / coefficients_;
      m.middleCols(first, d).noalias() +=
          rc.middleCols(first, d) * mean.block(first, first, d, d).cast<std::complex<double>>();
    }
    factors.emplace_back(m.cast<std::complex<float>>());
    HarmonicReceptance slot;
    slot.harmonic = r.harmonic;
    slot.cos_index = r.cos_index;
    slot.sin_index = r.sin_index;
    layout.push_back(std::move(slot));
  }
  return std::make_unique<HarmonicDecoupledPreconditioner>(
      coefficients_, components_, std::move(layout), std::move(factors), threads_);
}

}  // namespace frichb::core
