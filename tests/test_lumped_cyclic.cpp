// lumped_cyclic structure provider through the real loader, against oracles built here from
// the same spring-mass description without the plugin:
//  (1) the union over harmonic indices of the sector frequencies is the full disk's spectrum;
//  (2) R_h(W) from the modal basis inverts D_h(W) = K_h - W^2 M0 + i W C_h, K_h assembled here
//      as K0 + e^{-i h phi} K1 + e^{i h phi} K1^T;
//  (3) reciprocity: R_h(W)^T = R_{nb-h}(W) (K_h^T = K_{-h}); R_0 symmetric, real undamped;
//  (4) a travelling-wave force f_s = F e^{-i h s phi} on the full disk answers with
//      x_s = R_h F e^{-i h s phi};
//  (5) bad harmonic indices, coupling ends, DOFs and damping counts are refused by message.
// Needs frichb_lumped_cyclic built in FRICHB_PLUGIN_DIR.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <algorithm>
#include <complex>
#include <cstdio>
#include <memory>
#include <numbers>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include "frichb/core/model/reduced_structure.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/plugin_host/schema.hpp"
#include "test_support.hpp"

namespace {

using frichb::core::PluginError;
using frichb::core::ReducedStructure;
using frichb::core::StructureInstance;
using ::testing::HasSubstr;
using cd = std::complex<double>;
constexpr cd kI{0.0, 1.0};

struct Spring {
  int a, b;  // -1: ground
  double k;
};
struct Coupling {
  int i, j;  // DOF i of sector s, DOF j of sector s+1
  double k;
};

// One sector: disk DOF 0 (grounded), blade DOF 1, shroud DOF 2. The crossed coupling 2 -> 1
// makes K1 unsymmetric, so that K_h != K_{nb-h} and every sign convention is visible.
struct Model {
  int sectors = 7;
  std::vector<double> masses{0.5, 0.08, 0.02};
  std::vector<Spring> springs{{-1, 0, 2.0e6}, {0, 1, 4.0e5}, {1, 2, 1.5e5}};
  std::vector<Coupling> coupling{{0, 0, 3.0e5}, {2, 1, 5.0e4}, {2, 2, 8.0e4}};
  std::vector<double> ratios;  // modal damping ratios (empty: undamped)

  int n() const { return static_cast<int>(masses.size()); }
  double phi() const { return 2.0 * std::numbers::pi / sectors; }

  std::string yaml() const {
    std::ostringstream y;
    y.precision(17);
    auto end = [](int e) { return e < 0 ? std::string("ground") : std::to_string(e); };
    y << "{sectors: " << sectors << ", masses: [";
    for (std::size_t r = 0; r < masses.size(); ++r) y << (r ? ", " : "") << masses[r];
    y << "], springs: [";
    for (std::size_t r = 0; r < springs.size(); ++r)
      y << (r ? ", " : "") << "{between: [" << end(springs[r].a) << ", " << end(springs[r].b)
        << "], k: " << springs[r].k << "}";
    y << "], coupling: [";
    for (std::size_t r = 0; r < coupling.size(); ++r)
      y << (r ? ", " : "") << "{between: [" << coupling[r].i << ", " << coupling[r].j
        << "], k: " << coupling[r].k << "}";
    y << "], modal_damping: [";
    for (std::size_t r = 0; r < ratios.size(); ++r) y << (r ? ", " : "") << ratios[r];
    y << "]}";
    return y.str();
  }

  Eigen::MatrixXd sector_mass() const {
    return Eigen::VectorXd::Map(masses.data(), n()).asDiagonal();
  }

  // Harmonic-index stiffness from the ABI formula, K0 and K1 assembled here.
  Eigen::MatrixXcd k_h(int h) const {
    Eigen::MatrixXd k0 = Eigen::MatrixXd::Zero(n(), n()), k1 = Eigen::MatrixXd::Zero(n(), n());
    for (const Spring& s : springs) add_spring(k0, s.a, s.b, s.k);
    for (const Coupling& c : coupling) {
      k0(c.i, c.i) += c.k;
      k0(c.j, c.j) += c.k;
      k1(c.i, c.j) -= c.k;
    }
    const cd e = std::polar(1.0, -h * phi());
    return k0.cast<cd>() + e * k1.cast<cd>() + std::conj(e) * k1.transpose().cast<cd>();
  }

