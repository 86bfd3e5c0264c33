// `frichb loop` end to end: a Jenkins element under a cosine motion gives the closed-form
// loop energy, and the thesis Fig. 3.2 input traces with separation and many force harmonics.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "test_support.hpp"

namespace {

namespace fs = std::filesystem;

int run(const std::string& args) {
  const std::string command = std::string(FRICHB_EXE) + " --log-level warn " + args + " 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

TEST(Loop, JenkinsCosineMotionGivesTheClosedFormEnergy) {
  frichb::test::TempDir dir;
  // kt = 2, mu N = 0.5: slip above a = 0.25; a = 1 gives 4 mu N (a - mu N / kt) = 1.5 J.
  const auto input = dir.write("cosine.yaml", R"(
law: jenkins_1d
params: {kt: 2.0, mu: 0.5, normal_load: 1.0}
motion:
  t1: [{harmonic: 1, amplitude: 1.0, function: cos}]
sampling: {max_harmonic: 9, samples_per_period: 4000}
)");
  ASSERT_EQ(run("loop " + input.string() + " -o " + (dir.path() / "out").string()), 0);
  const auto summary = read_json(dir.path() / "out" / "summary.json");
  EXPECT_NEAR(summary["dissipated_energy_per_cycle_J"].get<double>(), 1.5, 1e-5);
  EXPECT_TRUE(summary["periodic"].get<bool>());
  // Odd harmonics only: a symmetric hysteresis under a pure cosine.
  for (int h : summary["significant_force_harmonics"]["t1"]) EXPECT_EQ(h % 2, 1) << h;
  EXPECT_TRUE(fs::is_regular_file(dir.path() / "out" / "loop.csv"));
  EXPECT_TRUE(fs::is_regular_file(dir.path() / "out" / "harmonics.csv"));
}

TEST(Loop, ThesisFigure32SeparatesAndHasAtLeastSixForceHarmonics) {
  frichb::test::TempDir dir;
  const std::string input = std::string(FRICHB_SOURCE_DIR) +
                            "/configs/friction_loops/fig3_2_1d_variable_normal_load.yaml";
  ASSERT_EQ(run("loop " + input + " -o " + (dir.path() / "out").string()), 0);
  const auto summary = read_json(dir.path() / "out" / "summary.json");
  // N = 0.6 + 0.8 cos - 0.2 cos 3...: the contact opens part of the period.
  EXPECT_GT(summary["fraction_open"].get<double>(), 0.2);
  EXPECT_GT(summary["dissipated_energy_per_cycle_J"].get<double>(), 0.0);
  // Three harmonics in the motion, at least six significant in the friction force.
  EXPECT_GE(summary["significant_force_harmonics"]["t1"].size(), 6u);
}

TEST(Loop, BadInputIsRefusedWithItsLocation) {
  frichb::test::TempDir dir;
  const auto input = dir.write("bad.yaml", R"(
law: jenkins_1d
params: {kt: 2.0, mu: 0.5, normal_load: 1.0}
motion:
  t1: [{harmonic: 1, amplitud: 1.0}]
)");
  const std::string command = std::string(FRICHB_EXE) + " loop " + input.string() + " -o " +
                              (dir.path() / "out").string() + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string text;
  char buffer[512];
  while (fgets(buffer, sizeof buffer, pipe)) text += buffer;
  const int status = pclose(pipe);
  EXPECT_EQ(WEXITSTATUS(status), 2) << text;
  EXPECT_NE(text.find("bad.yaml:5:"), std::string::npos) << text;
  EXPECT_NE(text.find("motion.t1[0].amplitud"), std::string::npos) << text;
  EXPECT_NE(text.find("did you mean 'amplitude'"), std::string::npos) << text;
  EXPECT_FALSE(fs::exists(dir.path() / "out"));
}

}  // namespace
