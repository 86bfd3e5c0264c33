// fe_sector structure provider through the real loader. The test builds a small FE-like
// sector itself (a 2D spring lattice "disk ring segment" with consistent bar masses, grounded
// at the hub row, and a blade chain), writes its M and K as Matrix Market files, and assembles
// the FULL disk (boundary DOFs merged) for the oracles:
//  (1) the union over harmonic indices of the sector's modes is the full disk's spectrum, and
//      each harmonic index's lowest modes are in it;
//  (2) a sector mode expanded as x_s = phi e^{-i h s phi} is a mode of the full disk, and its
//      left boundary equals the previous sector's right boundary (the lumped_cyclic
//      convention), while the opposite phase is not;
//  (3) Phi^H M_h Phi = I and Phi^H K_h Phi = W^2, K_h = K0 + e^{-i h phi} K1 + e^{i h phi} K1^T
//      with K0, K1 the full disk's blocks; R_h(W) D_h(W) = I with all modes kept;
//  (4) the Spectra (sparse) path agrees with the dense path on a 400-DOF sector;
//  (5) bad files, matrices, boundary lists, mode counts and indices are refused by message;
//  (6) with fewer modes than DOFs, the static residual flexibility makes the receptance exact
//      at W = 0 and much closer to D_h(W)^-1 below the first resonance;
//  (7) the disk cache is read back bitwise, validated, rewritten when corrupt, and keyed by
//      the inputs.
// Needs frichb_fe_sector built in FRICHB_PLUGIN_DIR.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <complex>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <numeric>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "fe_lattice.hpp"
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
using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

using frichb::test::list;
using frichb::test::market;
using frichb::test::Sector;

struct Provider {
  frichb::core::ParamValues values;
  std::unique_ptr<StructureInstance> instance;
};

Provider make_provider(const std::string& params_yaml) {
  auto plugin = frichb::test::built_plugins().load("fe_sector", FRICHB_KIND_STRUCTURE);
  Provider p;
  p.values = frichb::core::validate_params(YAML::Load(params_yaml), plugin->schema(), "params",
                                           frichb::core::YamlContext{"<test>"});
  p.instance = std::make_unique<StructureInstance>(plugin, p.values);
  return p;
}

// A sector written to a temporary folder, and the params of a provider reading it.
struct Files {
  frichb::test::TempDir dir;
  std::string mass, stiffness;
  explicit Files(const Sector& s) {
    mass = dir.write("sector_m.mtx", market(s.m, false)).string();
    stiffness = dir.write("sector_k.mtx", market(s.k, true)).string();
  }
  std::string params(const Sector& s, int sectors, int modes, const std::string& extra = "") const {
    return "{mass: '" + mass + "', stiffness: '" + stiffness +
           "', sectors: " + std::to_string(sectors) + ", left_dofs: " + list(s.left) +
           ", right_dofs: " + list(s.right) + ", modes: " + std::to_string(modes) + extra + "}";
  }
};

Eigen::MatrixXcd mode_rows(const frichb_modal_basis& b, std::size_t n_kept) {
  const auto rows = static_cast<Eigen::Index>(n_kept), cols = static_cast<Eigen::Index>(b.n_modes);
  Eigen::MatrixXcd phi = Eigen::Map<const RowMajor>(b.mode_rows_real, rows, cols).cast<cd>();
  if (b.mode_rows_imag) phi.imag() = Eigen::Map<const RowMajor>(b.mode_rows_imag, rows, cols);
  return phi;
}

Eigen::VectorXd full_frequencies(const Sector& s, int nb) {
  Eigen::MatrixXd kf, mf;
  s.assemble(nb, kf, mf);
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> full(kf, mf);
  EXPECT_EQ(full.info(), Eigen::Success);
  return full.eigenvalues().cwiseMax(0.0).cwiseSqrt();
}

// ---------------------------------------------------------------------------------------

TEST(FeSector, ReportsSectorsAndDofs) {
  const Sector s(3, 4, 4, true, 1);
  const Files f(s);
  auto p = make_provider(f.params(s, 7, 3));
  EXPECT_EQ(p.instance->sector_count(), 7U);
  EXPECT_EQ(p.instance->dof_count(), static_cast<std::size_t>(s.n));
}

// (1) All modes kept: the union over h is the whole full-disk spectrum.
TEST(FeSector, UnionOfHarmonicSpectraIsTheFullDiskSpectrum) {
  const Sector s(3, 4, 4, true, 2);  // 19 DOFs, 16 independent
  const Files f(s);
  for (int nb : {1, 2, 5, 6}) {
    auto p = make_provider(f.params(s, nb, s.m_count));
    std::vector<double> union_w;
    for (int h = 0; h < nb; ++h) {
      const frichb_modal_basis b = p.instance->modal_basis(h, s.all_dofs());
      ASSERT_EQ(b.n_modes, static_cast<std::size_t>(s.m_count));
      union_w.insert(union_w.end(), b.natural_frequencies, b.natural_frequencies + b.n_modes);
    }
    std::sort(union_w.begin(), union_w.end());
    const Eigen::VectorXd full = full_frequencies(s, nb);
    ASSERT_EQ(static_cast<Eigen::Index>(union_w.size()), full.size());
    double worst = 0.0;
    for (Eigen::Index r = 0; r < full.size(); ++r) {
      const double err = std::abs(union_w[static_cast<std::size_t>(r)] - full(r)) / full(r);
      worst = std::max(worst, err);
      EXPECT_LT(err, 1e-9) << "nb = " << nb << ", mode " << r;
    }
    std::printf("[ measured ] nb = %d: %zu frequencies %.6g..%.6g rad/s, worst relative %.2e\n", nb,
                union_w.size(), union_w.front(), union_w.back(), worst);
  }
}

