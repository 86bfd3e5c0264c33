// The resonance peak traced against a design parameter (model/peak_tracking.hpp,
// commands/peaks.hpp). Oracles: central differences of the extended residual for its
// Jacobian; the peaks of full response curves run at the traced parameter values (the same
// equations and the same measure, solved along each curve by model/resonance_peak.hpp).
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <complex>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "frichb/core/commands/peaks.hpp"
#include "frichb/core/commands/run.hpp"
#include "frichb/core/model/peak_tracking.hpp"
#include "frichb/core/report/peaks_report.hpp"
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

// The damper study's blade and damper with the damper's friction traced along the motion
// (configs/peaks/damper_normal_load.yaml), harmonics 1 and 3 and 64 samples here, plots off.
SceneInput damper(double normal_load = 3.0) {
  SceneInput input;
  input.file = std::filesystem::path(FRICHB_SOURCE_DIR) / "configs/peaks/damper_normal_load.yaml";
  input.overrides = {
      {"harmonic_balance.harmonics", "[1, 3]"},
      {"harmonic_balance.samples_per_period", "64"},
      {"output.plots", "false"},
      {"contacts.platform_friction.params.normal_load", format_scene_value(normal_load)}};
  return input;
}

// The measure's analytic gradient in (x, w) (the node's harmonics at the instant of the maximum
// times their derivatives through the contacts' force blocks and the receptances) against
// central differences of the measure, one unknown at a time, at a point off any solution: half
// the contact-free response at `hz`, where the contacts stick over part of the period and slip
// over the rest. `value`: the scene's value of `parameter`. Returns the largest error relative
// to the gradient's largest scaled entry.
double gradient_error_against_central_differences(const SceneInput& input,
                                                  const std::string& parameter, double value,
                                                  double hz) {
  BoundScene bound = load_bound_scene(input);
  const Scene& scene = bound.scene;
  const PreparedRun prepared = prepare_run(scene, 1);
  const HarmonicBalanceModel& model = *prepared.model;
  const Eigen::Index n = model.equation_count();
  SceneParameterModels models(scene, *bound.registry, parameter, 1);
  std::vector<Eigen::Index> kept;
  for (std::size_t d : scene.structure.find(scene.output.response.at(0))->dofs)
    kept.push_back(model.kept_index(d));
  const Eigen::VectorXd z_scale = prepared.setup.options.unknown_scale;
  const PeakCondition problem(models, kept, model.layout().harmonics(),
                              std::max(256, 8 * model.layout().samples()), z_scale, false, value);
  const double w = 2 * std::numbers::pi * hz;
  Eigen::VectorXd y(n + 2);
  y << 0.5 * model.linear_response(w), w, value;
  Eigen::VectorXd gradient;
  std::string why;
  EXPECT_TRUE(problem.amplitude_gradient(y, gradient, &why)) << why;
  if (gradient.size() != n + 1) return 1.0;
  const Eigen::VectorXd scaled = gradient.cwiseProduct(z_scale);
  double worst = 0.0;
  for (Eigen::Index j = 0; j <= n; ++j) {
    Eigen::VectorXd unit = Eigen::VectorXd::Zero(n + 2);
    unit(j) = 1.0;
    const double difference = problem.directional_amplitude(y, unit);
    worst = std::max(worst, std::abs(difference - gradient(j)) * z_scale(j));
  }
  return worst / scaled.cwiseAbs().maxCoeff();
}

TEST(PeakTracking, TheMeasuresAnalyticGradientMatchesCentralDifferences) {
  // The planar tip: the coupled law on two DOFs of one node.
  EXPECT_LE(gradient_error_against_central_differences(
                planar_tip(), "contacts.shroud.params.normal_load", 5.0, 350.0),
            1e-7);
  // The damper study's blade: the response node is not a contact's.
  EXPECT_LE(gradient_error_against_central_differences(
                damper(), "contacts.platform_friction.params.normal_load", 3.0, 280.0),
            1e-7);
  // The lumped bladed disk: complex gathers across the cyclic boundary, a harmonic index per
  // harmonic.
  SceneInput disk;
  disk.file = std::filesystem::path(FRICHB_SOURCE_DIR) / "configs/bladed_disk_lumped_eo3.yaml";
  disk.overrides = {{"harmonic_balance.samples_per_period", "64"}, {"output.plots", "false"}};
  EXPECT_LE(gradient_error_against_central_differences(disk, "contacts.shroud.params.normal_load",
                                                       5.0, 300.0),
            1e-7);
}

