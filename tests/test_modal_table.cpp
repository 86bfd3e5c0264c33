// modal_table structure provider through the real loader, against oracles built here:
//  (1) a table written from the eigen-solution of a 3-DOF chain gives the receptance of the
//      `lumped` provider on that chain (undamped in Hz, damped in rad/s, modes listed out of
//      order, a subset of DOFs kept, DOFs the table does not list);
//  (2) a cyclic table written only for h <= nb/2 gives, for every h, R_h = D_h^-1 with
//      D_h = K_h - W^2 M0 (+ i W C_h) assembled here: h > nb/2 is derived by conjugation;
//  (3) bad input (missing or malformed file, DOF out of range, negative frequency, duplicate
//      or absent h, damping count) is refused with a message naming the file;
//  (4) the example table of structures/modal_table/example loads.
// Needs frichb_modal_table and frichb_lumped built in FRICHB_PLUGIN_DIR.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <algorithm>
#include <complex>
#include <cstdio>
#include <functional>
#include <map>
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

struct Provider {
  frichb::core::ParamValues values;
  std::unique_ptr<StructureInstance> instance;
};

Provider make_provider(const std::string& name, const std::string& params_yaml) {
  auto plugin = frichb::test::built_plugins().load(name, FRICHB_KIND_STRUCTURE);
  Provider p;
  p.values = frichb::core::validate_params(YAML::Load(params_yaml), plugin->schema(), "params",
                                           frichb::core::YamlContext{"<test>"});
  p.instance = std::make_unique<StructureInstance>(plugin, p.values);
  return p;
}

// The message of the PluginError `fn` throws ("" when it throws none).
std::string error_of(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const PluginError& e) {
    return e.what();
  }
  return "";
}

std::string table_params(const std::string& file, int sectors, int dofs,
                         const std::string& extra = "") {
  return "{file: '" + file + "', sectors: " + std::to_string(sectors) +
         ", dof_count: " + std::to_string(dofs) + (extra.empty() ? "" : ", " + extra) + "}";
}

// One mode of a table: frequency in the table's unit, shape over all DOFs of the sector.
struct TableMode {
  double frequency;
  Eigen::VectorXcd shape;
};

// The YAML table; exact zeros are left out (a DOF not listed is zero), `im` only when nonzero.
std::string table_yaml(const std::map<int, std::vector<TableMode>>& table) {
  std::ostringstream y;
  y.precision(17);
  y << "# written by test_modal_table\nharmonic_indices:\n";
  for (const auto& [h, modes] : table) {
    y << "  - h: " << h << "\n    modes:\n";
    for (const TableMode& m : modes) {
      y << "      - frequency: " << m.frequency << "\n        shape: [";
      bool first = true;
      for (Eigen::Index i = 0; i < m.shape.size(); ++i) {
        if (m.shape(i) == cd(0.0, 0.0)) continue;
        y << (first ? "" : ", ") << "{dof: " << i << ", re: " << m.shape(i).real();
        if (m.shape(i).imag() != 0.0) y << ", im: " << m.shape(i).imag();
        y << "}";
        first = false;
      }
      y << "]\n";
    }
  }
  return y.str();
}

Eigen::MatrixXcd receptance(const ReducedStructure& rs, int h, double w) {
  Eigen::MatrixXcd r;
  rs.receptance(h, w, r);
  return r;
}

double relative(const Eigen::MatrixXcd& a, const Eigen::MatrixXcd& b) {
  return (a - b).norm() / b.norm();
}

// Excitation frequencies away from the resonances w (ascending): below, between, above.
std::vector<double> probe_frequencies(const Eigen::VectorXd& w) {
  std::vector<double> out{0.5 * w(0)};
  for (Eigen::Index r = 0; r + 1 < w.size(); ++r) out.push_back(0.5 * (w(r) + w(r + 1)));
  out.push_back(1.7 * w(w.size() - 1));
  return out;
}

std::vector<std::size_t> iota_dofs(std::size_t n) {
  std::vector<std::size_t> dofs(n);
  std::iota(dofs.begin(), dofs.end(), std::size_t{0});
  return dofs;
}

