// The response amplitude in continuous time and the peak solved along the curve. Oracles: the
// closed-form maxima of harmonic motions; a golden-section search over the frequency on the
// same measure, each probe a fixed-frequency solve (where the curve does not fold); a trace
// with steps a hundred times finer (where it does); finite differences of the curve's points
// for the chord solver's velocity.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/model/resonance_peak.hpp"
#include "frichb/core/model/response.hpp"
#include "frichb/core/model/response_curve.hpp"
#include "frichb/core/scene/scene.hpp"
#include "test_support.hpp"

namespace {

using namespace frichb::core;
using cd = std::complex<double>;

// Harmonic 1 alone: x(tau) = C (cos tau, sin tau) with C = [c s] (components x 2), whose
// largest norm over the period is C's largest singular value.
TEST(ResponseAmplitude, HarmonicOneMotionPeaksAtTheLargestSingularValue) {
  const std::vector<int> harmonics = {0, 1, 2, 3};
  AmplitudeSampler sampler(harmonics, 256);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::MatrixXd c(3, 2);
    for (Eigen::Index i = 0; i < c.size(); ++i) c.data()[i] = u(rng);
    std::vector<Eigen::VectorXcd> x(harmonics.size(), Eigen::VectorXcd::Zero(3));
    for (Eigen::Index a = 0; a < 3; ++a) x[1](a) = cd(c(a, 0), -c(a, 1));  // X = c - i s
    const double expected = Eigen::JacobiSVD<Eigen::MatrixXd>(c).singularValues()(0);
    EXPECT_NEAR(sampler.peak_amplitude(x, {0, 1, 2}), expected, 1e-14 * expected);
  }
}

// x(tau) = cos(tau - phi) + e cos(2 (tau - phi)), e < 1/4: the largest |x| is 1 + e at
// tau = phi, here half a sample spacing off the grid (where the largest sample is low by
// about (pi / 256)^2 / 2 (1 + 4 e) = 1.1e-4).
TEST(ResponseAmplitude, MaximumBetweenSamplesIsTheSeriesOwn) {
  const std::vector<int> harmonics = {0, 1, 2};
  AmplitudeSampler sampler(harmonics, 256);
  constexpr double kE = 0.2;
  for (const double phi : {std::numbers::pi / 256, 1.3, 4.0 + std::numbers::pi / 256}) {
    std::vector<Eigen::VectorXcd> x(harmonics.size(), Eigen::VectorXcd::Zero(1));
    x[1](0) = std::polar(1.0, -phi);
    x[2](0) = std::polar(kE, -2 * phi);
    EXPECT_NEAR(sampler.peak_amplitude(x, {0}), 1 + kE, 1e-14) << "phi " << phi;
  }
  // A static offset and the negative excursion: x = -0.5 + cos(tau - phi), max |x| = 1.5.
  std::vector<Eigen::VectorXcd> x(harmonics.size(), Eigen::VectorXcd::Zero(1));
  x[0](0) = -0.5;
  x[1](0) = std::polar(1.0, -std::numbers::pi / 256);
  EXPECT_NEAR(sampler.peak_amplitude(x, {0}), 1.5, 1e-14);
  // No motion.
  EXPECT_EQ(
      sampler.peak_amplitude(std::vector<Eigen::VectorXcd>(3, Eigen::VectorXcd::Zero(1)), {0}),
      0.0);
}