// The traced peaks of `scene(p)` from `from` to `to` equal the peaks of full response curves
// run at the same values of p (both solve the harmonic balance and the same measure's
// stationarity; the run's along its curve), at the range's ends, around the optimum and between
// them; the solved optimum equals the full curve's peak there, and the full curves 1 % either
// side peak higher (its location to 1e-2). Returns the result.
PeaksResult expect_traced_peaks_equal_full_curves(SceneInput (*scene)(double),
                                                  const std::string& parameter, double from,
                                                  double to, int check_runs) {
  PeaksOptions options;
  options.scene = scene(from);
  options.check_runs = check_runs;
  options.parameter = parameter;
  options.from = from;
  options.to = to;
  PeaksResult result = track_peaks(options);
  EXPECT_EQ(result.outcome.status, 0) << result.outcome.message;
  EXPECT_EQ(result.termination, "reached_end");
  EXPECT_TRUE(result.jumps.empty());
  EXPECT_TRUE(result.optimum && !result.optimum_at_end);
  if (!result.optimum || result.optimum_at_end) return result;
  const std::size_t best = *result.optimum;
  const auto& peaks = result.peaks;
  EXPECT_NEAR(peaks.front().parameter, from, 1e-12 * std::abs(from));
  EXPECT_NEAR(peaks.back().parameter, to, 1e-12 * std::abs(to));
  const auto full_peak = [&](double p) {
    Started s = run_at(scene(p));
    EXPECT_TRUE(s.run.table.peaks.at(0) && s.run.table.peaks[0]->refined) << p;
    return s.run.table.peaks.at(0).value_or(NodePeak{});
  };
  for (const std::size_t i :
       {std::size_t{0}, best - 1, best, best + 1, peaks.size() / 2 + best / 2, peaks.size() - 1}) {
    const NodePeak full = full_peak(peaks[i].parameter);
    EXPECT_NEAR(peaks[i].amplitude_m, full.amplitude_m, 1e-5 * full.amplitude_m)
        << parameter << " = " << peaks[i].parameter;
    EXPECT_NEAR(peaks[i].frequency_hz, full.omega_rad_s / (2 * std::numbers::pi),
                1e-6 * peaks[i].frequency_hz)
        << parameter << " = " << peaks[i].parameter;
  }
  const auto& optimum = result.solved_optimum;
  EXPECT_TRUE(optimum.solved) << optimum.message;
  if (!optimum.solved) return result;
  EXPECT_LE(optimum.amplitude_m, peaks[best].amplitude_m);
  for (const double factor : {0.99, 1.0, 1.01}) {
    const NodePeak full = full_peak(optimum.parameter * factor);
    if (factor == 1.0) {
      EXPECT_NEAR(optimum.amplitude_m, full.amplitude_m, 1e-5 * full.amplitude_m);
      EXPECT_NEAR(optimum.frequency_hz, full.omega_rad_s / (2 * std::numbers::pi),
                  1e-6 * optimum.frequency_hz);
    } else {
      EXPECT_GT(full.amplitude_m, optimum.amplitude_m) << parameter << " " << factor << " x";
    }
  }
  return result;
}