// (1b) A few modes per h: each is a full-disk frequency, the lowest of all is among them.
TEST(FeSector, LowestModesOfEachHarmonicIndexAreFullDiskModes) {
  const Sector s(4, 5, 5, true, 3);
  const Files f(s);
  const int nb = 7;
  auto p = make_provider(f.params(s, nb, 3));
  const Eigen::VectorXd full = full_frequencies(s, nb);
  double worst = 0.0, lowest = 1e300;
  for (int h = 0; h < nb; ++h) {
    const frichb_modal_basis b = p.instance->modal_basis(h, s.all_dofs());
    ASSERT_EQ(b.n_modes, 3U);
    for (std::size_t r = 0; r < 3; ++r) {
      const double w = b.natural_frequencies[r];
      lowest = std::min(lowest, w);
      const double err = (full.array() - w).abs().minCoeff() / w;
      worst = std::max(worst, err);
      EXPECT_LT(err, 1e-9) << "h = " << h << ", mode " << r;
    }
  }
  EXPECT_NEAR(lowest, full(0), 1e-9 * full(0));
  std::printf("[ measured ] 3 modes x %d harmonic indices in the full spectrum: worst %.2e\n", nb,
              worst);
}

// (2) Convention: x_s = phi e^{-i h s phi} is a full-disk mode whose left boundary is the
// previous sector's right boundary; the opposite phase e^{+i h s phi} is not a mode.
TEST(FeSector, SectorModesAreFullDiskModesWithTheCyclicConvention) {
  const Sector s(3, 4, 4, true, 4);
  const Files f(s);
  const int nb = 7;
  auto p = make_provider(f.params(s, nb, 4));
  Eigen::MatrixXd kf, mf;
  s.assemble(nb, kf, mf);
  const double phi = 2.0 * std::numbers::pi / nb;
  double worst_residual = 0.0, worst_seam = 0.0, least_wrong = 1e300;
  for (int h = 0; h < nb; ++h) {
    const frichb_modal_basis b = p.instance->modal_basis(h, s.all_dofs());
    const Eigen::MatrixXcd modes = mode_rows(b, s.all_dofs().size());
    EXPECT_EQ(b.mode_rows_imag == nullptr, h == 0) << "h = " << h;
    for (std::size_t r = 0; r < b.n_modes; ++r) {
      const double lambda = b.natural_frequencies[r] * b.natural_frequencies[r];
      for (double sign : {1.0, -1.0}) {
        Eigen::VectorXcd x = Eigen::VectorXcd::Zero(kf.rows());
        std::vector<bool> set(static_cast<std::size_t>(kf.rows()), false);
        double seam = 0.0;
        for (int sec = 0; sec < nb; ++sec)
          for (int d = 0; d < s.n; ++d) {
            const int g = s.global(sec, d, nb);
            const cd value =
                modes(d, static_cast<Eigen::Index>(r)) * std::polar(1.0, -sign * h * sec * phi);
            if (set[static_cast<std::size_t>(g)]) seam = std::max(seam, std::abs(x(g) - value));
            x(g) = value;
            set[static_cast<std::size_t>(g)] = true;
          }
        const Eigen::VectorXcd kx = kf.cast<cd>() * x;
        const double residual = (kx - lambda * (mf.cast<cd>() * x)).norm() / kx.norm();
        if (sign > 0) {
          worst_residual = std::max(worst_residual, residual);
          worst_seam = std::max(worst_seam, seam / modes.col(static_cast<Eigen::Index>(r)).norm());
          EXPECT_LT(residual, 1e-9) << "h = " << h << ", mode " << r;
        } else if (2 * h % nb != 0) {
          least_wrong = std::min(least_wrong, std::max(residual, seam));
        }
      }
    }
  }
  EXPECT_LT(worst_seam, 1e-12);
  EXPECT_GT(least_wrong, 1e-3) << "the opposite phase convention must fail";
  std::printf(
      "[ measured ] full-disk residual of expanded modes %.2e, seam mismatch %.2e; the "
      "opposite phase misses by >= %.2e\n",
      worst_residual, worst_seam, least_wrong);
}

