// Floquet multipliers of a harmonic-balance solution: whether a periodic response is stable.
//
// The multipliers are those of the monodromy matrix of the variational equations along the
// solution's orbit, integrated over one excitation period T = 2 pi / w on the contacts'
// tracing grid (N samples, step h = T / N). The linearised state holds
//   - the structure's modal coordinates and velocities (dq, dq'): all the provider's modes,
//     dq'' + C dq' + diag(w_r^2) dq = -P^T df, P = G Phi (contact components x modes);
//   - the contact-force samples df (the force of each step is the straight line between its
//     end samples, over which the modal equations are integrated exactly);
//   - the contact laws' states dz (slider offsets): the hysteresis in the linearisation.
// One step maps (dq, dq', df, dz) at sample j-1 to sample j through the laws' consistent
// tangents of that step (d force and d state with respect to the displacement at both ends,
// the rates du/ds of laws that step along the motion, and the state before the step), taken
// at the traced periodic state; the new force sample solves the step's small implicit
// system (I - K1 G1) df_j = ... (model/stability.cpp). With a static residual flexibility F
// (no mass behind it) the contacts move by u = P dq - F df, an algebraic constraint solved in
// that same system; for a cyclic disk F between the sectors' contacts comes from every nodal
// diameter's G_h F_h G_h^H (HarmonicBalanceModel::index_flexibility, kept when the scene asks
// for stability). The product of the N step maps is the
// monodromy; its eigenvalues are the multipliers, computed after a diagonal balancing (its
// displacements, velocities, forces and slider offsets differ in scale by many orders, which
// unbalanced splits a double multiplier by 1e-6).
//
// Two kinds are set apart from the physical multipliers:
//  - the force samples' own: df_j is a function of the state at sample j for the laws
//    shipped, so the step maps' image has the dimension of (dq, dq', dz) and the
//    `contact components` smallest multipliers are zero up to rounding (dropped);
//  - the neutral ones: a contact state component the period never changes (a contact stuck
//    throughout, a direction never slipping, a contact open with its slider kept) is a
//    family of periodic solutions, not an instability: its multiplier is exactly 1. Their
//    number is that of the eigenvalues of the contacts' own state monodromies (the product
//    of d state / d state_prev over the period, the motion held) within kNeutralTolerance
//    of 1; as many multipliers nearest 1 are set apart in `neutral`.
//
// A law that switches regime inside a step (starts or stops slipping, opens, closes) makes the
// linearised force jump there, which no straight line between samples represents. Such a step
// is split where the law switches: a candidate where its tangent d force / d u_now differs
// from a neighbouring step's by more than a quarter of its largest over the period, confirmed
// by the regimes at its two ends (the tangents of short steps from there), the switch located
// by bisection to 2.4e-4 of the step with the law's state followed along the harmonic motion,
// and crossed by a short step of its own.
// Convergence: the force between samples and switches is linear, so the multipliers carry an
// error of order h^2 on top of the harmonic truncation of the orbit (measured in
// tests/test_stability).
// A cyclic structure (one sector modelled) under engine-order excitation is perturbed in every
// nodal diameter, not only in those its response holds: the variational equations are those
// of the whole tuned disk, built from the sector's modes of every nodal diameter (their
// standing pairs, real) and the reference contacts copied into every sector, sector s delayed
// by s m / nb of the period (m the engine order, nb the sectors; the period's samples times m
// must be a multiple of nb). Its multipliers are those of the disk's Floquet-Bloch families
// together; each is named by the nodal diameter that holds most of its Floquet mode's modal
// energy. The dense monodromy costs (2 modes + components + states)^3 per step over the
// whole disk: beyond kMaxStabilityDimension unknowns the result's `failure` says so.
// Scope: real modes for a plain structure, diagonal modal damping for a cyclic one, and a
// model built from a scene with output.stability when its structure has a residual
// flexibility: the result's `failure` says so otherwise. Threading: reads the model,
// whose tracers are not thread-safe; one model per thread.
#pragma once

#include <Eigen/Dense>
#include <complex>
#include <string>
#include <vector>

#include "frichb/core/model/harmonic_balance.hpp"

namespace frichb::core {

inline constexpr double kNeutralTolerance = 1e-9;
// The largest monodromy dimension computed (2 modes + contact components + contact states).
inline constexpr Eigen::Index kMaxStabilityDimension = 2000;

struct FloquetMultipliers {
  // Physical multipliers, largest modulus first (neutral and force-sample ones excluded).
  std::vector<std::complex<double>> multipliers;
  // Cyclic structures: the nodal diameter of each multiplier (as `multipliers`); else empty.
  std::vector<int> nodal_diameters;
  // The neutral multipliers set apart (their distance from 1 is the rounding of the product).
  std::vector<std::complex<double>> neutral;
  double largest_modulus = 0.0;  // |multipliers[0]|, 0 when there is none
  // The multipliers outside the unit circle: how many, and the one of them nearest the circle
  // (along a curve, the last to have crossed it), 0 when there is none.
  int unstable_count = 0;
  std::complex<double> nearest_unstable = 0.0;
  int nearest_unstable_nodal_diameter = -1;  // cyclic structures; -1 otherwise or when stable
  // Stable when no physical multiplier lies outside the unit circle.
  bool stable() const { return largest_modulus <= 1.0; }
  int steps = 0;        // N, the steps of the period integrated
  int split_steps = 0;  // of those, the steps split where a law switches regime
  std::string failure;  // why no multipliers were computed (empty when they were)
};

// The Floquet multipliers of the solution y = [U; w] of `model` (a converged point).
FloquetMultipliers floquet_multipliers(const HarmonicBalanceModel& model, const Eigen::VectorXd& y);

// exp(A): scaling and squaring with a diagonal Pade approximant of degree 6.
Eigen::MatrixXd matrix_exponential(const Eigen::MatrixXd& a);

}  // namespace frichb::core