TEST(PeakTracking, TracedPeaksEqualThePeaksOfFullCurves) {
  const PeaksResult result = expect_traced_peaks_equal_full_curves(
      planar_tip, "contacts.shroud.params.normal_load", 1.5, 15.0, 0);
  EXPECT_TRUE(result.logarithmic);
  ASSERT_TRUE(result.optimum && !result.optimum_at_end);
  const std::size_t best = *result.optimum;
  const auto& peaks = result.peaks;
  PeaksOptions options;
  options.parameter = "contacts.shroud.params.normal_load";
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

// The damper study's optimum normal load (thesis case 2, Fig. 5.7) with the damper traced
// along the motion: the same checks against full curves, from 3 to 7 N (above about 8 N the
// damper's stuck-mode peak near 337 Hz overtakes the traced one).
TEST(PeakTracking, TheDamperStudysTracedPeaksEqualFullCurves) {
  const PeaksResult result = expect_traced_peaks_equal_full_curves(
      damper, "contacts.platform_friction.params.normal_load", 3.0, 5.2, kDefaultCheckRuns);
  EXPECT_FALSE(result.logarithmic);
  EXPECT_TRUE(result.exchanges.empty());
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
  options.check_runs = 0;
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
    options.check_runs = 0;
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

// Two resonances that exchange being the highest: masses a and b (1 kg each) on 1e6 and
// 1.44e6 N/m to the ground, coupled by 5e4 N/m, with dampers of 20 and 24 N s/m to the ground;
// 1 N on a and F1 in antiphase on b (the parameter). Seen at a, the first mode's peak (162.6 Hz)
// falls as F1 grows and the second's (194.7 Hz) rises. The system is linear: the peaks are
// those of |X_a(w)| with X = (K - w^2 M + i w C)^-1 (1, -F1), closed form.
constexpr double kCoupling = 5e4;

std::string two_resonances_scene(bool stability) {
  std::ostringstream s;
  s << "name: two_resonances\nstructure:\n  provider: lumped\n  params:\n"
    << "    masses: [1.0, 1.0]\n    springs:\n"
    << "      - {between: [ground, 0], k: 1.0e6}\n      - {between: [ground, 1], k: 1.44e6}\n"
    << "      - {between: [0, 1], k: " << kCoupling << "}\n"
    << "    dampers:\n      - {between: [ground, 0], c: 20.0}\n"
    << "      - {between: [ground, 1], c: 24.0}\n  dofs: {a: 0, b: 1}\n"
    << "excitation:\n  - {dof: a, amplitude: 1.0}\n"
    << "  - {dof: b, amplitude: 1.0, phase_deg: 180}\ncontacts: []\n"
    << "harmonic_balance: {max_harmonic: 1, samples_per_period: 16}\n"
    << "continuation:\n  frequency: {from: 130, to: 230, unit: Hz}\n"
    << "  step: {initial: 1, min: 1.0e-6, max: 5}\n"
    << "output: {response: [a], plots: false" << (stability ? ", stability: true" : "") << "}\n";
  return s.str();
}

struct LinearPair {
  Eigen::Matrix2d k, m, c;
  LinearPair() {
    m.setIdentity();
    k << 1e6 + kCoupling, -kCoupling, -kCoupling, 1.44e6 + kCoupling;
    c << 20.0, 0.0, 0.0, 24.0;
  }
  double amplitude(double w, double f1) const {
    const Eigen::Matrix2cd d = (k - w * w * m).cast<std::complex<double>>() +
                               std::complex<double>(0, w) * c.cast<std::complex<double>>();
    const Eigen::Vector2cd x = d.lu().solve(Eigen::Vector2cd(1.0, -f1));
    return std::abs(x(0));
  }
  // The peak of mode r (0 or 1) at a: golden section within 3 % of its natural frequency.
  std::pair<double, double> peak(int r, double f1) const {
    Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::Matrix2d> eig(k, m);
    const double w0 = std::sqrt(eig.eigenvalues()(r));
    double lo = 0.97 * w0, hi = 1.03 * w0;
    const double g = (std::sqrt(5.0) - 1) / 2;
    for (int i = 0; i < 200; ++i) {
      const double c1 = hi - g * (hi - lo), d1 = lo + g * (hi - lo);
      if (amplitude(c1, f1) > amplitude(d1, f1))
        hi = d1;
      else
        lo = c1;
    }
    const double w = 0.5 * (lo + hi);
    return {amplitude(w, f1), w / (2 * std::numbers::pi)};
  }
  // F1 where the two peaks are equally high (bisection).
  double crossing(double lo, double hi) const {
    for (int i = 0; i < 100; ++i) {
      const double mid = 0.5 * (lo + hi);
      if (peak(1, mid).first > peak(0, mid).first)
        hi = mid;
      else
        lo = mid;
    }
    return 0.5 * (lo + hi);
  }
};

PeaksResult track_two_resonances(const frichb::test::TempDir& dir, std::optional<double> near,
                                 bool stability) {
  const std::filesystem::path file = dir.path() / "two_resonances.yaml";
  std::ofstream(file) << two_resonances_scene(stability);
  PeaksOptions options;
  options.scene.file = file;
  options.parameter = "excitation.1.amplitude";
  options.from = 1.0;
  options.to = 7.0;
  options.near_hz = near;
  return track_peaks(options);
}

// The models of a contact's parameter share one reduction of the structure
// (HarmonicBalanceModel::with_contact_params): on the lumped bladed disk (complex gathers
// across the cyclic boundary) such a model's residual and Jacobian equal those of a model built
// from the scene at that value.
TEST(PeakTracking, AContactParametersModelsShareTheStructureAndEqualFreshOnes) {
  SceneInput disk;
  disk.file = std::filesystem::path(FRICHB_SOURCE_DIR) / "configs/bladed_disk_lumped_eo3.yaml";
  disk.overrides = {{"harmonic_balance.samples_per_period", "64"}, {"output.plots", "false"}};
  const BoundScene bound = load_bound_scene(disk);
  const PreparedRun prepared = prepare_run(bound.scene, 1);
  SceneInput other = disk;
  other.overrides.push_back({"contacts.shroud.params.normal_load", "7.5"});
  const BoundScene bound_other = load_bound_scene(other);
  const PreparedRun fresh = prepare_run(bound_other.scene, 1);
  const std::unique_ptr<HarmonicBalanceModel> shared =
      prepared.model->with_contact_params(bound_other.scene);
  EXPECT_EQ(&shared->structure(), &prepared.model->structure());
  const Eigen::Index n = shared->equation_count();
  const double w = 2 * std::numbers::pi * 300.0;
  Eigen::VectorXd y(n + 1);
  y << 0.5 * shared->linear_response(w), w;
  Eigen::VectorXd r_shared, r_fresh;
  Eigen::MatrixXd j_shared, j_fresh;
  std::string why;
  ASSERT_TRUE(shared->evaluate(y, r_shared, &j_shared, &why)) << why;
  ASSERT_TRUE(fresh.model->evaluate(y, r_fresh, &j_fresh, &why)) << why;
  EXPECT_LE((r_shared - r_fresh).cwiseAbs().maxCoeff(), 1e-14 * r_fresh.cwiseAbs().maxCoeff());
  EXPECT_LE((j_shared - j_fresh).cwiseAbs().maxCoeff(), 1e-14 * j_fresh.cwiseAbs().maxCoeff());
  // The normal load differs: so do the residuals of the two values.
  Eigen::VectorXd r_base;
  ASSERT_TRUE(prepared.model->evaluate(y, r_base, nullptr, &why)) << why;
  EXPECT_GT((r_base - r_fresh).cwiseAbs().maxCoeff(), 1e-6 * r_fresh.cwiseAbs().maxCoeff());
}

// At a bound of the parameter (a normal load of 0, below which the law refuses it) the
// parameter's column is one-sided: it agrees with a forward difference of the residual.
TEST(PeakTracking, TheParametersColumnIsOneSidedAtItsBound) {
  Started s = run_at(planar_tip(0.0));
  const HarmonicBalanceModel& model = *s.run.prepared.model;
  const Eigen::Index n = model.equation_count();
  ASSERT_TRUE(s.run.table.peaks.at(0));
  SceneParameterModels models(s.bound.scene, *s.bound.registry,
                              "contacts.shroud.params.normal_load", 1);
  std::vector<Eigen::Index> kept;
  for (std::size_t d : s.bound.scene.structure.find("tip")->dofs)
    kept.push_back(model.kept_index(d));
  const Eigen::VectorXd z_scale = s.run.prepared.setup.options.unknown_scale;
  const PeakCondition problem(models, kept, model.layout().harmonics(),
                              std::max(256, 8 * model.layout().samples()), z_scale, false, 5.0);
  Eigen::VectorXd y(n + 2);
  y << s.run.table.peaks[0]->y, 0.0;
  Eigen::VectorXd r, r_up;
  Eigen::MatrixXd j;
  std::string why;
  ASSERT_TRUE(problem.evaluate(y, r, &j, &why)) << why;
  const double h = 1e-4;
  Eigen::VectorXd up = y;
  up(n + 1) = h;
  ASSERT_TRUE(problem.evaluate(up, r_up, nullptr, &why)) << why;
  const Eigen::VectorXd forward = (r_up - r) / h;
  EXPECT_GT(forward.head(n).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LE((forward - j.col(n + 1)).head(n).cwiseAbs().maxCoeff(),
            1e-3 * forward.head(n).cwiseAbs().maxCoeff());
  EXPECT_NEAR(forward(n), j(n, n + 1), 1e-2 * std::abs(forward(n)) + 1e-12);
}

// Non-proportional dampers give a non-diagonal modal damping: the measure's derivative in the
// frequency goes through the formed modal impedance (ReducedStructure::respond's derivative).
TEST(PeakTracking, TheMeasuresFrequencyDerivativeHoldsWithNonDiagonalDamping) {
  frichb::test::TempDir dir;
  const std::filesystem::path file = dir.path() / "two_resonances.yaml";
  std::ofstream(file) << two_resonances_scene(false);
  SceneInput input;
  input.file = file;
  for (const double hz : {150.0, 162.6, 190.0})
    EXPECT_LE(gradient_error_against_central_differences(input, "excitation.1.amplitude", 1.0, hz),
              1e-7)
        << hz << " Hz";
}

// Traced from the highest peak (the first mode's), the second overtakes it: the crossing is
// solved to the closed form's F1, and every traced point is the first mode's peak.
TEST(PeakTracking, AnotherPeakOvertakingTheTracedOneIsLocated) {
  const LinearPair pair;
  const double crossing = pair.crossing(1.0, 7.0);
  frichb::test::TempDir dir;
  const PeaksResult result = track_two_resonances(dir, std::nullopt, false);
  ASSERT_EQ(result.outcome.status, 0) << result.outcome.message;
  EXPECT_TRUE(result.jumps.empty());
  for (const TrackedPeak& p : result.peaks) {
    const auto [amplitude, hz] = pair.peak(0, p.parameter);
    EXPECT_NEAR(p.amplitude_m, amplitude, 1e-10 * amplitude) << "F1 = " << p.parameter;
    EXPECT_NEAR(p.frequency_hz, hz, 2e-9 * hz) << "F1 = " << p.parameter;
  }
  ASSERT_TRUE(result.end_run.made);
  EXPECT_NEAR(result.end_run.amplitude_m, result.peaks.back().amplitude_m,
              1e-10 * result.peaks.back().amplitude_m);
  ASSERT_EQ(result.exchanges.size(), 1u);
  const PeakExchange& e = result.exchanges[0];
  ASSERT_TRUE(e.located) << e.message;
  EXPECT_TRUE(e.overtaken);
  EXPECT_NEAR(e.parameter, crossing, 1e-9 * crossing);
  const auto [amplitude, hz] = pair.peak(0, crossing);
  EXPECT_NEAR(e.amplitude_m, amplitude, 1e-10 * amplitude);
  EXPECT_NEAR(e.frequency_hz, hz, 2e-9 * hz);
  EXPECT_NEAR(e.other_frequency_hz, pair.peak(1, crossing).second, 2e-9 * hz);
}

// With --near the second mode's peak is traced: it is lower at the start, so the first mode's
// falls below it at the same F1; with output.stability every point's largest Floquet
// multiplier is exp(max Re(s) T), s the eigenvalues of the damped linear system and T the
// period at the peak.
TEST(PeakTracking, TheNearPeakIsTracedWithItsStability) {
  const LinearPair pair;
  const double crossing = pair.crossing(1.0, 7.0);
  frichb::test::TempDir dir;
  const PeaksResult result = track_two_resonances(dir, 195.0, true);
  ASSERT_EQ(result.outcome.status, 0) << result.outcome.message;
  ASSERT_FALSE(result.peaks.empty());
  Eigen::Matrix4d state = Eigen::Matrix4d::Zero();
  state.topRightCorner<2, 2>().setIdentity();
  state.bottomLeftCorner<2, 2>() = -pair.k;
  state.bottomRightCorner<2, 2>() = -pair.c;
  const double decay = Eigen::EigenSolver<Eigen::Matrix4d>(state).eigenvalues().real().maxCoeff();
  for (const TrackedPeak& p : result.peaks) {
    const auto [amplitude, hz] = pair.peak(1, p.parameter);
    EXPECT_NEAR(p.amplitude_m, amplitude, 1e-10 * amplitude) << "F1 = " << p.parameter;
    EXPECT_NEAR(p.frequency_hz, hz, 2e-9 * hz) << "F1 = " << p.parameter;
    ASSERT_TRUE(p.stable.has_value());
    EXPECT_TRUE(*p.stable);
    const double expected = std::exp(decay / p.frequency_hz);
    EXPECT_NEAR(p.largest_multiplier, expected, 1e-9 * expected) << "F1 = " << p.parameter;
  }
  ASSERT_EQ(result.exchanges.size(), 1u);
  const PeakExchange& e = result.exchanges[0];
  ASSERT_TRUE(e.located) << e.message;
  EXPECT_FALSE(e.overtaken);
  EXPECT_NEAR(e.parameter, crossing, 1e-9 * crossing);
  EXPECT_NEAR(e.frequency_hz, pair.peak(1, crossing).second, 2e-9 * e.frequency_hz);
  // peaks.png: the unstable stretches dashed under the stable points, the exchange marked with
  // the other peak's frequency (the first mode's, 162.5 Hz there).
  const std::string script = peaks_plot_script(result);
  EXPECT_NE(script.find("column('stable') > 0.5"), std::string::npos) << script;
  EXPECT_NE(script.find("dt 2"), std::string::npos) << script;
  std::ostringstream label;
  label << std::setprecision(4) << "highest again over the " << e.other_frequency_hz
        << " Hz peak' at " << std::setprecision(6) << e.parameter;
  EXPECT_NEAR(e.other_frequency_hz, 162.5, 0.1);
  EXPECT_NE(script.find(label.str()), std::string::npos) << label.str() << "\n" << script;
}

}  // namespace
