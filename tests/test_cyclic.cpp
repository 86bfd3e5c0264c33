// Cyclic symmetry: the thesis's Table 5.1, and a lumped bladed disk with shroud friction solved
// by the one-sector cyclic reduction equals the same disk assembled in full (all sectors, no
// symmetry used) at the harmonic-balance level.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "frichb/core/model/harmonic_balance.hpp"
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

constexpr int kSectors = 6, kEngineOrder = 2;

std::string cyclic_scene() {
  return R"(
cyclic: {sectors: 6, engine_order: 2}
structure:
  provider: lumped_cyclic
  params:
    sectors: 6
    masses: [0.5, 0.1]
    springs: [{between: [ground, 0], k: 2.0e6}, {between: [0, 1], k: 4.0e5}]
    coupling: [{between: [0, 0], k: 1.0e5}]
    modal_damping: [0.01]
  dofs: {disk: 0, blade: 1}
excitation: [{dof: blade, amplitude: 2.0}]
contacts:
  - name: shroud
    law: jenkins_1d
    between: [{node: blade, sector: 0}, {node: blade, sector: 1}]
    params: {kt: 1.0e5, mu: 0.5, normal_load: 5.0}
harmonic_balance: {harmonics: [0, 1, 2, 3], samples_per_period: 96}
continuation: {frequency: {from: 200, to: 400}}
output: {response: [blade, disk]}
)";
}

// 96 samples per period: a multiple of nb, so that the time shift between neighbouring
// sectors (m/nb of a period) is a whole number of samples and the sampled stick-slip traces
// of the full disk are exact shifts of the reference one (otherwise the two agree only to the
// AFT's time-discretisation error, about 1e-3 here).

// The same disk with every sector assembled, a contact between each pair of neighbouring
// blades, and the engine-order excitation as phase-shifted forces on every blade.
std::string full_scene() {
  std::ostringstream s;
  s << "structure:\n  provider: lumped\n  params:\n    masses: [";
  for (int k = 0; k < kSectors; ++k) s << (k ? ", " : "") << "0.5, 0.1";
  s << "]\n    springs:\n";
  for (int k = 0; k < kSectors; ++k) {
    const int disk = 2 * k, blade = 2 * k + 1, next_disk = 2 * ((k + 1) % kSectors);
    s << "      - {between: [ground, " << disk << "], k: 2.0e6}\n"
      << "      - {between: [" << disk << ", " << blade << "], k: 4.0e5}\n"
      << "      - {between: [" << disk << ", " << next_disk << "], k: 1.0e5}\n";
  }
  s << "    modal_damping: [0.01]\n  dofs: {";
  for (int k = 0; k < kSectors; ++k)
    s << (k ? ", " : "") << "disk" << k << ": " << 2 * k << ", blade" << k << ": " << 2 * k + 1;
  s << "}\nexcitation:\n";
  // Sector k is forced like the reference delayed by k Delta t: phase -k m 360 / nb degrees.
  for (int k = 0; k < kSectors; ++k)
    s << "  - {dof: blade" << k
      << ", amplitude: 2.0, phase_deg: " << -360.0 * k * kEngineOrder / kSectors << "}\n";
  s << "contacts:\n";
  for (int k = 0; k < kSectors; ++k)
    s << "  - {name: shroud" << k << ", law: jenkins_1d, between: [blade" << k << ", blade"
      << (k + 1) % kSectors << "], params: {kt: 1.0e5, mu: 0.5, normal_load: 5.0}}\n";
  s << "harmonic_balance: {harmonics: [0, 1, 2, 3], samples_per_period: 96}\n"
    << "continuation: {frequency: {from: 200, to: 400}}\noutput: {response: [blade0, disk0]}\n";
  return s.str();
}

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
  Built cyc = build(dir.write("cyclic.yaml", cyclic_scene()), registry);
  Built full = build(dir.write("full.yaml", full_scene()), registry);
  const Eigen::Index n = cyc.model->equation_count();
  ASSERT_EQ(full.model->equation_count(), kSectors * n);

  const auto curve = test::trace_hz(*cyc.model, 200, 400, 2.0);
  ASSERT_TRUE(curve.reached_end()) << curve.message;

  const auto& layout = cyc.model->layout();
  const int c = layout.coefficient_count();
  const double phi = 2 * std::numbers::pi / kSectors;
  double worst_residual = 0, worst_response = 0, scale = 0;
  bool slipped = false;
  for (const auto& p : curve.points) {
    // Contact k of the full disk is the reference contact delayed by k Delta t.
    Eigen::VectorXd y(kSectors * n + 1);
    for (int k = 0; k < kSectors; ++k)
      for (std::size_t h = 0; h < layout.harmonics().size(); ++h) {
        const int nh = layout.harmonics()[h];
        const int ci = layout.cos_index(h), si = layout.sin_index(h);
        const std::complex<double> x(p.y(ci), nh ? -p.y(si) : 0.0);
        const std::complex<double> shifted = x * std::polar(1.0, -nh * kEngineOrder * phi * k);
        y(k * c + ci) = shifted.real();
        if (nh) y(k * c + si) = -shifted.imag();
      }
    y(kSectors * n) = p.y(n);
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

}  // namespace
}  // namespace frichb::core
