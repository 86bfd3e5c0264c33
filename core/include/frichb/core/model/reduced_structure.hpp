// ReducedStructure: receptances R_h(W) = Phi (diag(w_r^2) - W^2 I + i W C)^-1 Phi^H
// (+ residual flexibility) and dR/dW at the DOFs a scene keeps, for each harmonic index the
// scene needs, from a structure provider's modal basis (fetched once, at construction). Where
// the caller has the residual flexibility reduced (FlexibilityUse), the receptance is no
// longer available over all kept DOFs, and responses only at the caller's response rows.
// Units: W in rad/s, R in m/N. Layout: R(i, j) = response at kept DOF i per unit force at
// kept DOF j, in the order of `kept_dofs`. Thread-safe after construction (const methods).
#pragma once

#include <Eigen/Dense>
#include <complex>
#include <functional>
#include <map>
#include <vector>

#include "frichb/core/plugin_host/registry.hpp"

namespace frichb::core {

class ReducedStructure {
 public:
  // What a caller needs of the static residual flexibility F, so that the kept x kept block
  // (16 kept^2 bytes per harmonic index: gigabytes for a meshed contact face of a thousand
  // node pairs) is held only while it is reduced. `reduce` is called once per harmonic index,
  // during construction and on the constructing thread, with F (kept x kept, Hermitian) of an
  // index whose modal damping is diagonal; the basis then keeps only F's rows at
  // `response_rows` (indices into the kept DOFs). A basis with non-diagonal damping keeps F
  // whole: its receptance is formed over the kept DOFs anyway.
  struct FlexibilityUse {
    std::vector<Eigen::Index> response_rows;
    std::function<void(int harmonic_index, const Eigen::MatrixXcd& flexibility)> reduce;
  };

  // Fetches the modal basis of every harmonic index from the provider. `use`: where F is
  // reduced (see FlexibilityUse), or null to keep it whole.
  ReducedStructure(StructureModel& provider, std::vector<std::size_t> kept_dofs,
                   const std::vector<int>& harmonic_indices, const FlexibilityUse* use = nullptr);

  const std::vector<std::size_t>& kept_dofs() const { return kept_dofs_; }
  std::size_t mode_count(int harmonic_index) const;
  // Natural frequencies (rad/s) of harmonic index h, ascending.
  const Eigen::VectorXd& natural_frequencies(int harmonic_index) const;

  // Writes R (kept x kept) at circular frequency W and, when requested, dR/dW. Throws
  // std::logic_error for a basis whose residual flexibility was reduced (FlexibilityUse).
  void receptance(int harmonic_index, double circular_frequency, Eigen::MatrixXcd& receptance,
                  Eigen::MatrixXcd* derivative = nullptr) const;
  // The response R(W) f to the force amplitudes f (kept DOFs, N) without forming R:
  // Phi (Z^-1 (Phi^H f)) + F f, modes x kept operations instead of kept^2 x modes. Where the
  // residual flexibility was reduced, only the response rows are computed: the other entries
  // are NaN. `derivative`, when given: dR/dW f (the residual flexibility does not depend on W),
  // NaN where the response is.
  Eigen::VectorXcd respond(int harmonic_index, double circular_frequency,
                           const Eigen::VectorXcd& force,
                           Eigen::VectorXcd* derivative = nullptr) const;
  // F f: the residual flexibility's static response to the force amplitudes f (kept DOFs, N),
  // m; where F was reduced, its response rows only (NaN elsewhere); zero without one.
  Eigen::VectorXcd residual_response(int harmonic_index, const Eigen::VectorXcd& force) const;

 public:
  // The modal basis of a harmonic index at the kept DOFs (as the provider gave it).
  struct Basis {
    Eigen::VectorXd frequencies;
    Eigen::MatrixXd damping;  // modal, n_modes x n_modes
    bool diagonal_damping = true;
    Eigen::MatrixXcd rows;                  // kept x n_modes
    Eigen::MatrixXcd residual_flexibility;  // kept x kept (Hermitian), or empty
    // Where F was reduced (FlexibilityUse): residual_flexibility is empty and F's rows at the
    // response rows are kept (response rows x kept).
    bool flexibility_reduced = false;
    Eigen::MatrixXcd flexibility_rows;
    bool has_residual_flexibility() const {
      return residual_flexibility.size() > 0 || flexibility_reduced;
    }
  };
  const Basis& basis(int harmonic_index) const;

 private:
  std::vector<std::size_t> kept_dofs_;
  std::vector<Eigen::Index> response_rows_;  // FlexibilityUse::response_rows, or empty
  std::map<int, Basis> bases_;
};

}  // namespace frichb::core
