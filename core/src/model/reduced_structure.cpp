#include "frichb/core/model/reduced_structure.hpp"

#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>

namespace frichb::core {
namespace {

constexpr std::complex<double> kImaginaryUnit(0.0, 1.0);

// Modal impedance z_r = w_r^2 - W^2 + i W c_rr of mode r (diagonal modal damping).
std::complex<double> modal_impedance(const ReducedStructure::Basis& b, Eigen::Index r, double w) {
  const double wr = b.frequencies(r);
  return wr * wr - w * w + kImaginaryUnit * w * b.damping(r, r);
}

// The full modal impedance Z = diag(w_r^2) - W^2 I + i W C (any modal damping).
Eigen::MatrixXcd modal_impedance_matrix(const ReducedStructure::Basis& b, double w) {
  const Eigen::Index m = b.frequencies.size();
  Eigen::MatrixXcd z = -w * w * Eigen::MatrixXcd::Identity(m, m) + kImaginaryUnit * w * b.damping;
  z.diagonal() += b.frequencies.array().square().matrix().cast<std::complex<double>>();
  return z;
}

}  // namespace

ReducedStructure::ReducedStructure(StructureModel& provider, std::vector<std::size_t> kept_dofs,
                                   const std::vector<int>& harmonic_indices,
                                   const FlexibilityUse* use)
    : kept_dofs_(std::move(kept_dofs)) {
  const auto kept = static_cast<Eigen::Index>(kept_dofs_.size());
  if (use != nullptr) {
    for (Eigen::Index row : use->response_rows)
      if (row < 0 || row >= kept)
        throw std::out_of_range("ReducedStructure: response row " + std::to_string(row) +
                                " is not among the " + std::to_string(kept) + " kept DOFs");
    response_rows_ = use->response_rows;
  }
  for (int h : harmonic_indices) {
    if (bases_.count(h)) continue;
    const frichb_modal_basis b = provider.modal_basis(h, kept_dofs_);
    const auto m = static_cast<Eigen::Index>(b.n_modes);
    Basis basis;
    basis.frequencies = Eigen::Map<const Eigen::VectorXd>(b.natural_frequencies, m);
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    basis.damping = Eigen::Map<const RowMajor>(b.modal_damping, m, m);
    basis.diagonal_damping =
        (basis.damping - Eigen::MatrixXd(basis.damping.diagonal().asDiagonal()))
            .cwiseAbs()
            .maxCoeff() <= 1e-14 * std::max(1.0, basis.damping.cwiseAbs().maxCoeff());
    basis.rows = Eigen::Map<const RowMajor>(b.mode_rows_real, kept, m).cast<std::complex<double>>();
    if (b.mode_rows_imag) basis.rows.imag() = Eigen::Map<const RowMajor>(b.mode_rows_imag, kept, m);
    if (b.residual_flexibility) {
      basis.residual_flexibility = Eigen::Map<const RowMajor>(b.residual_flexibility, kept, kept)
                                       .cast<std::complex<double>>();
      // The imaginary part came with ABI 1.1: read it only from a basis that has the field.
      const std::size_t needed = offsetof(frichb_modal_basis, residual_flexibility_imag) +
                                 sizeof(b.residual_flexibility_imag);
      if (b.struct_size >= needed && b.residual_flexibility_imag)
        basis.residual_flexibility.imag() =
            Eigen::Map<const RowMajor>(b.residual_flexibility_imag, kept, kept);
    }
    if (!basis.frequencies.allFinite() || !basis.damping.allFinite() || !basis.rows.allFinite())
      throw PluginError("structure '" + provider.name() +
                        "' returned a modal basis with NaN or Inf for harmonic index " +
                        std::to_string(h));
    if (use != nullptr && use->reduce && basis.diagonal_damping &&
        basis.residual_flexibility.size() > 0) {
      use->reduce(h, basis.residual_flexibility);
      basis.flexibility_rows = basis.residual_flexibility(response_rows_, Eigen::all);
      basis.residual_flexibility = Eigen::MatrixXcd();  // frees the kept x kept block
      basis.flexibility_reduced = true;
    }
    bases_.emplace(h, std::move(basis));
  }
}

const ReducedStructure::Basis& ReducedStructure::basis(int harmonic_index) const {
  auto it = bases_.find(harmonic_index);
  if (it == bases_.end())
    throw std::out_of_range("harmonic index " + std::to_string(harmonic_index) +
                            " was not prepared");
  return it->second;
}

std::size_t ReducedStructure::mode_count(int harmonic_index) const {
  return static_cast<std::size_t>(basis(harmonic_index).frequencies.size());
}

const Eigen::VectorXd& ReducedStructure::natural_frequencies(int harmonic_index) const {
  return basis(harmonic_index).frequencies;
}

void ReducedStructure::receptance(int harmonic_index, double w, Eigen::MatrixXcd& r,
                                  Eigen::MatrixXcd* dr) const {
  const Basis& b = basis(harmonic_index);
  if (b.flexibility_reduced)
    throw std::logic_error("ReducedStructure::receptance: harmonic index " +
                           std::to_string(harmonic_index) +
                           " keeps its residual flexibility only where it was reduced");
  const std::complex<double> i(0.0, 1.0);
  const Eigen::Index m = b.frequencies.size();
  if (b.diagonal_damping) {
    // Z is diagonal: R = sum_r phi_r phi_r^H / z_r, dR/dW = -sum_r phi_r phi_r^H z_r' / z_r^2.
    Eigen::VectorXcd inv_z(m), dinv_z(m);
    for (Eigen::Index k = 0; k < m; ++k) {
      const std::complex<double> z = modal_impedance(b, k, w);
      const std::complex<double> dz = -2.0 * w + i * b.damping(k, k);
      inv_z(k) = 1.0 / z;
      dinv_z(k) = -dz / (z * z);
    }
    r.noalias() = b.rows * inv_z.asDiagonal() * b.rows.adjoint();
    if (dr) dr->noalias() = b.rows * dinv_z.asDiagonal() * b.rows.adjoint();
  } else {
    Eigen::PartialPivLU<Eigen::MatrixXcd> lu(modal_impedance_matrix(b, w));
    const Eigen::MatrixXcd zinv_phiH = lu.solve(b.rows.adjoint());
    r.noalias() = b.rows * zinv_phiH;
    if (dr) {
      const Eigen::MatrixXcd dz =
          -2.0 * w * Eigen::MatrixXcd::Identity(m, m) + i * b.damping.cast<std::complex<double>>();
      dr->noalias() = -(b.rows * lu.solve(dz * zinv_phiH));
    }
  }
  if (b.residual_flexibility.size()) r += b.residual_flexibility;
}

Eigen::VectorXcd ReducedStructure::respond(int harmonic_index, double w,
                                           const Eigen::VectorXcd& force,
                                           Eigen::VectorXcd* derivative) const {
  const Basis& b = basis(harmonic_index);
  if (force.size() != b.rows.rows())
    throw std::invalid_argument("ReducedStructure::respond: force of the wrong size");
  const Eigen::VectorXcd projected = b.rows.adjoint() * force;
  Eigen::VectorXcd modal(projected.size());
  Eigen::VectorXcd modal_derivative;  // d(Z^-1)/dW Phi^H f = -Z^-1 Z' Z^-1 Phi^H f
  if (b.diagonal_damping) {
    if (derivative) modal_derivative.resize(projected.size());
    for (Eigen::Index k = 0; k < modal.size(); ++k) {
      const std::complex<double> z = modal_impedance(b, k, w);
      modal(k) = projected(k) / z;
      if (derivative)
        modal_derivative(k) = -(-2.0 * w + kImaginaryUnit * b.damping(k, k)) * modal(k) / z;
    }
  } else {
    const Eigen::PartialPivLU<Eigen::MatrixXcd> lu(modal_impedance_matrix(b, w));
    modal = lu.solve(projected);
    if (derivative) {
      const Eigen::MatrixXcd dz =
          -2.0 * w * Eigen::MatrixXcd::Identity(modal.size(), modal.size()) +
          kImaginaryUnit * b.damping.cast<std::complex<double>>();
      modal_derivative = -lu.solve(dz * modal);
    }
  }
  if (b.flexibility_reduced) {
    const std::complex<double> nan(std::numeric_limits<double>::quiet_NaN(),
                                   std::numeric_limits<double>::quiet_NaN());
    Eigen::VectorXcd x = Eigen::VectorXcd::Constant(b.rows.rows(), nan);
    x(response_rows_) = b.rows(response_rows_, Eigen::all) * modal + b.flexibility_rows * force;
    if (derivative) {
      *derivative = Eigen::VectorXcd::Constant(b.rows.rows(), nan);
      (*derivative)(response_rows_) = b.rows(response_rows_, Eigen::all) * modal_derivative;
    }
    return x;
  }
  Eigen::VectorXcd x = b.rows * modal;
  if (b.residual_flexibility.size()) x += b.residual_flexibility * force;
  if (derivative) *derivative = b.rows * modal_derivative;
  return x;
}

Eigen::VectorXcd ReducedStructure::residual_response(int harmonic_index,
                                                     const Eigen::VectorXcd& force) const {
  const Basis& b = basis(harmonic_index);
  if (force.size() != b.rows.rows())
    throw std::invalid_argument("ReducedStructure::residual_response: force of the wrong size");
  if (b.flexibility_reduced) {
    const std::complex<double> nan(std::numeric_limits<double>::quiet_NaN(),
                                   std::numeric_limits<double>::quiet_NaN());
    Eigen::VectorXcd x = Eigen::VectorXcd::Constant(b.rows.rows(), nan);
    x(response_rows_) = b.flexibility_rows * force;
    return x;
  }
  if (b.residual_flexibility.size()) return b.residual_flexibility * force;
  return Eigen::VectorXcd::Zero(b.rows.rows());
}

}  // namespace frichb::core
