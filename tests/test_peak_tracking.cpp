// The resonance peak traced against a design parameter (model/peak_tracking.hpp,
// commands/peaks.hpp). Oracles: central differences of the extended residual for its
// Jacobian; the peaks of full response curves run at the traced parameter values (the same
// equations and the same measure, solved along each curve by model/resonance_peak.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <tuple>
#include <vector>

#include "frichb/core/commands/peaks.hpp"
#include "frichb/core/commands/run.hpp"
#include "frichb/core/model/peak_tracking.hpp"
#include "frichb/core/scene/scene.hpp"
#include "test_support.hpp"

namespace {

using namespace frichb::core;

// The shipped example: a blade tip moving in a plane (0.1 kg on 4e5 and 5e5 N/m, 0.5 % damping,
// F = (2, 1) N) on the coupled friction circle (kt = 2e5 N/m, mu = 0.5), traced along the
// motion: smooth in the unknowns and in the normal load. Three harmonics here, plots off, the
// normal load `normal_load` N.
SceneInput planar_tip(double normal_load = 5.0) {
  SceneInput input;
  input.file =
      std::filesystem::path(FRICHB_SOURCE_DIR) / "configs/peaks/planar_tip_normal_load.yaml";
  input.overrides = {{"harmonic_balance.max_harmonic", "3"},
                     {"output.plots", "false"},
                     {"contacts.shroud.params.normal_load", format_scene_value(normal_load)}};
  return input;
}

struct Started {
  BoundScene bound;
  RunResult run;
};

Started run_at(const SceneInput& input) {
  Started s;
  s.bound = load_bound_scene(input);
  RunOptions options;
  options.plots = 0;
  options.quiet = true;
  s.run = trace_scene(s.bound.scene, options);
  return s;
}

TEST(PeakTracking, JacobianMatchesCentralDifferences) {
  Started s = run_at(planar_tip());
  const Scene& scene = s.bound.scene;
  const HarmonicBalanceModel& model = *s.run.prepared.model;
  const Eigen::Index n = model.equation_count();
  ASSERT_TRUE(s.run.table.peaks.at(0) && s.run.table.peaks[0]->refined);
  SceneParameterModels models(scene, *s.bound.registry, "contacts.shroud.params.normal_load", 1);
  std::vector<Eigen::Index> kept;
  for (std::size_t d : scene.structure.find("tip")->dofs) kept.push_back(model.kept_index(d));
  const Eigen::VectorXd z_scale = s.run.prepared.setup.options.unknown_scale;
  for (const bool logarithmic : {false, true}) {
    PeakCondition problem(models, kept, model.layout().harmonics(),
                          std::max(256, 8 * model.layout().samples()), z_scale, logarithmic,
                          logarithmic ? 1.0 : 5.0);
    Eigen::VectorXd y(n + 2);
    y << s.run.table.peaks[0]->y, problem.lambda(5.0);
    // Off the peak condition's zero, so that its row is exercised where g != 0 as well.
    y(n) *= 1.002;
    Eigen::VectorXd t;
    ASSERT_TRUE(problem.response_tangent(y, t, nullptr));
    problem.set_reference(t);
    Eigen::VectorXd r;
    Eigen::MatrixXd j;
    std::string why;
    ASSERT_TRUE(problem.evaluate(y, r, &j, &why)) << why;
    Eigen::VectorXd scale(n + 2);
    scale << z_scale, logarithmic ? 1.0 : 5.0;
    for (Eigen::Index c = 0; c < n + 2; ++c) {
      const double h = 1e-5 * scale(c);
      Eigen::VectorXd up = y, down = y, r_up, r_down;
      up(c) += h;
      down(c) -= h;
      ASSERT_TRUE(problem.evaluate(up, r_up, nullptr, &why)) << why;
      ASSERT_TRUE(problem.evaluate(down, r_down, nullptr, &why)) << why;
      const Eigen::VectorXd fd = (r_up - r_down) / (2 * h);
      // Each row against its own size: the HB rows' and the condition's.
      const double hb =
          std::max(fd.head(n).cwiseAbs().maxCoeff(), j.col(c).head(n).cwiseAbs().maxCoeff());
      EXPECT_LE((fd.head(n) - j.col(c).head(n)).cwiseAbs().maxCoeff(), 1e-6 * hb + 1e-12)
          << "column " << c << (logarithmic ? " (log axis)" : "");
      const double g_size = j.row(n).cwiseProduct(scale.transpose()).cwiseAbs().maxCoeff();
      EXPECT_LE(std::abs(fd(n) - j(n, c)) * scale(c), 2e-4 * g_size)
          << "column " << c << ": " << fd(n) << " against " << j(n, c)
          << (logarithmic ? " (log axis)" : "");
    }
  }
}

// The traced peaks equal the peaks of full response curves run at the same normal loads (both
// solve the harmonic balance and the same measure's stationarity; the run's along its curve),
// at the range's ends, around the optimum and between them.
TEST(PeakTracking, TracedPeaksEqualThePeaksOfFullCurves) {
  PeaksOptions options;
  options.scene = planar_tip();
  options.parameter = "contacts.shroud.params.normal_load";
  options.from = 1.5;
  options.to = 15.0;
  const PeaksResult result = track_peaks(options);
  ASSERT_EQ(result.outcome.status, 0) << result.outcome.message;
  EXPECT_TRUE(result.logarithmic);
  EXPECT_EQ(result.termination, "reached_end");
  EXPECT_TRUE(result.jumps.empty());
  ASSERT_TRUE(result.optimum);
  const std::size_t best = *result.optimum;
  ASSERT_FALSE(result.optimum_at_end);
  const auto& peaks = result.peaks;
  EXPECT_NEAR(peaks.front().parameter, 1.5, 1e-12);
  EXPECT_NEAR(peaks.back().parameter, 15.0, 1e-12);
  for (const std::size_t i :
       {std::size_t{0}, best - 1, best, best + 1, peaks.size() / 2 + best / 2, peaks.size() - 1}) {
    Started s = run_at(planar_tip(peaks[i].parameter));
    ASSERT_TRUE(s.run.table.peaks.at(0) && s.run.table.peaks[0]->refined);
    const NodePeak& full = *s.run.table.peaks[0];
    EXPECT_NEAR(peaks[i].amplitude_m, full.amplitude_m, 1e-5 * full.amplitude_m)
        << "normal load " << peaks[i].parameter;
    EXPECT_NEAR(peaks[i].frequency_hz, full.omega_rad_s / (2 * std::numbers::pi),
                1e-6 * peaks[i].frequency_hz)
        << "normal load " << peaks[i].parameter;
  }
  // The solved optimum: the full curve's peak there equals it, and the full curves 1 % either
  // side peak higher (its location to 1e-2).
  ASSERT_TRUE(result.solved_optimum.solved) << result.solved_optimum.message;
  const auto& optimum = result.solved_optimum;
  EXPECT_LE(optimum.amplitude_m, peaks[best].amplitude_m);
  for (const double factor : {0.99, 1.0, 1.01}) {
    Started s = run_at(planar_tip(optimum.parameter * factor));
    ASSERT_TRUE(s.run.table.peaks.at(0) && s.run.table.peaks[0]->refined);
    const NodePeak& full = *s.run.table.peaks[0];
    if (factor == 1.0) {
      EXPECT_NEAR(optimum.amplitude_m, full.amplitude_m, 1e-5 * full.amplitude_m);
      EXPECT_NEAR(optimum.frequency_hz, full.omega_rad_s / (2 * std::numbers::pi),
                  1e-6 * optimum.frequency_hz);
    } else {
      EXPECT_GT(full.amplitude_m, optimum.amplitude_m) << "normal load " << factor << " x";
    }
  }
  // The lowest traced point is a minimum of the traced peak amplitude, where its sensitivity
  // changes sign.
  EXPECT_LT(peaks[best - 1].d_amplitude_m_d_parameter, 0.0);
  EXPECT_GT(peaks[best + 1].d_amplitude_m_d_parameter, 0.0);
  // The sensitivities (the implicit function theorem on the extended Jacobian) against the
  // peaks solved at fixed parameters either side of a few points: within 1 % of the central
  // difference, plus the difference of the one-sided ones (where the peak curve has a kink: a
  // contact starting to stick over part of the period at the peak).
  Started s = run_at(planar_tip());
  const HarmonicBalanceModel& model = *s.run.prepared.model;
  const Eigen::Index n = model.equation_count();
  SceneParameterModels models(s.bound.scene, *s.bound.registry, options.parameter, 1);
  std::vector<Eigen::Index> kept;
  for (std::size_t d : s.bound.scene.structure.find("tip")->dofs)
    kept.push_back(model.kept_index(d));
  Eigen::VectorXd z_scale = Eigen::VectorXd::Constant(n + 1, peaks.front().amplitude_m);
  z_scale(n) = 0.1 * peaks.front().y(n);
  PeakCondition problem(models, kept, model.layout().harmonics(),
                        std::max(256, 8 * model.layout().samples()), z_scale, true, 1.0);
  ContinuationOptions solve = s.run.prepared.setup.options;
  solve.unknown_scale.resize(n + 2);
  solve.unknown_scale << z_scale, 1.0;
  solve.residual_scale = Eigen::VectorXd::Constant(n + 1, s.run.prepared.setup.peak);
  solve.linear_solver = LinearSolverKind::kDenseLu;
  solve.newton.residual_tolerance = kPeakResidualTolerance;
  solve.newton.step_tolerance = kPeakStepTolerance;
  constexpr double kDelta = 2e-3;  // in ln p
  for (const std::size_t i : {std::size_t{1}, best / 2, best, best + 1, peaks.size() - 2}) {
    Eigen::VectorXd t;
    ASSERT_TRUE(problem.response_tangent(peaks[i].y, t, nullptr));
    problem.set_reference(t);
    double w[3] = {0, peaks[i].y(n), 0}, a[3] = {0, peaks[i].amplitude_m, 0};
    for (const int side : {0, 2}) {
      Eigen::VectorXd guess = peaks[i].y;
      guess(n + 1) += (side - 1) * kDelta;
      const NewtonResult solved = solve_fixed_parameter(problem, guess, solve);
      ASSERT_TRUE(solved.converged) << solved.message;
      w[side] = solved.y(n);
      a[side] = problem.amplitude(solved.y);
    }
    const double p = peaks[i].parameter, dp = p * kDelta;  // dp / d(ln p) = p
    for (const auto& [sensitivity, v, what] :
         {std::tuple{peaks[i].d_frequency_hz_d_parameter, w, "frequency"},
          std::tuple{peaks[i].d_amplitude_m_d_parameter, a, "amplitude"}}) {
      const double scale = std::string(what) == "frequency" ? 1 / (2 * std::numbers::pi) : 1.0;
      const double left = (v[1] - v[0]) * scale / dp, right = (v[2] - v[1]) * scale / dp;
      const double central = (left + right) / 2;
      EXPECT_NEAR(sensitivity, central, 0.01 * std::abs(central) + std::abs(right - left))
          << what << " at normal load " << p;
    }
  }
}

// The damper study's blade (a sample-by-sample Jenkins law) has two maxima a few tenths of a
// hertz apart near 278 Hz; traced from 2 N, the branch of the right one stalls among the
// response's corners close to the range's end, and the tracking jumps to the peak of a run 1 %
// further on. Each branch starts at its jump, and the peak at the range's end equals a full run's
// there.
TEST(PeakTracking, AStalledBranchJumpsToTheRunsPeakAndGoesOn) {
  PeaksOptions options;
  options.scene.file =
      std::filesystem::path(FRICHB_SOURCE_DIR) / "configs/studies/damper_normal_load_sweep.yaml";
  options.parameter = "contacts.platform_friction.params.normal_load";
  options.from = 2.0;
  options.to = 2.3;
  const PeaksResult result = track_peaks(options);
  ASSERT_EQ(result.outcome.status, 0) << result.outcome.message;
  ASSERT_FALSE(result.jumps.empty());
  const auto& peaks = result.peaks;
  for (std::size_t j = 0; j < result.jumps.size(); ++j) {
    const PeakJump& jump = result.jumps[j];
    std::size_t first = 0;
    while (first < peaks.size() && peaks[first].branch <= static_cast<int>(j)) ++first;
    ASSERT_LT(first, peaks.size());
    EXPECT_EQ(peaks[first].branch, static_cast<int>(j) + 1);
    EXPECT_DOUBLE_EQ(peaks[first].parameter, jump.parameter);
    // kPeakJumpStep of the range further on (a linear axis: 2 to 2.3 spans no decade), or the
    // range's end.
    EXPECT_FALSE(result.logarithmic);
    EXPECT_NEAR(jump.parameter, std::min(jump.from_parameter + kPeakJumpStep * 0.3, 2.3), 1e-12);
    EXPECT_DOUBLE_EQ(peaks[first - 1].parameter, jump.from_parameter);
    EXPECT_FALSE(jump.reason.empty());
  }
  EXPECT_NEAR(peaks.back().parameter, 2.3, 1e-12);
  SceneInput input = options.scene;
  input.overrides.push_back({options.parameter, "2.3"});
  const BoundScene bound = load_bound_scene(input);
  RunOptions run_options;
  run_options.plots = 0;
  run_options.quiet = true;
  const RunResult full = trace_scene(bound.scene, run_options);
  ASSERT_TRUE(full.table.peaks.at(0) && full.table.peaks[0]->refined);
  EXPECT_NEAR(peaks.back().amplitude_m, full.table.peaks[0]->amplitude_m,
              1e-5 * full.table.peaks[0]->amplitude_m);
  EXPECT_NEAR(peaks.back().frequency_hz, full.table.peaks[0]->omega_rad_s / (2 * std::numbers::pi),
              1e-6 * peaks.back().frequency_hz);
}

// The normalised design chart: with a constant normal load the friction circle's equations are
// homogeneous in (x, f, mu N0), so the peaks at three excitation levels collapse onto one
// curve of A / f against mu N0 / f: the solved optima agree to 1e-6.
TEST(PeakTracking, NormalisedOptimaOfThreeExcitationLevelsCollapse) {
  double location[3] = {}, amplitude[3] = {}, frequency[3] = {};
  const double levels[3] = {1.0, 3.0, 7.0};  // not powers of 2, whose scaling is exact
  for (int i = 0; i < 3; ++i) {
    PeaksOptions options;
    options.scene = planar_tip();
    options.scene.overrides.push_back({"excitation.0.amplitude", format_scene_value(levels[i])});
    options.parameter = "contacts.shroud.params.normal_load";
    options.from = 2.6 * levels[i];  // mu N0 / f from 1.3 to 1.5, around the optimum
    options.to = 3.0 * levels[i];
    options.normalise = true;
    const PeaksResult result = track_peaks(options);
    ASSERT_EQ(result.outcome.status, 0) << result.outcome.message;
    EXPECT_DOUBLE_EQ(result.mu_over_force, 0.5 / levels[i]);
    EXPECT_DOUBLE_EQ(result.per_force, 1.0 / levels[i]);
    ASSERT_TRUE(result.solved_optimum.solved) << result.solved_optimum.message;
    location[i] = result.solved_optimum.parameter * result.mu_over_force;
    amplitude[i] = result.solved_optimum.amplitude_m * result.per_force;
    frequency[i] = result.solved_optimum.frequency_hz;
  }
  for (int i = 1; i < 3; ++i) {
    EXPECT_NEAR(location[i], location[0], 1e-6 * location[0]) << "f = " << levels[i] << " N";
    EXPECT_NEAR(amplitude[i], amplitude[0], 1e-6 * amplitude[0]) << "f = " << levels[i] << " N";
    EXPECT_NEAR(frequency[i], frequency[0], 1e-6 * frequency[0]) << "f = " << levels[i] << " N";
  }
}

// --normalise needs a normal load and one excitation.
TEST(PeakTracking, NormaliseRefusesAnotherParameter) {
  PeaksOptions options;
  options.scene = planar_tip();
  options.parameter = "contacts.shroud.params.mu";
  options.from = 0.3;
  options.to = 0.6;
  options.normalise = true;
  try {
    track_peaks(options);
    ADD_FAILURE() << "accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("contacts.NAME.params.normal_load"), std::string::npos)
        << e.what();
  }
}

}  // namespace
