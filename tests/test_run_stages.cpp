// The stages of a run called from C++ without the command line, as a Python binding or a
// program of its own would: prepare_run, find_start_point, trace_response, tabulate_response,
// solve_friction_loops. Oracles: the closed-form peak of a damped one-DOF oscillator for a
// linear scene; the files run_bound_scene writes for the quick-start scene (the same stages
// composed by the program); a scene error located at its key.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <latch>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/numerics/dense_lu.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/plugin_host/schema.hpp"
#include "frichb/core/report/run_report.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/support/interrupt.hpp"
#include "test_support.hpp"

namespace {

namespace fs = std::filesystem;
using namespace frichb::core;

Scene bound_scene(const fs::path& file, const Registry& registry) {
  Scene scene = load_scene(file);
  bind_plugins(scene, registry);
  return scene;
}

std::vector<std::vector<double>> read_csv_numbers(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);  // header
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::stringstream cells(line);
    std::string cell;
    while (std::getline(cells, cell, ',')) row.push_back(std::stod(cell));
    rows.push_back(row);
  }
  return rows;
}

// One DOF on a spring to ground, no contact (m = 0.1 kg, k = 4e5 N/m, zeta = 0.005, F = 2 N),
// swept over 250-450 Hz; `dof` is the DOF the node `blade` names (line 10 of the text).
std::string one_dof_scene(int dof) {
  return R"(
name: linear_oscillator
structure:
  provider: lumped
  params:
    masses: [0.1]
    springs:
      - {between: [ground, 0], k: 4.0e5}
    modal_damping: [0.005]
  dofs: {blade: )" +
         std::to_string(dof) + R"(}
excitation:
  - {dof: blade, amplitude: 2.0, harmonic: 1}
harmonic_balance: {max_harmonic: 1, samples_per_period: 16}
continuation:
  frequency: {from: 250, to: 450, unit: Hz}
  step: {initial: 1.0, min: 1.0e-5, max: 2.0}
output: {response: [blade], plots: false}
)";
}

// One DOF, m x'' + 2 zeta w_n m x' + k x = F cos(w t), no contact: the curve is sampled and its
// refined peak is F / (2 zeta k sqrt(1 - zeta^2)) at w_n sqrt(1 - 2 zeta^2).
TEST(RunStages, LinearSceneMeetsTheClosedFormPeak) {
  constexpr double kMass = 0.1, kStiffness = 4e5, kZeta = 0.005, kForce = 2.0;
  frichb::test::TempDir dir;
  const fs::path file = dir.write("linear.yaml", one_dof_scene(0));
  const Registry registry(Registry::default_search_path({FRICHB_PLUGIN_DIR}));
  const Scene scene = bound_scene(file, registry);
  const PreparedRun run = prepare_run(scene, 1);
  ASSERT_EQ(run.model->equation_count(), 0);
  const auto& options = run.setup.options;
  const Eigen::VectorXd start = find_start_point(*run.model, options);
  const ContinuationSummary summary = trace_response(scene, *run.model, options, start);
  ASSERT_TRUE(summary.reached_end()) << summary.message;
  const ResponseTable table = tabulate_response(scene, *run.model, options, summary);
  ASSERT_EQ(table.peaks.size(), 1u);
  ASSERT_TRUE(table.peaks[0].has_value());
  EXPECT_TRUE(table.peaks[0]->refined);

  const double wn = std::sqrt(kStiffness / kMass);
  const double peak = kForce / (2 * kZeta * kStiffness * std::sqrt(1 - kZeta * kZeta));
  const double at = wn * std::sqrt(1 - 2 * kZeta * kZeta);
  // The amplitude is the series' own maximum over the period, and the peak is solved until
  // what it can still rise is below 1e-10 of it: near the peak the amplitude falls as
  // 1 - x^2 / 2 (x: distance in half-widths zeta w_n), so the frequency is within
  // sqrt(2e-10) half-widths.
  EXPECT_NEAR(table.peaks[0]->amplitude_m / peak, 1.0, 1e-10);
  EXPECT_NEAR(table.peaks[0]->omega_rad_s / at, 1.0, kZeta * std::sqrt(2e-10));
  // The resonance band put a sample within 0.1 half-widths of the peak.
  const double half_width = kZeta * wn;
  double nearest = 1e300;
  for (const auto& p : summary.points) nearest = std::min(nearest, std::abs(p.y(0) - at));
  EXPECT_LT(nearest, 0.1 * half_width);
}