// (3) Mass normalisation against the ABI's M_h and K_h, modal damping, and with all modes
// kept the receptance inverts D_h(W) = K_h - W^2 M_h (undamped, off resonance).
TEST(FeSector, MassNormalisedModesAndReceptanceInvertTheHarmonicDynamicStiffness) {
  const Sector s(3, 4, 4, true, 5);
  const Files f(s);
  const int nb = 6;
  const auto kept = s.independent_dofs();
  const auto nk = static_cast<Eigen::Index>(kept.size());
  {
    auto p = make_provider(f.params(s, nb, 5, ", modal_damping: [0.02]"));
    double worst = 0.0;
    for (int h = 0; h < nb; ++h) {
      Eigen::MatrixXcd kh, mh;
      s.harmonic(h, nb, kh, mh);
      const frichb_modal_basis b = p.instance->modal_basis(h, kept);
      const Eigen::MatrixXcd modes = mode_rows(b, kept.size());
      EXPECT_EQ(b.mode_rows_imag == nullptr, h == 0 || h == 3) << "h = " << h;
      const Eigen::Map<const Eigen::VectorXd> w(b.natural_frequencies, 5);
      const Eigen::Map<const RowMajor> c(b.modal_damping, 5, 5);
      EXPECT_TRUE(std::is_sorted(w.data(), w.data() + 5));
      const Eigen::MatrixXcd ortho = modes.adjoint() * mh * modes;
      const Eigen::MatrixXcd stiff = modes.adjoint() * kh * modes;
      const Eigen::MatrixXcd w2 =
          w.array().square().matrix().asDiagonal().toDenseMatrix().cast<cd>();
      worst = std::max(worst, (ortho - Eigen::MatrixXcd::Identity(5, 5)).norm());
      worst = std::max(worst, (stiff - w2).norm() / w2.norm());
      for (int r = 0; r < 5; ++r)
        for (int q = 0; q < 5; ++q)
          EXPECT_NEAR(c(r, q), r == q ? 2.0 * 0.02 * w(r) : 0.0, 1e-12 * w(r));
    }
    EXPECT_LT(worst, 1e-10);
    std::printf("[ measured ] 5 modes: |Phi^H M_h Phi - I|, |Phi^H K_h Phi - W^2|/|W^2| <= %.2e\n",
                worst);
  }
  auto p = make_provider(f.params(s, nb, s.m_count));
  std::vector<int> all_h(static_cast<std::size_t>(nb));
  std::iota(all_h.begin(), all_h.end(), 0);
  const ReducedStructure rs(*p.instance, kept, all_h);
  double worst = 0.0;
  for (int h = 0; h < nb; ++h) {
    Eigen::MatrixXcd kh, mh;
    s.harmonic(h, nb, kh, mh);
    const Eigen::VectorXd& w = rs.natural_frequencies(h);
    std::vector<double> probes{0.5 * w(0), 1.7 * w(w.size() - 1)};
    for (Eigen::Index r = 0; r + 1 < w.size(); r += 3) probes.push_back(0.5 * (w(r) + w(r + 1)));
    for (double omega : probes) {
      Eigen::MatrixXcd r;
      rs.receptance(h, omega, r);
      const Eigen::MatrixXcd d = kh - omega * omega * mh;
      const double err = (r * d - Eigen::MatrixXcd::Identity(nk, nk)).norm();
      worst = std::max(worst, err);
      EXPECT_LT(err, 1e-8) << "h = " << h << ", W = " << omega;
      // The response to a force without forming R: D x = f.
      const Eigen::VectorXcd force = Eigen::VectorXcd::LinSpaced(nk, 1.0, -2.0) * (1.0 + 0.5 * h);
      const Eigen::VectorXcd x = rs.respond(h, omega, force);
      EXPECT_LT((d * x - force).norm(), 1e-8 * force.norm()) << "h = " << h << ", W = " << omega;
      // Its derivative in W against central differences of the response.
      Eigen::VectorXcd dx;
      rs.respond(h, omega, force, &dx);
      const double step = 1e-6 * omega;
      const Eigen::VectorXcd difference =
          (rs.respond(h, omega + step, force) - rs.respond(h, omega - step, force)) / (2 * step);
      EXPECT_LT((dx - difference).norm(), 1e-6 * dx.norm()) << "h = " << h << ", W = " << omega;
    }
  }
  std::printf("[ measured ] all modes kept: |R_h D_h - I| worst %.2e\n", worst);
}

