// The harmonic-balance Jacobian of HarmonicBalanceModel as an operator (JacobianOperator):
//
//   e_U = I + Rc D,   e_w = dRc/dw F - dU0/dw,
//
// with D = dF/dU block diagonal over the contacts (one p x p tangent block per contact, its
// unknowns contiguous) and Rc block diagonal over the kept harmonics (one complex m x m block
// per harmonic, m the contact components). A product costs pairs p^2 + harmonics x (the cost of
// one Rc product: 2 m x modes for the modal form, plus m^2 with a residual flexibility), against
// n^2 for the formed matrix and n^3 / 3 for its LU.
//
// Preconditioner: the harmonic-decoupled approximation I + Rc D0, with D0 each contact's
// time-averaged tangent (the harmonic-0 block of D, or the mean of a harmonic's cos-cos and
// sin-sin blocks when harmonic 0 is not kept) on every harmonic: exact for contacts whose
// tangent does not vary over the period, and one complex m x m LU per harmonic. For a modal
// receptance the LU is of I + F D0, and the retained modes enter by a Woodbury update, so that
// the preconditioner follows the frequency (JacobianPreconditioner::follow: one modes x modes
// LU per harmonic) while D0 stays that of the point it was made at.
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <vector>

#include "frichb/core/solver/continuation.hpp"

namespace frichb::core {

// Rc of one kept harmonic at one frequency: modal, Rc = P diag(inv_z) P^H (+ F), with P and F
// shared with the model (which must outlive it); or formed (m x m).
struct HarmonicReceptance {
  int harmonic = 0;
  int cos_index = 0;
  int sin_index = 0;
  const Eigen::MatrixXcd* projected = nullptr;    // P (m x modes), modal form
  const Eigen::MatrixXcd* flexibility = nullptr;  // F (m x m) or null
  Eigen::VectorXcd inv_z;                         // modal form
  Eigen::MatrixXcd formed;                        // formed form (projected null)
  // y = Rc x for the columns of x (m x k).
  void apply(const Eigen::MatrixXcd& x, Eigen::MatrixXcd& y) const;
  // Rc formed (m x m).
  Eigen::MatrixXcd matrix() const;
};

// One contact's tangent block dF/dU (p x p) and where its unknowns start.
struct ContactTangent {
  Eigen::Index first = 0;
  Eigen::MatrixXd block;
};

class HarmonicJacobian final : public JacobianOperator {
 public:
  // `coefficients`: the layout's coefficient count c (unknown a * c + coefficient for component
  // a); `components`: m. The blocks and receptances are those of one evaluation. `threads`:
  // from 600 components on, products and preconditioner solves spread the kept harmonics over
  // up to this many threads (each harmonic on one thread: the results do not depend on it).
  HarmonicJacobian(int coefficients, int components, std::vector<HarmonicReceptance> receptances,
                   std::vector<ContactTangent> tangents, Eigen::VectorXd parameter_column,
                   int threads = 1);

  Eigen::Index rows() const override { return parameter_column_.size(); }
  void apply(const Eigen::Ref<const Eigen::MatrixXd>& x,
             Eigen::Ref<Eigen::MatrixXd> y) const override;
  // I + Rc D contact by contact: Rc's columns of a contact's components times its tangent
  // block, m x d x p per harmonic and contact (the product with the identity would cost m^2 n).
  void form(Eigen::Ref<Eigen::MatrixXd> out) const override;
  const Eigen::VectorXd& parameter_column() const override { return parameter_column_; }
  std::unique_ptr<JacobianPreconditioner> make_preconditioner() const override;
  // The kept harmonics' receptances at this point.
  const std::vector<HarmonicReceptance>& receptances() const { return receptances_; }

 private:
  int coefficients_;
  int components_;
  int threads_;
  std::vector<HarmonicReceptance> receptances_;
  std::vector<ContactTangent> tangents_;
  Eigen::VectorXd parameter_column_;
};

}  // namespace frichb::core