  // The full disk: sector s holds global DOFs s*n .. s*n+n-1.
  Eigen::MatrixXd full_mass() const {
    const int n_all = sectors * n();
    Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n_all, n_all);
    for (int s = 0; s < sectors; ++s) m.block(s * n(), s * n(), n(), n()) = sector_mass();
    return m;
  }
  Eigen::MatrixXd full_stiffness() const {
    const int n_all = sectors * n();
    Eigen::MatrixXd k = Eigen::MatrixXd::Zero(n_all, n_all);
    for (int s = 0; s < sectors; ++s) {
      const int next = (s + 1) % sectors;
      for (const Spring& sp : springs)
        add_spring(k, sp.a < 0 ? -1 : s * n() + sp.a, sp.b < 0 ? -1 : s * n() + sp.b, sp.k);
      for (const Coupling& c : coupling) add_spring(k, s * n() + c.i, next * n() + c.j, c.k);
    }
    return k;
  }

  static void add_spring(Eigen::MatrixXd& k, int a, int b, double value) {
    if (a >= 0) k(a, a) += value;
    if (b >= 0) k(b, b) += value;
    if (a >= 0 && b >= 0) {
      k(a, b) -= value;
      k(b, a) -= value;
    }
  }
};

struct Provider {
  frichb::core::ParamValues values;
  std::unique_ptr<StructureInstance> instance;
};

Provider make_provider(const std::string& params_yaml) {
  auto plugin = frichb::test::built_plugins().load("lumped_cyclic", FRICHB_KIND_STRUCTURE);
  Provider p;
  p.values = frichb::core::validate_params(YAML::Load(params_yaml), plugin->schema(), "params",
                                           frichb::core::YamlContext{"<test>"});
  p.instance = std::make_unique<StructureInstance>(plugin, p.values);
  return p;
}

std::vector<std::size_t> all_dofs(const Model& m) {
  std::vector<std::size_t> dofs(static_cast<std::size_t>(m.n()));
  std::iota(dofs.begin(), dofs.end(), std::size_t{0});
  return dofs;
}

std::vector<int> all_indices(const Model& m) {
  std::vector<int> h(static_cast<std::size_t>(m.sectors));
  std::iota(h.begin(), h.end(), 0);
  return h;
}

Eigen::MatrixXcd receptance(const ReducedStructure& rs, int h, double w) {
  Eigen::MatrixXcd r;
  rs.receptance(h, w, r);
  return r;
}

double relative(const Eigen::MatrixXcd& a, const Eigen::MatrixXcd& b) {
  return (a - b).norm() / b.norm();
}

// Excitation frequencies away from the resonances of h: below, between and above them.
std::vector<double> probe_frequencies(const Eigen::VectorXd& w) {
  std::vector<double> out{0.5 * w(0)};
  for (Eigen::Index r = 0; r + 1 < w.size(); ++r) out.push_back(0.5 * (w(r) + w(r + 1)));
  out.push_back(1.7 * w(w.size() - 1));
  return out;
}

// Independent eigen-solution of harmonic index h (Hermitian, mass-normalised): frequencies
// ascending and modes.
void solve_h(const Model& m, int h, Eigen::VectorXd& w, Eigen::MatrixXcd& modes) {
  const Eigen::VectorXd inv_sqrt_m =
      Eigen::VectorXd::Map(m.masses.data(), m.n()).cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXcd a = inv_sqrt_m.asDiagonal() * m.k_h(h) * inv_sqrt_m.asDiagonal();
  const Eigen::ComplexEigenSolver<Eigen::MatrixXcd> eig(a);  // general solver: no shared path
  ASSERT_EQ(eig.info(), Eigen::Success);
  std::vector<Eigen::Index> order(static_cast<std::size_t>(m.n()));
  std::iota(order.begin(), order.end(), Eigen::Index{0});
  std::sort(order.begin(), order.end(), [&](Eigen::Index x, Eigen::Index y) {
    return eig.eigenvalues()(x).real() < eig.eigenvalues()(y).real();
  });
  w.resize(m.n());
  modes.resize(m.n(), m.n());
  for (int r = 0; r < m.n(); ++r) {
    const auto c = order[static_cast<std::size_t>(r)];
    w(r) = std::sqrt(eig.eigenvalues()(c).real());
    const Eigen::VectorXcd v = eig.eigenvectors().col(c).normalized();
    modes.col(r) = inv_sqrt_m.asDiagonal() * v;
  }
}