// (4) Spectra's shift-invert path against the dense path on a 400-independent-DOF sector,
// complex (h = 1, 5) and real (h = 0, 6) harmonic indices, grounded and free (rigid mode).
TEST(FeSector, SparsePathAgreesWithDensePath) {
  const Sector s(12, 30, 40, true, 6);  // 412 DOFs, 400 independent
  ASSERT_EQ(s.m_count, 400);
  const Files f(s);
  const int nb = 12, modes = 10;
  auto dense = make_provider(f.params(s, nb, modes, ", solver: dense"));
  auto sparse = make_provider(f.params(s, nb, modes, ", solver: sparse"));
  auto automatic = make_provider(f.params(s, nb, modes));
  const auto kept = s.independent_dofs();
  double worst_w = 0.0, worst_shape = 0.0, sparse_s = 0.0, dense_s = 0.0;
  for (int h : {0, 1, 5, 6}) {
    Eigen::MatrixXcd kh, mh;
    s.harmonic(h, nb, kh, mh);
    using clock = std::chrono::steady_clock;
    const auto t0 = clock::now();
    const frichb_modal_basis bd = dense.instance->modal_basis(h, kept);
    const Eigen::VectorXd wd = Eigen::Map<const Eigen::VectorXd>(bd.natural_frequencies, modes);
    const Eigen::MatrixXcd pd = mode_rows(bd, kept.size());
    const auto t1 = clock::now();
    const frichb_modal_basis bs = sparse.instance->modal_basis(h, kept);
    const auto t2 = clock::now();
    dense_s += std::chrono::duration<double>(t1 - t0).count();
    sparse_s += std::chrono::duration<double>(t2 - t1).count();
    const Eigen::VectorXd ws = Eigen::Map<const Eigen::VectorXd>(bs.natural_frequencies, modes);
    const Eigen::MatrixXcd ps = mode_rows(bs, kept.size());
    EXPECT_EQ(bs.mode_rows_imag == nullptr, h == 0 || h == 6);
    const frichb_modal_basis ba = automatic.instance->modal_basis(h, kept);
    for (int r = 0; r < modes; ++r) {
      const double err = std::abs(ws(r) - wd(r)) / wd(r);
      worst_w = std::max(worst_w, err);
      EXPECT_LT(err, 1e-8) << "h = " << h << ", mode " << r;
      EXPECT_NEAR(ba.natural_frequencies[r], ws(r), 1e-8 * ws(r));
      // Same mode up to a unit complex factor (the lowest modes here are well separated).
      const double overlap = std::abs(cd(pd.col(r).dot(mh * ps.col(r))));
      worst_shape = std::max(worst_shape, std::abs(overlap - 1.0));
      EXPECT_NEAR(overlap, 1.0, 1e-8) << "h = " << h << ", mode " << r;
    }
    const Eigen::MatrixXcd ortho = ps.adjoint() * mh * ps;
    EXPECT_LT((ortho - Eigen::MatrixXcd::Identity(modes, modes)).norm(), 1e-10) << "h = " << h;
  }
  std::printf(
      "[ measured ] 400 independent DOFs, %d modes, h = 0, 1, 5, 6: frequencies %.2e, "
      "shapes %.2e; sparse %.3f s, dense %.3f s in all\n",
      modes, worst_w, worst_shape, sparse_s, dense_s);

  // Free disk (no hub springs): h = 0 has a rigid-body mode at zero frequency.
  const Sector free_sector(12, 30, 40, false, 7);
  const Files ff(free_sector);
  auto fd = make_provider(ff.params(free_sector, nb, 6, ", solver: dense"));
  auto fs = make_provider(ff.params(free_sector, nb, 6, ", solver: sparse"));
  const frichb_modal_basis bd = fd.instance->modal_basis(0, kept);
  const std::vector<double> wd(bd.natural_frequencies, bd.natural_frequencies + 6);
  const frichb_modal_basis bs = fs.instance->modal_basis(0, kept);
  EXPECT_LT(bs.natural_frequencies[0], 1e-6 * wd[1]);
  for (int r = 1; r < 6; ++r)
    EXPECT_NEAR(bs.natural_frequencies[r], wd[static_cast<std::size_t>(r)], 1e-8 * wd[1]);
}

