// `frichb timesim` against harmonic balance: the shipped 1-DOF and 2-DOF scenes, first-harmonic
// amplitude of the response within 1 % at several frequencies including the peaks.
#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>

#include "frichb/core/commands/timesim.hpp"
#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/solver/continuation.hpp"
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

// The library entry point on a scene loaded in process gives what the command line writes to
// summary.json for the same scene and frequency (one code path), and refuses a cyclic scene.
TEST(SimulateInTime, MatchesTheCommandLineSummaryAndRefusesCyclicScenes) {
  const std::string file =
      std::string(FRICHB_SOURCE_DIR) + "/configs/quickstart_friction_oscillator.yaml";
  const double f = 348.0;
  Scene scene = load_scene(file);
  bind_plugins(scene, test::built_plugins());
  TimesimOptions options;
  options.frequency_hz = f;
  const TimesimResult result = simulate_in_time(scene, options);

  test::TempDir dir;
  const auto out = dir.path() / "out";
  const std::string command = std::string(FRICHB_EXE) + " --log-level warn timesim " + file +
                              " --at-hz " + std::to_string(f) + " -o " + out.string();
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  std::ifstream in(out / "summary.json");
  const auto doc = nlohmann::json::parse(in);
  EXPECT_EQ(result.periodic, doc["periodic"].get<bool>());
  EXPECT_EQ(result.periods, doc["periods"].get<int>());
  ASSERT_EQ(result.nodes.size(), 1u);
  const auto& node = result.nodes[0];
  EXPECT_EQ(node.node, "blade");
  const auto& expected = doc["response"]["blade"];
  const double amplitude = expected["amplitude_m"].get<double>();
  EXPECT_GT(amplitude, 0.0);
  EXPECT_NEAR(node.amplitude_m, amplitude, 1e-12 * amplitude);
  const double half_p2p = expected["half_peak_to_peak_m"].get<double>();
  EXPECT_NEAR(node.half_peak_to_peak_m, half_p2p, 1e-12 * half_p2p);
  ASSERT_EQ(node.harmonic_amplitudes_m.size(), result.harmonics.size());
  for (std::size_t k = 0; k < result.harmonics.size(); ++k) {
    const double h =
        expected["harmonic_amplitudes_m"][std::to_string(result.harmonics[k])].get<double>();
    EXPECT_NEAR(node.harmonic_amplitudes_m[k], h, 1e-12 * amplitude) << result.harmonics[k];
  }
  ASSERT_EQ(result.time_s.size(), static_cast<std::size_t>(options.steps_per_period));
  ASSERT_EQ(node.samples_m.size(), 1u);
  EXPECT_EQ(node.samples_m[0].size(), result.time_s.size());

  Scene cyclic =
      load_scene(std::string(FRICHB_SOURCE_DIR) + "/configs/bladed_disk_lumped_eo3.yaml");
  bind_plugins(cyclic, test::built_plugins());
  try {
    simulate_in_time(cyclic, options);
    ADD_FAILURE() << "a cyclic scene was integrated";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.key_path(), "cyclic");
  }
}

// A stop requested while the structure is integrated ends the integration after the period
// under way: the outcome says interrupted (128 + the signal) and how many periods were done.
TEST(SimulateInTime, AStopEndsTheIntegrationAfterItsPeriod) {
  Scene scene =
      load_scene(std::string(FRICHB_SOURCE_DIR) + "/configs/quickstart_friction_oscillator.yaml");
  bind_plugins(scene, test::built_plugins());
  const StopSource source;
  TimesimOptions options;
  options.frequency_hz = 348.0;
  options.stop = source.token();
  source.request_stop(SIGTERM);
  const TimesimResult stopped = simulate_in_time(scene, options);
  EXPECT_EQ(stopped.outcome.status, 128 + SIGTERM);
  EXPECT_EQ(stopped.outcome.termination, "interrupted");
  EXPECT_EQ(stopped.outcome.message, "interrupted by signal 15 after 0 periods");
  EXPECT_EQ(stopped.periods, 0);
  EXPECT_FALSE(stopped.periodic);
}

}  // namespace
}  // namespace frichb::core
