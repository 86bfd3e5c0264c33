// Two independent Jenkins sliders in t1 and t2 (square friction limit) through the real loader
// and the periodic tracer: component-wise equality with jenkins_1d, the analytic Jacobian
// against central differences (with a variable normal load and separation), and circular
// motion, where |T| exceeds mu N (up to sqrt(2) mu N) unlike coupled_3d.
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

// Under a constant normal load the two directions are two jenkins_1d elements.
TEST(Uncoupled2d, EqualsTwoJenkinsTracesComponentWise) {
  const std::string params = "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}";
  auto law = test::make_law("uncoupled_2d", params);
  auto jenkins = test::make_law("jenkins_1d", params);
  HarmonicLayout layout({0, 1, 2, 3, 4, 5}, 128);
  const int c = layout.coefficient_count();
  PeriodicTracer tu(*law.law, layout), tj(*jenkins.law, layout);
  ASSERT_EQ(tu.components(), (std::vector<int>{0, 1}));
  for (unsigned seed : {1u, 2u, 3u}) {
    const Eigen::VectorXd u = random_motion(2 * c, 3e-5, seed);
    ContactTrace t, first, second;
    std::string error;
    ASSERT_TRUE(tu.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
    ASSERT_TRUE(tj.trace(u.head(c), JacobianMode::kAnalytic, first, &error)) << error;
    ASSERT_TRUE(tj.trace(u.tail(c), JacobianMode::kAnalytic, second, &error)) << error;
    EXPECT_GT(first.force.cwiseAbs().maxCoeff(), 2.5 - 1e-12) << "t1 must slip";
    EXPECT_GT(second.force.cwiseAbs().maxCoeff(), 2.5 - 1e-12) << "t2 must slip";
    EXPECT_LT((t.force_coefficients.head(c) - first.force_coefficients).cwiseAbs().maxCoeff(),
              1e-12);
    EXPECT_LT((t.force_coefficients.tail(c) - second.force_coefficients).cwiseAbs().maxCoeff(),
              1e-12);
    // The Jacobian is block diagonal with the two jenkins_1d Jacobians.
    const double scale =
        std::max(first.jacobian.cwiseAbs().maxCoeff(), second.jacobian.cwiseAbs().maxCoeff());
    EXPECT_LT((t.jacobian.topLeftCorner(c, c) - first.jacobian).cwiseAbs().maxCoeff(),
              1e-12 * scale);
    EXPECT_LT((t.jacobian.bottomRightCorner(c, c) - second.jacobian).cwiseAbs().maxCoeff(),
              1e-12 * scale);
    EXPECT_EQ(t.jacobian.topRightCorner(c, c).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_EQ(t.jacobian.bottomLeftCorner(c, c).cwiseAbs().maxCoeff(), 0.0);
  }
}

TEST(Uncoupled2d, OneDimensionalMotionEqualsJenkins) {
  for (const std::string params : {"{kt: 2.0e5, mu: 0.5, normal_load: 5.0}",
                                   "{kt: 2.0e5, mu: 0.4, normal_load: 2.0, kn: 1.0e5}"}) {
    auto law = test::make_law("uncoupled_2d", params);
    auto jenkins = test::make_law("jenkins_1d", params);
    HarmonicLayout layout({0, 1, 2, 3}, 128);
    const int c = layout.coefficient_count();
    PeriodicTracer tu(*law.law, layout), tj(*jenkins.law, layout);
    const bool variable = tj.dimension() == 2;
    Eigen::VectorXd uj = random_motion(tj.unknown_count(), variable ? 1e-5 : 3e-5, 7);
    if (variable) uj(c + 1) = 4e-5;  // normal first harmonic: the contact opens
    Eigen::VectorXd u = Eigen::VectorXd::Zero(tu.unknown_count());  // (t1, t2 = 0[, n])
    u.head(c) = uj.head(c);
    if (variable) u.tail(c) = uj.tail(c);
    ContactTrace a, b;
    std::string error;
    ASSERT_TRUE(tu.trace(u, JacobianMode::kAnalytic, a, &error)) << error;
    ASSERT_TRUE(tj.trace(uj, JacobianMode::kAnalytic, b, &error)) << error;
    EXPECT_GT(b.force.col(0).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_LT((a.force_coefficients.head(c) - b.force_coefficients.head(c)).cwiseAbs().maxCoeff(),
              1e-12)
        << params;
    EXPECT_EQ(a.force.col(1).cwiseAbs().maxCoeff(), 0.0);
    if (variable) {
      EXPECT_TRUE((b.force.col(1).array() == 0.0).any() && (b.force.col(1).array() > 0.0).any());
      EXPECT_LT((a.force_coefficients.tail(c) - b.force_coefficients.tail(c)).cwiseAbs().maxCoeff(),
                1e-12);
    }
  }
}

TEST(Uncoupled2d, AnalyticJacobianEqualsCentralDifferences) {
  struct Case {
    std::string params;
    bool separation;
  };
  for (const Case& k : {Case{"{kt: 2.0e5, mu: 0.5, normal_load: 5.0}", false},
                        Case{"{kt: 2.0e5, mu: 0.4, normal_load: 2.0, kn: 1.0e5}", false},
                        Case{"{kt: 2.0e5, mu: 0.4, normal_load: 2.0, kn: 1.0e5}", true}}) {
    auto h = test::make_law("uncoupled_2d", k.params);
    HarmonicLayout layout({0, 1, 2, 3}, 128);
    PeriodicTracer tracer(*h.law, layout);
    const int c = layout.coefficient_count();
    Eigen::VectorXd u = random_motion(tracer.unknown_count(), 2e-5, 5);
    if (tracer.dimension() == 3) {
      u.tail(c) *= 0.25;                      // normal variation below the preload ...
      if (k.separation) u(2 * c + 1) = 4e-5;  // ... or beyond it: the contact opens
    }
    ContactTrace t;
    std::string error;
    ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
    ASSERT_TRUE(t.periodic) << t.diagnostic;
    ASSERT_FALSE(t.used_finite_differences);
    if (tracer.dimension() == 3) {
      EXPECT_EQ((t.force.col(2).array() == 0.0).any(), k.separation) << k.params;
    }
    const Eigen::MatrixXd fd = central_differences(tracer, u);
    const double scale = fd.cwiseAbs().maxCoeff();
    EXPECT_GT(scale, 1e3);
    const double err = (t.jacobian - fd).cwiseAbs().maxCoeff() / scale;
    EXPECT_LT(err, 1e-6) << k.params << " separation " << k.separation << "\nanalytic\n"
                         << t.jacobian << "\nfd\n"
                         << fd;
    std::cout << k.params << (k.separation ? " with separation" : "")
              << ": Jacobian relative error " << err << "\n";
  }
}

// t1 slips every cycle (its slider's start is forgotten: the periodic state's derivative is the
// fixed point of one pass), t2 slips once to a static offset during the first pass and then
// sticks (its slider keeps what the warm-up made of U: a direction the passes never contract).
// The Jacobian of both, together, against central differences.
TEST(Uncoupled2d, AnalyticJacobianWithOneAxisSlippingAndOneStuckAfterTheWarmUp) {
  auto h = test::make_law("uncoupled_2d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  HarmonicLayout layout({0, 1, 2}, 64);
  PeriodicTracer tracer(*h.law, layout);
  const int c = layout.coefficient_count();
  Eigen::VectorXd u = Eigen::VectorXd::Zero(2 * c);
  u(1) = 4e-5;      // t1: cosine amplitude 3.2 mu N / kt, slipping twice a cycle
  u(c) = 1e-3;      // t2: static offset 80 mu N / kt ...
  u(c + 2) = 4e-6;  // ... and a sine amplitude below the reversal threshold 2 mu N / kt
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
  ASSERT_TRUE(t.periodic) << t.diagnostic;
  ASSERT_FALSE(t.used_finite_differences);
  const Eigen::MatrixXd fd = central_differences(tracer, u);
  EXPECT_NEAR(fd(c, c), 0.0, 1e-6 * 2e5);  // t2's mean force stays at mu N whatever its offset
  EXPECT_LT((t.jacobian - fd).cwiseAbs().maxCoeff(), 1e-6 * fd.cwiseAbs().maxCoeff());
}

TEST(Uncoupled2d, SeparationReleasesBothSliders) {
  auto h = test::make_law("uncoupled_2d", "{kt: 2.0e5, mu: 0.4, normal_load: 2.0, kn: 1.0e5}");
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
    const double normal = std::max(0.0, 2.0 + 1e5 * t.displacement(j, 2));
    EXPECT_NEAR(t.force(j, 2), normal, 1e-12) << "sample " << j;
    EXPECT_LE(std::abs(t.force(j, 0)), 0.4 * t.force(j, 2) + 1e-12);
    EXPECT_LE(std::abs(t.force(j, 1)), 0.4 * t.force(j, 2) + 1e-12);
    if (normal == 0.0) {
      ++open;
      EXPECT_EQ(t.force(j, 0), 0.0);
      EXPECT_EQ(t.force(j, 1), 0.0);
    }
  }
  EXPECT_GT(open, 10);
}

// The documented difference from coupled_3d: on circular motion u_t = a (cos, sin) each
// direction is a 1D Jenkins loop of amplitude a, so |T| reaches sqrt(2) mu N where both slip
// and the energy per cycle is 2 x 4 mu N (a - mu N / kt) instead of coupled_3d's
// 2 pi mu N sqrt(a^2 - (mu N / kt)^2) with |T| = mu N (tests/test_coupled_3d.cpp; only the
// closed form is used here so that this suite needs no other plugin than jenkins_1d).
TEST(Uncoupled2d, CircularMotionExceedsTheFrictionCircle) {
  const double kt = 2e5, slip_force = 2.5, delta = slip_force / kt, a = 4 * delta;
  const std::string params = "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}";
  auto uncoupled = test::make_law("uncoupled_2d", params);
  HarmonicLayout layout({0, 1, 2, 3}, 2048);
  const int c = layout.coefficient_count();
  Eigen::VectorXd u = Eigen::VectorXd::Zero(2 * c);
  u(1) = a;      // t1: a cos(theta)
  u(c + 2) = a;  // t2: a sin(theta)
  PeriodicTracer tu(*uncoupled.law, layout);
  ContactTrace square;
  std::string error;
  ASSERT_TRUE(tu.trace(u, JacobianMode::kNone, square, &error)) << error;
  const Eigen::VectorXd magnitude = square.force.rowwise().norm();
  EXPECT_GT(magnitude.maxCoeff(), 1.41 * slip_force);
  EXPECT_LE(magnitude.maxCoeff(), std::sqrt(2.0) * slip_force + 1e-12);
  EXPECT_LE(square.force.cwiseAbs().maxCoeff(), slip_force + 1e-12);  // each within mu N
  // Where both directions slip |T| = sqrt(2) mu N: a good part of the period for a = 4 delta
  // (each reverses and sticks over an angle acos(1 - 2 delta / a) = 60 deg of every 180 deg).
  const int both =
      static_cast<int>((magnitude.array() > std::sqrt(2.0) * slip_force * (1 - 1e-12)).count());
  EXPECT_GT(both, layout.samples() / 4);
  const double energy_square = loop_energy(square);
  const double expected_square = 8 * slip_force * (a - delta);
  EXPECT_NEAR(energy_square, expected_square, 2e-5 * expected_square);
  // The energies differ too, though little at this amplitude (24 vs 24.3 mu N delta); for
  // a >> delta the square dissipates 8 / (2 pi) = 1.27 times more.
  const double energy_circle = 2 * kPi * slip_force * std::sqrt(a * a - delta * delta);
  std::cout << "circular motion a = 4 mu N / kt: max |T| / mu N = "
            << magnitude.maxCoeff() / slip_force
            << ", energy uncoupled / coupled = " << energy_square / energy_circle << "\n";
}

TEST(Uncoupled2d, ZeroFrictionAndFullStick) {
  auto free = test::make_law("uncoupled_2d", "{kt: 3.0e5, mu: 0.0, normal_load: 10.0}");
  auto stuck = test::make_law("uncoupled_2d", "{kt: 3.0e5, mu: 0.5, normal_load: 1.0e9}");
  HarmonicLayout layout({0, 1, 2, 3}, 64);
  PeriodicTracer tf(*free.law, layout), ts(*stuck.law, layout);
  const Eigen::VectorXd u = random_motion(tf.unknown_count(), 2e-4, 9);
  ContactTrace a, b;
  std::string error;
  ASSERT_TRUE(tf.trace(u, JacobianMode::kAnalytic, a, &error)) << error;
  ASSERT_TRUE(ts.trace(u, JacobianMode::kAnalytic, b, &error)) << error;
  EXPECT_EQ(a.force.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(a.jacobian.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LT((b.force_coefficients - 3e5 * u).cwiseAbs().maxCoeff(), 1e-9);
  const auto p = ts.unknown_count();
  EXPECT_LT((b.jacobian - 3e5 * Eigen::MatrixXd::Identity(p, p)).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(Uncoupled2d, GapWithoutNormalStiffnessOrWithPreloadIsRefused) {
  EXPECT_THROW(test::make_law("uncoupled_2d", "{kt: 1.0e5, mu: 0.3, gap: 1.0e-5}"), PluginError);
  try {
    test::make_law("uncoupled_2d", "{kt: 1.0e5, mu: 0.3, kn: 2.0e5, gap: 1.0e-5, normal_load: 1}");
    FAIL() << "a gap with a preload must be refused";
  } catch (const PluginError& e) {
    EXPECT_NE(std::string(e.what()).find("either normal_load (preload) or gap"), std::string::npos);
  }
}

// ---------------------------------------------------------------------------------------
TEST(Uncoupled2d, EveryStepTangentBlockMatchesDifferencesOfOneStep) {
  auto h = test::make_law("uncoupled_2d", "{kt: 2.0e5, mu: 0.4, normal_load: 2.0, kn: 1.0e5}");
  const ContactLawInstance& law = *h.law;
  // N = 2 + 1e5 * 1e-5 = 3, mu N = 1.2 N, mu N / kt = 6e-6 m.
  const Eigen::Vector3d u(1e-5, -4e-6, 1e-5);
  expect_step_tangents_match_differences(law, {0, 0}, u);                    // both slip
  expect_step_tangents_match_differences(law, {2e-6, -3e-6}, u);             // t1 slips, t2 sticks
  expect_step_tangents_match_differences(law, {9e-6, -3e-6}, u);             // stick
  expect_step_tangents_match_differences(law, {0, 0}, {1e-5, 2e-6, -3e-5});  // separated
}

TEST(Uncoupled2d, SeparationReleasesTheSlider) {
  auto h = test::make_law("uncoupled_2d", "{kt: 2.0e5, mu: 0.4, normal_load: 2.0, kn: 1.0e5}");
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

}  // namespace
}  // namespace frichb::core