// (5) Bad input.
std::string message_of(const std::string& yaml) {
  try {
    make_provider(yaml);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "accepted";
}

TEST(FeSector, RefusesBadFilesAndMatrices) {
  const Sector s(2, 3, 2, true, 8);
  const Files f(s);
  const std::string ok_k = f.stiffness, ok_m = f.mass;
  auto with = [&](const std::string& mass, const std::string& stiffness, const std::string& rest) {
    return "{mass: '" + mass + "', stiffness: '" + stiffness + "', " + rest + "}";
  };
  const std::string plain = "sectors: 1, modes: 2";
  EXPECT_THAT(message_of(with(ok_m, (f.dir.path() / "missing.mtx").string(), plain)),
              HasSubstr("cannot open the stiffness matrix file"));
  const auto rect = f.dir.write("rect.mtx",
                                "%%MatrixMarket matrix coordinate real general\n"
                                "3 4 2\n1 1 1.0\n3 4 2.0\n");
  EXPECT_THAT(message_of(with(rect.string(), ok_k, plain)), HasSubstr("is 3 x 4, not square"));
  Eigen::MatrixXd bad = s.k;
  bad(0, 1) += 1.0e3;
  const auto unsym = f.dir.write("unsym.mtx", market(bad, false));
  EXPECT_THAT(message_of(with(ok_m, unsym.string(), plain)),
              HasSubstr("the stiffness matrix '" + unsym.string() + "' is not symmetric: entries"));
  const auto garbage = f.dir.write("garbage.mtx", "1 2 3\n");
  EXPECT_THAT(message_of(with(garbage.string(), ok_k, plain)),
              HasSubstr("not a Matrix Market file"));
  const auto complex_file = f.dir.write(
      "complex.mtx", "%%MatrixMarket matrix coordinate complex general\n1 1 1\n1 1 1 0\n");
  EXPECT_THAT(message_of(with(complex_file.string(), ok_k, plain)), HasSubstr("field 'complex'"));
  const auto short_file =
      f.dir.write("short.mtx",
                  "%%MatrixMarket matrix coordinate real symmetric\n2 2 3\n1 1 1.000000000\n"
                  "2 1 0.500000000\n");
  EXPECT_THAT(message_of(with(short_file.string(), ok_k, plain)),
              HasSubstr("short.mtx:4: the file ends after 2 of 3 entries"));
  // Fewer bytes than the announced entries need: refused before anything is allocated.
  const auto huge = f.dir.write(
      "huge.mtx", "%%MatrixMarket matrix coordinate real general\n100000 100000 9000000000\n");
  EXPECT_THAT(message_of(with(huge.string(), ok_k, plain)),
              HasSubstr("huge.mtx:2: the size line announces 9000000000 entries, which the 0 "
                        "bytes after it cannot hold"));
  // Both triangles of a symmetric file: the upper one is not the format's.
  const auto upper = f.dir.write(
      "upper.mtx", "%%MatrixMarket matrix coordinate real symmetric\n2 2 2\n1 1 1\n1 2 0.5\n");
  EXPECT_THAT(message_of(with(upper.string(), ok_k, plain)),
              HasSubstr("upper.mtx:4: entry (1, 2) lies above the diagonal"));
  const auto out_of_range =
      f.dir.write("range.mtx", "%%MatrixMarket matrix coordinate real general\n2 2 1\n3 1 1\n");
  EXPECT_THAT(message_of(with(out_of_range.string(), ok_k, plain)),
              HasSubstr("row 3 is outside [1, 2]"));
  const auto small = f.dir.write("small.mtx", market(Eigen::MatrixXd::Identity(3, 3), true));
  EXPECT_THAT(
      message_of(with(small.string(), ok_k, plain)),
      HasSubstr("the mass matrix has 3 DOFs but the stiffness matrix " + std::to_string(s.n)));
}

// A cyclic_pairs file (as a model pipeline writes) is the same boundary as the inline lists:
// the same full-disk frequencies for every harmonic index; bad lines name the file and line.
TEST(FeSector, CyclicPairsFileIsTheSameBoundaryAsTheInlineLists) {
  const Sector s(3, 4, 4, true, 5);
  const Files f(s);
  std::string pairs = "# left right\n";
  for (std::size_t j = 0; j < s.left.size(); ++j)
    pairs += std::to_string(s.left[j]) + " " + std::to_string(s.right[j]) + "  # pair\n\n";
  const auto pairs_file = f.dir.write("pairs.txt", pairs);
  const std::string files = "{mass: '" + f.mass + "', stiffness: '" + f.stiffness + "', ";
  const int nb = 5;
  auto inline_lists = make_provider(f.params(s, nb, 4));
  auto from_file = make_provider(files + "sectors: " + std::to_string(nb) + ", cyclic_pairs: '" +
                                 pairs_file.string() + "', modes: 4}");
  for (int h = 0; h < nb; ++h) {
    const frichb_modal_basis a = inline_lists.instance->modal_basis(h, s.all_dofs());
    const std::vector<double> wa(a.natural_frequencies, a.natural_frequencies + a.n_modes);
    const frichb_modal_basis b = from_file.instance->modal_basis(h, s.all_dofs());
    const std::vector<double> wb(b.natural_frequencies, b.natural_frequencies + b.n_modes);
    EXPECT_EQ(wa, wb) << "h = " << h;
  }
  // Without the pairs the sectors are uncoupled: another spectrum (the test can fail).
  auto uncoupled = make_provider(files + "sectors: " + std::to_string(nb) + ", modes: 4}");
  EXPECT_NE(uncoupled.instance->modal_basis(1, s.all_dofs()).natural_frequencies[0],
            inline_lists.instance->modal_basis(1, s.all_dofs()).natural_frequencies[0]);

  const auto bad = f.dir.write("bad.txt", "# header\n0 3\n4 seven\n");
  EXPECT_THAT(message_of(files + "sectors: 4, cyclic_pairs: '" + bad.string() + "', modes: 2}"),
              HasSubstr(bad.string() + ":3: expected two DOF indices"));
  const auto three = f.dir.write("three.txt", "0 3 5\n");
  EXPECT_THAT(message_of(files + "sectors: 4, cyclic_pairs: '" + three.string() + "', modes: 2}"),
              HasSubstr(three.string() + ":1: expected two DOF indices"));
  const auto negative = f.dir.write("negative.txt", "-1 3\n");
  EXPECT_THAT(
      message_of(files + "sectors: 4, cyclic_pairs: '" + negative.string() + "', modes: 2}"),
      HasSubstr(negative.string() + ":1: expected two DOF indices (integers >= 0)"));
  EXPECT_THAT(message_of(files + "sectors: 4, cyclic_pairs: '" + pairs_file.string() +
                         "', left_dofs: [0], right_dofs: [3], modes: 2}"),
              HasSubstr("either as cyclic_pairs or as left_dofs/right_dofs, not both"));
  EXPECT_THAT(message_of(files + "sectors: 4, cyclic_pairs: '" +
                         (f.dir.path() / "missing.txt").string() + "', modes: 2}"),
              HasSubstr("cyclic_pairs: cannot open"));
}

TEST(FeSector, RefusesBadBoundaryListsAndCounts) {
  const Sector s(2, 3, 2, true, 9);  // 10 DOFs, left {0, 4}, right {3, 7}
  const Files f(s);
  const std::string files = "{mass: '" + f.mass + "', stiffness: '" + f.stiffness + "', ";
  EXPECT_THAT(message_of(files + "sectors: 4, left_dofs: [0, 4], right_dofs: [3], modes: 2}"),
              HasSubstr("left_dofs has 2 entries but right_dofs has 1"));
  EXPECT_THAT(message_of(files + "sectors: 4, left_dofs: [0, 10], right_dofs: [3, 7], modes: 2}"),
              HasSubstr("left_dofs[1] = DOF 10 is outside [0, 10)"));
  EXPECT_THAT(message_of(files + "sectors: 4, left_dofs: [0, 4.5], right_dofs: [3, 7], modes: 2}"),
              HasSubstr("left_dofs[1] = 4.5"));
  EXPECT_THAT(message_of(files + "sectors: 4, left_dofs: [0, 3], right_dofs: [3, 7], modes: 2}"),
              HasSubstr("DOF 3 is in both left_dofs and right_dofs"));
  EXPECT_THAT(message_of(files + "sectors: 4, left_dofs: [0, 0], right_dofs: [3, 7], modes: 2}"),
              HasSubstr("DOF 0 appears twice in left_dofs"));
  EXPECT_THAT(message_of(files + "sectors: 4, left_dofs: [0, 4], right_dofs: [3, 7], modes: 9}"),
              HasSubstr("modes = 9 exceeds the 8 independent DOFs"));
  EXPECT_THAT(message_of(files + "sectors: 4, left_dofs: [0, 4], right_dofs: [3, 7], modes: 3, "
                                 "modal_damping: [0.1, 0.2]}"),
              HasSubstr("modal_damping has 2 values; give 1 or one per kept mode (modes = 3)"));
  auto p = make_provider(f.params(s, 4, 2));
  const std::vector<std::size_t> bad_kept{0, 10};
  try {
    p.instance->modal_basis(1, bad_kept);
    FAIL() << "DOF 10 accepted";
  } catch (const PluginError& e) {
    EXPECT_THAT(e.what(), HasSubstr("DOF 10 does not exist (the sector matrices have 10 DOFs)"));
  }
  try {
    p.instance->modal_basis(4, s.all_dofs());
    FAIL() << "h = 4 accepted";
  } catch (const PluginError& e) {
    EXPECT_THAT(e.what(), HasSubstr("harmonic index 4 is outside [0, 4)"));
  }
}

// (6) Static residual flexibility. The oracle is the exact receptance at the kept DOFs,
// S (K_h - W^2 M_h)^-1 S^H with S the kept rows of T_h (left DOFs: e^{+i h phi} times the
// right partner's independent DOF).
Eigen::MatrixXcd exact_receptance(const Sector& s, int h, int nb, double w,
                                  const std::vector<std::size_t>& kept) {
  Eigen::MatrixXcd kh, mh;
  s.harmonic(h, nb, kh, mh);
  const cd e = std::polar(1.0, 2.0 * std::numbers::pi * h / nb);
  Eigen::MatrixXcd sel = Eigen::MatrixXcd::Zero(static_cast<Eigen::Index>(kept.size()), s.m_count);
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const int d = static_cast<int>(kept[i]);
    const auto it = std::find(s.left.begin(), s.left.end(), d);
    const auto r = static_cast<Eigen::Index>(i);
    if (it == s.left.end())
      sel(r, s.independent[kept[i]]) = 1.0;
    else
      sel(r, s.independent[static_cast<std::size_t>(
                 s.right[static_cast<std::size_t>(it - s.left.begin())])]) = e;
  }
  const Eigen::MatrixXcd d = kh - w * w * mh;
  return sel * d.lu().solve(sel.adjoint());
}

