// `frichb timesim` against harmonic balance: the shipped 1-DOF and 2-DOF scenes, first-harmonic
// amplitude of the response within 1 % at several frequencies including the peaks.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>

#include "frichb/core/continuation.hpp"
#include "frichb/core/harmonic_balance.hpp"
#include "frichb/core/scene.hpp"
#include "test_support.hpp"

namespace frichb::core {
namespace {

// First-harmonic amplitude of `node` by harmonic balance, traced from the scene's start to f.
double harmonic_balance_h1(const std::string& scene_file, const std::string& node, double f) {
  Scene scene = load_scene(scene_file);
  bind_plugins(scene, test::built_plugins());
  StructureInstance structure(scene.structure.plugin, scene.structure.values);
  HarmonicBalanceModel model(scene, structure);
  const auto curve = test::trace_hz(model, scene.continuation.from, f, 2.0);
  EXPECT_TRUE(curve.reached_end()) << curve.message;
  const auto x = model.kept_response(curve.points.back().y);
  const auto& h = model.layout().harmonics();
  const auto k = static_cast<std::size_t>(std::find(h.begin(), h.end(), 1) - h.begin());
  return std::abs(x[k](model.kept_index(scene.structure.find(node)->dofs[0])));
}

double timesim_h1(const std::string& scene_file, const std::string& node, double f,
                  const std::filesystem::path& out) {
  const std::string command = std::string(FRICHB_EXE) + " --log-level warn timesim " + scene_file +
                              " --at-hz " + std::to_string(f) + " -o " + out.string();
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
  std::ifstream in(out / "summary.json");
  const auto doc = nlohmann::json::parse(in);
  EXPECT_TRUE(doc["periodic"].get<bool>());
  return doc["response"][node]["harmonic_amplitudes_m"]["1"].get<double>();
}

struct Case {
  const char* scene;
  const char* node;
  double frequency_hz;
};

class TimesimVersusHarmonicBalance : public ::testing::TestWithParam<Case> {};

TEST_P(TimesimVersusHarmonicBalance, FirstHarmonicAgreesWithinOnePercent) {
  const Case c = GetParam();
  const std::string scene = std::string(FRICHB_SOURCE_DIR) + "/configs/" + c.scene;
  test::TempDir dir;
  const double hb = harmonic_balance_h1(scene, c.node, c.frequency_hz);
  const double ti = timesim_h1(scene, c.node, c.frequency_hz, dir.path() / "out");
  std::printf("%s %s at %.1f Hz: HB %.6e m, time integration %.6e m (%+.3f %%)\n", c.scene, c.node,
              c.frequency_hz, hb, ti, 100 * (hb - ti) / ti);
  EXPECT_NEAR(hb, ti, 0.01 * ti);
}

INSTANTIATE_TEST_SUITE_P(
    ShippedScenes, TimesimVersusHarmonicBalance,
    ::testing::Values(Case{"quickstart_friction_oscillator.yaml", "blade", 300.0},
                      Case{"quickstart_friction_oscillator.yaml", "blade", 348.0},  // the peak
                      Case{"quickstart_friction_oscillator.yaml", "blade", 400.0},
                      Case{"two_dof_blade_damper.yaml", "blade", 250.0},
                      Case{"two_dof_blade_damper.yaml", "blade", 298.0},  // the peak
                      Case{"two_dof_blade_damper.yaml", "damper", 330.0}));

}  // namespace
}  // namespace frichb::core