// The quick-start scene through the stages gives what `frichb run` writes (the same points,
// every number of response.csv, the same peaks), and its friction loops meet the Jenkins
// element's closed form.
TEST(RunStages, StagesGiveTheFilesOfTheComposedRun) {
  const fs::path file = fs::path(FRICHB_SOURCE_DIR) / "configs/quickstart_friction_oscillator.yaml";
  const Registry registry(Registry::default_search_path({FRICHB_PLUGIN_DIR}));
  const Scene scene = bound_scene(file, registry);

  const PreparedRun run = prepare_run(scene, 1);
  const auto& options = run.setup.options;
  const Eigen::VectorXd start = find_start_point(*run.model, options, spdlog::level::debug);
  const ContinuationSummary summary = trace_response(scene, *run.model, options, start);
  ASSERT_TRUE(summary.reached_end()) << summary.message;
  const ResponseTable table = tabulate_response(scene, *run.model, options, summary);
  const std::vector<FrictionLoop> loops = solve_friction_loops(scene, *run.model, options, summary);

  frichb::test::TempDir dir;
  RunOptions quiet;
  quiet.quiet = true;
  quiet.plots = 0;
  const RunOutcome outcome = run_bound_scene(scene, dir.path() / "out", quiet);
  ASSERT_EQ(outcome.exit_code, kExitOk) << outcome.message;
  EXPECT_EQ(outcome.points, summary.points.size());
  const auto rows = read_csv_numbers(dir.path() / "out" / "response.csv");
  ASSERT_EQ(rows.size(), table.rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].size(), table.rows[i].size());
    for (std::size_t j = 0; j < rows[i].size(); ++j)
      EXPECT_NEAR(rows[i][j], table.rows[i][j], 1e-10 * std::max(1.0, std::abs(table.rows[i][j])))
          << "row " << i << " column " << j;
  }
  ASSERT_EQ(outcome.peaks.size(), 1u);
  ASSERT_TRUE(table.peaks[0].has_value());
  EXPECT_EQ(outcome.peaks[0].amplitude_m, table.peaks[0]->amplitude_m);
  EXPECT_EQ(outcome.peaks[0].omega_rad_s, table.peaks[0]->omega_rad_s);
  // 330 and 400 Hz are each crossed once by the curve; one contact.
  ASSERT_EQ(loops.size(), 2u);
  for (const FrictionLoop& loop : loops) EXPECT_EQ(loop.crossing, 1);
  // The Jenkins element (kt = 2e5 N/m, mu N = 2.5 N) against its closed form. At 330 Hz it
  // sticks (|kt u| < mu N all period): a closed loop on one line, no energy. At 400 Hz it slips:
  // a relative motion with one maximum and one minimum per period, half-range d > mu N / kt,
  // dissipates 4 mu N (d - mu N / kt) per cycle. On samples, the trapezoid misses at most
  // kt du^2 / 2 at each of the two stick-to-slip transitions (du the largest sample step).
  constexpr double kKt = 2e5, kLimit = 2.5;
  const ContactTrace& stuck = loops[0].trace;
  const auto u_stuck = stuck.displacement.col(0);
  EXPECT_LT(stuck.force.col(0).cwiseAbs().maxCoeff(), kLimit);
  EXPECT_LE(std::abs(stuck.energy_per_cycle),
            1e-9 * kLimit * (u_stuck.maxCoeff() - u_stuck.minCoeff()));
  const ContactTrace& slipping = loops[1].trace;
  const Eigen::VectorXd u = slipping.displacement.col(0);
  const Eigen::Index n = u.size();
  double step = 0.0;
  for (Eigen::Index j = 0; j < n; ++j) step = std::max(step, std::abs(u((j + 1) % n) - u(j)));
  const double half_range = 0.5 * (u.maxCoeff() - u.minCoeff());
  ASSERT_GT(half_range, kLimit / kKt);
  const double closed_form = 4 * kLimit * (half_range - kLimit / kKt);
  EXPECT_NEAR(slipping.energy_per_cycle, closed_form, kKt * step * step);
}

