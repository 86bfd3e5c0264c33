// The resonance peak traced against a design parameter (model/peak_tracking.hpp,
// commands/peaks.hpp). Oracles: central differences of the extended residual for its
// Jacobian; the peaks of full response curves run at the traced parameter values (the same
// equations and the same measure, solved along each curve by model/resonance_peak.hpp).
#include <gtest/gtest.h>

#include <cmath>
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

// A blade tip moving in a plane (0.1 kg on 4e5 and 5e5 N/m, 0.5 % damping, F = (2, 1) N) on
// the coupled friction circle (kt = 2e5 N/m, mu = 0.5), traced along the motion: smooth in the
// unknowns and in the normal load.
std::string circle_scene() {
  return R"(
name: planar_tip
structure:
  provider: lumped
  params:
    masses: [0.1, 0.1]
    springs:
      - {between: [ground, 0], k: 4.0e5}
      - {between: [ground, 1], k: 5.0e5}
    modal_damping: [0.005, 0.005]
  dofs: {tip: [0, 1]}
excitation:
  - {dof: tip, amplitude: 2.0, direction: [1.0, 0.5]}
contacts:
  - name: shroud
    law: coupled_3d
    between: [ground, tip]
    frame: {tangent1: [1.0, 0.0], tangent2: [0.0, 1.0]}
    params: {kt: 2.0e5, mu: 0.5, normal_load: 5.0}
harmonic_balance: {max_harmonic: 3, samples_per_period: 64}
continuation:
  frequency: {from: 300, to: 400, unit: Hz}
  tolerance: 1.0e-12
  step: {initial: 1.0, min: 1.0e-6, max: 2.0}
output: {response: [tip], plots: false}
)";
}

struct Started {
  BoundScene bound;
  RunResult run;
};

Started run_at(const std::string& text, const frichb::test::TempDir& dir) {
  Started s;
  SceneInput input;
  input.file = dir.write("scene.yaml", text);
  s.bound = load_bound_scene(input);
  RunOptions options;
  options.plots = 0;
  options.quiet = true;
  s.run = trace_scene(s.bound.scene, options);
  return s;
}

TEST(PeakTracking, JacobianMatchesCentralDifferences) {
  frichb::test::TempDir dir;
  Started s = run_at(circle_scene(), dir);
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
  frichb::test::TempDir dir;
  PeaksOptions options;
  options.scene.file = dir.write("scene.yaml", circle_scene());
  options.parameter = "contacts.shroud.params.normal_load";
  options.from = 1.5;
  options.to = 15.0;
  const PeaksResult result = track_peaks(options);
  ASSERT_EQ(result.outcome.status, 0) << result.outcome.message;
  EXPECT_TRUE(result.logarithmic);
  EXPECT_EQ(result.termination, "reached_end");
  ASSERT_TRUE(result.optimum);
  const std::size_t best = *result.optimum;
  ASSERT_FALSE(result.optimum_at_end);
  const auto& peaks = result.peaks;
  EXPECT_NEAR(peaks.front().parameter, 1.5, 1e-12);
  EXPECT_NEAR(peaks.back().parameter, 15.0, 1e-12);
  for (const std::size_t i :
       {std::size_t{0}, best - 1, best, best + 1, peaks.size() / 2 + best / 2, peaks.size() - 1}) {
    std::string text = circle_scene();
    text.replace(text.find("normal_load: 5.0"), 16,
                 "normal_load: " + format_scene_value(peaks[i].parameter));
    frichb::test::TempDir here;
    Started s = run_at(text, here);
    ASSERT_TRUE(s.run.table.peaks.at(0) && s.run.table.peaks[0]->refined);
    const NodePeak& full = *s.run.table.peaks[0];
    EXPECT_NEAR(peaks[i].amplitude_m, full.amplitude_m, 1e-5 * full.amplitude_m)
        << "normal load " << peaks[i].parameter;
    EXPECT_NEAR(peaks[i].frequency_hz, full.omega_rad_s / (2 * std::numbers::pi),
                1e-6 * peaks[i].frequency_hz)
        << "normal load " << peaks[i].parameter;
  }
  // The optimum is a minimum of the traced peak amplitude, where its sensitivity changes sign.
  EXPECT_LT(peaks[best - 1].d_amplitude_m_d_parameter, 0.0);
  EXPECT_GT(peaks[best + 1].d_amplitude_m_d_parameter, 0.0);
  // The sensitivities (the implicit function theorem on the extended Jacobian) against the
  // peaks solved at fixed parameters either side of a few points: within 1 % of the central
  // difference, plus the difference of the one-sided ones (where the peak curve has a kink: a
  // contact starting to stick over part of the period at the peak).
  Started s = run_at(circle_scene(), dir);
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

}  // namespace
