#include "frichb/core/model/nonlinear_modes.hpp"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <complex>
#include <stdexcept>
#include <vector>

namespace frichb::core {

NonlinearModeProblem::NonlinearModeProblem(const HarmonicBalanceModel& model, Eigen::Index mode)
    : model_(model), mode_(mode), n_(model.equation_count()) {
  const auto& h = model.layout().harmonics();
  bool found = false;
  for (std::size_t k = 0; k < h.size(); ++k)
    if (h[k] == 1) {
      first_harmonic_ = k;
      found = true;
    }
  if (!found) throw std::invalid_argument("nonlinear modes: the scene's harmonics must include 1");
  for (const auto& form : model.receptance_forms())
    if (form.harmonic > 0 && !form.modal)
      throw std::invalid_argument(
          "nonlinear modes: harmonic " + std::to_string(form.harmonic) +
          " has non-diagonal modal damping; the mode's damping shift needs a diagonal one");
  dynamic_ = Eigen::VectorXd::Ones(n_);
  const int c = model.layout().coefficient_count();
  for (std::size_t k = 0; k < h.size(); ++k)
    if (h[k] == 0)
      for (int a = 0; a < model.component_count(); ++a)
        dynamic_(a * c + model.layout().cos_index(k)) = 0.0;
  const auto modes = static_cast<Eigen::Index>(
      model.structure().mode_count(model.receptance_forms()[first_harmonic_].harmonic_index));
  if (mode < 0 || mode >= modes)
    throw std::invalid_argument("nonlinear modes: mode " + std::to_string(mode) +
                                " is not one of the structure's " + std::to_string(modes) +
                                " retained modes at harmonic 1");
}

Eigen::VectorXd NonlinearModeProblem::balance_point(const Eigen::VectorXd& y) const {
  const double a = std::exp(y(n_ + 2));
  Eigen::VectorXd z = y.head(n_ + 1);
  z.head(n_).array() *= (dynamic_.array() > 0).select(a, Eigen::ArrayXd::Ones(n_));
  return z;
}

bool NonlinearModeProblem::evaluate(const Eigen::VectorXd& y, Eigen::VectorXd& residual,
                                    Eigen::MatrixXd* jacobian, std::string* message) const {
  const Eigen::Index n = n_;
  if (y.size() != n + 3) {
    if (message) *message = "nonlinear modes: y has the wrong size";
    return false;
  }
  const Eigen::VectorXd z = balance_point(y);
  const double xi = y(n + 1);
  const double a = std::exp(y(n + 2));
  // U = S V with S = diag(a at the dynamic unknowns, 1 at harmonic 0's); rows scaled by
  // R = diag(1 / a at the dynamic rows, 1 at harmonic 0's).
  const Eigen::ArrayXd unknown_scale = (dynamic_.array() > 0).select(a, Eigen::ArrayXd::Ones(n));
  const Eigen::ArrayXd row_scale = 1.0 / unknown_scale;
  Eigen::VectorXd balance;
  Eigen::MatrixXd balance_jacobian;
  if (!model_.evaluate_autonomous(z, xi, balance, jacobian ? &balance_jacobian : nullptr, message))
    return false;
  Eigen::VectorXcd gradient;
  std::complex<double> q;
  try {
    q = model_.modal_coordinate(z, xi, first_harmonic_, mode_,
                                jacobian != nullptr ? &gradient : nullptr);
  } catch (const std::exception& e) {
    if (message) *message = e.what();
    return false;
  }
  residual.resize(n + 2);
  residual.head(n) = (balance.array() * row_scale).matrix();
  residual(n) = q.real() / a - 1.0;
  residual(n + 1) = q.imag() / a;
  if (jacobian != nullptr) {
    // dU/d ln a = a V at the dynamic unknowns (0 at harmonic 0's).
    const Eigen::VectorXd du_dlog = (z.head(n).array() * dynamic_.array()).matrix();
    jacobian->setZero(n + 2, n + 3);
    auto rows = jacobian->topRows(n);
    rows.leftCols(n) = row_scale.matrix().asDiagonal() * balance_jacobian.leftCols(n) *
                       unknown_scale.matrix().asDiagonal();
    rows.col(n) = (balance_jacobian.col(n).array() * row_scale).matrix();
    rows.col(n + 1) = (balance_jacobian.col(n + 1).array() * row_scale).matrix();
    // d(R e)/d ln a = R (e_U dU/d ln a) + (dR/d ln a) e, dR/d ln a = -R at the dynamic rows.
    rows.col(n + 2) = ((balance_jacobian.leftCols(n) * du_dlog).array() * row_scale -
                       dynamic_.array() * balance.array() * row_scale)
                          .matrix();
    const Eigen::VectorXd re = gradient.real(), im = gradient.imag();
    jacobian->row(n).head(n) = (re.head(n).array() * unknown_scale).matrix().transpose() / a;
    jacobian->row(n + 1).head(n) = (im.head(n).array() * unknown_scale).matrix().transpose() / a;
    jacobian->row(n).segment(n, 2) = re.tail(2).transpose() / a;
    jacobian->row(n + 1).segment(n, 2) = im.tail(2).transpose() / a;
    // d(q / a)/d ln a = (dq/dU dU/d ln a) / a - q / a.
    (*jacobian)(n, n + 2) = re.head(n).dot(du_dlog) / a - q.real() / a;
    (*jacobian)(n + 1, n + 2) = im.head(n).dot(du_dlog) / a - q.imag() / a;
  }
  if (!residual.allFinite() || (jacobian != nullptr && !jacobian->allFinite())) {
    if (message) *message = "nonlinear modes: the residual or its Jacobian is not finite";
    return false;
  }
  return true;
}

NonlinearModeProblem::RestModes NonlinearModeProblem::rest_modes() const {
  const Eigen::Index n = n_;
  const HarmonicLayout& layout = model_.layout();
  const int c = layout.coefficient_count();
  const int ci = layout.cos_index(first_harmonic_), si = layout.sin_index(first_harmonic_);
  const int index = model_.receptance_forms()[first_harmonic_].harmonic_index;
  const ReducedStructure::Basis& basis = model_.structure().basis(index);
  const Eigen::Index m = basis.frequencies.size();
  const int components = model_.component_count();

  // The contacts' tangents at rest, through q's gradients: g_r = -z_r dq_r/dU = p_r^H dF_1/dU.
  // The tangents do not depend on w: they are taken at w = 0, where z_r = w_r^2 is no
  // resonance (at w = w_K an undamped mode's z_K would vanish).
  Eigen::VectorXd z = Eigen::VectorXd::Zero(n + 1);
  if (!(basis.frequencies.minCoeff() > 0))
    throw std::runtime_error("nonlinear modes: the structure has a rigid-body mode at harmonic 1");
  Eigen::VectorXd residual;
  Eigen::MatrixXd jacobian;
  std::string message;
  if (!model_.evaluate_autonomous(z, 0.0, residual, &jacobian, &message))
    throw std::runtime_error("nonlinear modes: the contacts at rest: " + message);
  // The harmonic-1 unknowns of the motion with complex amplitudes x (components): cos Re x,
  // sin -Im x.
  const auto unknowns_of = [&](const Eigen::VectorXcd& x) {
    Eigen::VectorXd u = Eigen::VectorXd::Zero(n);
    for (int a = 0; a < components; ++a) {
      u(a * c + ci) = x(a).real();
      u(a * c + si) = -x(a).imag();
    }
    return u;
  };
  Eigen::MatrixXcd tangent_rows(m, n);  // row r: p_r^H dF_1/dU
  for (Eigen::Index r = 0; r < m; ++r) {
    Eigen::VectorXcd gradient;
    model_.modal_coordinate(z, 0.0, first_harmonic_, r, &gradient);
    // At w = 0: z_r = w_r^2.
    tangent_rows.row(r) =
        -(basis.frequencies(r) * basis.frequencies(r)) * gradient.head(n).transpose();
  }
  // Each retained mode at the contacts (P = G Phi at harmonic 1).
  const Eigen::MatrixXcd& modes_at_contacts = model_.contact_modes(first_harmonic_);
  Eigen::MatrixXcd stiffness = basis.frequencies.array().square().matrix().asDiagonal();
  stiffness = stiffness.cast<std::complex<double>>();
  for (Eigen::Index s = 0; s < m; ++s)
    stiffness.col(s) +=
        tangent_rows * unknowns_of(modes_at_contacts.col(s)).cast<std::complex<double>>();
  const Eigen::MatrixXcd hermitian = 0.5 * (stiffness + stiffness.adjoint());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXcd> eigen(hermitian);
  if (eigen.info() != Eigen::Success)
    throw std::runtime_error("nonlinear modes: the linearised modes did not converge");
  RestModes rest;
  rest.stiffness = eigen.eigenvalues();
  rest.shapes = eigen.eigenvectors();
  rest.shapes.row(mode_).cwiseAbs().maxCoeff(&rest.chosen);
  rest.damping.resize(m);
  for (Eigen::Index j = 0; j < m; ++j)
    rest.damping(j) =
        (rest.shapes.col(j).cwiseAbs2().array() * basis.damping.diagonal().array()).sum();
  return rest;
}

Eigen::VectorXd NonlinearModeProblem::linear_guess(double amplitude) const {
  const Eigen::Index n = n_;
  const RestModes rest = rest_modes();
  const Eigen::VectorXcd v = rest.shapes.col(rest.chosen);
  const double lambda = rest.stiffness(rest.chosen);
  if (!(lambda > 0))
    throw std::runtime_error("nonlinear modes: the linearised mode has no positive stiffness");
  // V = U / a at harmonic 1 (the motion per unit of a), harmonic 0 at rest.
  const Eigen::VectorXcd q = v / v(mode_);
  const HarmonicLayout& layout = model_.layout();
  const int c = layout.coefficient_count();
  const int ci = layout.cos_index(first_harmonic_), si = layout.sin_index(first_harmonic_);
  const Eigen::VectorXcd x = model_.contact_modes(first_harmonic_) * q;
  Eigen::VectorXd y = Eigen::VectorXd::Zero(n + 3);
  for (int a = 0; a < model_.component_count(); ++a) {
    y(a * c + ci) = x(a).real();
    y(a * c + si) = -x(a).imag();
  }
  y(n) = std::sqrt(lambda);
  y(n + 1) = rest.damping(rest.chosen);
  y(n + 2) = std::log(amplitude);
  return y;
}

}  // namespace frichb::core