// The contact harmonics of the quick start (output.contact_forces) against the blade's own
// equation of motion, m x'' + c x' + k x = F cos(w t) - f(t), f the Jenkins element's force
// on u = x_blade - x_ground: harmonic by harmonic, with X = cos - i sin,
//   (k - n^2 w^2 m + i n w c) X_n + F_n = F delta_{n1},   c = 2 zeta sqrt(k m),
// at every point of the curve, to the Newton tolerance (a relative residual of 1e-9 of the
// contact displacement, times the dynamic stiffness: about 1e-8 N against F = 2 N). The
// contact's displacement is the blade's (one component, the ground fixed): the unknowns U
// against the blade's motion recovered from the forces, x = R (F_ext - F), to the same
// tolerance.
TEST(RunStages, ContactHarmonicsBalanceTheBladesEquationOfMotion) {
  constexpr double kMass = 0.1, kStiffness = 4e5, kZeta = 0.005, kForce = 2.0;
  const fs::path file = fs::path(FRICHB_SOURCE_DIR) / "configs/quickstart_friction_oscillator.yaml";
  SceneInput input;
  input.file = file;
  input.overrides = {parse_scene_override("output.contact_forces=true")};
  const RunResult run = run_scene(input);
  ASSERT_EQ(run.outcome.status, kExitOk) << run.outcome.message;
  const ContinuationSummary& summary = run.summary;
  const ResponseTable& table = run.table;
  ASSERT_EQ(table.contacts.size(), summary.points.size());
  ASSERT_EQ(table.contact_components, (std::vector<std::vector<int>>{{0}}));
  const auto& harmonics = run.prepared.model->layout().harmonics();
  const double damping = 2 * kZeta * std::sqrt(kStiffness * kMass);
  const Eigen::Index n = run.prepared.model->equation_count();
  double worst = 0.0;
  for (std::size_t i = 0; i < summary.points.size(); ++i) {
    ASSERT_EQ(table.contacts[i].size(), 1u);
    const ContactHarmonics& h = table.contacts[i][0];
    EXPECT_TRUE(h.periodic);
    const Eigen::MatrixXcd& x = table.harmonics[i][0];
    const double w = summary.points[i].y(n);
    for (std::size_t k = 0; k < harmonics.size(); ++k) {
      const auto kk = static_cast<Eigen::Index>(k);
      EXPECT_LE(std::abs(h.displacement(0, kk) - x(0, kk)), 1e-8 * x.cwiseAbs().maxCoeff())
          << "point " << i << " harmonic " << harmonics[k];
      const double nw = harmonics[k] * w;
      const std::complex<double> dynamic(kStiffness - nw * nw * kMass, nw * damping);
      const double excitation = harmonics[k] == 1 ? kForce : 0.0;
      worst =
          std::max(worst, std::abs(dynamic * h.displacement(0, kk) + h.force(0, kk) - excitation));
    }
  }
  EXPECT_LT(worst, 1e-8 * kForce);
  std::cout << "largest imbalance of the equation of motion: " << worst << " N\n";
}