// ---------------------------------------------------------------------------------------

TEST(LumpedCyclic, ReportsSectorsAndDofs) {
  const Model m;
  auto p = make_provider(m.yaml());
  EXPECT_EQ(p.instance->sector_count(), 7U);
  EXPECT_EQ(p.instance->dof_count(), 3U);
}

// The ABI contract directly: Phi^H M0 Phi = I and Phi^H K_h Phi = diag(w^2), w ascending,
// damping diagonal 2 z w, real modes (no imaginary part) at h = 0 and h = nb/2.
TEST(LumpedCyclic, ModalBasisIsMassNormalisedAndDiagonalisesKh) {
  Model m;
  m.sectors = 6;
  m.ratios = {0.01, 0.02, 0.03};
  auto p = make_provider(m.yaml());
  const auto kept = all_dofs(m);
  double worst = 0.0;
  for (int h = 0; h < m.sectors; ++h) {
    const frichb_modal_basis b = p.instance->modal_basis(h, kept);
    ASSERT_EQ(b.n_modes, 3U);
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    Eigen::MatrixXcd phi = Eigen::Map<const RowMajor>(b.mode_rows_real, 3, 3).cast<cd>();
    if (h == 0 || h == 3) {
      EXPECT_EQ(b.mode_rows_imag, nullptr) << "h = " << h;
    } else {
      ASSERT_NE(b.mode_rows_imag, nullptr) << "h = " << h;
      phi.imag() = Eigen::Map<const RowMajor>(b.mode_rows_imag, 3, 3);
    }
    const Eigen::Map<const Eigen::VectorXd> w(b.natural_frequencies, 3);
    const Eigen::Map<const RowMajor> c(b.modal_damping, 3, 3);
    const Eigen::MatrixXcd ortho = phi.adjoint() * m.sector_mass() * phi;
    const Eigen::MatrixXcd stiff = phi.adjoint() * m.k_h(h) * phi;
    const Eigen::MatrixXcd w2 = w.array().square().matrix().asDiagonal().toDenseMatrix().cast<cd>();
    worst = std::max(worst, (ortho - Eigen::MatrixXcd::Identity(3, 3)).norm());
    worst = std::max(worst, relative(stiff, w2));
    EXPECT_TRUE(std::is_sorted(w.data(), w.data() + 3)) << "h = " << h;
    for (int r = 0; r < 3; ++r)
      for (int s = 0; s < 3; ++s)
        EXPECT_NEAR(c(r, s), r == s ? 2.0 * m.ratios[static_cast<std::size_t>(r)] * w(r) : 0.0,
                    1e-12 * w(r))
            << "h = " << h;
  }
  EXPECT_LT(worst, 1e-12);
  std::printf(
      "[ measured ] modal basis: worst |Phi^H M Phi - I|, |Phi^H K Phi - W^2|/|W^2| = %.2e\n",
      worst);
}

// (1) Full-disk equivalence of the spectra, for odd, even and the smallest sector counts.
TEST(LumpedCyclic, UnionOfHarmonicSpectraIsTheFullDiskSpectrum) {
  for (int sectors : {2, 5, 6, 7}) {
    Model m;
    m.sectors = sectors;
    auto p = make_provider(m.yaml());
    const ReducedStructure rs(*p.instance, all_dofs(m), all_indices(m));
    std::vector<double> union_w;
    for (int h = 0; h < sectors; ++h) {
      const Eigen::VectorXd& w = rs.natural_frequencies(h);
      ASSERT_EQ(w.size(), m.n());
      union_w.insert(union_w.end(), w.data(), w.data() + w.size());
    }
    std::sort(union_w.begin(), union_w.end());

    const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> full(m.full_stiffness(),
                                                                         m.full_mass());
    ASSERT_EQ(full.info(), Eigen::Success);
    const Eigen::VectorXd& lambda = full.eigenvalues();  // ascending
    ASSERT_EQ(static_cast<Eigen::Index>(union_w.size()), lambda.size());
    double worst = 0.0;
    for (Eigen::Index r = 0; r < lambda.size(); ++r) {
      const double w_full = std::sqrt(lambda(r));
      const double err = std::abs(union_w[static_cast<std::size_t>(r)] - w_full) / w_full;
      worst = std::max(worst, err);
      EXPECT_LT(err, 1e-9) << "nb = " << sectors << ", mode " << r;
    }
    std::printf("[ measured ] nb = %d: %zu frequencies %.6g..%.6g rad/s, worst relative %.2e\n",
                sectors, union_w.size(), union_w.front(), union_w.back(), worst);
  }
}

