// Cyclic symmetry: the thesis's Table 5.1, and a lumped bladed disk with shroud friction solved
// by the one-sector cyclic reduction equals the same disk assembled in full (all sectors, no
// symmetry used) at the harmonic-balance level.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "cyclic_disk.hpp"
#include "fe_lattice.hpp"
#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/model/reduced_structure.hpp"
#include "frichb/core/model/stability.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/solver/continuation.hpp"
#include "test_support.hpp"

namespace frichb::core {
namespace {

TEST(Cyclic, ThesisTable51HarmonicIndexAndNodalDiameter) {
  // nb = 8, m = 3: n -> h = mod(3 n, 8) -> ND (direction), as printed in Table 5.1.
  CyclicSpec c;
  c.sectors = 8;
  c.engine_order = 3;
  const struct {
    int n, h, nd;
    char dir;
  } table[] = {{1, 3, 3, '-'}, {2, 6, 2, '+'}, {3, 1, 1, '-'}, {4, 4, 4, ' '}, {5, 7, 1, '+'},
               {6, 2, 2, '-'}, {7, 5, 3, '+'}, {8, 0, 0, ' '}, {9, 3, 3, '-'}};
  for (const auto& row : table) {
    const int h = c.harmonic_index(row.n);
    EXPECT_EQ(h, row.h) << "n = " << row.n;
    EXPECT_EQ(c.nodal_diameter(h), row.nd) << "n = " << row.n;
    EXPECT_EQ(c.wave_direction(h), row.dir) << "n = " << row.n;
  }
}

// The disk's samples per period (96) are a multiple of nb, so that the time shift between
// neighbouring sectors (m/nb of a period) is a whole number of samples and the sampled
// stick-slip traces of the full disk are exact shifts of the reference one (otherwise the two
// agree only to the AFT's time-discretisation error, about 1e-3 here).
constexpr int kSectors = test::kDiskSectors;

struct Built {
  Scene scene;
  std::unique_ptr<StructureInstance> structure;
  std::unique_ptr<HarmonicBalanceModel> model;
};

Built build(const std::filesystem::path& file, const Registry& registry) {
  Built b;
  b.scene = load_scene(file);
  bind_plugins(b.scene, registry);
  b.structure =
      std::make_unique<StructureInstance>(b.scene.structure.plugin, b.scene.structure.values);
  b.model = std::make_unique<HarmonicBalanceModel>(b.scene, *b.structure);
  return b;
}

TEST(Cyclic, OneSectorReductionEqualsTheFullyAssembledDisk) {
  const Registry registry({FRICHB_PLUGIN_DIR});
  if (!registry.contains("lumped_cyclic")) GTEST_SKIP() << "lumped_cyclic not built";
  test::TempDir dir;
  Built cyc = build(dir.write("cyclic.yaml", test::cyclic_disk_scene()), registry);
  Built full = build(dir.write("full.yaml", test::full_disk_scene()), registry);
  const Eigen::Index n = cyc.model->equation_count();
  ASSERT_EQ(full.model->equation_count(), kSectors * n);

  const auto curve = test::trace_hz(*cyc.model, 200, 400, 2.0);
  ASSERT_TRUE(curve.reached_end()) << curve.message;

  const auto& layout = cyc.model->layout();
  double worst_residual = 0, worst_response = 0, scale = 0;
  bool slipped = false;
  for (const auto& p : curve.points) {
    const Eigen::VectorXd y = test::full_disk_unknowns(layout, p.y);
    Eigen::VectorXd e;
    std::string message;
    ASSERT_TRUE(full.model->evaluate(y, e, nullptr, &message)) << message;
    scale = std::max(scale, y.head(kSectors * n).cwiseAbs().maxCoeff());
    worst_residual = std::max(worst_residual, e.cwiseAbs().maxCoeff());
    // The blade and disk of sector 0 respond alike in both models.
    const auto xc = cyc.model->kept_response(p.y);
    const auto xf = full.model->kept_response(y);
    for (std::size_t h = 0; h < xc.size(); ++h) {
      worst_response =
          std::max({worst_response,
                    std::abs(xc[h](cyc.model->kept_index(1)) - xf[h](full.model->kept_index(1))),
                    std::abs(xc[h](cyc.model->kept_index(0)) - xf[h](full.model->kept_index(0)))});
    }
    // Slip starts where the relative amplitude exceeds mu N / kt = 2.5e-5 m.
    slipped = slipped || std::hypot(p.y(layout.cos_index(1)), p.y(layout.sin_index(1))) > 2.5e-5;
  }
  EXPECT_TRUE(slipped) << "the sweep must reach slip for the comparison to mean something";
  EXPECT_LT(worst_residual, 1e-8 * scale);
  EXPECT_LT(worst_response, 1e-8 * scale);
  std::printf("cyclic vs full disk over %zu points: residual %.2e, response %.2e (scale %.2e m)\n",
              curve.points.size(), worst_residual, worst_response, scale);
}

TEST(Cyclic, ModesWritesTheNodalDiameterMapAndTheEngineOrderExcitation) {
  const Registry registry({FRICHB_PLUGIN_DIR});
  if (!registry.contains("lumped_cyclic")) GTEST_SKIP() << "lumped_cyclic not built";
  test::TempDir dir;
  const std::string command =
      std::string(FRICHB_EXE) + " --log-level warn modes " + FRICHB_SOURCE_DIR +
      "/configs/bladed_disk_lumped_eo3.yaml --rpm 270 -o " + (dir.path() / "modes").string();
  ASSERT_EQ(std::system(command.c_str()), 0);
  std::ifstream modes(dir.path() / "modes" / "modes.csv");
  std::string line;
  int rows = 0;
  std::getline(modes, line);
  while (std::getline(modes, line)) ++rows;
  EXPECT_EQ(rows, 8 * 4);  // 8 harmonic indices x 4 DOFs per sector
  // Excitation at 270 rpm, EO3: harmonic n at n * 3 * 4.5 Hz on the nodal diameter of Table 5.1.
  std::ifstream excitation(dir.path() / "modes" / "excitation.csv");
  std::getline(excitation, line);
  const int nd[] = {3, 2, 1};
  for (int n = 1; n <= 3; ++n) {
    ASSERT_TRUE(std::getline(excitation, line));
    std::stringstream ss(line);
    std::vector<double> v;
    for (std::string cell; std::getline(ss, cell, ',');) v.push_back(std::stod(cell));
    EXPECT_EQ(v.at(0), 270.0);  // rpm
    EXPECT_EQ(v.at(1), n);
    EXPECT_EQ(v.at(3), nd[n - 1]);
    EXPECT_NEAR(v.at(4), n * 3 * 270.0 / 60.0, 1e-9);
  }
}

TEST(Cyclic, AModalTablePathIsResolvedAgainstTheSceneFolder) {
  const Registry registry({FRICHB_PLUGIN_DIR});
  if (!registry.contains("modal_table")) GTEST_SKIP() << "modal_table not built";
  test::TempDir dir;
  std::filesystem::create_directories(dir.path() / "model");
  std::filesystem::copy_file(
      std::string(FRICHB_SOURCE_DIR) + "/structures/modal_table/example/bladed_disk_4.yaml",
      dir.path() / "model" / "table.yaml");
  dir.write("model/scene.yaml", R"(
cyclic: {sectors: 4, engine_order: 1}
structure:
  provider: modal_table
  params: {file: table.yaml, sectors: 4, dof_count: 3, modal_damping: [0.01]}
  dofs: {disk: 0, tip: 2}
excitation: [{dof: tip, amplitude: 1.0}]
harmonic_balance: {harmonics: [1, 2, 3]}
continuation: {frequency: {from: 100, to: 500}}
)");
  // Run from another folder: `table.yaml` must be found beside the scene, not in the cwd.
  const std::string command = "cd " + dir.path().string() + " && " + FRICHB_EXE +
                              " --log-level warn modes model/scene.yaml -o out";
  ASSERT_EQ(std::system(command.c_str()), 0);
  std::ifstream modes(dir.path() / "out" / "modes.csv");
  std::string header, first;
  std::getline(modes, header);
  std::getline(modes, first);
  EXPECT_NE(first.find("199.334"), std::string::npos) << first;
}

TEST(Cyclic, BladedDiskPeakConvergesWithTheNumberOfHarmonics) {
  const Registry registry({FRICHB_PLUGIN_DIR});
  if (!registry.contains("lumped_cyclic")) GTEST_SKIP() << "lumped_cyclic not built";
  std::ifstream in(std::string(FRICHB_SOURCE_DIR) + "/configs/bladed_disk_lumped_eo3.yaml");
  const std::string scene((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string key = "  max_harmonic: 3";
  ASSERT_NE(scene.find(key), std::string::npos);
  test::TempDir dir;
  std::map<int, double> peak;
  for (int h : {1, 3, 5, 10}) {
    std::string text = scene;
    text.replace(text.find(key), key.size(), "  max_harmonic: " + std::to_string(h));
    const auto file = dir.write("h" + std::to_string(h) + ".yaml", text);
    const auto out = dir.path() / ("out" + std::to_string(h));
    const std::string command =
        std::string(FRICHB_EXE) + " --log-level warn run " + file.string() + " -o " + out.string();
    ASSERT_EQ(std::system(command.c_str()), 0) << "H = " << h;
    std::ifstream summary(out / "summary.json");
    const auto doc = nlohmann::json::parse(summary);
    peak[h] = doc["peak"]["tip"]["amplitude_m"].get<double>();
    std::printf("H = %2d: peak %.6e m at %.3f Hz, %d points, %d turning points\n", h, peak[h],
                doc["peak"]["tip"]["frequency_hz"].get<double>(), doc["points"].get<int>(),
                doc["turning_points"].get<int>());
  }
  // The peak settles as harmonics are added (thesis case study 1: the 1F peak barely moves).
  EXPECT_LT(std::abs(peak[5] - peak[10]), 1e-3 * peak[10]);
  EXPECT_LT(std::abs(peak[5] - peak[10]), std::abs(peak[1] - peak[10]));
}

// The Floquet multipliers of nodal diameter h of the disk with its shrouds stuck (a spring kt
// between neighbouring blades): the Bloch wave of h, q'' + C q' + (W^2 + kt P^H P) q = 0 with
// P = G_h Phi_h and G_h = sum over sector offsets o of W_o e^{-i h phi o}; exp(lambda T) of
// its eigenvalues (Eigen's complex solver), each twice for 0 < h < nb/2 (h and nb - h). With
// the contacts' residual flexibility C_h = G_h F_h G_h^H (`flexibility`), the springs see
// u = P q - C_h f: kt P^H P becomes P^H (I / kt + C_h)^-1 P.
std::vector<std::complex<double>> bloch_wave_multipliers(
    const HarmonicBalanceModel& model, int h, double kt, double period,
    const Eigen::MatrixXcd* flexibility = nullptr) {
  const auto& b = model.structure().basis(h);
  const double phi = 2 * std::numbers::pi / kSectors;
  Eigen::MatrixXcd g = Eigen::MatrixXcd::Zero(model.component_count(), b.rows.rows());
  for (int o = -1; o <= 1; ++o)
    g += Eigen::MatrixXd(model.side_gather(o)).cast<std::complex<double>>() *
         std::polar(1.0, -h * phi * o);
  const Eigen::MatrixXcd p = g * b.rows;
  const Eigen::Index r = b.rows.cols();
  Eigen::MatrixXcd a = Eigen::MatrixXcd::Zero(2 * r, 2 * r);
  a.topRightCorner(r, r).setIdentity();
  Eigen::MatrixXcd stiffness = kt * p.adjoint() * p;
  if (flexibility != nullptr) {
    const Eigen::MatrixXcd compliance =
        Eigen::MatrixXcd::Identity(p.rows(), p.rows()) / kt + *flexibility;
    stiffness = p.adjoint() * compliance.lu().solve(p);
  }
  stiffness.diagonal() += b.frequencies.array().square().matrix().cast<std::complex<double>>();
  a.bottomLeftCorner(r, r) = -stiffness;
  a.bottomRightCorner(r, r) = -b.damping.cast<std::complex<double>>();
  const Eigen::VectorXcd lambda = Eigen::ComplexEigenSolver<Eigen::MatrixXcd>(a).eigenvalues();
  std::vector<std::complex<double>> out;
  for (int copy = 0; copy < (h == 0 || 2 * h == kSectors ? 1 : 2); ++copy)
    for (Eigen::Index i = 0; i < lambda.size(); ++i) out.push_back(std::exp(lambda(i) * period));
  return out;
}

// The distance from mu to the nearest of `set`, relative to |mu|.
double nearest_relative(std::complex<double> mu, const std::vector<std::complex<double>>& set) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& s : set) best = std::min(best, std::abs(mu - s) / std::abs(mu));
  return best;
}

// With the shrouds stuck (mu N far above any spring force) the disk is linear: its multipliers
// are those of the Bloch waves of every nodal diameter, each one where its diameter's linear
// system puts it, and each sector's slider offset is neutral. The cyclic stability labels
// every multiplier by its nodal diameter: the label must name the diameter whose closed form
// holds it (the diameters' multipliers are 0.05 rad apart or more here, the step's error
// 1e-3).
TEST(CyclicStability, StuckShroudsGiveEveryNodalDiametersBlochWave) {
  const Registry registry({FRICHB_PLUGIN_DIR});
  if (!registry.contains("lumped_cyclic")) GTEST_SKIP() << "lumped_cyclic not built";
  test::TempDir dir;
  test::DiskOptions o;
  o.params = "{kt: 1.0e5, mu: 0.5, normal_load: 1.0e6}";
  o.samples = 192;
  o.stability = true;
  o.from_hz = 290;
  o.to_hz = 300;
  Built cyc = build(dir.write("cyclic.yaml", test::cyclic_disk_scene(o)), registry);
  const auto curve = test::trace_hz(*cyc.model, o.from_hz, o.to_hz, 2.0);
  ASSERT_TRUE(curve.reached_end()) << curve.message;
  const Eigen::VectorXd& y = curve.points.back().y;
  const double period = 2 * std::numbers::pi / y(y.size() - 1);
  const FloquetMultipliers f = floquet_multipliers(*cyc.model, y);
  ASSERT_TRUE(f.failure.empty()) << f.failure;
  EXPECT_EQ(f.neutral.size(), std::size_t{kSectors});  // each sector's slider
  ASSERT_EQ(f.multipliers.size(), 24u);                // 12 modes of the disk, twice
  ASSERT_EQ(f.nodal_diameters.size(), f.multipliers.size());
  std::vector<std::vector<std::complex<double>>> exact;
  for (int h = 0; 2 * h <= kSectors; ++h)
    exact.push_back(bloch_wave_multipliers(*cyc.model, h, 1.0e5, period));
  double worst = 0, separation = std::numeric_limits<double>::infinity();
  std::vector<std::size_t> count(exact.size(), 0);
  for (std::size_t k = 0; k < f.multipliers.size(); ++k) {
    const int h = f.nodal_diameters[k];
    ASSERT_GE(h, 0);
    ASSERT_LT(h, static_cast<int>(exact.size()));
    ++count[static_cast<std::size_t>(h)];
    worst = std::max(worst, nearest_relative(f.multipliers[k], exact[static_cast<std::size_t>(h)]));
    for (std::size_t other = 0; other < exact.size(); ++other)
      if (static_cast<int>(other) != h)
        separation = std::min(separation, nearest_relative(f.multipliers[k], exact[other]));
  }
  for (std::size_t h = 0; h < exact.size(); ++h)
    EXPECT_EQ(count[h], exact[h].size()) << "nodal diameter " << h;
  std::printf(
      "stuck shrouds: multipliers vs their nodal diameter's Bloch wave %.2e, vs the "
      "nearest of another diameter %.2e\n",
      worst, separation);
  EXPECT_LT(worst, 2e-3);
  EXPECT_GT(separation, 10 * worst);
  EXPECT_TRUE(f.stable());
}

// An FE sector (tests/fe_lattice.hpp: 19 DOFs, 16 independent) with 5 of its 16 modes per
// nodal diameter and the static residual flexibility of the rest, and two stuck 1D contacts to
// the next sector (blade tip to blade tip, and the tip to the next blade's DOF below its tip, so
// that C_h = G_h F_h G_h^H has complex off-diagonal entries): the flexibility has no mass behind
// it, and the variational equations carry it as an algebraic constraint u = P q - F f. Each
// multiplier against its nodal diameter's closed form with C_h, which the test gathers itself
// from the provider's F_h (not through the model's assembly of the disk's flexibility); and the
// farthest multiplier from the same closed form without C_h, or with C_h conjugated (the
// opposite cyclic phase), at the diameters 0 < h < nb/2 for the latter.
struct FlexibleSectorErrors {
  double worst = 0, without = 0, conjugated = 0;
};

FlexibleSectorErrors flexible_sector_errors(int samples) {
  FlexibleSectorErrors out;
  const Registry registry({FRICHB_PLUGIN_DIR});
  test::TempDir dir;
  const test::Sector sector(3, 4, 4, true, 5);
  const auto mass = dir.write("sector_m.mtx", test::market(sector.m, false));
  const auto stiffness = dir.write("sector_k.mtx", test::market(sector.k, true));
  constexpr double kt = 2.0e5;
  const int tip = sector.n - 1;
  auto contact = [&](const std::string& name, const std::string& other) {
    std::ostringstream c;
    c << "  - {name: " << name
      << ", law: jenkins_1d, between: [{node: tip, sector: 0}, {node: " << other
      << ", sector: 1}], frame: {tangent1: [1.0]}, params: {kt: " << kt
      << ", mu: 0.5, normal_load: 1.0e6}}\n";
    return c.str();
  };
  std::ostringstream scene;
  scene << "cyclic: {sectors: " << kSectors << ", engine_order: 2}\n"
        << "structure:\n  provider: fe_sector\n  params:\n    mass: '" << mass.string()
        << "'\n    stiffness: '" << stiffness.string() << "'\n    sectors: " << kSectors
        << "\n    left_dofs: " << test::list(sector.left)
        << "\n    right_dofs: " << test::list(sector.right)
        << "\n    modes: 5\n    modal_damping: [0.01]\n"
        << "  dofs: {tip: " << tip << ", below_tip: " << tip - 1 << "}\n"
        << "excitation: [{dof: tip, amplitude: 1.0}]\ncontacts:\n"
        << contact("shroud", "tip") << contact("lug", "below_tip")
        << "harmonic_balance: {harmonics: [0, 1, 2, 3], samples_per_period: " << samples << "}\n"
        << "continuation: {frequency: {from: 500, to: 510}}\n"
        << "output: {response: [tip], stability: true}\n";
  Built cyc = build(dir.write("cyclic.yaml", scene.str()), registry);
  const auto curve = test::trace_hz(*cyc.model, 500, 510, 2.0);
  EXPECT_TRUE(curve.reached_end()) << curve.message;
  const Eigen::VectorXd& y = curve.points.back().y;
  const double period = 2 * std::numbers::pi / y(y.size() - 1);
  const FloquetMultipliers f = floquet_multipliers(*cyc.model, y);
  EXPECT_TRUE(f.failure.empty()) << f.failure;
  EXPECT_EQ(f.neutral.size(), std::size_t{2 * kSectors});          // each contact's slider
  EXPECT_EQ(f.multipliers.size(), std::size_t{2 * 5 * kSectors});  // 5 modes a diameter, twice
  const std::vector<int> diameters{0, 1, 2, 3};
  const ReducedStructure whole(*cyc.structure, cyc.model->structure().kept_dofs(), diameters);
  const double phi = 2 * std::numbers::pi / kSectors;
  out.without = out.conjugated = std::numeric_limits<double>::infinity();
  for (int h : diameters) {
    Eigen::MatrixXcd g = Eigen::MatrixXcd::Zero(
        cyc.model->component_count(), static_cast<Eigen::Index>(whole.kept_dofs().size()));
    for (int o = -1; o <= 1; ++o)
      g += Eigen::MatrixXd(cyc.model->side_gather(o)).cast<std::complex<double>>() *
           std::polar(1.0, -h * phi * o);
    const auto& flexibility = whole.basis(h).residual_flexibility;
    EXPECT_GT(flexibility.size(), 0) << "nodal diameter " << h;
    const Eigen::MatrixXcd c = g * flexibility * g.adjoint(), c_conjugated = c.conjugate();
    const auto exact = bloch_wave_multipliers(*cyc.model, h, kt, period, &c);
    const auto stiff = bloch_wave_multipliers(*cyc.model, h, kt, period);
    const auto mirrored = bloch_wave_multipliers(*cyc.model, h, kt, period, &c_conjugated);
    double far_stiff = 0, far_mirrored = 0;
    for (std::size_t k = 0; k < f.multipliers.size() && k < f.nodal_diameters.size(); ++k) {
      if (f.nodal_diameters[k] != h) continue;
      out.worst = std::max(out.worst, nearest_relative(f.multipliers[k], exact));
      far_stiff = std::max(far_stiff, nearest_relative(f.multipliers[k], stiff));
      far_mirrored = std::max(far_mirrored, nearest_relative(f.multipliers[k], mirrored));
    }
    out.without = std::min(out.without, far_stiff);
    if (h != 0 && 2 * h != kSectors) out.conjugated = std::min(out.conjugated, far_mirrored);
  }
  std::printf(
      "stuck contacts on a residual flexibility, %d samples: multipliers vs their nodal "
      "diameter's closed form %.2e; that closed form without the flexibility %.2e away, with "
      "it conjugated %.2e\n",
      samples, out.worst, out.without, out.conjugated);
  return out;
}

// The step is second order: the error falls 4 times from 384 to 768 samples (measured 6.63e-3,
// 1.66e-3; 4.15e-4 at 1536), to the closed form with the flexibility and away from the others.
TEST(CyclicStability, StuckContactsOnAResidualFlexibilityGiveEveryNodalDiametersBlochWave) {
  const Registry registry({FRICHB_PLUGIN_DIR});
  if (!registry.contains("fe_sector")) GTEST_SKIP() << "fe_sector not built";
  const FlexibleSectorErrors coarse = flexible_sector_errors(384),
                             fine = flexible_sector_errors(768);
  EXPECT_LT(fine.worst, 2.5e-3);
  EXPECT_NEAR(coarse.worst / fine.worst, 4.0, 0.4);
  EXPECT_GT(fine.without, 20 * fine.worst);
  EXPECT_GT(fine.conjugated, 20 * fine.worst);
}

// The cyclic stability against the whole disk assembled (lumped, every sector's shroud its own
// contact, no symmetry used) at the same orbit: the disk's multipliers and neutral ones agree
// point by point along the curve, through stick and slip, to rounding (1.1e-14; the degenerate
// standing pairs of nodal diameters 1 and 2 among them).
TEST(CyclicStability, SlippingShroudsAgreeWithTheFullyAssembledDisk) {
  const Registry registry({FRICHB_PLUGIN_DIR});
  if (!registry.contains("lumped_cyclic")) GTEST_SKIP() << "lumped_cyclic not built";
  // Engine order 2 (gcd 2 with 6 sectors: a third of the period integrated, then turned) and 1
  // (coprime: a sixth).
  for (const int engine_order : {2, 1}) {
    test::TempDir dir;
    test::DiskOptions o;
    o.engine_order = engine_order;
    o.stability = true;
    Built cyc = build(dir.write("cyclic.yaml", test::cyclic_disk_scene(o)), registry);
    Built full = build(dir.write("full.yaml", test::full_disk_scene(o)), registry);
    const auto curve = test::trace_hz(*cyc.model, o.from_hz, o.to_hz, 2.0);
    ASSERT_TRUE(curve.reached_end()) << curve.message;
    const auto& layout = cyc.model->layout();
    double worst = 0;
    int slipping = 0, compared = 0, split = 0;
    for (std::size_t i = 0; i < curve.points.size(); i += 7) {
      const Eigen::VectorXd& y = curve.points[i].y;
      const FloquetMultipliers fc = floquet_multipliers(*cyc.model, y);
      const FloquetMultipliers ff =
          floquet_multipliers(*full.model, test::full_disk_unknowns(layout, y, engine_order));
      ASSERT_TRUE(fc.failure.empty()) << fc.failure;
      ASSERT_TRUE(ff.failure.empty()) << ff.failure;
      ASSERT_EQ(fc.multipliers.size(), ff.multipliers.size()) << "point " << i;
      ASSERT_EQ(fc.neutral.size(), ff.neutral.size()) << "point " << i;
      // Absolute: the multipliers that slip makes tiny (1e-10 and less) are rounding apart.
      for (const auto& mu : fc.multipliers)
        worst = std::max(worst, nearest_relative(mu, ff.multipliers) * std::abs(mu));
      for (const auto& mu : ff.multipliers)
        worst = std::max(worst, nearest_relative(mu, fc.multipliers) * std::abs(mu));
      EXPECT_EQ(fc.stable(), ff.stable());
      EXPECT_EQ(fc.split_steps, ff.split_steps) << "point " << i;
      slipping += fc.split_steps > 0 ? 1 : 0;
      split = std::max(split, fc.split_steps);
      ++compared;
    }
    std::printf(
        "engine order %d: cyclic vs full disk multipliers over %d points (%d with slip "
        "switches, up to %d split steps): %.2e\n",
        engine_order, compared, slipping, split, worst);
    EXPECT_GT(slipping, 3);
    EXPECT_LT(worst, 1e-12);
  }
}

// A hardening shroud (f = k3 u^3 between neighbouring blades, a test plugin) bends the disk's
// resonance and folds its curve. Before the first fold the engine-order-2 wave (nodal
// diameters 0 and 2 in its harmonics) loses stability to a perturbation of nodal diameter 1,
// which its response never holds (the shroud's stiffness, modulated by the wave, pumps the
// standing pair of diameter 1): a real multiplier crosses +1 at 263.5 Hz. The cyclic stability
// finds it and names its diameter, and the whole disk assembled gives the same multipliers on
// both sides of the crossing.
TEST(CyclicStability, HardeningShroudLosesStabilityInTheNodalDiameterTheFullDiskConfirms) {
  const Registry registry({FRICHB_PLUGIN_DIR, FRICHB_TEST_PLUGIN_DIR});
  if (!registry.contains("lumped_cyclic") || !registry.contains("hardening_spring"))
    GTEST_SKIP() << "lumped_cyclic or hardening_spring not built";
  test::TempDir dir;
  test::DiskOptions o;
  o.law = "hardening_spring";
  o.params = "{k: 0.0, k3: 2.0e12}";
  o.harmonics = "[1, 3, 5]";
  o.stability = true;
  o.from_hz = 250;
  o.to_hz = 450;
  Built cyc = build(dir.write("cyclic.yaml", test::cyclic_disk_scene(o)), registry);
  Built full = build(dir.write("full.yaml", test::full_disk_scene(o)), registry);
  const auto curve = test::trace_hz(*cyc.model, o.from_hz, o.to_hz, 2.0);
  ASSERT_TRUE(curve.reached_end()) << curve.message;
  const Eigen::Index n = cyc.model->equation_count();
  std::size_t first_unstable = 0, first_turn = 0;
  int diameter = -1;
  for (std::size_t i = 1; i < curve.points.size(); ++i) {
    if (first_turn == 0 && curve.points[i - 1].tangent(n) * curve.points[i].tangent(n) < 0)
      first_turn = i;
    const FloquetMultipliers f = floquet_multipliers(*cyc.model, curve.points[i].y);
    ASSERT_TRUE(f.failure.empty()) << f.failure;
    if (!f.stable()) {
      first_unstable = i;
      diameter = f.nearest_unstable_nodal_diameter;
      break;
    }
  }
  ASSERT_GT(first_unstable, 0u) << "the curve never lost stability";
  const double hz = curve.points[first_unstable].y(n) / (2 * std::numbers::pi);
  std::printf(
      "hardening shroud: first unstable at point %zu (%.3f Hz; first turning point %zu), "
      "nodal diameter %d\n",
      first_unstable, hz, first_turn, diameter);
  EXPECT_EQ(first_turn, 0u) << "the loss of stability comes before the first fold";
  EXPECT_EQ(diameter, 1);
  const auto& layout = cyc.model->layout();
  for (const std::size_t i : {first_unstable - 1, first_unstable}) {
    const Eigen::VectorXd& y = curve.points[i].y;
    const FloquetMultipliers fc = floquet_multipliers(*cyc.model, y);
    const FloquetMultipliers ff =
        floquet_multipliers(*full.model, test::full_disk_unknowns(layout, y));
    ASSERT_TRUE(ff.failure.empty()) << ff.failure;
    EXPECT_EQ(fc.stable(), ff.stable()) << "point " << i;
    EXPECT_EQ(fc.unstable_count, ff.unstable_count) << "point " << i;
    EXPECT_NEAR(fc.largest_modulus, ff.largest_modulus, 1e-10) << "point " << i;
    std::printf("  point %zu: largest |mu| %.9f cyclic, %.9f full disk\n", i, fc.largest_modulus,
                ff.largest_modulus);
  }
}

}  // namespace
}  // namespace frichb::core