// The quick start's blade: 1 DOF (m = 0.1 kg, k = 4e5 N/m, 0.5 % damping) with a Jenkins
// contact to ground (kt = 2e5 N/m, mu N = 2.5 N) and F = 2 N: the contact slips over part of
// the period near the resonance. The law's step is sample-only: where a sample switches
// between stick and slip the curve has a corner.
std::string jenkins_scene(double max_step_hz) {
  return R"(
name: friction_oscillator
structure:
  provider: lumped
  params:
    masses: [0.1]
    springs:
      - {between: [ground, 0], k: 4.0e5}
    modal_damping: [0.005]
  dofs: {blade: 0}
excitation:
  - {dof: blade, amplitude: 2.0, harmonic: 1}
contacts:
  - name: root
    law: jenkins_1d
    between: [ground, blade]
    frame: {tangent1: [1.0]}
    params: {kt: 2.0e5, mu: 0.5, normal_load: 5.0}
harmonic_balance: {max_harmonic: 5, samples_per_period: 128}
continuation:
  frequency: {from: 280, to: 440, unit: Hz}
  tolerance: 1.0e-12
  step: {initial: 1.0, min: 1.0e-6, max: )" +
         std::to_string(max_step_hz) + R"(}
output: {response: [blade], plots: false}
)";
}

// A blade tip moving in a plane (0.1 kg on 4e5 and 5e5 N/m, 0.5 % damping, F = (2, 1) N) on
// the coupled friction circle (kt = 2e5 N/m, mu N = 2.5 N), traced along the motion: the tip
// slips along an ellipse and the curve is smooth.
std::string circle_scene(double max_step_hz) {
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
harmonic_balance: {max_harmonic: 5, samples_per_period: 64}
continuation:
  frequency: {from: 300, to: 400, unit: Hz}
  tolerance: 1.0e-12
  step: {initial: 1.0, min: 1.0e-6, max: )" +
         std::to_string(max_step_hz) + R"(}
output: {response: [tip], plots: false}
)";
}

struct Traced {
  Scene scene;
  PreparedRun run;
  ContinuationSummary summary;
  ResponseTable table;
};

Traced trace(const std::string& text, const frichb::test::TempDir& dir) {
  Traced t;
  t.scene = load_scene(dir.write("scene.yaml", text));
  bind_plugins(t.scene, frichb::test::built_plugins());
  t.run = prepare_run(t.scene, 1);
  const auto& options = t.run.setup.options;
  const Eigen::VectorXd start = find_start_point(*t.run.model, options);
  t.summary = trace_response(t.scene, *t.run.model, options, start);
  t.table = tabulate_response(t.scene, *t.run.model, options, t.summary);
  return t;
}

std::size_t highest_point(const ResponseTable& table) {
  std::size_t top = 0;
  for (std::size_t i = 1; i < table.rows.size(); ++i)
    if (table.rows[i][3] > table.rows[top][3]) top = i;
  return top;
}