// A DOF with almost no mass (a mid-side node of a fine contact mesh) raises max_i K_ii / M_ii
// by orders of magnitude; K_h is still regular, and the residual flexibility is still returned:
// the static receptance is exact with it.
TEST(FeSector, ALightDofDoesNotMakeTheStiffnessLookSingular) {
  Sector s(3, 4, 4, true, 5);
  const int light = s.n - 1;  // a blade DOF, not a left one
  s.m.row(light) *= 1e-5;     // D M D with D = diag(1, ..., 1e-5): still positive definite
  s.m.col(light) *= 1e-5;
  const Files f(s);
  const int nb = 6, modes = 5;
  const auto kept = s.all_dofs();
  auto provider = make_provider(f.params(s, nb, modes));
  const std::vector<int> hs{0, 1, 2, 3, 4, 5};
  const ReducedStructure reduced(*provider.instance, kept, hs);
  for (int h : hs) {
    EXPECT_NE(provider.instance->modal_basis(h, kept).residual_flexibility, nullptr) << "h = " << h;
    const Eigen::MatrixXcd exact = exact_receptance(s, h, nb, 0.0, kept);
    Eigen::MatrixXcd r;
    reduced.receptance(h, 0.0, r);
    EXPECT_LT((r - exact).norm() / exact.norm(), 1e-8) << "h = " << h;
  }
}

