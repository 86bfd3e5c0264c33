// The harmonic-balance Jacobian as an operator, and its harmonic-decoupled preconditioner
// (harmonic_jacobian.hpp).
#include "model/harmonic_jacobian.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <memory>
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

// LU factors of the preconditioner (complex, partial pivoting) in single precision: a
// preconditioner needs no more digits than its approximation has, and each GMRES iteration
// streams these factors from memory (half the bytes of double precision).
using PreconditionerFactor = Eigen::PartialPivLU<Eigen::MatrixXcf>;

// What one kept harmonic's preconditioner keeps from the point it was made at. Either the LU
// of M = I + Rc D0 (formed receptances, and harmonic 0 with a complex P or F), or, for a modal
// receptance Rc = P diag(inv_z) P^H + F, the split
//   M = A + P diag(inv_z) V,   A = I + F D0,   V = P^H D0 (modes x m),
// with A's LU (none without F: A = I), W = A^-1 P (m x modes) and S = V W (modes x modes):
// by Woodbury's identity
//   M^-1 = A^-1 - W diag(inv_z) (I + S diag(inv_z))^-1 V A^-1,
// so that M follows the frequency through inv_z at the cost of a modes x modes LU.
struct HarmonicFactor {
  HarmonicReceptance slot;  // harmonic and indices; the model's P and F it was made with
  bool split = false;
  bool has_lu = false;
  PreconditionerFactor lu;  // of M, or of A in the split
  double condition = 1.0;   // the LU's condition estimate (1 without one)
  MatrixXcd w, v, s;        // the split's W, V and S
};

// The modal split's capacitance I + S diag(inv_z) of one harmonic, LU-factorised (double).
using Capacitance = Eigen::PartialPivLU<MatrixXcd>;

double condition_of(double rcond) {
  return rcond > 0.0 && std::isfinite(rcond) ? 1.0 / rcond
                                             : std::numeric_limits<double>::infinity();
}

class HarmonicDecoupledPreconditioner final : public JacobianPreconditioner {
 public:
  // `inv_z`: the point's 1 / z of each harmonic (used by the split harmonics only).
  HarmonicDecoupledPreconditioner(int coefficients, int components,
                                  std::shared_ptr<const std::vector<HarmonicFactor>> factors,
                                  const std::vector<Eigen::VectorXcd>& inv_z, int threads)
      : coefficients_(coefficients),
        components_(components),
        threads_(threads),
        factors_(std::move(factors)),
        inv_z_(inv_z),
        capacitance_(factors_->size()) {
    // Each harmonic's M is a block of the preconditioner: its condition is the largest of
    // theirs. A split one's M = A (I + W diag(inv_z) V) has cond(M) <= cond(A) times that of
    // the second factor, for which the capacitance's condition stands (they share their
    // non-unit eigenvalues).
    for (std::size_t k = 0; k < factors_->size(); ++k) {
      const HarmonicFactor& f = (*factors_)[k];
      double c = 1.0;
      if (f.split) {
        capacitance_[k].compute(MatrixXcd::Identity(f.s.rows(), f.s.cols()) +
                                f.s * inv_z_[k].asDiagonal());
        c = condition_of(capacitance_[k].rcond());
      }
      condition_ = std::max(condition_, f.condition * c);
    }
  }

  // Each harmonic writes its own rows of x: the harmonics may run on threads.
  void solve(const Eigen::Ref<const VectorXd>& b, Eigen::Ref<VectorXd> x) const override {
    x.setZero();
    for_each_harmonic(factors_->size(), threads_, [&](std::size_t k) {
      const HarmonicFactor& f = (*factors_)[k];
      // One vector: matrix-vector products and triangular solves (a one-column matrix would
      // take the blocked matrix paths).
      MatrixXcd y(components_, 1);
      Eigen::VectorXcd column = gather_harmonic(f.slot, coefficients_, components_, b).col(0);
      if (f.has_lu)
        column = f.lu.solve(column.cast<std::complex<float>>()).cast<std::complex<double>>();
      if (f.split) {
        const Eigen::VectorXcd u = capacitance_[k].solve(f.v * column);
        column.noalias() -= f.w * inv_z_[k].cwiseProduct(u);
      }
      y.col(0) = column;
      if (f.slot.harmonic == 0) y.imag().setZero();
      scatter_harmonic(f.slot, coefficients_, components_, y, x);
    });
  }
  double condition() const override { return condition_; }