// (2a) Undamped: R_h(W) D_h(W) = I away from resonances.
TEST(LumpedCyclic, UndampedReceptanceInvertsTheHarmonicDynamicStiffness) {
  const Model m;  // nb = 7, undamped
  auto p = make_provider(m.yaml());
  const ReducedStructure rs(*p.instance, all_dofs(m), all_indices(m));
  double worst = 0.0;
  for (int h = 0; h < m.sectors; ++h) {
    for (double w : probe_frequencies(rs.natural_frequencies(h))) {
      const Eigen::MatrixXcd d = m.k_h(h) - w * w * m.sector_mass().cast<cd>();
      const Eigen::MatrixXcd product = receptance(rs, h, w) * d;
      const double err = (product - Eigen::MatrixXcd::Identity(m.n(), m.n())).norm();
      worst = std::max(worst, err);
      EXPECT_LT(err, 1e-9) << "h = " << h << ", W = " << w;
    }
  }
  std::printf("[ measured ] undamped |R_h D_h - I| worst %.2e\n", worst);
}

// (2b) Modal damping ratios (one value, then one per mode): R_h = D_h^-1 with
// C_h = M0 Phi diag(2 z w) Phi^H M0 from this test's own eigen-solution of K_h.
TEST(LumpedCyclic, DampedReceptanceIsTheInverseOfTheHarmonicDynamicStiffness) {
  for (const std::vector<double>& ratios :
       {std::vector<double>{0.02}, std::vector<double>{0.01, 0.03, 0.005}}) {
    Model m;
    m.ratios = ratios;
    auto p = make_provider(m.yaml());
    const ReducedStructure rs(*p.instance, all_dofs(m), all_indices(m));
    const Eigen::MatrixXcd mass = m.sector_mass().cast<cd>();
    double worst = 0.0;
    for (int h = 0; h < m.sectors; ++h) {
      Eigen::VectorXd w_h;
      Eigen::MatrixXcd modes;
      solve_h(m, h, w_h, modes);
      Eigen::VectorXd c_modal(m.n());
      for (int r = 0; r < m.n(); ++r)
        c_modal(r) = 2.0 * ratios[ratios.size() == 1 ? 0 : static_cast<std::size_t>(r)] * w_h(r);
      const Eigen::MatrixXcd c_h = mass * modes * c_modal.asDiagonal() * modes.adjoint() * mass;
      std::vector<double> probes = probe_frequencies(w_h);
      for (int r = 0; r < m.n(); ++r) probes.push_back(w_h(r));  // at resonance too: damped
      for (double w : probes) {
        const Eigen::MatrixXcd d = m.k_h(h) - w * w * mass + kI * w * c_h;
        const Eigen::MatrixXcd expected = d.inverse();
        const double err = relative(receptance(rs, h, w), expected);
        worst = std::max(worst, err);
        EXPECT_LT(err, 1e-9) << "h = " << h << ", W = " << w;
      }
    }
    std::printf("[ measured ] %zu damping ratio(s): |R_h - D_h^-1|/|D_h^-1| worst %.2e\n",
                ratios.size(), worst);
  }
}