// Golden section on the amplitude over the frequency between the neighbours of `top`, each
// probe a fixed-frequency Newton solve from the chord, to 1e-13 relative in frequency.
std::pair<double, double> golden_peak(const Traced& t, std::size_t top) {
  const HarmonicBalanceModel& model = *t.run.model;
  const Eigen::Index n = model.equation_count();
  FixedParameterSolver solver(model, t.run.setup.options);
  AmplitudeSampler sampler(model.layout().harmonics(), 8 * model.layout().samples());
  const auto& p = t.summary.points;
  const std::vector<Eigen::Index> kept = t.table.nodes[0].kept;
  auto amplitude = [&](double w) {
    const auto& a =
        (w - p[top].y(n)) * (p[top - 1].y(n) - p[top].y(n)) > 0 ? p[top - 1].y : p[top + 1].y;
    const double s = (w - p[top].y(n)) / (a(n) - p[top].y(n));
    Eigen::VectorXd y = (1 - s) * p[top].y + s * a;
    y(n) = w;
    const NewtonResult solved = solver.solve(y);
    EXPECT_TRUE(solved.converged) << solved.message;
    return sampler.peak_amplitude(model.kept_response(solved.y), kept);
  };
  const double inv_phi = (std::sqrt(5.0) - 1) / 2;
  double a = p[top - 1].y(n), b = p[top + 1].y(n);
  double c = b - inv_phi * (b - a), d = a + inv_phi * (b - a);
  double fc = amplitude(c), fd = amplitude(d);
  while (std::abs(b - a) > 1e-13 * std::abs(b)) {
    if (fc > fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - inv_phi * (b - a);
      fc = amplitude(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + inv_phi * (b - a);
      fd = amplitude(d);
    }
  }
  return fc > fd ? std::make_pair(fc, c) : std::make_pair(fd, d);
}

TEST(ResonancePeak, SolvedPeakMatchesGoldenSectionOnTheSameMeasure) {
  frichb::test::TempDir dir;
  const Traced t = trace(circle_scene(2.0), dir);
  ASSERT_TRUE(t.summary.reached_end()) << t.summary.message;
  ASSERT_EQ(t.table.peaks.size(), 1u);
  const NodePeak& peak = *t.table.peaks[0];
  ASSERT_TRUE(peak.refined);
  const std::size_t top = highest_point(t.table);
  const Eigen::Index n = t.run.model->equation_count();
  const auto& p = t.summary.points;
  ASSERT_GT((p[top].y(n) - p[top - 1].y(n)) * (p[top + 1].y(n) - p[top].y(n)), 0.0)
      << "the oracle needs a curve that does not fold beside its top";
  const auto [golden_amplitude, golden_omega] = golden_peak(t, top);
  EXPECT_NEAR(peak.amplitude_m, golden_amplitude, 1e-9 * golden_amplitude);
  EXPECT_NEAR(peak.omega_rad_s, golden_omega, 1e-7 * golden_omega);
  EXPECT_GE(peak.amplitude_m, t.table.rows[top][3]);
  EXPECT_EQ(peak.y.size(), n + 1);
  EXPECT_EQ(peak.y(n), peak.omega_rad_s);
}

// A sample-only law: the amplitude along the curve has a corner wherever a sample switches
// between stick and slip (about 1e-5 of the chord apart near this peak), and the peak is one of
// them. Golden section and the solve stop on corners next to each other; the amplitudes differ
// by the corners' heights, measured 3.8e-9 of the peak.
TEST(ResonancePeak, SampleOnlyLawPeaksWithinItsCorners) {
  frichb::test::TempDir dir;
  const Traced t = trace(jenkins_scene(2.0), dir);
  ASSERT_TRUE(t.summary.reached_end()) << t.summary.message;
  const NodePeak& peak = *t.table.peaks[0];
  ASSERT_TRUE(peak.refined);
  const std::size_t top = highest_point(t.table);
  const auto [golden_amplitude, golden_omega] = golden_peak(t, top);
  EXPECT_NEAR(peak.amplitude_m, golden_amplitude, 1e-8 * golden_amplitude);
  EXPECT_NEAR(peak.omega_rad_s, golden_omega, 1e-7 * golden_omega);
  EXPECT_GE(peak.amplitude_m, t.table.rows[top][3]);
}

// A tip 50 um from a Hertz contact (N = c_n p^1.5) that moves 330 um at its free resonance: the
// closing gap stiffens the structure, and the resonance bends up into a fold beside its peak
// (configs/stress/hertz_gap_folds.yaml with three harmonics).
std::string hertz_scene(double max_step_hz, bool turning_point_control) {
  return R"(
name: hertz_gap
structure:
  provider: lumped
  params:
    masses: [0.1, 0.1, 0.1]
    springs:
      - {between: [ground, 0], k: 4.0e5}
      - {between: [ground, 1], k: 5.0e5}
      - {between: [ground, 2], k: 6.0e5}
    modal_damping: [0.005, 0.005, 0.005]
  dofs: {tip: [0, 1, 2]}
excitation:
  - {dof: tip, amplitude: 2.0, direction: [0.0, 0.0, 1.0]}
contacts:
  - name: shroud
    law: hertz_3d
    between: [ground, tip]
    frame: {tangent1: [1, 0, 0], tangent2: [0, 1, 0], normal: [0, 0, 1]}
    params: {normal_coefficient: 1.0e8, tangential_coefficient: 2.0e8, mu: 0.3, gap: 5.0e-5}
harmonic_balance: {max_harmonic: 3, samples_per_period: 128}
continuation:
  frequency: {from: 300, to: 600, unit: Hz}
  tolerance: 1.0e-12
  step: {initial: 0.05, min: 1.0e-6, max: )" +
         std::to_string(max_step_hz) + R"(}
  max_points: 40000
  turning_point_control: )" +
         (turning_point_control ? "true" : "false") + R"(
output: {response: [tip], plots: false}
)";
}