// ---------------------------------------------------------------------------------------
// (1) A 3-DOF chain: ground - 0 - 1 - 2.

struct Chain {
  std::vector<double> masses{0.3, 0.12, 0.05};
  std::vector<double> springs{3.0e5, 1.5e5, 8.0e4};  // ground-0, 0-1, 1-2

  std::string lumped_yaml(const std::string& damping) const {
    std::ostringstream y;
    y.precision(17);
    y << "{masses: [" << masses[0] << ", " << masses[1] << ", " << masses[2] << "], springs: ["
      << "{between: [ground, 0], k: " << springs[0] << "}, {between: [0, 1], k: " << springs[1]
      << "}, {between: [1, 2], k: " << springs[2] << "}], modal_damping: [" << damping << "]}";
    return y.str();
  }

  // Mass-normalised modes and natural frequencies (rad/s, ascending), solved here.
  void solve(Eigen::VectorXd& w, Eigen::MatrixXd& modes) const {
    Eigen::MatrixXd k = Eigen::MatrixXd::Zero(3, 3);
    k(0, 0) = springs[0] + springs[1];
    k(1, 1) = springs[1] + springs[2];
    k(2, 2) = springs[2];
    k(0, 1) = k(1, 0) = -springs[1];
    k(1, 2) = k(2, 1) = -springs[2];
    const Eigen::MatrixXd m = Eigen::VectorXd::Map(masses.data(), 3).asDiagonal();
    const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(k, m);
    ASSERT_EQ(eig.info(), Eigen::Success);
    w = eig.eigenvalues().cwiseSqrt();
    modes = eig.eigenvectors();
  }
};

TEST(ModalTable, ChainTableGivesTheLumpedReceptance) {
  const Chain chain;
  Eigen::VectorXd w;
  Eigen::MatrixXd modes;
  chain.solve(w, modes);
  const frichb::test::TempDir dir;

  struct Case {
    const char* unit;
    double scale;              // table frequency = w * scale
    std::vector<double> zeta;  // per mode, ascending frequency (empty: undamped)
  };
  const std::vector<Case> cases{{"Hz", 0.5 / std::numbers::pi, {}},
                                {"rad/s", 1.0, {0.01, 0.03, 0.005}}};
  for (const Case& c : cases) {
    // Modes listed in descending frequency: the damping ratios follow the table's order.
    std::vector<TableMode> listed;
    std::string table_zeta, lumped_zeta;
    for (int r = 2; r >= 0; --r) {
      listed.push_back({w(r) * c.scale, modes.col(r).cast<cd>()});
      if (!c.zeta.empty())
        table_zeta += (r == 2 ? "" : ", ") + std::to_string(c.zeta[static_cast<std::size_t>(r)]);
    }
    for (std::size_t r = 0; r < c.zeta.size(); ++r)
      lumped_zeta += (r ? ", " : "") + std::to_string(c.zeta[r]);
    const auto file = dir.write(std::string("chain_") + (c.zeta.empty() ? "a" : "b") + ".yaml",
                                table_yaml({{0, listed}}));
    auto table =
        make_provider("modal_table", table_params(file.string(), 1, 3,
                                                  "frequency_unit: " + std::string(c.unit) +
                                                      ", modal_damping: [" + table_zeta + "]"));
    auto lumped = make_provider("lumped", chain.lumped_yaml(lumped_zeta));
    EXPECT_EQ(table.instance->dof_count(), 3U);
    EXPECT_EQ(table.instance->sector_count(), 1U);

    for (const std::vector<std::size_t>& kept :
         {iota_dofs(3), std::vector<std::size_t>{2, 0}, std::vector<std::size_t>{1}}) {
      const ReducedStructure rt(*table.instance, kept, {0});
      const ReducedStructure rl(*lumped.instance, kept, {0});
      const Eigen::VectorXd& wt = rt.natural_frequencies(0);
      ASSERT_EQ(wt.size(), 3);
      EXPECT_LT((wt - rl.natural_frequencies(0)).norm() / w.norm(), 1e-12);
      std::vector<double> probes = probe_frequencies(w);
      if (!c.zeta.empty()) probes.insert(probes.end(), w.data(), w.data() + 3);  // resonances
      double worst = 0.0;
      for (double f : probes) {
        const double err = relative(receptance(rt, 0, f), receptance(rl, 0, f));
        worst = std::max(worst, err);
        EXPECT_LT(err, 1e-9) << c.unit << ", W = " << f << ", " << kept.size() << " DOFs kept";
      }
      std::printf(
          "[ measured ] chain, %s, %s, %zu DOFs kept: |R_table - R_lumped|/|R| worst "
          "%.2e\n",
          c.unit, c.zeta.empty() ? "undamped" : "damped", kept.size(), worst);
    }
  }
}