// (3) K_h^T = K0 + e^{-i h phi} K1^T + e^{i h phi} K1 = K_{nb-h}, and with modal damping
// C_h^T = conj(C_h) = C_{nb-h} (the modes of nb-h are the conjugates of those of h), so
// R_h(W)^T = R_{nb-h}(W). Hence R_0 (and R_{nb/2}) are symmetric, real when undamped, and an
// undamped R_h is Hermitian. R_h itself is not symmetric: the coupling makes h and nb-h differ.
TEST(LumpedCyclic, ReceptancesAreReciprocalBetweenHAndSectorsMinusH) {
  for (int sectors : {6, 7}) {
    for (const std::vector<double>& ratios :
         {std::vector<double>{}, std::vector<double>{0.01, 0.03, 0.005}}) {
      Model m;
      m.sectors = sectors;
      m.ratios = ratios;
      auto p = make_provider(m.yaml());
      const ReducedStructure rs(*p.instance, all_dofs(m), all_indices(m));
      double worst = 0.0, least_asymmetry = 1.0;
      for (int h = 0; h < sectors; ++h) {
        const int mirror = (sectors - h) % sectors;
        for (double w : probe_frequencies(rs.natural_frequencies(h))) {
          const Eigen::MatrixXcd r = receptance(rs, h, w);
          const Eigen::MatrixXcd r_mirror = receptance(rs, mirror, w);
          const double err = relative(r.transpose(), r_mirror);
          worst = std::max(worst, err);
          EXPECT_LT(err, 1e-9) << "nb = " << sectors << ", h = " << h << ", W = " << w;
          if (ratios.empty()) {
            EXPECT_LT(relative(r.adjoint(), r), 1e-9) << "h = " << h;
          }
          if (h == mirror) {
            EXPECT_LT(relative(r.transpose(), r), 1e-12) << "h = " << h;
            if (ratios.empty()) {
              EXPECT_EQ(r.imag().cwiseAbs().maxCoeff(), 0.0) << "h = " << h;
            }
          } else {
            least_asymmetry = std::min(least_asymmetry, relative(r.transpose(), r));
          }
        }
      }
      EXPECT_GT(least_asymmetry, 1e-4) << "the oracle must tell h from nb-h";
      std::printf(
          "[ measured ] nb = %d, %s: |R_h^T - R_{nb-h}| worst %.2e; |R_h^T - R_h| >= "
          "%.2e for h != nb-h\n",
          sectors, ratios.empty() ? "undamped" : "damped", worst, least_asymmetry);
    }
  }
}

// (4) The thesis's reduction: sector s's equation K0 x_s + K1 x_{s+1} + K1^T x_{s-1} = f_s with
// x_s = x_0 e^{-i h s phi} is K_h x_0 = f_0, so f_s = F e^{-i h s phi} gives x_s = R_h F
// e^{-i h s phi}. Full disk solved directly, with the full disk's own uniform modal damping.
TEST(LumpedCyclic, TravellingWaveOnTheFullDiskMatchesTheSectorReceptance) {
  for (int sectors : {6, 7}) {
    for (double zeta : {0.0, 0.02}) {
      Model m;
      m.sectors = sectors;
      if (zeta > 0) m.ratios = {zeta};
      auto p = make_provider(m.yaml());
      const ReducedStructure rs(*p.instance, all_dofs(m), all_indices(m));

      const Eigen::MatrixXd mass = m.full_mass(), stiffness = m.full_stiffness();
      const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> full(stiffness, mass);
      ASSERT_EQ(full.info(), Eigen::Success);
      const Eigen::MatrixXd& modes = full.eigenvectors();
      const Eigen::VectorXd c_modal = 2.0 * zeta * full.eigenvalues().cwiseSqrt();
      const Eigen::MatrixXd damping =
          mass * modes * c_modal.asDiagonal() * modes.transpose() * mass;

      const int n = m.n();
      Eigen::VectorXcd force(n);
      force << cd(1.0, 0.3), cd(-0.4, 0.8), cd(0.25, -0.6);
      double worst = 0.0, least_mirror_gap = 1.0;
      for (int h = 0; h < sectors; ++h) {
        const int mirror = (sectors - h) % sectors;
        std::vector<double> probes = probe_frequencies(rs.natural_frequencies(h));
        if (zeta > 0) probes.push_back(rs.natural_frequencies(h)(1));  // at a resonance
        for (double w : probes) {
          Eigen::VectorXcd f(sectors * n);
          for (int s = 0; s < sectors; ++s)
            f.segment(s * n, n) = force * std::polar(1.0, -h * s * m.phi());
          const Eigen::MatrixXcd d =
              stiffness.cast<cd>() - w * w * mass.cast<cd>() + kI * w * damping.cast<cd>();
          const Eigen::VectorXcd x = d.partialPivLu().solve(f);
          const Eigen::VectorXcd x0 = receptance(rs, h, w) * force;
          for (int s = 0; s < sectors; ++s) {
            const Eigen::VectorXcd expected = x0 * std::polar(1.0, -h * s * m.phi());
            const double err = (x.segment(s * n, n) - expected).norm() / expected.norm();
            worst = std::max(worst, err);
            EXPECT_LT(err, 1e-9) << "nb = " << sectors << ", h = " << h << ", sector " << s
                                 << ", W = " << w;
          }
          if (mirror != h) {
            const Eigen::VectorXcd wrong = receptance(rs, mirror, w) * force;
            least_mirror_gap = std::min(least_mirror_gap, (wrong - x0).norm() / x0.norm());
          }
        }
      }
      EXPECT_GT(least_mirror_gap, 1e-4) << "the opposite phase convention must fail";
      std::printf(
          "[ measured ] nb = %d, zeta = %.2f: travelling wave worst relative %.2e; "
          "R_{nb-h} F misses by >= %.2e\n",
          sectors, zeta, worst, least_mirror_gap);
    }
  }
}