// The curve's points beside its peak chosen across the fold that follows it (a before the
// peak, b on the branch back from the fold): the frequency is no parameter between them (the
// golden section over it has no bracket), the chord's parameter is. Oracles: the peak solved
// from the trace's own neighbours, before the fold, and the highest point of a trace over the
// peak with a hundredth of the step, which lies below it by the curvature's share of at most
// half that step.
TEST(ResonancePeak, PeakBesideAFoldIsSolvedAcrossIt) {
  frichb::test::TempDir dir;
  const Traced t = trace(hertz_scene(5.0, true), dir);
  ASSERT_TRUE(t.summary.reached_end()) << t.summary.message;
  const HarmonicBalanceModel& model = *t.run.model;
  const Eigen::Index n = model.equation_count();
  const auto& p = t.summary.points;
  const std::size_t top = highest_point(t.table);
  ASSERT_TRUE(t.table.peaks[0]->refined);
  std::size_t fold = top;
  while (fold + 1 < p.size() && p[fold + 1].y(n) > p[fold].y(n)) ++fold;
  ASSERT_GT(fold, top);
  std::size_t back = fold + 1;  // the first point back below the top's frequency
  while (back < p.size() && p[back].y(n) > p[top].y(n)) ++back;
  ASSERT_LT(back, p.size());
  const std::vector<ContinuationPoint> across = {p[top - 1], p[top], p[back]};
  ASSERT_LT((p[top].y(n) - p[top - 1].y(n)) * (p[back].y(n) - p[top].y(n)), 0.0);
  ASSERT_LT(t.table.rows[back][3], t.table.rows[top][3]);

  ChordSolver chord(model, t.run.setup.options);
  AmplitudeSampler sampler(model.layout().harmonics(), 8 * model.layout().samples());
  const ResonancePeak solved =
      solve_resonance_peak(model, chord, across, 1, t.table.nodes[0].kept, sampler, StopToken());
  ASSERT_TRUE(solved.solved) << solved.message;
  const NodePeak& traced = *t.table.peaks[0];
  EXPECT_NEAR(solved.amplitude_m, traced.amplitude_m, 1e-10 * traced.amplitude_m);
  EXPECT_NEAR(solved.y(n), traced.omega_rad_s, 1e-8 * traced.omega_rad_s);
  EXPECT_LE(solved.evaluations, 20);

  // The fine trace: from point top - 2 over the peak with a hundredth of the step.
  ContinuationOptions options = t.run.setup.options;
  options.lambda_start = p[top - 2].y(n);
  options.initial_step = options.max_step = std::abs(p[top].step) / 100;
  options.min_step = options.max_step * 1e-6;
  options.max_points = 400;
  options.turning_point_control = false;
  const ContinuationSummary fine = trace_curve(model, p[top - 2].y, options);
  ASSERT_EQ(fine.termination, TerminationType::kMaxPoints) << fine.message;
  double fine_amplitude = 0;
  std::size_t fine_top = 0;
  for (std::size_t i = 0; i < fine.points.size(); ++i) {
    const double a =
        sampler.peak_amplitude(model.kept_response(fine.points[i].y), t.table.nodes[0].kept);
    if (a > fine_amplitude) {
      fine_amplitude = a;
      fine_top = i;
    }
  }
  ASSERT_GT(fine_top, 0u);
  ASSERT_LT(fine_top + 1, fine.points.size());  // the fine trace passes over the peak
  // Measured: the fine trace's highest point 8.6e-12 below, 5e-5 rad/s away; 10 evaluations.
  EXPECT_LE(fine_amplitude, solved.amplitude_m * (1 + 1e-12));
  EXPECT_NEAR(fine_amplitude, solved.amplitude_m, 1e-9 * solved.amplitude_m);
}