// DOFs the table does not list are zero: a 5-DOF model whose table lists DOFs 0..2 only.
TEST(ModalTable, UnlistedDofsAreZero) {
  const Chain chain;
  Eigen::VectorXd w;
  Eigen::MatrixXd modes;
  chain.solve(w, modes);
  std::vector<TableMode> listed;
  listed.reserve(3);
  for (int r = 0; r < 3; ++r) listed.push_back({w(r), modes.col(r).cast<cd>()});
  const frichb::test::TempDir dir;
  const auto file = dir.write("chain.yaml", table_yaml({{0, listed}}));
  auto table =
      make_provider("modal_table", table_params(file.string(), 1, 5, "frequency_unit: rad/s"));
  auto lumped = make_provider("lumped", chain.lumped_yaml(""));
  const ReducedStructure rt(*table.instance, {0, 3, 1, 2, 4}, {0});
  const ReducedStructure rl(*lumped.instance, iota_dofs(3), {0});
  const double f = 0.5 * (w(0) + w(1));
  const Eigen::MatrixXcd r = receptance(rt, 0, f), expected = receptance(rl, 0, f);
  const std::vector<Eigen::Index> at{0, 3, 1, 2, 4};  // row of kept DOF i in `r`
  for (Eigen::Index i = 0; i < 5; ++i)
    for (Eigen::Index j = 0; j < 5; ++j) {
      const Eigen::Index a = at[static_cast<std::size_t>(i)], b = at[static_cast<std::size_t>(j)];
      const cd want = (a < 3 && b < 3) ? expected(a, b) : cd(0.0, 0.0);
      EXPECT_LT(std::abs(r(i, j) - want), 1e-12 * expected.norm()) << i << ", " << j;
    }
}

// ---------------------------------------------------------------------------------------
// (2) A cyclic model: 2 DOFs per sector (disk 0 grounded, blade 1); coupling 0 -> 0 and the
// crossed 1 -> 0 of the next sector, so K1 is unsymmetric and K_h != K_{nb-h}.

struct Cyclic {
  int sectors = 4;
  Eigen::Vector2d masses{1.0, 0.1};

  Eigen::MatrixXd mass() const { return masses.asDiagonal(); }
  Eigen::MatrixXcd k_h(int h) const {
    Eigen::Matrix2d k0, k1;
    const double ground = 5.0e6, blade = 3.0e5, disk_coupling = 2.0e5, crossed = 5.0e4;
    k0 << ground + blade + 2.0 * disk_coupling + crossed, -blade,  //
        -blade, blade + crossed;
    k1 << -disk_coupling, 0.0,  //
        -crossed, 0.0;          // K1(1, 0): DOF 1 of sector s to DOF 0 of sector s+1
    const cd e = std::polar(1.0, -2.0 * std::numbers::pi * h / sectors);
    return k0.cast<cd>() + e * k1.cast<cd>() + std::conj(e) * k1.transpose().cast<cd>();
  }
  // Hermitian eigen-solution of h, mass-normalised, ascending.
  void solve(int h, Eigen::VectorXd& w, Eigen::MatrixXcd& modes) const {
    const Eigen::Vector2d inv_sqrt_m = masses.cwiseSqrt().cwiseInverse();
    const Eigen::MatrixXcd a = inv_sqrt_m.asDiagonal() * k_h(h) * inv_sqrt_m.asDiagonal();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXcd> eig(a);
    ASSERT_EQ(eig.info(), Eigen::Success);
    w = eig.eigenvalues().cwiseSqrt();
    modes = inv_sqrt_m.cast<cd>().asDiagonal() * eig.eigenvectors();
  }
};