  // The split harmonics at `op`'s frequency (its inv_z): one modes x modes LU each. Null when
  // `op` is not a HarmonicJacobian of the same layout and receptances. The tangents stay
  // those of the point the factors were made at.
  std::unique_ptr<JacobianPreconditioner> follow(const JacobianOperator& op) const override {
    const auto* harmonic = dynamic_cast<const HarmonicJacobian*>(&op);
    if (harmonic == nullptr) return nullptr;
    const std::vector<HarmonicReceptance>& at = harmonic->receptances();
    if (at.size() != factors_->size() ||
        op.rows() != static_cast<Eigen::Index>(coefficients_) * components_)
      return nullptr;
    std::vector<Eigen::VectorXcd> inv_z(at.size());
    bool any = false;
    for (std::size_t k = 0; k < at.size(); ++k) {
      const HarmonicFactor& f = (*factors_)[k];
      // The factors hold the model's P and F of each harmonic: the same receptances or none.
      if (at[k].harmonic != f.slot.harmonic || at[k].cos_index != f.slot.cos_index ||
          at[k].sin_index != f.slot.sin_index || at[k].projected != f.slot.projected ||
          at[k].flexibility != f.slot.flexibility)
        return nullptr;
      if (!f.split) continue;
      if (at[k].inv_z.size() != f.s.rows() || !at[k].inv_z.allFinite()) return nullptr;
      inv_z[k] = at[k].inv_z;
      any = true;
    }
    if (!any) return nullptr;
    return std::make_unique<HarmonicDecoupledPreconditioner>(coefficients_, components_, factors_,
                                                             inv_z, threads_);
  }

 private:
  int coefficients_;
  int components_;
  int threads_;
  std::shared_ptr<const std::vector<HarmonicFactor>> factors_;
  std::vector<Eigen::VectorXcd> inv_z_;
  std::vector<Capacitance> capacitance_;
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
  auto factors = std::make_shared<std::vector<HarmonicFactor>>(receptances_.size());
  std::vector<Eigen::VectorXcd> inv_z(receptances_.size());
  // Rc D0 contact by contact (D0 is block diagonal): `target` += `rc` D0.
  const auto add_times_mean = [&](const MatrixXcd& rc, MatrixXcd& target) {
    for (const ContactTangent& t : tangents_) {
      const Index d = t.block.rows() / coefficients_;
      const Index first = t.first / coefficients_;
      target.middleCols(first, d).noalias() +=
          rc.middleCols(first, d) * mean.block(first, first, d, d).cast<std::complex<double>>();
    }
  };
  // Each harmonic's factors are its own: the harmonics may run on threads.
  for_each_harmonic(receptances_.size(), threads_, [&](std::size_t k) {
    const HarmonicReceptance& r = receptances_[k];
    HarmonicFactor& f = (*factors)[k];
    f.slot.harmonic = r.harmonic;
    f.slot.cos_index = r.cos_index;
    f.slot.sin_index = r.sin_index;
    f.slot.projected = r.projected;
    f.slot.flexibility = r.flexibility;
    MatrixXcd m = MatrixXcd::Identity(components_, components_);
    // Harmonic 0 takes the real part of Rc x: split only where P and F are real (no cyclic
    // phase), so that the split is of that real part.
    const bool real_at_zero = r.projected != nullptr && r.projected->size() > 0 &&
                              r.projected->imag().cwiseAbs().maxCoeff() == 0.0 &&
                              (r.flexibility == nullptr || r.flexibility->size() == 0 ||
                               r.flexibility->imag().cwiseAbs().maxCoeff() == 0.0);
    f.split = r.projected != nullptr && r.projected->cols() > 0 && (r.harmonic > 0 || real_at_zero);
    if (!f.split) {
      MatrixXcd rc = r.matrix();
      if (r.harmonic == 0) rc.imag().setZero();
      add_times_mean(rc, m);
      f.lu.compute(m.cast<std::complex<float>>());
      f.has_lu = true;
      f.condition = condition_of(f.lu.rcond());
      return;
    }
    const MatrixXcd& p = *r.projected;
    f.v.resize(p.cols(), components_);
    for (const ContactTangent& t : tangents_) {
      const Index d = t.block.rows() / coefficients_;
      const Index first = t.first / coefficients_;
      f.v.middleCols(first, d).noalias() =
          p.middleRows(first, d).adjoint() *
          mean.block(first, first, d, d).cast<std::complex<double>>();
    }
    if (r.flexibility != nullptr && r.flexibility->size() > 0) {
      add_times_mean(*r.flexibility, m);
      f.lu.compute(m.cast<std::complex<float>>());
      f.has_lu = true;
      f.condition = condition_of(f.lu.rcond());
      f.w = f.lu.solve(p.cast<std::complex<float>>()).cast<std::complex<double>>();
    } else {
      f.w = p;
    }
    f.s.noalias() = f.v * f.w;
    inv_z[k] = r.inv_z;
  });
  return std::make_unique<HarmonicDecoupledPreconditioner>(coefficients_, components_,
                                                           std::move(factors), inv_z, threads_);
}

}  // namespace frichb::core