// prepare_run locates an error that needs the structure's instance at the scene's key.
TEST(RunStages, PrepareLocatesADofTheStructureLacks) {
  frichb::test::TempDir dir;
  const fs::path file = dir.write("bad.yaml", one_dof_scene(3));
  const Registry registry(Registry::default_search_path({FRICHB_PLUGIN_DIR}));
  const Scene scene = bound_scene(file, registry);
  try {
    prepare_run(scene, 1);
    FAIL() << "a DOF beyond the structure's must be refused";
  } catch (const SceneError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("structure.dofs.blade"), std::string::npos) << what;
    EXPECT_NE(what.find("DOF 3 does not exist"), std::string::npos) << what;
    EXPECT_NE(what.find("bad.yaml:10"), std::string::npos) << what;
  }
}

}  // namespace

namespace {

std::string file_bytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// `document` without its times (keys ending in _s) and the process's peak memory: what two
// identical runs differ in.
void drop_times(nlohmann::json& document) {
  if (!document.is_object()) return;
  for (auto it = document.begin(); it != document.end();) {
    if (it.key().ends_with("_s") || it.key() == "peak_memory_mib") {
      it = document.erase(it);
    } else {
      drop_times(it.value());
      ++it;
    }
  }
}

// Every regular file under `folder`, by its path relative to it, with its bytes; summary.json
// without its times.
std::map<std::string, std::string> folder_bytes(const fs::path& folder) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(folder)) {
    if (!entry.is_regular_file()) continue;
    const std::string name = entry.path().lexically_relative(folder).string();
    if (name == "summary.json") {
      auto summary = nlohmann::json::parse(file_bytes(entry.path()));
      drop_times(summary);
      files[name] = summary.dump(1);
    } else if (name != std::string(StagedOutput::kManifest)) {
      files[name] = file_bytes(entry.path());
    }
  }
  return files;
}

}  // namespace

// Two different scenes traced at once on two threads of one process (the verb as a library
// calls it: run_scene, then write_run_folder) give the results of the same two runs made one
// after the other: the same numbers in memory, bit for bit, and the same files byte for byte.
// Thread counts are fixed (one contact thread per run, one dense-solver thread). The first
// scene carries an override of its own, which the other must not see.
TEST(RunStages, TwoScenesRunConcurrentlyGiveTheResultsOfTwoRunsInTurn) {
  const std::vector<fs::path> scenes = {
      fs::path(FRICHB_SOURCE_DIR) / "configs/quickstart_friction_oscillator.yaml",
      fs::path(FRICHB_SOURCE_DIR) / "configs/two_dof_blade_damper.yaml"};
  set_dense_solver_threads(1);
  RunOptions options;
  options.contact_threads = 1;
  options.plots = 0;
  options.quiet = true;
  frichb::test::TempDir dir;
  auto run = [&](std::size_t k, const std::string& tag) {
    std::vector<SceneOverride> overrides;
    if (k == 0) overrides.push_back({"contacts.root_friction.params.normal_load", "3"});
    RunResult result = run_scene(SceneInput{scenes[k], overrides, false}, options);
    write_run_folder(result, dir.path() / (tag + std::to_string(k)));
    return result;
  };
  std::vector<RunResult> in_turn;
  for (std::size_t k = 0; k < scenes.size(); ++k) in_turn.push_back(run(k, "in_turn_"));
  // Together: both threads start at once and each traces its scene three times, so that the
  // runs overlap (each takes about 0.1 s); the last of each is compared.
  constexpr int kRepeats = 3;
  std::vector<std::optional<RunResult>> together(scenes.size());
  std::vector<std::exception_ptr> failures(scenes.size());
  {
    std::latch start(static_cast<std::ptrdiff_t>(scenes.size()));
    std::vector<std::jthread> threads;
    for (std::size_t k = 0; k < scenes.size(); ++k)
      threads.emplace_back([&, k] {
        try {
          start.arrive_and_wait();
          for (int r = 0; r < kRepeats; ++r) together[k] = run(k, "together_");
        } catch (...) {
          failures[k] = std::current_exception();
        }
      });
  }
  for (const auto& failure : failures)
    if (failure) std::rethrow_exception(failure);
  for (std::size_t k = 0; k < scenes.size(); ++k) {
    SCOPED_TRACE(scenes[k].filename().string());
    ASSERT_EQ(in_turn[k].outcome.status, kExitOk) << in_turn[k].outcome.message;
    ASSERT_TRUE(together[k].has_value());
    ASSERT_EQ(together[k]->outcome.status, kExitOk) << together[k]->outcome.message;
    ASSERT_GT(in_turn[k].table.rows.size(), 50u);
    EXPECT_EQ(together[k]->table.rows, in_turn[k].table.rows);
    ASSERT_EQ(together[k]->peaks.size(), in_turn[k].peaks.size());
    for (std::size_t p = 0; p < in_turn[k].peaks.size(); ++p) {
      EXPECT_EQ(together[k]->peaks[p].amplitude_m, in_turn[k].peaks[p].amplitude_m);
      EXPECT_EQ(together[k]->peaks[p].omega_rad_s, in_turn[k].peaks[p].omega_rad_s);
    }
    const auto a = folder_bytes(dir.path() / ("in_turn_" + std::to_string(k)));
    const auto b = folder_bytes(dir.path() / ("together_" + std::to_string(k)));
    EXPECT_GE(a.size(), 2u);  // response.csv, summary.json (and the friction loops)
    EXPECT_EQ(a, b);
  }
  // The two scenes are different runs: the comparison above is not of a run with itself.
  EXPECT_NE(in_turn[0].table.rows, in_turn[1].table.rows);
  // The override reached its own run only.
  const auto summary = [&](const std::string& folder) {
    return nlohmann::json::parse(file_bytes(dir.path() / folder / "summary.json"));
  };
  EXPECT_EQ(
      summary("together_0")["command_line_overrides"]["contacts.root_friction.params.normal_load"],
      3);
  EXPECT_FALSE(summary("together_1").contains("command_line_overrides"));
}