TEST(ModalTable, CyclicTableDerivesTheMirrorIndicesByConjugation) {
  const frichb::test::TempDir dir;
  for (int sectors : {4, 5}) {
    for (const std::vector<double>& zeta :
         {std::vector<double>{}, std::vector<double>{0.02, 0.01}}) {
      Cyclic m;
      m.sectors = sectors;
      std::map<int, std::vector<TableMode>> table;
      for (int h = 0; 2 * h <= sectors; ++h) {
        Eigen::VectorXd w;
        Eigen::MatrixXcd modes;
        m.solve(h, w, modes);
        for (int r = 0; r < 2; ++r)  // an arbitrary phase per mode, as an FE code may give
          table[h].push_back({w(r) * 0.5 / std::numbers::pi,
                              modes.col(r) * std::polar(1.0, 0.7 * (r + 1) + 0.3 * h)});
      }
      std::string ratios;
      for (std::size_t r = 0; r < zeta.size(); ++r)
        ratios += (r ? ", " : "") + std::to_string(zeta[r]);
      const auto file = dir.write("cyclic_" + std::to_string(sectors) + ".yaml", table_yaml(table));
      auto p = make_provider("modal_table", table_params(file.string(), sectors, 2,
                                                         "modal_damping: [" + ratios + "]"));
      EXPECT_EQ(p.instance->sector_count(), static_cast<std::size_t>(sectors));
      std::vector<int> all(static_cast<std::size_t>(sectors));
      std::iota(all.begin(), all.end(), 0);
      const ReducedStructure rs(*p.instance, iota_dofs(2), all);

      double worst = 0.0, least_mirror_gap = 1.0;
      for (int h = 0; h < sectors; ++h) {
        Eigen::VectorXd w;
        Eigen::MatrixXcd modes;
        m.solve(h, w, modes);  // directly, also for h > nb/2
        EXPECT_LT((rs.natural_frequencies(h) - w).norm() / w.norm(), 1e-12) << "h = " << h;
        Eigen::MatrixXcd c_h = Eigen::MatrixXcd::Zero(2, 2);
        if (!zeta.empty()) {
          const Eigen::Vector2d c_modal(2.0 * zeta[0] * w(0), 2.0 * zeta[1] * w(1));
          c_h = m.mass() * modes * c_modal.asDiagonal() * modes.adjoint() * m.mass();
        }
        std::vector<double> probes = probe_frequencies(w);
        if (!zeta.empty()) probes.insert(probes.end(), w.data(), w.data() + 2);
        const int mirror = (sectors - h) % sectors;
        for (double f : probes) {
          const Eigen::MatrixXcd d = m.k_h(h) - f * f * m.mass().cast<cd>() + kI * f * c_h;
          const Eigen::MatrixXcd expected = d.inverse();
          const Eigen::MatrixXcd r = receptance(rs, h, f);
          const double err = relative(r, expected);
          worst = std::max(worst, err);
          EXPECT_LT(err, 1e-9) << "nb = " << sectors << ", h = " << h << ", W = " << f;
          if (h != mirror)
            least_mirror_gap =
                std::min(least_mirror_gap, relative(receptance(rs, mirror, f), expected));
        }
      }
      EXPECT_GT(least_mirror_gap, 1e-4) << "the oracle must tell h from nb - h";
      std::printf(
          "[ measured ] nb = %d, %s, table h <= nb/2: |R_h - D_h^-1|/|D_h^-1| worst %.2e "
          "over h = 0..%d; |R_{nb-h} - D_h^-1| >= %.2e\n",
          sectors, zeta.empty() ? "undamped" : "damped", worst, sectors - 1, least_mirror_gap);
    }
  }
}

