// FricHB plugin SDK: the arrays behind a structure provider's frichb_modal_basis.
//
// A provider's modal_basis() returns a frichb_modal_basis whose pointers must stay valid
// until the next modal_basis() call on the same instance or its destruction (abi.h).
// ModalBasisBuilder owns those arrays in the layouts abi.h defines, so a provider hands it
// the modal data and returns basis():
//
//   class MyStructure : public frichb::sdk::StructureProvider {
//     frichb_modal_basis modal_basis(int h, const size_t* kept, size_t n_kept) override {
//       basis_.set_frequencies(w);            // w_r in rad/s; the damping becomes zero
//       basis_.add_damping_ratios(ratios);    // C_rr += 2 z_r w_r (or set_damping_matrix)
//       basis_.gather_mode_rows(phi, kept, n_kept);  // rows of Phi at the kept DOFs
//       return basis_.basis();
//     }
//     frichb::sdk::ModalBasisBuilder basis_;  // a member: it outlives the call
//   };
//
// Contract:
//  - Units and layouts as abi.h's frichb_modal_basis: natural frequencies w_r in rad/s
//    (n_modes); the modal damping matrix C in 1/s (n_modes x n_modes, row-major; a modal
//    damping ratio z_r adds C_rr = 2 z_r w_r); mode rows Phi at the kept DOFs in m/sqrt(kg),
//    mass-normalised (n_kept x n_modes, row-major, real and imaginary parts); residual
//    flexibility in m/N (n_kept x n_kept, row-major, real and imaginary parts).
//  - Real or complex: a setter given a real matrix stores a real quantity and basis() gives
//    a NULL imaginary part; given a complex matrix it stores both parts and basis() points
//    at both. A provider whose complex shapes are real for some harmonic index passes
//    `.real()` to say so (the host then treats them as real).
//  - Ownership and lifetime: the builder owns every array basis() points to. The pointers
//    stay valid until the builder is next changed (any set_, add_, gather_ or clear_ call)
//    or destroyed: keep the builder as a member of the provider and change it only inside
//    modal_basis(), which gives the lifetime the ABI asks for.
//  - Order: set_frequencies() first (it fixes n_modes and resets the damping to zero), then
//    the damping, the mode rows (which fix n_kept and drop any residual flexibility, since
//    it belongs to the previous kept DOFs), then the residual flexibility.
//  - Failure: a size that does not match (damping not n_modes square, mode rows without
//    n_modes columns, residual flexibility not n_kept square, a damping-ratio list of
//    neither 1 nor n_modes values, a kept DOF beyond the shapes' rows) throws
//    std::invalid_argument or std::out_of_range, which the SDK's trampolines report as the
//    modal_basis() error. A provider that wants its own wording checks before.
//  - Threading: none; like modal_basis() itself, a builder is used by one thread at a time.
//
// Header-only and C++17; it needs Eigen 3.3 or later (the FricHB::sdk target brings it).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include "frichb/plugin/abi.h"

namespace frichb::sdk {

class ModalBasisBuilder {
 public:
  using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  // Natural frequencies w_r (rad/s), a vector of n_modes; the damping becomes zero
  // (n_modes x n_modes).
  template <class Derived>
  void set_frequencies(const Eigen::MatrixBase<Derived>& w) {
    frequencies_ = w;
    const Eigen::Index n = frequencies_.size();
    damping_ = RowMajorMatrix::Zero(n, n);
  }

  // The modal damping matrix C (1/s), n_modes x n_modes, copied entry by entry.
  template <class Derived>
  void set_damping_matrix(const Eigen::MatrixBase<Derived>& c) {
    if (c.rows() != mode_count() || c.cols() != mode_count())
      throw std::invalid_argument("modal damping matrix of " + size_text(c.rows(), c.cols()) +
                                  " for " + std::to_string(mode_count()) + " modes");
    damping_ = c;
  }

  // Adds 2 z_r w_r to C_rr for the modal damping ratios z: none (empty), one value for every
  // mode, or one per mode.
  void add_damping_ratios(const std::vector<double>& ratios) {
    if (ratios.empty()) return;
    const auto n = static_cast<std::size_t>(mode_count());
    if (ratios.size() != 1 && ratios.size() != n)
      throw std::invalid_argument(std::to_string(ratios.size()) + " modal damping ratios for " +
                                  std::to_string(n) + " modes; give 1 or one per mode");
    for (std::size_t r = 0; r < n; ++r) {
      const double z = ratios.size() == 1 ? ratios[0] : ratios[r];
      const auto i = static_cast<Eigen::Index>(r);
      damping_(i, i) += 2.0 * z * frequencies_(i);
    }
  }

  // Phi at the kept DOFs, n_kept x n_modes: row i belongs to the i-th kept DOF. Real or
  // complex (see the contract above). Drops the residual flexibility.
  template <class Derived>
  void set_mode_rows(const Eigen::MatrixBase<Derived>& rows) {
    if (rows.cols() != mode_count())
      throw std::invalid_argument("mode rows with " + std::to_string(rows.cols()) +
                                  " columns for " + std::to_string(mode_count()) + " modes");
    if constexpr (Eigen::NumTraits<typename Derived::Scalar>::IsComplex) {
      rows_real_ = rows.real();
      rows_imag_ = rows.imag();
      complex_rows_ = true;
    } else {
      rows_real_ = rows;
      rows_imag_.resize(0, 0);
      complex_rows_ = false;
    }
    clear_residual_flexibility();
  }