// The chord solver's velocity dy/dtheta against central differences of its own points.
TEST(ChordSolver, VelocityIsTheDerivativeOfThePoints) {
  frichb::test::TempDir dir;
  const Traced t = trace(circle_scene(2.0), dir);
  const auto& p = t.summary.points;
  const std::size_t top = highest_point(t.table);
  ChordSolver chord(*t.run.model, t.run.setup.options);
  for (const double theta : {0.0, 0.3, 0.8}) {
    const ChordPoint at = chord.solve(p[top - 1].y, p[top + 1].y, theta, p[top].y);
    ASSERT_TRUE(at.converged) << at.message;
    EXPECT_NEAR(chord.theta(p[top - 1].y, p[top + 1].y, at.y), theta, 1e-12);
    constexpr double kH = 1e-4;
    const ChordPoint up = chord.solve(p[top - 1].y, p[top + 1].y, theta + kH, at.y);
    const ChordPoint down = chord.solve(p[top - 1].y, p[top + 1].y, theta - kH, at.y);
    ASSERT_TRUE(up.converged && down.converged);
    const Eigen::VectorXd differences = (up.y - down.y) / (2 * kH);
    EXPECT_LE((differences - at.velocity).norm(), 1e-6 * at.velocity.norm()) << "theta " << theta;
  }
}

// A point of the curve keeps the contact forces of its last evaluation when that was at the
// point itself (point_record), so that the response table need not trace the contacts again:
// the kept forces give the response a fresh trace gives, and a record is never handed out for
// another point.
TEST(ResponseCurve, PointsKeepTheForcesAFreshTraceGives) {
  frichb::test::TempDir dir;
  const Traced t = trace(circle_scene(2.0), dir);
  ASSERT_TRUE(t.summary.reached_end()) << t.summary.message;
  const HarmonicBalanceModel& model = *t.run.model;
  const Eigen::Index n = model.equation_count();
  std::size_t kept_points = 0;
  for (const ContinuationPoint& p : t.summary.points) {
    if (p.record.size() == 0) continue;  // its last evaluation was not at the point itself
    ++kept_points;
    ASSERT_EQ(p.record.size(), n);
    const auto kept = model.kept_response(p.y, p.record);
    const auto fresh = model.kept_response(p.y);
    ASSERT_EQ(kept.size(), fresh.size());
    for (std::size_t k = 0; k < kept.size(); ++k)
      EXPECT_LE((kept[k] - fresh[k]).norm(), 1e-12 * fresh[1].norm())
          << "harmonic " << k << " at " << p.y(n) << " rad/s";
  }
  // Measured: 100 of the 102 points; the tracer's last evaluation before accepting each of the
  // others was elsewhere (a line-search trial, a check past the point), and they trace again.
  EXPECT_GE(kept_points, 9 * t.summary.points.size() / 10);
  // The last evaluation was at another point: nothing to keep for this one.
  const ContinuationPoint& first = t.summary.points.front();
  Eigen::VectorXd residual;
  ASSERT_TRUE(model.evaluate(t.summary.points.back().y, residual, nullptr, nullptr));
  EXPECT_EQ(model.point_record(first.y).size(), 0);
  EXPECT_EQ(model.point_record(t.summary.points.back().y).size(), n);
  // A chord solver's points keep theirs too.
  ChordSolver chord(model, t.run.setup.options);
  const std::size_t top = highest_point(t.table);
  const ChordPoint at = chord.solve(t.summary.points[top - 1].y, t.summary.points[top + 1].y, 0.4,
                                    t.summary.points[top].y);
  ASSERT_TRUE(at.converged) << at.message;
  ASSERT_EQ(at.record.size(), n);
  const auto kept = model.kept_response(at.y, at.record);
  const auto fresh = model.kept_response(at.y);
  for (std::size_t k = 0; k < kept.size(); ++k)
    EXPECT_LE((kept[k] - fresh[k]).norm(), 1e-12 * fresh[1].norm()) << "harmonic " << k;
}

}  // namespace