// A table giving h and nb - h both: each is served as given (no conjugation).
TEST(ModalTable, BothMirrorsGivenAreUsedAsGiven) {
  Cyclic m;
  m.sectors = 5;
  std::map<int, std::vector<TableMode>> table;
  for (int h : {1, 4}) {
    Eigen::VectorXd w;
    Eigen::MatrixXcd modes;
    m.solve(h, w, modes);
    for (int r = 0; r < 2; ++r) table[h].push_back({w(r), modes.col(r)});
  }
  const frichb::test::TempDir dir;
  const auto file = dir.write("both.yaml", table_yaml(table));
  auto p = make_provider("modal_table", table_params(file.string(), 5, 2, "frequency_unit: rad/s"));
  const ReducedStructure rs(*p.instance, iota_dofs(2), {1, 4});
  for (int h : {1, 4}) {
    const double f = 0.5 * (rs.natural_frequencies(h)(0) + rs.natural_frequencies(h)(1));
    const Eigen::MatrixXcd expected = (m.k_h(h) - f * f * m.mass().cast<cd>()).inverse();
    EXPECT_LT(relative(receptance(rs, h, f), expected), 1e-9) << "h = " << h;
  }
}

// ---------------------------------------------------------------------------------------
// (3) Bad input.

const char* const kGoodTable =
    "harmonic_indices:\n"
    "  - h: 0\n"
    "    modes:\n"
    "      - frequency: 120.5\n"
    "        shape: [{dof: 0, re: 0.1}, {dof: 1, re: -0.02}]\n"
    "  - h: 1\n"
    "    modes:\n"
    "      - frequency: 130.0\n"
    "        shape: [{dof: 0, re: 0.1, im: 0.05}]\n";

TEST(ModalTable, MissingFileIsRefusedByName) {
  const frichb::test::TempDir dir;
  const auto missing = (dir.path() / "no_such_table.yaml").string();
  const std::string e =
      error_of([&] { make_provider("modal_table", table_params(missing, 1, 2)); });
  EXPECT_THAT(e, HasSubstr("cannot open the modal table"));
  EXPECT_THAT(e, HasSubstr(missing));
  const std::string rel =
      error_of([&] { make_provider("modal_table", table_params("nowhere/table.yaml", 1, 2)); });
  EXPECT_THAT(rel, HasSubstr("relative to the current working directory"));
  std::printf("[ message  ] %s\n[ message  ] %s\n", e.c_str(), rel.c_str());
}

TEST(ModalTable, BadTablesAreRefusedWithFileAndLine) {
  const frichb::test::TempDir dir;
  struct Case {
    const char* name;
    std::string text;
    int sectors;
    std::string extra;
    std::vector<std::string> expected;  // substrings of the message
  };
  const std::vector<Case> cases{
      {"malformed",
       "harmonic_indices:\n  - h: 0\n    modes: [{frequency: 1, shape: [\n",
       1,
       "",
       {"malformed.yaml:4:", "malformed YAML"}},
      {"dof_range",
       "harmonic_indices:\n  - h: 0\n    modes:\n      - frequency: 1\n"
       "        shape: [{dof: 0, re: 1}, {dof: 7, re: 2}]\n",
       1,
       "",
       {"dof_range.yaml:5:", "dof 7 is outside [0, 2)", "dof_count"}},
      {"negative",
       "harmonic_indices:\n  - h: 0\n    modes:\n      - frequency: -3.5\n        shape: []\n",
       1,
       "",
       {"negative.yaml:4:", "negative frequency -3.5"}},
      {"duplicate",
       std::string(kGoodTable) + "  - h: 0\n    modes: [{frequency: 1, shape: []}]\n",
       2,
       "",
       {"duplicate.yaml:10:", "h = 0 is given twice (first at line 2)"}},
      {"h_range", kGoodTable, 1, "", {"h_range.yaml:6:", "h = 1 is outside [0, 1)"}},
      {"typo",
       "harmonic_indices:\n  - h: 0\n    modes: [{frequncy: 1, shape: []}]\n",
       1,
       "",
       {"typo.yaml:3:", "unknown key 'frequncy'"}},
      {"not_number",
       "harmonic_indices:\n  - h: 0\n    modes: [{frequency: fast, shape: []}]\n",
       1,
       "",
       {"not_number.yaml:3:", "'frequency' must be a finite number"}},
      {"damping",
       kGoodTable,
       2,
       "modal_damping: [0.01, 0.02]",
       {"damping.yaml:4:", "'modal_damping' has 2 values but h = 0 has 1 mode;"}},
  };
  for (const Case& c : cases) {
    const auto file = dir.write(std::string(c.name) + ".yaml", c.text);
    const std::string e = error_of(
        [&] { make_provider("modal_table", table_params(file.string(), c.sectors, 2, c.extra)); });
    for (const std::string& s : c.expected) EXPECT_THAT(e, HasSubstr(s)) << c.name;
    std::printf("[ message  ] %s\n", e.c_str());
  }
}

