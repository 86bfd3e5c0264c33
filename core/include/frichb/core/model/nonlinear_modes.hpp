// Nonlinear modes of a friction-damped structure by the extended periodic motion concept
// (EPMC; Krack, Computers & Structures 154, 2015): the harmonic-balance equations of the
// structure and its contacts without the dynamic excitation, with a damping -xi M that makes
// the damped free motion periodic. Its frequency w and xi, as functions of the motion's
// amplitude, are the mode's amplitude-dependent natural frequency and damping: the modal
// damping ratio is xi / (2 w) (of a linear mode with damping ratio zeta, xi = 2 zeta w).
//
// Unknowns y = (V, w, xi, ln a): the contacts' relative-displacement harmonics divided by the
// amplitude, V_n = U_n / a for n >= 1 (U as HarmonicBalanceModel's, n entries), and harmonic 0
// left as it is, V_0 = U_0 (m), so that a static load or a contact's preload stays physical at
// every amplitude and the unknowns keep their size over decades of a; the circular frequency
// w (rad/s); the damping shift xi (rad/s); the log of the amplitude a, the continuation
// parameter. Equations (n + 2):
//   e(U, w; xi) / a = 0       HarmonicBalanceModel::evaluate_autonomous, its rows of
//                             harmonics n >= 1 divided by a (harmonic 0's as they are)
//   Re q / a - 1 = 0          q: the modal coordinate of mode K at harmonic 1
//   Im q / a     = 0          (HarmonicBalanceModel::modal_coordinate)
// where mode K is a retained mode of the structure at harmonic 1 (for a cyclic scene, of the
// harmonic index the scene's engine order excites: a travelling wave). a is the amplitude of
// mode K's fundamental modal coordinate, q(t) = a cos(w t) (m sqrt(kg): the structure's modes
// are mass-normalised), and the second condition fixes the motion's phase. The Jacobian is
// analytic: the model's quasi-analytical blocks, its column in xi, and q's derivatives from
// the contacts' force blocks of the same evaluation, through the scaling by a.
//
// Failure: an evaluation the model refuses (a failed trace, a harmonic with non-diagonal modal
// damping) is false with the message. Threading: one problem per thread (the model is not
// thread-safe).
#pragma once

#include <Eigen/Dense>
#include <string>

#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/solver/continuation.hpp"

namespace frichb::core {

class NonlinearModeProblem final : public CurveProblem {
 public:
  // The modes of `model` (which must outlive the problem) near its retained mode `mode` of
  // harmonic 1 (0-based, ascending frequency). Throws std::invalid_argument where harmonic 1
  // is not kept, its modal damping is not diagonal, or `mode` is out of range.
  NonlinearModeProblem(const HarmonicBalanceModel& model, Eigen::Index mode);

  Eigen::Index equation_count() const override { return n_ + 2; }
  bool evaluate(const Eigen::VectorXd& y, Eigen::VectorXd& residual, Eigen::MatrixXd* jacobian,
                std::string* message) const override;

  // n, the harmonic-balance unknowns (y has n + 3 entries).
  Eigen::Index harmonic_unknowns() const { return n_; }
  // The model's unknowns [U; w] of y: U_n = a V_n for n >= 1, U_0 = V_0.
  Eigen::VectorXd balance_point(const Eigen::VectorXd& y) const;
  // 1 at the unknowns of harmonics n >= 1 (scaled by a), 0 at harmonic 0's (n entries).
  const Eigen::VectorXd& dynamic_unknowns() const { return dynamic_; }
  const HarmonicBalanceModel& model() const { return model_; }
  Eigen::Index mode() const { return mode_; }
  // The kept harmonic index k of harmonic 1.
  std::size_t first_harmonic() const { return first_harmonic_; }

  // A start for y at amplitude a (m sqrt(kg)), accurate where the contacts keep the tangent
  // they have at rest: the linear mode of the structure with each contact replaced by its
  // tangent dF/dU at U = 0 (at harmonic 1), over the retained modes (the residual flexibility
  // left out), chosen as the one whose mode K participation is largest; xi is that mode's
  // modal damping. Throws std::runtime_error where the contacts cannot be traced at rest.
  Eigen::VectorXd linear_guess(double amplitude) const;
  // The linear modes of the structure with each contact replaced by its tangent at rest (at
  // harmonic 1, over the retained modes, the residual flexibility left out): the Hermitian
  // eigenproblem of diag(w_r^2) + P^H dF_1/dU P. `stiffness`: the eigenvalues, rad^2/s^2,
  // ascending; `shapes`: the eigenvectors in the retained modes' coordinates (columns, unit
  // norm: mass-normalised); `damping`: each one's modal damping v^H C v (rad/s, the
  // structure's diagonal C, the coupling between them left out); `chosen`: the one whose
  // participation of mode K is largest (linear_guess's). Throws as linear_guess.
  struct RestModes {
    Eigen::VectorXd stiffness, damping;
    Eigen::MatrixXcd shapes;
    Eigen::Index chosen = 0;
  };
  RestModes rest_modes() const;

 private:
  const HarmonicBalanceModel& model_;
  Eigen::Index mode_;
  std::size_t first_harmonic_ = 0;
  Eigen::Index n_ = 0;
  Eigen::VectorXd dynamic_;
};

}  // namespace frichb::core
