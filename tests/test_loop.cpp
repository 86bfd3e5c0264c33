// `frichb loop` end to end: a Jenkins element under a cosine motion gives the closed-form
// loop energy, and the thesis Fig. 3.2 input traces with separation and many force harmonics.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

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

// Area enclosed by the (T1, T2) friction loop of a loop.csv (shoelace formula).
double tangential_loop_area(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  std::vector<std::pair<double, double>> points;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) v.push_back(std::stod(cell));
    // phase, u_t1, u_t2, u_n, f_t1, f_t2, f_n, status
    points.emplace_back(v.at(4), v.at(5));
  }
  double area = 0;
  for (std::size_t i = 0; i + 1 < points.size(); ++i)
    area += points[i].first * points[i + 1].second - points[i + 1].first * points[i].second;
  return std::abs(0.5 * area);
}

TEST(Loop, EveryShippedThesisInputRuns) {
  frichb::test::TempDir dir;
  int count = 0;
  for (const auto& entry :
       fs::directory_iterator(std::string(FRICHB_SOURCE_DIR) + "/configs/friction_loops")) {
    if (entry.path().extension() != ".yaml") continue;
    ++count;
    const auto out = dir.path() / entry.path().stem();
    ASSERT_EQ(run("loop " + entry.path().string() + " -o " + out.string()), 0) << entry.path();
    const auto summary = read_json(out / "summary.json");
    EXPECT_TRUE(summary["periodic"].get<bool>()) << entry.path();
    EXPECT_GE(summary["dissipated_energy_per_cycle_J"].get<double>(), 0.0) << entry.path();
  }
  EXPECT_GE(count, 6);
}

TEST(Loop, ThesisFigure36VariableStiffnessLoopIsLargerAndPassesThroughTheOrigin) {
  frichb::test::TempDir dir;
  const std::string configs = std::string(FRICHB_SOURCE_DIR) + "/configs/friction_loops/";
  ASSERT_EQ(run("loop " + configs + "fig3_5_2d_variable_stiffness.yaml -o " +
                (dir.path() / "variable").string()),
            0);
  ASSERT_EQ(run("loop " + configs + "fig3_6_constant_stiffness.yaml -o " +
                (dir.path() / "constant").string()),
            0);
  // Separation: the variable-stiffness loop sits at (0, 0) while the contact is open.
  EXPECT_GT(read_json(dir.path() / "variable" / "summary.json")["fraction_open"].get<double>(),
            0.1);
  const double ratio = tangential_loop_area(dir.path() / "variable" / "loop.csv") /
                       tangential_loop_area(dir.path() / "constant" / "loop.csv");
  // The thesis reads "approximately 1.5 times"; these inputs give 1.62 (docs/validation.md).
  EXPECT_GT(ratio, 1.3);
  EXPECT_LT(ratio, 1.8);
  std::printf("Fig. 3.6 loop-area ratio variable / constant stiffness: %.3f\n", ratio);
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