TEST(FeSector, ResidualFlexibilityCorrectsTheTruncatedReceptance) {
  const Sector s(3, 4, 4, true, 5);  // 19 DOFs, 16 independent
  const Files f(s);
  const int nb = 6, modes = 5;
  const auto kept = s.all_dofs();  // left DOFs included: their rows carry the cyclic phase
  auto with = make_provider(f.params(s, nb, modes));
  auto without = make_provider(f.params(s, nb, modes, ", residual_flexibility: false"));
  for (int h = 0; h < nb; ++h) {
    // Real for h = 0, nb/2; Hermitian with an imaginary part (ABI 1.1 field) otherwise.
    const frichb_modal_basis b = with.instance->modal_basis(h, kept);
    EXPECT_NE(b.residual_flexibility, nullptr) << "h = " << h;
    EXPECT_EQ(b.residual_flexibility_imag != nullptr, h != 0 && h != 3) << "h = " << h;
    EXPECT_EQ(without.instance->modal_basis(h, kept).residual_flexibility, nullptr);
  }
  const std::vector<int> hs{0, 1, 2, 3, 4, 5};
  const ReducedStructure rw(*with.instance, kept, hs), ro(*without.instance, kept, hs);
  for (int h : hs) {
    const Eigen::MatrixXcd exact0 = exact_receptance(s, h, nb, 0.0, kept);
    Eigen::MatrixXcd r;
    rw.receptance(h, 0.0, r);
    const double static_err = (r - exact0).norm() / exact0.norm();
    EXPECT_LT(static_err, 1e-10) << "h = " << h;
    const double w = 0.5 * rw.natural_frequencies(h)(0);
    const Eigen::MatrixXcd exact = exact_receptance(s, h, nb, w, kept);
    rw.receptance(h, w, r);
    const double err_with = (r - exact).norm() / exact.norm();
    ro.receptance(h, w, r);
    const double err_without = (r - exact).norm() / exact.norm();
    EXPECT_GT(err_without, 5.0 * err_with) << "h = " << h;
    std::printf(
        "[ measured ] h = %d, %d of 16 modes, 19 kept DOFs: W = 0 error %.2e with residual "
        "flexibility; W = w1/2 error %.2e with, %.2e without (x%.0f)\n",
        h, modes, static_err, err_with, err_without, err_without / err_with);
  }
  // A complex h with one kept DOF: G_h is 1 x 1 Hermitian, hence real, and is returned.
  const std::vector<std::size_t> one{static_cast<std::size_t>(s.n - 1)};
  const ReducedStructure r1(*with.instance, one, {1});
  Eigen::MatrixXcd r;
  r1.receptance(1, 0.0, r);
  const Eigen::MatrixXcd exact1 = exact_receptance(s, 1, nb, 0.0, one);
  EXPECT_LT(std::abs(r(0, 0) - exact1(0, 0)) / std::abs(exact1(0, 0)), 1e-10);
  // Every mode kept: the correction is zero and is not returned.
  auto all = make_provider(f.params(s, nb, s.m_count));
  EXPECT_EQ(all.instance->modal_basis(0, kept).residual_flexibility, nullptr);
  // Free disk: K_0 is singular (rigid-body mode), K_{nb/2} is not.
  const Sector free_sector(3, 4, 4, false, 12);
  const Files ff(free_sector);
  auto fr = make_provider(ff.params(free_sector, 2, modes));
  EXPECT_EQ(fr.instance->modal_basis(0, kept).residual_flexibility, nullptr);
  EXPECT_NE(fr.instance->modal_basis(1, kept).residual_flexibility, nullptr);
  // ... also with one mode retained (the rigid-body mode itself is the highest retained).
  auto one_mode = make_provider(ff.params(free_sector, 2, 1));
  EXPECT_EQ(one_mode.instance->modal_basis(0, kept).residual_flexibility, nullptr);
  EXPECT_NE(one_mode.instance->modal_basis(1, kept).residual_flexibility, nullptr);
}

// (7) Disk cache.
struct Snapshot {
  std::vector<double> frequencies, damping, real, imag, residual;
  bool operator==(const Snapshot&) const = default;  // bitwise for finite values
};

Snapshot snapshot(StructureInstance& p, int h, const std::vector<std::size_t>& kept) {
  const frichb_modal_basis b = p.modal_basis(h, kept);
  const std::size_t m = b.n_modes, k = kept.size();
  Snapshot out;
  out.frequencies.assign(b.natural_frequencies, b.natural_frequencies + m);
  out.damping.assign(b.modal_damping, b.modal_damping + m * m);
  out.real.assign(b.mode_rows_real, b.mode_rows_real + k * m);
  if (b.mode_rows_imag) out.imag.assign(b.mode_rows_imag, b.mode_rows_imag + k * m);
  if (b.residual_flexibility)
    out.residual.assign(b.residual_flexibility, b.residual_flexibility + k * k);
  return out;
}

std::set<std::filesystem::path> folder(const std::filesystem::path& dir) {
  std::set<std::filesystem::path> out;
  for (const auto& e : std::filesystem::directory_iterator(dir)) out.insert(e.path());
  return out;
}

std::string read_bytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const std::filesystem::path& p, const std::string& data) {
  std::ofstream(p, std::ios::binary | std::ios::trunc) << data;
}

// The documented trailer: FNV-1a 64 of every byte before it.
void reseal(std::string& data) {
  std::uint64_t h = 14695981039346656037ULL;
  for (std::size_t i = 0; i + 8 < data.size(); ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 1099511628211ULL;
  }
  std::memcpy(data.data() + data.size() - 8, &h, 8);
}

