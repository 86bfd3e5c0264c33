#include "frichb/core/model/linear_resonances.hpp"

#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <complex>
#include <string>

#include "frichb/core/plugin_host/registry.hpp"

namespace frichb::core {

namespace {

// The relative displacement of the stiffness probe, m: far below any slip distance a scene
// meets (mu N / kt), and above zero so that a contact without friction force (mu N = 0) is
// seen to slip rather than to sit on its stick limit.
constexpr double kProbeDisplacement = 1e-12;

// A stuck resonance this close to a free one (in the smaller half-width) is the same one.
constexpr double kSameResonanceInHalfWidths = 0.1;

// The narrowest half-width a resonance is given (relative to its centre), so that an
// undamped mode still bounds the step by a finite amount.
constexpr double kSmallestDampingRatio = 1e-9;

// Eigenvalues at or below this fraction of the largest are rigid-body (or numerical) zeros.
constexpr double kRigidBodyShare = 1e-12;

}  // namespace

const char* system_name(LinearResonance::System system) {
  return system == LinearResonance::System::kFree ? "free" : "stuck";
}

Eigen::MatrixXd static_contact_stiffness(const HarmonicBalanceModel& model) {
  const Eigen::Index n = model.component_count();
  Eigen::MatrixXd stiffness = Eigen::MatrixXd::Zero(n, n);
  for (const ContactModel& contact : model.contacts()) {
    const ContactLawInstance& law = *contact.law;
    const frichb_contact_law_traits& traits = law.traits();
    if (traits.provides_tangent == 0) continue;
    const auto s = static_cast<std::size_t>(std::max(traits.state_size, 0));
    std::vector<double> state_prev(s), state_now(s), force(3);
    std::vector<double> du_now(9), du_prev(9), dforce_dstate(3 * s), dstate_du_now(3 * s),
        dstate_du_prev(3 * s), dstate_dstate(s * s);
    frichb_step_tangents tangents{du_now.data(),         du_prev.data(),
                                  dforce_dstate.data(),  dstate_du_now.data(),
                                  dstate_du_prev.data(), dstate_dstate.data()};
    law.initial_state(state_prev.data());
    const auto& comps = contact.tracer->components();
    double u_prev[3] = {0, 0, 0};
    double u_now[3] = {0, 0, 0};
    for (int c : comps)
      if (c < 2) u_now[c] = kProbeDisplacement;
    std::string error;
    if (!law.step(state_prev.data(), u_prev, u_now, force.data(), state_now.data(), &tangents,
                  &error))
      throw PluginError("contact '" + contact.name +
                        "': its law failed at the static state: " + error);
    for (std::size_t a = 0; a < comps.size(); ++a)
      for (std::size_t b = 0; b < comps.size(); ++b)
        stiffness(contact.offset + static_cast<Eigen::Index>(a),
                  contact.offset + static_cast<Eigen::Index>(b)) =
            du_now[(static_cast<std::size_t>(comps[a]) * 3) + static_cast<std::size_t>(comps[b])];
  }
  return stiffness;
}

std::vector<LinearResonance> linear_resonances(const Scene& scene,
                                               const HarmonicBalanceModel& model, double lambda_min,
                                               double lambda_max) {
  std::vector<LinearResonance> free, stuck;
  const auto in_window = [&](double centre) {
    return centre >= lambda_min && centre <= lambda_max;
  };
  const auto add = [&](std::vector<LinearResonance>& to, LinearResonance::System system, int k,
                       int index, double w, double zeta) {
    if (!(w > 0) || !in_window(w / k)) return;
    LinearResonance r;
    r.system = system;
    r.harmonic = k;
    r.harmonic_index = index;
    r.natural_frequency = w;
    r.centre = w / k;
    r.damping_ratio = zeta;
    r.half_width = std::max(zeta, kSmallestDampingRatio) * r.centre;
    to.push_back(r);
  };

  const Eigen::MatrixXd contact_stiffness = static_contact_stiffness(model);
  const bool any_stiffness = contact_stiffness.size() > 0 && !contact_stiffness.isZero(0.0);
  const auto& harmonics = model.layout().harmonics();
  for (std::size_t kept = 0; kept < harmonics.size(); ++kept) {
    const int k = harmonics[kept];
    if (k <= 0) continue;
    const int index = scene.cyclic.harmonic_index(k);
    const ReducedStructure::Basis& basis = model.structure().basis(index);
    for (Eigen::Index r = 0; r < basis.frequencies.size(); ++r) {
      const double w = basis.frequencies(r);
      add(free, LinearResonance::System::kFree, k, index, w,
          w > 0 ? basis.damping(r, r) / (2 * w) : 0.0);
    }
    if (!any_stiffness || basis.frequencies.size() == 0) continue;

    const SparseGather& gather = model.gather(kept);
    const Eigen::MatrixXcd projected = gather * basis.rows;  // P = G Phi
    // K_c is block diagonal (one block per contact): sparse.
    const Eigen::SparseMatrix<std::complex<double>> kc =
        contact_stiffness.cast<std::complex<double>>().sparseView();
    // K_e P = K_c S^-1 P with S = I + G F G^H K_c: one LU of S and a solve for the modes'
    // columns, never K_e itself.
    Eigen::MatrixXcd effective_on_modes = kc * projected;
    // G F G^H: the model's where it reduced F, else from the basis's whole F.
    Eigen::MatrixXcd gathered;
    const Eigen::MatrixXcd* flexibility = &model.contact_flexibility(kept);
    if (flexibility->size() == 0 && basis.residual_flexibility.size() > 0) {
      gathered = gather_hermitian(gather, basis.residual_flexibility);
      flexibility = &gathered;
    }
    if (flexibility->size() > 0) {
      const Eigen::MatrixXcd series =
          Eigen::MatrixXcd::Identity(kc.rows(), kc.cols()) + *flexibility * kc;
      effective_on_modes = kc * series.partialPivLu().solve(projected);
    }
    Eigen::MatrixXcd stiffened = projected.adjoint() * effective_on_modes;
    stiffened.diagonal() +=
        basis.frequencies.array().square().matrix().cast<std::complex<double>>();
    stiffened = 0.5 * (stiffened + stiffened.adjoint()).eval();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXcd> eigen(stiffened);
    if (eigen.info() != Eigen::Success) continue;
    const double largest = eigen.eigenvalues().cwiseAbs().maxCoeff();
    const Eigen::MatrixXcd damping = basis.damping.cast<std::complex<double>>();
    for (Eigen::Index r = 0; r < eigen.eigenvalues().size(); ++r) {
      const double value = eigen.eigenvalues()(r);
      if (!(value > kRigidBodyShare * largest)) continue;
      const double w = std::sqrt(value);
      const Eigen::VectorXcd psi = eigen.eigenvectors().col(r);
      const double zeta = (psi.adjoint() * damping * psi)(0, 0).real() / (2 * w);
      add(stuck, LinearResonance::System::kStuck, k, index, w, zeta);
    }
  }

  std::vector<LinearResonance> all = free;
  for (const LinearResonance& s : stuck) {
    const bool repeats = std::any_of(free.begin(), free.end(), [&](const LinearResonance& f) {
      return f.harmonic == s.harmonic &&
             std::abs(f.centre - s.centre) <=
                 kSameResonanceInHalfWidths * std::min(f.half_width, s.half_width);
    });
    if (!repeats) all.push_back(s);
  }
  std::sort(all.begin(), all.end(),
            [](const LinearResonance& a, const LinearResonance& b) { return a.centre < b.centre; });
  return all;
}

}  // namespace frichb::core