// A run whose token is stopped ends interrupted, before its first point, and its folder is not
// written; a run beside it on another thread, with a token of its own, gives what it gives
// alone.
TEST(RunStages, AStoppedRunEndsInterruptedAndARunBesideItIsNotStopped) {
  const fs::path quickstart =
      fs::path(FRICHB_SOURCE_DIR) / "configs/quickstart_friction_oscillator.yaml";
  RunOptions options;
  options.contact_threads = 1;
  options.plots = 0;
  options.quiet = true;
  const RunResult alone = run_scene(SceneInput{quickstart, {}, false}, options);
  ASSERT_EQ(alone.outcome.status, kExitOk) << alone.outcome.message;
  RunOptions stopped_options = options;
  const StopSource source;
  stopped_options.stop = source.token();
  source.request_stop(SIGINT);
  std::optional<RunResult> stopped, beside;
  {
    std::latch start(2);
    std::jthread a([&] {
      start.arrive_and_wait();
      stopped = run_scene(SceneInput{quickstart, {}, false}, stopped_options);
    });
    std::jthread b([&] {
      start.arrive_and_wait();
      beside = run_scene(SceneInput{quickstart, {}, false}, options);
    });
  }
  ASSERT_TRUE(stopped && beside);
  EXPECT_EQ(stopped->outcome.status, 128 + SIGINT);
  EXPECT_EQ(stopped->outcome.termination, "interrupted");
  EXPECT_NE(stopped->outcome.message.find("interrupted by signal 2 at point 0"), std::string::npos)
      << stopped->outcome.message;
  EXPECT_TRUE(stopped->summary.points.empty());
  frichb::test::TempDir dir;
  EXPECT_THROW(write_run_folder(*stopped, dir.path() / "stopped"), Interrupted);
  EXPECT_FALSE(fs::exists(dir.path() / "stopped"));
  ASSERT_EQ(beside->outcome.status, kExitOk) << beside->outcome.message;
  EXPECT_EQ(beside->table.rows, alone.table.rows);
}