// (5) Bad input.
TEST(LumpedCyclic, RefusesHarmonicIndicesOutsideTheSectors) {
  const Model m;
  auto p = make_provider(m.yaml());
  const auto kept = all_dofs(m);
  for (int h : {7, 8, -1}) {
    try {
      p.instance->modal_basis(h, kept);
      FAIL() << "harmonic index " << h << " accepted";
    } catch (const PluginError& e) {
      EXPECT_THAT(e.what(), HasSubstr("harmonic index " + std::to_string(h)));
      EXPECT_THAT(e.what(), HasSubstr("outside [0, 7)"));
      EXPECT_THAT(e.what(), HasSubstr("7 sectors"));
    }
  }
  EXPECT_NO_THROW(p.instance->modal_basis(6, kept));
}

TEST(LumpedCyclic, RefusesBadCouplingEnds) {
  const std::string base =
      "{sectors: 4, masses: [1, 2, 3], springs: [{between: [ground, 0], k: 1}], ";
  for (const auto& [coupling, bad] :
       std::vector<std::pair<std::string, std::string>>{{"[0, 3]", "end '3'"},
                                                        {"[-1, 0]", "end '-1'"},
                                                        {"[ground, 1]", "end 'ground'"},
                                                        {"[1, x]", "end 'x'"}}) {
    std::string yaml = base;
    yaml += "coupling: [{between: [0, 0], k: 1}, {between: ";
    yaml += coupling;
    yaml += ", k: 2}]}";
    try {
      make_provider(yaml);
      FAIL() << coupling << " accepted";
    } catch (const PluginError& e) {
      EXPECT_THAT(e.what(), HasSubstr("coupling[1]"));
      EXPECT_THAT(e.what(), HasSubstr(bad));
      EXPECT_THAT(e.what(), HasSubstr("[0, 2]"));
    }
  }
}

TEST(LumpedCyclic, RefusesOtherBadInput) {
  auto message_of = [](const std::string& yaml) -> std::string {
    try {
      make_provider(yaml);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "accepted";
  };
  // Schema: sectors >= 2, integer.
  EXPECT_THAT(message_of("{sectors: 1, masses: [1], springs: [{between: [ground, 0], k: 1}]}"),
              HasSubstr("sectors"));
  EXPECT_THAT(message_of("{sectors: 2.5, masses: [1], springs: [{between: [ground, 0], k: 1}]}"),
              HasSubstr("integer"));
  EXPECT_THAT(message_of("{sectors: 3, masses: [1, 1], modal_damping: [0.1, 0.2, 0.3]}"),
              HasSubstr("give 1 or one per mode (2)"));
  EXPECT_THAT(message_of("{sectors: 3, masses: [1], springs: [{between: [0, 0], k: 1}]}"),
              HasSubstr("springs[0] joins an end to itself"));
  EXPECT_THAT(message_of("{sectors: 3, masses: [1], springs: [{between: [ground, 1], k: 1}]}"),
              HasSubstr("end '1' is neither 'ground' nor a DOF index in [0, 0]"));
  // Kept DOFs outside the sector.
  auto p = make_provider("{sectors: 3, masses: [1, 1], springs: [{between: [ground, 0], k: 1}]}");
  const std::vector<std::size_t> kept{0, 2};
  try {
    p.instance->modal_basis(1, kept);
    FAIL() << "DOF 2 accepted";
  } catch (const PluginError& e) {
    EXPECT_THAT(e.what(), HasSubstr("DOF 2 does not exist (the model has 2 DOFs)"));
  }
}

}  // namespace
