// MistunedDisk: the whole disk of a tuned cyclic sector with every blade's stiffness scaled by
// its own factor, as a plain structure (one harmonic index, 0) for the engine.
//
// Method: the subset-of-nominal-modes reduction (Yang and Griffin, 2001) with a stiffness
// mistuning of the blade part. The tuned disk's modes, from the sector's modes of every
// harmonic index h = 0..nb/2 as standing waves (real: sqrt(2/nb) Re and Im of
// phi_h e^{-i h j 2pi/nb} on blade j, or phi_h e^{-i h j 2pi/nb} / sqrt(nb) where that is real),
// are mass-orthonormal; blade j's stiffness (1 + delta_j) K_b adds
//   Delta(a, b) = sum_j delta_j a_j^T K_b b_j
// to their modal stiffness diag(w^2), with a_j, b_j the modes on blade j and a_j^T K_b b_j
// from the provider's projections Phi_h^H K_b Phi_h' and Phi_h^T K_b Phi_h'
// (frichb_structure_api.blade_stiffness). The eigenvectors V of diag(w^2) + Delta give the
// mistuned modes, their rows at the kept DOFs from the sector's mode rows. The reduction is
// exact where the sector's modes are all kept (lumped_cyclic); with a truncated basis it is
// the projection on the tuned modes kept (the truncated modes' mistuning is lost).
//
// Damping: mistuned mode k has the tuned modes' damping ratios averaged with the weights
// V(a, k)^2 (exact for a uniform modal damping ratio). A sector with residual flexibility
// (truncated modes) is refused: its mistuning is not modelled.
//
// DOFs: DOF d of blade j is d * nb + j (MistuningSpec). Units: rad/s, m/sqrt(kg), 1/s.
// Not thread-safe (as StructureModel).
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/scene/scene.hpp"

namespace frichb::core {

class MistunedDisk final : public StructureModel {
 public:
  // Solves the mistuned disk's modes. Throws PluginError (the sector cannot be mistuned, or
  // its provider fails) or std::invalid_argument (a sector count other than the pattern's, a
  // residual flexibility).
  MistunedDisk(std::unique_ptr<StructureInstance> sector, const MistuningSpec& mistuning);

  std::string name() const override { return "mistuned disk of " + sector_->name(); }
  std::size_t dof_count() const override;
  std::size_t sector_count() const override { return 1; }
  frichb_modal_basis modal_basis(int harmonic_index,
                                 std::span<const std::size_t> kept_dofs) override;

  // The mistuned modes' natural frequencies (rad/s, ascending) and the tuned disk's, each
  // mode of a pair of travelling waves counted twice.
  const Eigen::VectorXd& natural_frequencies() const { return frequencies_; }
  const Eigen::VectorXd& tuned_frequencies() const { return tuned_frequencies_; }

 private:
  // A standing-wave mode of the tuned disk: mode r of harmonic index h, its real part or
  // (imaginary) its imaginary part, times `scale`.
  struct TunedMode {
    int h = 0;
    Eigen::Index r = 0;
    bool imaginary = false;
    double scale = 0;
  };
  void solve(const MistuningSpec& mistuning);

  std::unique_ptr<StructureInstance> sector_;
  int sectors_ = 0;
  std::vector<TunedMode> tuned_;
  Eigen::VectorXd tuned_frequencies_;      // rad/s, ascending
  Eigen::VectorXd frequencies_, damping_;  // mistuned, rad/s and 2 zeta w
  Eigen::MatrixXd vectors_;                // V: tuned x mistuned
  // The arrays behind the last modal_basis().
  Eigen::MatrixXd damping_matrix_, rows_;
};

// The structure a scene computes: its provider's instance, or the mistuned disk built on it
// when the scene has a `mistuning` section. Throws as StructureInstance and MistunedDisk.
std::unique_ptr<StructureModel> instantiate_structure(const Scene& scene);

}  // namespace frichb::core