TEST(FeSector, DiskCacheIsReadBackValidatedAndKeyedByTheInputs) {
  namespace fs = std::filesystem;
  const Sector s(3, 4, 4, true, 11);
  const Files f(s);
  const int nb = 5, modes = 4;
  const fs::path dir = f.dir.path() / "cache" / "fe";  // created by the provider
  const std::string cached = ", cache_dir: '" + dir.string() + "'";
  const auto kept = s.all_dofs();
  std::vector<Snapshot> first;
  std::vector<fs::path> file_of;
  {
    auto p = make_provider(f.params(s, nb, modes, cached));
    for (int h = 0; h < nb; ++h) {
      const auto before = folder(dir);
      first.push_back(snapshot(*p.instance, h, kept));
      const auto after = folder(dir);
      ASSERT_EQ(after.size(), before.size() + 1) << "h = " << h;  // one file, no temporary
      for (const auto& e : after)
        if (!before.count(e)) file_of.push_back(e);
      EXPECT_EQ(file_of.back().extension(), ".bin");
    }
  }
  EXPECT_FALSE(first[0].residual.empty());
  // Without the cache: bitwise the same.
  auto plain = make_provider(f.params(s, nb, modes));
  for (int h = 0; h < nb; ++h) EXPECT_TRUE(snapshot(*plain.instance, h, kept) == first[h]);
  // Same inputs again: every file is read, none rewritten (mtimes set in the past stay).
  const auto old = fs::file_time_type::clock::now() - std::chrono::hours(24 * 365);
  for (const auto& file : file_of) fs::last_write_time(file, old);
  {
    auto p = make_provider(f.params(s, nb, modes, cached));
    for (int h = 0; h < nb; ++h) EXPECT_TRUE(snapshot(*p.instance, h, kept) == first[h]);
  }
  for (const auto& file : file_of) EXPECT_EQ(fs::last_write_time(file), old);
  EXPECT_EQ(folder(dir).size(), static_cast<std::size_t>(nb));
  // The solution does come from the file: a doctored (resealed) frequency is returned.
  {
    std::string data = read_bytes(file_of[2]);
    double w = 0.0;
    std::memcpy(&w, data.data() + 56, 8);  // header: magic + 6 u64, then the frequencies
    EXPECT_EQ(w, first[2].frequencies[0]);
    w *= 1.5;
    std::memcpy(data.data() + 56, &w, 8);
    reseal(data);
    write_bytes(file_of[2], data);
    auto p = make_provider(f.params(s, nb, modes, cached));
    EXPECT_EQ(p.instance->modal_basis(2, kept).natural_frequencies[0], w);
    fs::remove(file_of[2]);
  }
  // Corrupt (flipped byte, not resealed), truncated, or another key's file under this name:
  // ignored, re-solved (bitwise the same) and rewritten.
  {
    std::string flipped = read_bytes(file_of[1]);
    flipped[200] = static_cast<char>(flipped[200] ^ 0x10);
    write_bytes(file_of[1], flipped);
    const std::string full = read_bytes(file_of[3]);
    write_bytes(file_of[3], full.substr(0, full.size() / 2));
    fs::copy_file(file_of[0], file_of[4], fs::copy_options::overwrite_existing);
    for (int h : {1, 3, 4}) fs::last_write_time(file_of[static_cast<std::size_t>(h)], old);
    auto p = make_provider(f.params(s, nb, modes, cached));
    for (int h = 0; h < nb; ++h) EXPECT_TRUE(snapshot(*p.instance, h, kept) == first[h]);
    for (int h : {1, 3, 4}) {
      EXPECT_NE(fs::last_write_time(file_of[static_cast<std::size_t>(h)]), old) << "h = " << h;
      EXPECT_EQ(fs::file_size(file_of[static_cast<std::size_t>(h)]), full.size());
    }
    EXPECT_EQ(folder(dir).size(), static_cast<std::size_t>(nb));
  }
  // Any change of the inputs changes the key: a new file appears.
  auto new_files = [&](const std::string& params, int h) {
    const auto before = folder(dir);
    auto p = make_provider(params);
    p.instance->modal_basis(h, kept);
    return folder(dir).size() - before.size();
  };
  EXPECT_EQ(new_files(f.params(s, nb, modes + 1, cached), 0), 1U);
  EXPECT_EQ(new_files(f.params(s, nb + 1, modes, cached), 0), 1U);
  EXPECT_EQ(new_files(f.params(s, nb, modes, cached + ", solver: dense"), 0), 1U);
  EXPECT_EQ(new_files(f.params(s, nb, modes, cached + ", modal_damping: [0.01]"), 0), 0U);
  Sector changed = s;
  changed.k(5, 5) *= 1.0 + 1e-12;
  f.dir.write("sector_k.mtx", market(changed.k, true));
  EXPECT_EQ(new_files(f.params(s, nb, modes, cached), 0), 1U);
  f.dir.write("sector_k.mtx", market(s.k, true));
  EXPECT_EQ(new_files(f.params(s, nb, modes, cached), 0), 0U);
  std::printf("[ measured ] %zu cache files of %zu bytes\n", folder(dir).size(),
              static_cast<std::size_t>(fs::file_size(file_of[0])));
}

}  // namespace
