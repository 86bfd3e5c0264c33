// The linear resonances of a harmonic-balance model in a frequency window: where the traced
// curve can have a sharp peak that a step must not jump over.
//
// Two linear limits bracket a friction contact's behaviour: the free structure (every contact
// open or slipping without force) and the stuck structure (every contact with the stiffness its
// law has at the static state u = 0: stuck where a preload holds it, closed where the preload
// closes it). For every kept temporal harmonic k >= 1 the modes of its harmonic index resonate
// at the excitation frequency w_r / k, with half-power half-width zeta_r w_r / k.
//
// The stuck modes are those of the modal basis stiffened by the contacts,
//   K_s = diag(w_r^2) + P^H K_e P,   P = G Phi (contact components x modes),
//   K_e = K_c (I + G F G^H K_c)^-1,
// K_c the contacts' stiffness (block diagonal, one block of used local components per
// contact) in series with the residual flexibility F at the contacts (the static correction of
// the truncated modes); their damping ratio is psi^H C psi / (2 w_s) for the mass-normalised
// eigenvector psi of K_s and the modal damping C. Exact for a model whose basis keeps every
// mode; with truncated modes a Rayleigh-Ritz estimate, accurate where the stuck modes lie well
// below the highest kept one.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/scene/scene.hpp"

namespace frichb::core {

struct LinearResonance {
  enum class System { kFree, kStuck };
  System system = System::kFree;
  int harmonic = 1;                // kept temporal harmonic k
  int harmonic_index = 0;          // cyclic harmonic index of its modes (0 without cyclic symmetry)
  double natural_frequency = 0.0;  // w_r of the mode, rad/s
  double centre = 0.0;             // excitation frequency w_r / k, rad/s
  double half_width = 0.0;         // half-power half-width zeta_r w_r / k, rad/s
  double damping_ratio = 0.0;      // zeta_r
};

const char* system_name(LinearResonance::System system);

// The contacts' stiffness at the static state, components x components (the model's stacked
// used local components, in N/m): for each contact the consistent tangent d force / d u of one
// step of its law from the initial state to a relative displacement of 1e-12 m along each used
// tangential direction (0 along the normal). A contact that slips there (no normal load: no
// friction force) has no tangential stiffness. A law that provides no tangent counts as free.
// Throws PluginError when a law's step fails.
Eigen::MatrixXd static_contact_stiffness(const HarmonicBalanceModel& model);

// The free and the stuck structure's resonances with centre in [lambda_min, lambda_max]
// (rad/s), sorted by centre. A stuck resonance within a tenth of a half-width of a free one of
// the same harmonic (a contact without stiffness there) is left out. Reads the model only
// (its laws' step() is const): safe beside other readers of the same model.
std::vector<LinearResonance> linear_resonances(const Scene& scene,
                                               const HarmonicBalanceModel& model, double lambda_min,
                                               double lambda_max);

}  // namespace frichb::core
