// The coupled 3D law (friction circle) through the real loader and the periodic tracer,
// against closed forms and independent oracles: steady circular slip (|T| = mu N and the loop
// energy 2 pi mu N sqrt(a^2 - (mu N / kt)^2)) along the motion between samples and, for the
// sample-only step (radial return), its exact discrete orbit; equality of that step with
// jenkins_1d under 1D motion, mu = 0 and full stick, separation, frame invariance, the Coulomb
// bound, and the Jacobian (through events and kinks) against central differences.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <numbers>
#include <random>

#include "frichb/core/plugin_host/periodic_trace.hpp"
#include "law_step_checks.hpp"
#include "test_support.hpp"

namespace frichb::core {
namespace {

using test::central_differences;
using test::random_motion;

using test::expect_step_tangents_match_differences;
using test::step_law;
using test::StepResult;

constexpr double kPi = std::numbers::pi;

// The law's sample-only step (the radial return between samples), which the tests of its
// discrete orbit and of its equality with jenkins_1d pin; by default the tracer steps the law
// along the motion between samples.
TraceOptions sample_steps() {
  TraceOptions o;
  o.along_motion = false;
  return o;
}

// Index of the first harmonic's cosine and sine coefficients in a layout that keeps it.
struct FirstHarmonicIndex {
  int cos, sin;
};
FirstHarmonicIndex first_harmonic_index(const HarmonicLayout& layout) {
  for (std::size_t k = 0; k < layout.harmonics().size(); ++k)
    if (layout.harmonics()[k] == 1) return {layout.cos_index(k), layout.sin_index(k)};
  ADD_FAILURE() << "the layout does not keep harmonic 1";
  return {0, 0};
}

// u_t = a (cos(theta), sin(theta)): circular motion in the tangential plane.
Eigen::VectorXd circular_motion(const HarmonicLayout& layout, double a) {
  const int c = layout.coefficient_count();
  const auto [ic, is] = first_harmonic_index(layout);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(2 * c);
  u(ic) = a;
  u(c + is) = a;
  return u;
}

// Closed integral of T . du over the traced samples (trapezoids), tangential components only.
double loop_energy(const ContactTrace& t) {
  const Eigen::Index n = t.force.rows();
  double energy = 0;
  for (Eigen::Index j = 0; j < n; ++j) {
    const Eigen::Index jn = (j + 1) % n;
    for (int a = 0; a < 2; ++a)
      energy +=
          0.5 * (t.force(j, a) + t.force(jn, a)) * (t.displacement(jn, a) - t.displacement(j, a));
  }
  return energy;
}

// ---------------------------------------------------------------------------------------
// (1) Steady circular slip, u_t = a (cos(theta), sin(theta)), delta = mu N / kt.
// Continuous limit: the slider w trails u on a concentric circle of radius r; in slip
// T = kt (u - w) has |T| = mu N and is parallel to the slider velocity, i.e. tangent to w's
// circle, so u - w is perpendicular to w: a^2 = r^2 + delta^2. The elastic energy is periodic,
// so the energy per cycle is the friction work on the slider, mu N times its path length:
//   E = 2 pi mu N r = 2 pi mu N sqrt(a^2 - delta^2).
// Sampled at N points (step D = 2 pi / N), the radial return puts u_j - w_j along the CHORD
// w_{j-1} -> w_j, i.e. the tangent half a step back, not along the tangent at w_j. With
// s = sin(D/2), c = cos(D/2) the steady discrete orbit is exactly
//   a^2 = r_d^2 + 2 r_d delta s + delta^2,   r_d = sqrt(a^2 - delta^2 c^2) - delta s,
// and T_j = mu N e^{i(theta_j + psi)} with sin(psi) = c r_d / a, so that
//   from the first harmonics: E_h = pi a (c1(T2) - s1(T1)) = 2 pi mu N c r_d,
//   trapezoidal sum of T . du:  E_t = N sin(D) mu N c r_d.
// Both tend to E with a first-order error E_h - E = -pi mu N delta D + O(D^2): relative
// pi delta / (N r), e.g. 4e-4 at a = 4 delta and 3.8e-5 at a = 40 delta with N = 2048.
// For a <= delta the whole circle sticks: |T| = kt a, E = 0.
double discrete_slider_radius(double a, double delta, int samples) {
  const double half = kPi / samples;
  return std::sqrt(a * a - delta * delta * std::cos(half) * std::cos(half)) -
         delta * std::sin(half);
}

class CoupledCircularSlip : public ::testing::TestWithParam<double> {};

TEST_P(CoupledCircularSlip, ForceOnTheFrictionCircleAndLoopEnergy) {
  const double kt = 2e5, slip_force = 0.5 * 5.0, delta = slip_force / kt;
  auto h = test::make_law("coupled_3d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  const int n = 2048;
  HarmonicLayout layout({0, 1, 2, 3}, n);
  PeriodicTracer tracer(*h.law, layout, sample_steps());
  ASSERT_EQ(tracer.components(), (std::vector<int>{0, 1}));
  const double a = GetParam() * delta;
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(circular_motion(layout, a), JacobianMode::kNone, t, &error)) << error;
  ASSERT_TRUE(t.periodic) << t.diagnostic;
  const double energy = loop_energy(t);
  // The trace's energy comes from the harmonics: pi a (c1(T2) - s1(T1)) on this circle.
  const double energy_from_harmonics = t.energy_per_cycle;
  if (a <= delta) {
    for (int j = 0; j < n; ++j)
      EXPECT_NEAR(t.force.row(j).norm(), kt * a, 1e-9 * kt * a) << "sample " << j;
    EXPECT_NEAR(energy, 0.0, 1e-12 * slip_force * a);
    EXPECT_NEAR(energy_from_harmonics, 0.0, 1e-9 * slip_force * a);
    return;
  }
  for (int j = 0; j < n; ++j)
    EXPECT_NEAR(t.force.row(j).norm(), slip_force, 1e-9 * slip_force) << "sample " << j;
  // The sampled steady orbit, exactly.
  const double step = 2 * kPi / n, rd = discrete_slider_radius(a, delta, n);
  const double discrete_harmonic = 2 * kPi * slip_force * std::cos(step / 2) * rd;
  const double discrete_trapezoid = n * std::sin(step) * slip_force * std::cos(step / 2) * rd;
  EXPECT_NEAR(energy_from_harmonics, discrete_harmonic, 1e-9 * discrete_harmonic);
  EXPECT_NEAR(energy, discrete_trapezoid, 1e-9 * discrete_trapezoid);
  // The continuous limit, within its first-order sampling error pi mu N delta D (+1%) and
  // the second-order terms of c (D^2 / 8) and of the trapezoids (D^2 / 6).
  const double expected = 2 * kPi * slip_force * std::sqrt(a * a - delta * delta);
  const double bound = 1.01 * kPi * slip_force * delta * step + 0.3 * expected * step * step;
  EXPECT_NEAR(energy, expected, bound);
  EXPECT_NEAR(energy_from_harmonics, expected, bound);
  const double relative = std::abs(energy / expected - 1);
  if (a >= 40 * delta) {
    EXPECT_LT(relative, 1e-4);
  }
  std::cout << "a / (mu N / kt) = " << GetParam() << ": loop energy vs 2 pi mu N sqrt(a^2 - "
            << "delta^2) " << relative << ", vs the sampled orbit "
            << std::abs(energy / discrete_trapezoid - 1) << "\n";
}

INSTANTIATE_TEST_SUITE_P(AmplitudeOverSlipThreshold, CoupledCircularSlip,
                         ::testing::Values(0.5, 1.05, 1.5, 4.0, 40.0, 100.0));

// Along the motion (the default trace) the slider follows the series between samples: at
// 256 samples the force harmonics meet the continuous closed form, T = mu N (cos(theta +
// alpha), sin(theta + alpha)) with cos(alpha) = delta / a, and the energy 2 pi mu N r, far
// below the sampled orbit's first-order error (1.1e-2 at a = 1.5 delta).
class CoupledCircularSlipAlongTheMotion : public ::testing::TestWithParam<double> {};

TEST_P(CoupledCircularSlipAlongTheMotion, MeetsTheContinuousClosedFormAt256Samples) {
  const double kt = 2e5, slip_force = 0.5 * 5.0, delta = slip_force / kt;
  auto h = test::make_law("coupled_3d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  HarmonicLayout layout({0, 1, 2, 3}, 256);
  PeriodicTracer tracer(*h.law, layout);
  ASSERT_TRUE(tracer.along_motion());
  const double a = GetParam() * delta;
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(circular_motion(layout, a), JacobianMode::kAnalytic, t, &error))
      << error;
  ASSERT_TRUE(t.periodic) << t.diagnostic;
  const int c = layout.coefficient_count();
  const auto [ic, is] = first_harmonic_index(layout);
  Eigen::VectorXd expected = Eigen::VectorXd::Zero(2 * c);
  if (a <= delta) {
    // Full stick from the unloaded start: T = kt u_t exactly.
    expected = kt * circular_motion(layout, a);
  } else {
    const double cos_alpha = delta / a, sin_alpha = std::sqrt(a * a - delta * delta) / a;
    expected(ic) = slip_force * cos_alpha;
    expected(is) = -slip_force * sin_alpha;
    expected(c + ic) = slip_force * sin_alpha;
    expected(c + is) = slip_force * cos_alpha;
  }
  const double scale = std::max(slip_force, expected.cwiseAbs().maxCoeff());
  const double err = (t.force_coefficients - expected).cwiseAbs().maxCoeff() / scale;
  // Measured: 1e-16 (stick), 9e-10 (a = 1.01 delta, the cubic motion's error) to 4.4e-8
  // (a = 100 delta: the Runge-Kutta sub-steps, kt |u'| ds / (mu N) <= 0.2, dominate).
  EXPECT_LT(err, 1e-6) << "a / delta = " << GetParam();
  const double energy = t.energy_per_cycle;
  EXPECT_NEAR(energy, kPi * a * (t.force_coefficients(c + ic) - t.force_coefficients(is)),
              1e-12 * slip_force * a);
  const double exact = a <= delta ? 0.0 : 2 * kPi * slip_force * std::sqrt(a * a - delta * delta);
  EXPECT_NEAR(energy, exact, 1e-6 * slip_force * a) << "a / delta = " << GetParam();
  std::cout << "along the motion, a / delta = " << GetParam() << ": force harmonics " << err
            << ", energy " << std::abs(energy - exact) / (slip_force * a) << "\n";
}

INSTANTIATE_TEST_SUITE_P(AmplitudeOverSlipThreshold, CoupledCircularSlipAlongTheMotion,
                         ::testing::Values(0.5, 1.01, 1.05, 1.5, 4.0, 40.0, 100.0));

TEST(Coupled3d, CircularSlipEnergyConvergesAtFirstOrderInTheSampling) {
  // The error of the loop energy against 2 pi mu N sqrt(a^2 - delta^2) is pi mu N delta D to
  // leading order: it halves when N doubles.
  const double slip_force = 2.5, delta = slip_force / 2e5, a = 4 * delta;
  auto h = test::make_law("coupled_3d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  const double expected = 2 * kPi * slip_force * std::sqrt(a * a - delta * delta);
  double previous = 0;
  for (const int n : {2048, 4096, 8192}) {
    HarmonicLayout layout({0, 1}, n);
    PeriodicTracer tracer(*h.law, layout, sample_steps());
    ContactTrace t;
    std::string error;
    ASSERT_TRUE(tracer.trace(circular_motion(layout, a), JacobianMode::kNone, t, &error));
    const double err = expected - loop_energy(t);
    EXPECT_NEAR(err, kPi * slip_force * delta * 2 * kPi / n, 0.01 * err) << "N = " << n;
    if (previous > 0) {
      EXPECT_NEAR(previous / err, 2.0, 0.01) << "N = " << n;
    }
    previous = err;
  }
}

// ---------------------------------------------------------------------------------------
// (2) Purely 1D tangential motion: the friction circle meets the t1 axis at +-mu N, so the
// law is jenkins_1d exactly, for constant and for variable normal load.
TEST(Coupled3d, OneDimensionalMotionEqualsJenkinsConstantNormalLoad) {
  const std::string params = "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}";
  auto coupled = test::make_law("coupled_3d", params);
  auto jenkins = test::make_law("jenkins_1d", params);
  HarmonicLayout layout({0, 1, 2, 3, 4, 5}, 128);
  const int c = layout.coefficient_count();
  PeriodicTracer tc(*coupled.law, layout, sample_steps()), tj(*jenkins.law, layout);
  for (unsigned seed : {1u, 2u, 3u}) {
    const Eigen::VectorXd u1 = random_motion(c, 3e-5, seed);
    Eigen::VectorXd u = Eigen::VectorXd::Zero(2 * c);
    u.head(c) = u1;
    ContactTrace a, b;
    std::string error;
    ASSERT_TRUE(tc.trace(u, JacobianMode::kAnalytic, a, &error)) << error;
    ASSERT_TRUE(tj.trace(u1, JacobianMode::kAnalytic, b, &error)) << error;
    EXPECT_GT(b.force.col(0).cwiseAbs().maxCoeff(), 2.5 - 1e-12) << "the motion must slip";
    EXPECT_LT((a.force_coefficients.head(c) - b.force_coefficients).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_EQ(a.force.col(1).cwiseAbs().maxCoeff(), 0.0);
    // The t1-t1 block of the Jacobian is jenkins_1d's, and T1 does not depend on u_t2.
    const double scale = b.jacobian.cwiseAbs().maxCoeff();
    EXPECT_LT((a.jacobian.topLeftCorner(c, c) - b.jacobian).cwiseAbs().maxCoeff(), 1e-12 * scale);
    EXPECT_LT(a.jacobian.block(0, c, c, c).cwiseAbs().maxCoeff(), 1e-12 * scale);
  }
}

TEST(Coupled3d, OneDimensionalMotionEqualsJenkinsVariableNormalLoad) {
  const std::string params = "{kt: 2.0e5, mu: 0.4, normal_load: 2.0, kn: 1.0e5}";
  auto coupled = test::make_law("coupled_3d", params);
  auto jenkins = test::make_law("jenkins_1d", params);
  HarmonicLayout layout({0, 1, 2, 3}, 128);
  const int c = layout.coefficient_count();
  PeriodicTracer tc(*coupled.law, layout, sample_steps()), tj(*jenkins.law, layout);
  ASSERT_EQ(tc.components(), (std::vector<int>{0, 1, 2}));
  ASSERT_EQ(tj.components(), (std::vector<int>{0, 2}));
  Eigen::VectorXd uj = random_motion(2 * c, 1e-5, 7);  // (t1, n)
  uj(c + 1) = 4e-5;  // normal first harmonic: the contact opens during part of the period
  Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * c);  // (t1, t2 = 0, n)
  u.head(c) = uj.head(c);
  u.tail(c) = uj.tail(c);
  ContactTrace a, b;
  std::string error;
  ASSERT_TRUE(tc.trace(u, JacobianMode::kAnalytic, a, &error)) << error;
  ASSERT_TRUE(tj.trace(uj, JacobianMode::kAnalytic, b, &error)) << error;
  EXPECT_TRUE((b.force.col(1).array() == 0.0).any() && (b.force.col(1).array() > 0.0).any());
  EXPECT_LT((a.force_coefficients.head(c) - b.force_coefficients.head(c)).cwiseAbs().maxCoeff(),
            1e-12);
  EXPECT_LT((a.force_coefficients.tail(c) - b.force_coefficients.tail(c)).cwiseAbs().maxCoeff(),
            1e-12);
  EXPECT_EQ(a.force.col(1).cwiseAbs().maxCoeff(), 0.0);
  // Jacobian rows and columns (t1, n) against jenkins_1d's.
  const double scale = b.jacobian.cwiseAbs().maxCoeff();
  for (int r = 0; r < 2; ++r)
    for (int q = 0; q < 2; ++q)
      EXPECT_LT(
          (a.jacobian.block(2 * r * c, 2 * q * c, c, c) - b.jacobian.block(r * c, q * c, c, c))
              .cwiseAbs()
              .maxCoeff(),
          1e-12 * scale)
          << "block " << r << ", " << q;
}

// ---------------------------------------------------------------------------------------
// (3) Analytic Jacobian against central differences on random multiharmonic 3D motion.
TEST(Coupled3d, AnalyticJacobianEqualsCentralDifferencesConstantNormalLoad) {
  auto h = test::make_law("coupled_3d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  HarmonicLayout layout({0, 1, 2, 3, 4, 5}, 128);
  PeriodicTracer tracer(*h.law, layout);
  for (unsigned seed : {1u, 2u, 3u}) {
    const Eigen::VectorXd u = random_motion(tracer.unknown_count(), 3e-5, seed);
    ContactTrace t;
    std::string error;
    ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
    ASSERT_TRUE(t.periodic) << t.diagnostic;
    ASSERT_FALSE(t.used_finite_differences);
    // The contact both slips (|T| = mu N) and sticks somewhere in the period.
    const Eigen::VectorXd magnitude = t.force.rowwise().norm();
    EXPECT_TRUE((magnitude.array() > 2.5 - 1e-9).any() && (magnitude.array() < 2.4).any());
    const Eigen::MatrixXd fd = central_differences(tracer, u);
    const double scale = fd.cwiseAbs().maxCoeff();
    EXPECT_GT(scale, 1e3);
    const double err = (t.jacobian - fd).cwiseAbs().maxCoeff() / scale;
    EXPECT_LT(err, 1e-6) << "seed " << seed;
    std::cout << "constant N, seed " << seed << ": Jacobian relative error " << err << "\n";
  }
}

TEST(Coupled3d, AnalyticJacobianEqualsCentralDifferencesVariableNormalLoad) {
  // N = max(0, 2 + 1e5 u_n); the second case opens the contact during part of the period.
  auto h = test::make_law("coupled_3d", "{kt: 2.0e5, mu: 0.4, normal_load: 2.0, kn: 1.0e5}");
  HarmonicLayout layout({0, 1, 2, 3}, 128);
  PeriodicTracer tracer(*h.law, layout);
  ASSERT_EQ(tracer.dimension(), 3);
  const int c = layout.coefficient_count();
  for (const bool separation : {false, true}) {
    Eigen::VectorXd u = random_motion(3 * c, 1e-5, separation ? 7u : 8u);
    u.tail(c) *= 0.5;                     // normal variation below the preload ...
    if (separation) u(2 * c + 1) = 4e-5;  // ... or beyond it: the contact opens
    ContactTrace t;
    std::string error;
    ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
    ASSERT_TRUE(t.periodic) << t.diagnostic;
    const bool opens = (t.force.col(2).array() == 0.0).any();
    EXPECT_EQ(opens, separation);
    EXPECT_TRUE((t.force.col(2).array() > 0.0).any());
    const Eigen::MatrixXd fd = central_differences(tracer, u);
    const double scale = fd.cwiseAbs().maxCoeff();
    const double err = (t.jacobian - fd).cwiseAbs().maxCoeff() / scale;
    EXPECT_LT(err, 1e-6) << "separation " << separation;
    // The normal load couples into the tangential forces: d T / d U_n is not zero.
    EXPECT_GT(fd.block(0, 2 * c, 2 * c, c).cwiseAbs().maxCoeff(), 1e-3 * scale);
    std::cout << "variable N, separation " << separation << ": Jacobian relative error " << err
              << "\n";
  }
}

TEST(Coupled3d, AnalyticJacobianFollowsTheSteadyCircularSlip) {
  auto h = test::make_law("coupled_3d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  HarmonicLayout layout({0, 1, 2, 3}, 256);
  PeriodicTracer tracer(*h.law, layout);
  Eigen::VectorXd u = circular_motion(layout, 4 * 1.25e-5);
  u += random_motion(u.size(), 2e-6, 4);  // a distorted circle: no symmetric degeneracy
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
  const Eigen::MatrixXd fd = central_differences(tracer, u);
  const double scale = fd.cwiseAbs().maxCoeff();
  EXPECT_LT((t.jacobian - fd).cwiseAbs().maxCoeff(), 1e-6 * scale);
}

// ---------------------------------------------------------------------------------------
// (4) Limits: mu = 0 gives no tangential force, a huge preload gives full stick T = kt u_t.
TEST(Coupled3d, ZeroFrictionGivesNoTangentialForce) {
  auto h = test::make_law("coupled_3d", "{kt: 3.0e5, mu: 0.0, normal_load: 10.0}");
  HarmonicLayout layout({0, 1, 3}, 32);
  PeriodicTracer tracer(*h.law, layout);
  const Eigen::VectorXd u = random_motion(tracer.unknown_count(), 1e-4, 3);
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
  EXPECT_EQ(t.force.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(t.jacobian.cwiseAbs().maxCoeff(), 0.0);
}

TEST(Coupled3d, ZeroFrictionWithVariableNormalLoadKeepsOnlyTheNormalForce) {
  auto h = test::make_law("coupled_3d", "{kt: 3.0e5, mu: 0.0, normal_load: 2.0, kn: 1.0e5}");
  HarmonicLayout layout({0, 1, 3}, 32);
  PeriodicTracer tracer(*h.law, layout);
  const Eigen::VectorXd u = random_motion(tracer.unknown_count(), 1e-5, 3);
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
  EXPECT_EQ(t.force.leftCols(2).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(t.jacobian.topRows(2 * layout.coefficient_count()).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Coupled3d, FullStickGivesTheLinearSpringForce) {
  auto h = test::make_law("coupled_3d", "{kt: 3.0e5, mu: 0.5, normal_load: 1.0e9}");
  HarmonicLayout layout({0, 1, 2, 3}, 64);
  PeriodicTracer tracer(*h.law, layout);
  const Eigen::VectorXd u = random_motion(tracer.unknown_count(), 2e-4, 9);
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
  EXPECT_EQ(t.passes, 1);
  EXPECT_LT((t.force - 3e5 * t.displacement).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((t.force_coefficients - 3e5 * u).cwiseAbs().maxCoeff(), 1e-9);
  const auto p = tracer.unknown_count();
  EXPECT_LT((t.jacobian - 3e5 * Eigen::MatrixXd::Identity(p, p)).cwiseAbs().maxCoeff(), 1e-6);
}

// ---------------------------------------------------------------------------------------
// (5) Separation: N = max(0, N0 + kn u_n) sample by sample, no tangential force when open;
// (7) the Coulomb bound |T| <= mu N at every sample.
TEST(Coupled3d, SeparationGivesNoForceAndTheNormalForceFollowsTheGapLaw) {
  const double mu = 0.4, n0 = 2.0, kn = 1e5;
  auto h = test::make_law("coupled_3d", "{kt: 2.0e5, mu: 0.4, normal_load: 2.0, kn: 1.0e5}");
  HarmonicLayout layout({0, 1, 2, 3}, 200);
  PeriodicTracer tracer(*h.law, layout);
  const int c = layout.coefficient_count();
  Eigen::VectorXd u = random_motion(3 * c, 1e-5, 21);
  u(2 * c + 1) = 5e-5;
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kNone, t, &error)) << error;
  int open = 0;
  for (int j = 0; j < layout.samples(); ++j) {
    const double normal = std::max(0.0, n0 + kn * t.displacement(j, 2));
    EXPECT_NEAR(t.force(j, 2), normal, 1e-12) << "sample " << j;
    if (normal == 0.0) {
      ++open;
      EXPECT_EQ(t.force(j, 0), 0.0) << "sample " << j;
      EXPECT_EQ(t.force(j, 1), 0.0) << "sample " << j;
    }
    EXPECT_LE(t.force.row(j).head(2).norm(), mu * t.force(j, 2) + 1e-12) << "sample " << j;
  }
  EXPECT_GT(open, 10);
  EXPECT_LT(open, layout.samples() - 10);
}

TEST(Coupled3d, InitialGapClosesOnlyBeyondTheGap) {
  auto h = test::make_law("coupled_3d", "{kt: 1.0e5, mu: 0.3, kn: 2.0e5, gap: 1.0e-5}");
  HarmonicLayout layout({0, 1, 2, 3}, 96);
  PeriodicTracer tracer(*h.law, layout);
  EXPECT_EQ(tracer.reference_force().norm(), 0.0);  // an open contact carries no preload
  const int c = layout.coefficient_count();
  Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * c);
  u(2) = 3e-5;            // t1 sin(theta)
  u(c + 1) = 2e-5;        // t2 cos(theta)
  u(2 * c + 1) = 2.1e-5;  // normal cos(theta); no sample on the kink
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
  for (int j = 0; j < layout.samples(); ++j) {
    EXPECT_NEAR(t.force(j, 2), std::max(0.0, 2e5 * (t.displacement(j, 2) - 1e-5)), 1e-12);
    EXPECT_LE(t.force.row(j).head(2).norm(), 0.3 * t.force(j, 2) + 1e-12);
  }
  const Eigen::MatrixXd fd = central_differences(tracer, u);
  EXPECT_LT((t.jacobian - fd).cwiseAbs().maxCoeff(), 1e-6 * fd.cwiseAbs().maxCoeff());
}

TEST(Coupled3d, CoulombBoundHoldsAtEverySample) {
  auto h = test::make_law("coupled_3d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  HarmonicLayout layout({0, 1, 2, 3, 4, 5}, 256);
  PeriodicTracer tracer(*h.law, layout);
  for (unsigned seed : {11u, 12u, 13u, 14u}) {
    ContactTrace t;
    std::string error;
    ASSERT_TRUE(tracer.trace(random_motion(tracer.unknown_count(), 5e-5, seed), JacobianMode::kNone,
                             t, &error))
        << error;
    const Eigen::VectorXd magnitude = t.force.rowwise().norm();
    EXPECT_LE(magnitude.maxCoeff(), 2.5 + 1e-12) << "seed " << seed;
    EXPECT_GT(magnitude.maxCoeff(), 2.5 - 1e-9) << "seed " << seed << ": the motion must slip";
  }
}

// ---------------------------------------------------------------------------------------
// (6) Frame invariance: rotating the tangential motion by an angle rotates the force.
TEST(Coupled3d, RotatingTheTangentialMotionRotatesTheForce) {
  for (const std::string params : {"{kt: 2.0e5, mu: 0.5, normal_load: 5.0}",
                                   "{kt: 2.0e5, mu: 0.4, normal_load: 2.0, kn: 1.0e5}"}) {
    auto h = test::make_law("coupled_3d", params);
    HarmonicLayout layout({0, 1, 2, 3}, 128);
    PeriodicTracer tracer(*h.law, layout);
    const int c = layout.coefficient_count();
    Eigen::VectorXd u = random_motion(tracer.unknown_count(), 3e-5, 17);
    if (tracer.dimension() == 3) u(2 * c + 1) = 3e-5;  // with separation
    ContactTrace base;
    std::string error;
    ASSERT_TRUE(tracer.trace(u, JacobianMode::kNone, base, &error)) << error;
    for (const double angle : {0.3, kPi / 2, 2.0, -1.1}) {
      const double co = std::cos(angle), si = std::sin(angle);
      Eigen::VectorXd v = u;
      v.head(c) = co * u.head(c) - si * u.segment(c, c);
      v.segment(c, c) = si * u.head(c) + co * u.segment(c, c);
      ContactTrace rotated;
      ASSERT_TRUE(tracer.trace(v, JacobianMode::kNone, rotated, &error)) << error;
      for (int j = 0; j < layout.samples(); ++j) {
        const double t1 = co * base.force(j, 0) - si * base.force(j, 1);
        const double t2 = si * base.force(j, 0) + co * base.force(j, 1);
        EXPECT_NEAR(rotated.force(j, 0), t1, 1e-12) << params << " angle " << angle;
        EXPECT_NEAR(rotated.force(j, 1), t2, 1e-12) << params << " angle " << angle;
        if (tracer.dimension() == 3) {
          EXPECT_NEAR(rotated.force(j, 2), base.force(j, 2), 1e-12);
        }
      }
    }
  }
}

TEST(Coupled3d, GapWithoutNormalStiffnessOrWithPreloadIsRefused) {
  EXPECT_THROW(test::make_law("coupled_3d", "{kt: 1.0e5, mu: 0.3, gap: 1.0e-5}"), PluginError);
  try {
    test::make_law("coupled_3d", "{kt: 1.0e5, mu: 0.3, kn: 2.0e5, gap: 1.0e-5, normal_load: 1}");
    FAIL() << "a gap with a preload must be refused";
  } catch (const PluginError& e) {
    EXPECT_NE(std::string(e.what()).find("either normal_load (preload) or gap"), std::string::npos);
  }
}

TEST(Coupled3d, TraitsFollowTheNormalStiffness) {
  auto constant = test::make_law("coupled_3d", "{kt: 1.0e5, mu: 0.3, normal_load: 1.0}");
  auto variable = test::make_law("coupled_3d", "{kt: 1.0e5, mu: 0.3, kn: 1.0e5}");
  EXPECT_EQ(constant.law->traits().tangential_dimensions, 2);
  EXPECT_EQ(constant.law->traits().uses_normal, 0);
  EXPECT_EQ(variable.law->traits().uses_normal, 1);
  EXPECT_EQ(variable.law->traits().state_size, 2);
  EXPECT_EQ(variable.law->traits().provides_tangent, 1);
}

// ---------------------------------------------------------------------------------------
TEST(Coupled3d, EveryStepTangentBlockMatchesDifferencesOfOneStep) {
  auto h = test::make_law("coupled_3d", "{kt: 2.0e5, mu: 0.4, normal_load: 2.0, kn: 1.0e5}");
  const ContactLawInstance& law = *h.law;
  // N = 2 + 1e5 * 1e-5 = 3, mu N = 1.2 N, mu N / kt = 6e-6 m.
  const Eigen::Vector3d u(1e-5, -4e-6, 1e-5);
  expect_step_tangents_match_differences(law, {0, 0}, u);         // both slip
  expect_step_tangents_match_differences(law, {2e-6, -3e-6}, u);  // slip (t2 alone would stick)
  expect_step_tangents_match_differences(law, {9e-6, -3e-6}, u);  // stick
  expect_step_tangents_match_differences(law, {0, 0}, {1e-5, 2e-6, -3e-5});  // separated
}

TEST(Coupled3d, SeparationReleasesTheSlider) {
  auto h = test::make_law("coupled_3d", "{kt: 2.0e5, mu: 0.4, normal_load: 2.0, kn: 1.0e5}");
  // Open (2 + 1e5 * (-3e-5) < 0): no force, the slider jumps to u_t.
  const StepResult open = step_law(*h.law, {3e-5, -2e-5}, {1e-5, 2e-5, -3e-5});
  EXPECT_EQ(open.force, Eigen::Vector3d::Zero());
  EXPECT_EQ(open.state, Eigen::Vector2d(1e-5, 2e-5));
  // Closing again (N = 3, mu N = 1.2) 1e-6 m further sticks from the released slider.
  const StepResult closed = step_law(*h.law, open.state, {1.1e-5, 2e-5, 1e-5});
  EXPECT_NEAR(closed.force(0), 2e5 * 1e-6, 1e-12);
  EXPECT_EQ(closed.force(1), 0.0);
  EXPECT_NEAR(closed.force(2), 3.0, 1e-12);
  EXPECT_EQ(closed.state, open.state);
}

// ---------------------------------------------------------------------------------------
// (7) Newton steps on the periodic state against plain passes. A line motion along t1 just
// above the slip amplitude delta slips for a short part of the period, and a small t2 motion
// leaves the slider's t2 position to settle by the little it moves at each slip: the plain
// passes contract slowly (hundreds of passes to 1e-11 near a = delta). Plain passes (up to
// 5000) are the oracle; they stop when a pass changes the state by 1e-11, which leaves them
// up to 1e-11 / (1 - rho) from their limit (rho the contraction per pass), so the Jacobians
// agree to 1e-9, the forces to 1e-12. The Jacobian of the Newton traces is checked against
// central differences as well.
TEST(Coupled3d, NewtonOnThePeriodicStateMeetsThePlainPassesInFewPasses) {
  auto h = test::make_law("coupled_3d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  HarmonicLayout layout({0, 1, 2, 3}, 256);
  TraceOptions plain_options;
  plain_options.newton_on_periodic_state = false;
  plain_options.max_passes = 5000;
  PeriodicTracer newton(*h.law, layout), plain(*h.law, layout, plain_options);
  const int c = layout.coefficient_count();
  const auto [ic, is] = first_harmonic_index(layout);
  const double delta = 0.5 * 5.0 / 2e5;
  int most_plain_passes = 0;
  for (const double a : {1.01, 1.05, 1.2, 1.5}) {
    for (const double b : {0.1, 0.3, 0.6, 1.0}) {
      Eigen::VectorXd u = Eigen::VectorXd::Zero(2 * c);
      u(ic) = a * delta;
      u(c + is) = b * delta;
      u(c) = 0.5 * delta;  // a static t2 offset
      ContactTrace fast, slow;
      std::string error;
      ASSERT_TRUE(newton.trace(u, JacobianMode::kAnalytic, fast, &error)) << error;
      ASSERT_TRUE(plain.trace(u, JacobianMode::kAnalytic, slow, &error)) << error;
      ASSERT_TRUE(fast.periodic) << fast.diagnostic;
      ASSERT_TRUE(slow.periodic) << slow.diagnostic;
      EXPECT_EQ(slow.newton_passes, 0);
      EXPECT_LE(fast.passes, 12) << "a " << a << ", b " << b;
      most_plain_passes = std::max(most_plain_passes, slow.passes);
      const double force_scale = slow.force_coefficients.cwiseAbs().maxCoeff();
      EXPECT_LT((fast.force_coefficients - slow.force_coefficients).cwiseAbs().maxCoeff(),
                1e-12 * force_scale)
          << "a " << a << ", b " << b;
      const double jacobian_scale = slow.jacobian.cwiseAbs().maxCoeff();
      EXPECT_LT((fast.jacobian - slow.jacobian).cwiseAbs().maxCoeff(), 1e-9 * jacobian_scale)
          << "a " << a << ", b " << b;
      std::cout << "a/delta " << a << ", b/delta " << b << ": " << fast.passes << " passes ("
                << fast.newton_passes << " Newton steps) against " << slow.passes << "\n";
      if (a == 1.01 && b == 0.1) {
        const Eigen::MatrixXd fd = central_differences(newton, u);
        EXPECT_LT((fast.jacobian - fd).cwiseAbs().maxCoeff(), 1e-6 * fd.cwiseAbs().maxCoeff());
      }
    }
  }
  EXPECT_GT(most_plain_passes, 300);  // the slow regime is exercised
}

// The motion of one node pair of the patch_100 shroud contact (scaled kt, kn and preload, three
// local components over harmonics 0..5) near its resonance: the slider's periodic state
// contracts by only 1 - 5.6e-4 per period in its slow direction, the multiplier growing from
// 0.71 to that value as the passes approach it, while the other direction settles in one pass.
// Newton steps on the periodic state whose next pass changed it by more than the pass before
// (the fast direction following the step) are refused without giving up the steps: the trace
// becomes periodic within the default 200 passes, on the periodic state that plain passes
// reach after some 30000 (the oracle, to a tighter tolerance).
TEST(Coupled3d, SlowlyContractingSliderStateBecomesPeriodicWithNewtonSteps) {
  auto h = test::make_law("coupled_3d",
                          "{kt: 2631.5789473684263, kn: 1315.7894736842131, mu: 0.5, "
                          "normal_load: 0.08518005540166185}");
  const HarmonicLayout layout({0, 1, 2, 3, 4, 5}, 256);
  const Eigen::VectorXd u{
      {1.0887344368998084e-06, 7.070901237105558e-06,   -8.80228646140838e-06,
       2.144176381537392e-07,  3.8483352048810136e-07,  1.015254464638649e-08,
       -9.928482852787434e-09, 2.001788911408127e-10,   -3.8178910186136933e-10,
       4.772532279050302e-10,  9.931703367716629e-11,   4.5221684622550924e-07,
       1.0035269710095901e-05, 7.641981976880874e-06,   1.4433704627706539e-06,
       -3.22601680325962e-07,  1.7632265473557672e-08,  3.431181352779203e-08,
       -6.428707160635705e-09, 6.182704829957802e-10,   -4.983951899342815e-10,
       6.363667160191904e-10,  -8.54989859185197e-09,   -1.9768491458776366e-05,
       2.4248847343312227e-05, 4.180405406476013e-08,   2.1983945832741601e-07,
       9.904557789814531e-10,  -2.4511443776186032e-09, -7.15364491889459e-10,
       5.688390690072505e-10,  -1.7385916580048558e-11, -2.1671433992967115e-11}};
  TraceOptions plain;
  plain.newton_on_periodic_state = false;
  plain.max_passes = 200000;
  plain.relative_tolerance = 1e-14;
  PeriodicTracer oracle_tracer(*h.law, layout, plain);
  ASSERT_EQ(oracle_tracer.unknown_count(), u.size());
  ContactTrace oracle;
  std::string error;
  ASSERT_TRUE(oracle_tracer.trace(u, JacobianMode::kNone, oracle, &error)) << error;
  ASSERT_TRUE(oracle.periodic) << oracle.diagnostic;
  EXPECT_GT(oracle.passes, 10000);
  const double scale = oracle.force_coefficients.cwiseAbs().maxCoeff();
  PeriodicTracer tracer(*h.law, layout);
  for (const JacobianMode mode : {JacobianMode::kNone, JacobianMode::kAnalytic}) {
    ContactTrace t;
    ASSERT_TRUE(tracer.trace(u, mode, t, &error)) << error;
    EXPECT_TRUE(t.periodic) << t.diagnostic;
    EXPECT_LT(t.passes, 100);
    // The oracle stops within 1e-14 per pass of the state, 2e-11 of it at this contraction.
    EXPECT_LT((t.force_coefficients - oracle.force_coefficients).cwiseAbs().maxCoeff(),
              1e-8 * scale);
    if (mode != JacobianMode::kAnalytic) continue;
    // The Jacobian of the periodic forces, against central differences of traces that each
    // become periodic as well. The periodic state moves by 1 / (1 - 0.99944) times a pass's
    // response to U, and the differences err by as much: measured against the analytic
    // Jacobian, 2.3e-3 at steps of 1e-5 of the largest coefficient and 2.3e-5 at 1e-6
    // (truncation, quadratic in the step), 1.9e-6 at 1e-7 (central_differences), 2.2e-5 at 1e-8
    // (rounding).
    const Eigen::MatrixXd fd = central_differences(tracer, u);
    const double jacobian_scale = fd.cwiseAbs().maxCoeff();
    const double err = (t.jacobian - fd).cwiseAbs().maxCoeff() / jacobian_scale;
    EXPECT_LT(err, 1e-5);
    std::cout << "slowly contracting slider: " << t.passes << " passes, Jacobian relative error "
              << err << "\n";
  }
}

}  // namespace
}  // namespace frichb::core
