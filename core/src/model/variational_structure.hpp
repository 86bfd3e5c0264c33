// The linear part of a harmonic-balance solution's variational equations (model/stability.cpp):
// the structure's real modes, their modal damping and P = G Phi over the contacts' copies - a
// plain structure's own modes with each contact once, or a cyclic sector's modes of every nodal
// diameter expanded to the whole tuned disk with each contact copied into every sector - and
// the turning of a disk's state by whole sectors, with which a travelling wave's monodromy is
// completed from a part of its period. Internal to the model layer; not thread-safe beyond
// what the model is (it only reads it).
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "frichb/core/model/harmonic_balance.hpp"

namespace frichb::core {

// The linear structure of the variational equations: real modes (mass-normalised), their
// modal damping and P = G Phi over the contacts' copies; for a cyclic structure, the whole
// disk's modes and the nodal diameter of each.
struct VariationalStructure {
  Eigen::VectorXd frequencies;
  Eigen::MatrixXd damping;
  bool diagonal = true;
  Eigen::MatrixXd p;  // copies' components x modes
  // The residual flexibility between the copies' components (copies' components squared,
  // symmetric; m/N): u = P q - F f. Empty without one.
  Eigen::MatrixXd flexibility;
  std::vector<int> nodal_diameter;  // per mode; empty without cyclic symmetry
  // Cyclic, per mode: 0 alone (h = 0, or h = nb/2 whose sign flips from sector to sector), 1
  // the real part of a standing pair (the imaginary part, 2, next).
  std::vector<int> pair_role;
};

// A contact as the variational equations see it: the model's contact `contact` in a sector
// whose motion is the reference sector's delayed by `shift` samples; its first row in P and
// its first state.
struct ContactCopy {
  std::size_t contact = 0;
  int shift = 0;
  Eigen::Index row = 0;
  Eigen::Index state = 0;
};

// A plain structure: its modes as the model holds them, each contact once. False, with
// `failure`, for complex modes.
bool plain_structure(const HarmonicBalanceModel& model, VariationalStructure& vs,
                     std::vector<ContactCopy>& copies, std::string& failure);

// A cyclic structure: the whole disk, from the sector's modes of every nodal diameter h <= nb/2
// (the model holds them when its scene asks for stability), each contact copied into every
// sector and delayed by s m / nb of the `samples` of a period; the residual flexibility between
// the copies from every nodal diameter's. False, with `failure`, where that delay is not a whole
// number of samples, or a basis has non-diagonal modal damping.
bool cyclic_structure(const HarmonicBalanceModel& model, int samples, VariationalStructure& vs,
                      std::vector<ContactCopy>& copies, std::string& failure);

// The period's monodromy from that of its first 1 / `repeats` (a cyclic disk's, A = Phi(tau)):
// Phi(T) = Q^-k (Q A)^k with k = repeats and Q the turn by `turn` sectors, in place; the
// contacts' own state monodromies (`own`, one per copy) the same way, into one over all copies
// (`own` then holds it alone).
void complete_by_turning(Eigen::MatrixXd& monodromy, std::vector<Eigen::MatrixXd>& own,
                         const VariationalStructure& vs, const std::vector<ContactCopy>& copies,
                         int nb, int repeats, int turn);

}  // namespace frichb::core