TEST(ModalTable, AbsentHarmonicIndexNamesTheFileAndWhatItHas) {
  const frichb::test::TempDir dir;
  const auto file = dir.write("table.yaml", kGoodTable);
  auto p = make_provider("modal_table", table_params(file.string(), 6, 2));
  // Given: 0, 1; derived: 5 (conjugate of 1); absent: 2, 3, 4.
  EXPECT_EQ(p.instance->modal_basis(5, iota_dofs(2)).n_modes, 1U);
  const frichb_modal_basis b5 = p.instance->modal_basis(5, std::vector<std::size_t>{0});
  ASSERT_NE(b5.mode_rows_imag, nullptr);
  EXPECT_EQ(b5.mode_rows_real[0], 0.1);
  EXPECT_EQ(b5.mode_rows_imag[0], -0.05);
  EXPECT_NEAR(b5.natural_frequencies[0], 2.0 * std::numbers::pi * 130.0, 1e-12);
  EXPECT_EQ(p.instance->modal_basis(0, iota_dofs(2)).mode_rows_imag, nullptr);

  const std::string e = error_of([&] { p.instance->modal_basis(3, iota_dofs(2)); });
  EXPECT_THAT(e, HasSubstr("harmonic index 3 is not in the modal table"));
  EXPECT_THAT(e, HasSubstr(file.string()));
  EXPECT_THAT(e, HasSubstr("the table gives h = 0, 1"));
  EXPECT_THAT(e, HasSubstr("(with their mirrors by complex conjugation: 0, 1, 5)"));
  EXPECT_THAT(error_of([&] { p.instance->modal_basis(2, iota_dofs(2)); }),
              HasSubstr("harmonic index 2 is not in the modal table '" + file.string() +
                        "', nor its mirror 4 = sectors - h"));
  const std::string outside = error_of([&] { p.instance->modal_basis(6, iota_dofs(2)); });
  EXPECT_THAT(outside, HasSubstr("harmonic index 6 is outside [0, 6)"));
  const std::string dof =
      error_of([&] { p.instance->modal_basis(0, std::vector<std::size_t>{2}); });
  EXPECT_THAT(dof, HasSubstr("DOF 2 does not exist"));
  std::printf("[ message  ] %s\n[ message  ] %s\n", e.c_str(), outside.c_str());
}

// ---------------------------------------------------------------------------------------
// (4) The shipped example loads with the parameters its README gives.

TEST(ModalTable, ExampleTableLoads) {
  const std::string file =
      std::string(FRICHB_SOURCE_DIR) + "/structures/modal_table/example/bladed_disk_4.yaml";
  auto p = make_provider("modal_table", table_params(file, 4, 3, "modal_damping: [0.005]"));
  const ReducedStructure rs(*p.instance, {0, 2}, {0, 1, 2, 3});
  for (int h = 0; h < 4; ++h) EXPECT_EQ(rs.mode_count(h), 3U) << "h = " << h;
  EXPECT_EQ(rs.natural_frequencies(1), rs.natural_frequencies(3));
}

}  // namespace