  // set_mode_rows() with row i taken from row kept[i] of `shapes` (mode shapes at every DOF
  // of the model, one column per mode). Throws std::out_of_range for a kept DOF beyond the
  // rows of `shapes`.
  template <class Derived>
  void gather_mode_rows(const Eigen::MatrixBase<Derived>& shapes, const size_t* kept,
                        size_t n_kept) {
    if (shapes.cols() != mode_count())
      throw std::invalid_argument("mode shapes with " + std::to_string(shapes.cols()) +
                                  " columns for " + std::to_string(mode_count()) + " modes");
    constexpr bool complex = Eigen::NumTraits<typename Derived::Scalar>::IsComplex;
    const auto n = static_cast<Eigen::Index>(n_kept);
    rows_real_.resize(n, mode_count());
    rows_imag_.resize(complex ? n : 0, complex ? mode_count() : 0);
    for (Eigen::Index i = 0; i < n; ++i) {
      const size_t dof = kept[static_cast<size_t>(i)];
      if (dof >= static_cast<size_t>(shapes.rows()))
        throw std::out_of_range("kept DOF " + std::to_string(dof) + " is not among the " +
                                std::to_string(shapes.rows()) + " rows of the mode shapes");
      const auto row = shapes.row(static_cast<Eigen::Index>(dof));
      if constexpr (complex) {
        rows_real_.row(i) = row.real();
        rows_imag_.row(i) = row.imag();
      } else {
        rows_real_.row(i) = row;
      }
    }
    complex_rows_ = complex;
    clear_residual_flexibility();
  }

  // Static residual flexibility of the truncated modes at the kept DOFs, n_kept x n_kept:
  // real, or complex (Hermitian; its imaginary part reaches the host through the ABI 1.1
  // field residual_flexibility_imag).
  template <class Derived>
  void set_residual_flexibility(const Eigen::MatrixBase<Derived>& g) {
    if (g.rows() != kept_count() || g.cols() != kept_count())
      throw std::invalid_argument("residual flexibility of " + size_text(g.rows(), g.cols()) +
                                  " for " + std::to_string(kept_count()) + " kept DOFs");
    if constexpr (Eigen::NumTraits<typename Derived::Scalar>::IsComplex) {
      residual_real_ = g.real();
      residual_imag_ = g.imag();
      complex_residual_ = true;
    } else {
      residual_real_ = g;
      residual_imag_.resize(0, 0);
      complex_residual_ = false;
    }
    has_residual_ = true;
  }

  // No residual flexibility (the default): basis() gives NULL for both parts.
  void clear_residual_flexibility() {
    residual_real_.resize(0, 0);
    residual_imag_.resize(0, 0);
    has_residual_ = false;
    complex_residual_ = false;
  }

  Eigen::Index mode_count() const { return frequencies_.size(); }
  Eigen::Index kept_count() const { return rows_real_.rows(); }
  const Eigen::VectorXd& frequencies() const { return frequencies_; }
  const RowMajorMatrix& damping() const { return damping_; }
  const RowMajorMatrix& mode_rows_real() const { return rows_real_; }
  const RowMajorMatrix& mode_rows_imag() const { return rows_imag_; }  // empty when real
  const RowMajorMatrix& residual_flexibility_real() const { return residual_real_; }
  const RowMajorMatrix& residual_flexibility_imag() const { return residual_imag_; }

  // The ABI struct, pointing into this builder's arrays (see the lifetime above). Throws
  // std::invalid_argument when the mode rows do not have one column per mode (frequencies
  // changed after the rows were given).
  frichb_modal_basis basis() const {
    if (rows_real_.cols() != mode_count())
      throw std::invalid_argument("mode rows with " + std::to_string(rows_real_.cols()) +
                                  " columns for " + std::to_string(mode_count()) + " modes");
    frichb_modal_basis b{};
    b.struct_size = sizeof(b);
    b.n_modes = static_cast<size_t>(mode_count());
    b.natural_frequencies = frequencies_.data();
    b.modal_damping = damping_.data();
    b.mode_rows_real = rows_real_.data();
    b.mode_rows_imag = complex_rows_ ? rows_imag_.data() : nullptr;
    b.residual_flexibility = has_residual_ ? residual_real_.data() : nullptr;
    b.residual_flexibility_imag =
        has_residual_ && complex_residual_ ? residual_imag_.data() : nullptr;
    return b;
  }

 private:
  static std::string size_text(Eigen::Index rows, Eigen::Index cols) {
    return std::to_string(rows) + " x " + std::to_string(cols);
  }

  Eigen::VectorXd frequencies_;
  RowMajorMatrix damping_, rows_real_, rows_imag_, residual_real_, residual_imag_;
  bool complex_rows_ = false;
  bool has_residual_ = false;
  bool complex_residual_ = false;
};

}  // namespace frichb::sdk
