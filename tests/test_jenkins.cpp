// The Jenkins element through the real loader and the periodic tracer, against closed forms:
// loop energy, describing function, full stick, mu = 0, and the analytic Jacobian against
// central differences.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "frichb/core/plugin_host/periodic_trace.hpp"
#include "test_support.hpp"

namespace frichb::core {
namespace {

using test::central_differences;
using test::random_motion;

constexpr double kPi = std::numbers::pi;

// u = a cos(theta) in the first tangential direction.
Eigen::VectorXd cosine_motion(const HarmonicLayout& layout, double a) {
  Eigen::VectorXd u = Eigen::VectorXd::Zero(layout.coefficient_count());
  for (std::size_t k = 0; k < layout.harmonics().size(); ++k)
    if (layout.harmonics()[k] == 1) u(layout.cos_index(k)) = a;
  return u;
}

struct FirstHarmonic {
  double c1, s1;
};
FirstHarmonic first_harmonic(const HarmonicLayout& layout, const Eigen::VectorXd& f) {
  for (std::size_t k = 0; k < layout.harmonics().size(); ++k)
    if (layout.harmonics()[k] == 1) return {f(layout.cos_index(k)), f(layout.sin_index(k))};
  return {0, 0};
}

class JenkinsClosedForm : public ::testing::TestWithParam<double> {};

// kt = 2e5 N/m, mu N = 2.5 N: slip starts at a = mu N / kt = 1.25e-5 m.
TEST_P(JenkinsClosedForm, LoopEnergyAndDescribingFunction) {
  const double kt = 2e5, slip_force = 0.5 * 5.0;
  auto h = test::make_law("jenkins_1d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  HarmonicLayout layout({0, 1, 2, 3, 4, 5, 6, 7}, 4096);
  PeriodicTracer tracer(*h.law, layout);
  const double a = GetParam() * slip_force / kt;
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(cosine_motion(layout, a), JacobianMode::kNone, t, &error)) << error;
  ASSERT_TRUE(t.periodic);
  const auto [c1, s1] = first_harmonic(layout, t.force_coefficients);
  // Energy per cycle: closed integral of T du over the traced loop.
  double energy = 0;
  const int n = layout.samples();
  for (int j = 0; j < n; ++j) {
    const int jn = (j + 1) % n;
    energy +=
        0.5 * (t.force(j, 0) + t.force(jn, 0)) * (t.displacement(jn, 0) - t.displacement(j, 0));
  }
  if (a <= slip_force / kt) {
    EXPECT_NEAR(energy, 0.0, 1e-12 * slip_force * a);
    EXPECT_NEAR(c1, kt * a, 1e-10 * kt * a);
    EXPECT_NEAR(s1, 0.0, 1e-10 * kt * a);
    return;
  }
  const double expected_energy = 4 * slip_force * (a - slip_force / kt);
  EXPECT_NEAR(energy, expected_energy, 2e-5 * expected_energy);
  EXPECT_NEAR(-kPi * a * s1, expected_energy, 2e-5 * expected_energy);  // energy from s1
  // Describing function: cos(phi) = 1 - 2 mu N / (kt a),
  //   c1 = kt a / pi (phi - sin(2 phi) / 2),  s1 = -(4 mu N / pi)(1 - mu N / (kt a)).
  const double phi = std::acos(1 - 2 * slip_force / (kt * a));
  EXPECT_NEAR(c1, kt * a / kPi * (phi - 0.5 * std::sin(2 * phi)), 2e-5 * kt * a);
  EXPECT_NEAR(s1, -4 * slip_force / kPi * (1 - slip_force / (kt * a)), 2e-5 * slip_force);
}

INSTANTIATE_TEST_SUITE_P(AmplitudeOverSlipThreshold, JenkinsClosedForm,
                         ::testing::Values(0.3, 0.999, 1.2, 2.0, 5.0, 40.0));

TEST(Jenkins, FullStickGivesTheLinearSpringForce) {
  auto h = test::make_law("jenkins_1d", "{kt: 3.0e5, mu: 0.5, normal_load: 1.0e9}");
  HarmonicLayout layout({0, 1, 2, 3}, 64);
  PeriodicTracer tracer(*h.law, layout);
  Eigen::VectorXd u(7);
  u << 1e-4, 2e-4, -1e-4, 5e-5, 3e-5, -2e-5, 1e-5;
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error));
  EXPECT_EQ(t.passes, 1);
  EXPECT_LT((t.force_coefficients - 3e5 * u).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((t.jacobian - 3e5 * Eigen::MatrixXd::Identity(7, 7)).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(Jenkins, ZeroFrictionGivesNoForce) {
  auto h = test::make_law("jenkins_1d", "{kt: 3.0e5, mu: 0.0, normal_load: 10.0}");
  HarmonicLayout layout({0, 1, 3}, 32);
  PeriodicTracer tracer(*h.law, layout);
  Eigen::VectorXd u(5);
  u << 1e-4, 2e-4, -1e-4, 5e-5, 3e-5;
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error));
  EXPECT_EQ(t.force.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(t.jacobian.cwiseAbs().maxCoeff(), 0.0);
}

TEST(Jenkins, AnalyticJacobianEqualsCentralDifferencesConstantNormalLoad) {
  auto h = test::make_law("jenkins_1d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  HarmonicLayout layout({0, 1, 2, 3, 4, 5}, 128);
  PeriodicTracer tracer(*h.law, layout);
  for (unsigned seed : {1u, 2u, 3u}) {
    const Eigen::VectorXd u = random_motion(layout.coefficient_count(), 3e-5, seed);
    ContactTrace t;
    std::string error;
    ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
    ASSERT_FALSE(t.used_finite_differences);
    const Eigen::MatrixXd fd = central_differences(tracer, u);
    const double scale = fd.cwiseAbs().maxCoeff();
    EXPECT_GT(scale, 1e3);  // the contact slips: the Jacobian is not trivially zero
    EXPECT_LT((t.jacobian - fd).cwiseAbs().maxCoeff(), 1e-6 * scale) << "seed " << seed;
  }
}

TEST(Jenkins, AnalyticJacobianEqualsCentralDifferencesWithSeparation) {
  // N = max(0, 2 + 1e5 u_n): the normal motion opens the contact during part of the period.
  auto h = test::make_law("jenkins_1d", "{kt: 2.0e5, mu: 0.4, normal_load: 2.0, kn: 1.0e5}");
  HarmonicLayout layout({0, 1, 2, 3}, 128);
  PeriodicTracer tracer(*h.law, layout);
  ASSERT_EQ(tracer.dimension(), 2);
  Eigen::VectorXd u = random_motion(2 * layout.coefficient_count(), 1e-5, 7);
  u(layout.coefficient_count() + 1) =
      4e-5;  // normal first harmonic: separation (4 > 2/1e5*1e5... )
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
  const bool separates = (t.force.col(1).array() == 0.0).any();
  const bool closed = (t.force.col(1).array() > 0.0).any();
  EXPECT_TRUE(separates && closed) << "the scenario must both open and close the contact";
  const Eigen::MatrixXd fd = central_differences(tracer, u);
  const double scale = fd.cwiseAbs().maxCoeff();
  EXPECT_LT((t.jacobian - fd).cwiseAbs().maxCoeff(), 1e-6 * scale) << "analytic\n"
                                                                   << t.jacobian << "\nfd\n"
                                                                   << fd;
  // The normal force equals max(0, N0 + kn u_n) sample by sample.
  for (int j = 0; j < layout.samples(); ++j)
    EXPECT_NEAR(t.force(j, 1), std::max(0.0, 2.0 + 1e5 * t.displacement(j, 1)), 1e-12);
}

TEST(Jenkins, InitialGapClosesOnlyBeyondTheGap) {
  // N = max(0, kn (u_n - g0)) with g0 = 1e-5 m: u_n = 2.1e-5 cos(theta) closes ~0.35 of the time.
  auto h = test::make_law("jenkins_1d", "{kt: 1.0e5, mu: 0.3, kn: 2.0e5, gap: 1.0e-5}");
  HarmonicLayout layout({0, 1, 2, 3}, 96);
  PeriodicTracer tracer(*h.law, layout);
  ASSERT_EQ(tracer.components(), (std::vector<int>{0, 2}));
  // The reference force is zero: an open contact carries no preload.
  EXPECT_EQ(tracer.reference_force().norm(), 0.0);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(2 * layout.coefficient_count());
  u(2) = 3e-5;                                 // tangential sin(theta)
  u(layout.coefficient_count() + 1) = 2.1e-5;  // normal cos(theta); no sample on the kink
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
  int closed = 0;
  for (int j = 0; j < layout.samples(); ++j) {
    const double un = t.displacement(j, 1);
    EXPECT_NEAR(t.force(j, 1), std::max(0.0, 2e5 * (un - 1e-5)), 1e-12);
    EXPECT_LE(std::abs(t.force(j, 0)), 0.3 * t.force(j, 1) + 1e-12);  // Coulomb bound
    if (un > 1e-5) ++closed;
  }
  // closed while cos(theta) > 1e-5 / 2.1e-5: a fraction acos(0.476) / pi = 0.342 of the period
  EXPECT_NEAR(closed, 0.342 * layout.samples(), 2);
  const Eigen::MatrixXd fd = central_differences(tracer, u);
  EXPECT_LT((t.jacobian - fd).cwiseAbs().maxCoeff(), 1e-6 * fd.cwiseAbs().maxCoeff());
}

TEST(Jenkins, NormalForceHarmonicsOfAContactThatSeparatesEqualTheClippedCosine) {
  // N = max(0, N0 + kn b cos(theta)) with kn b = A > N0: closed on |theta| < alpha,
  // cos(alpha) = -N0 / A. Fourier coefficients of the clipped cosine A (cos - cos alpha):
  //   c0 = A/pi (sin a - a cos a),  c1 = A/pi (a - sin a cos a),
  //   cn = A/pi (sin((n-1)a)/(n-1) + sin((n+1)a)/(n+1) - 2 cos a sin(n a)/n),  sn = 0.
  const double n0 = 2.0, kn = 1e5, b = 5e-5, A = kn * b;
  auto h = test::make_law("jenkins_1d", "{kt: 1.0e5, mu: 0.3, normal_load: 2.0, kn: 1.0e5}");
  HarmonicLayout layout({0, 1, 2, 3, 4, 5, 6, 7}, 8192);
  PeriodicTracer tracer(*h.law, layout);
  const int c = layout.coefficient_count();
  Eigen::VectorXd u = Eigen::VectorXd::Zero(2 * c);
  u(c + layout.cos_index(1)) = b;
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kNone, t, &error)) << error;
  Aft aft(layout);
  Eigen::VectorXd normal = t.force.col(1), coefficients(c);
  aft.to_coefficients(normal.data(), coefficients.data());
  const double a = std::acos(-n0 / A);
  auto expected = [&](int n) {
    if (n == 0) return A / kPi * (std::sin(a) - a * std::cos(a));
    if (n == 1) return A / kPi * (a - std::sin(a) * std::cos(a));
    return A / kPi *
           (std::sin((n - 1) * a) / (n - 1) + std::sin((n + 1) * a) / (n + 1) -
            2 * std::cos(a) * std::sin(n * a) / n);
  };
  for (std::size_t k = 0; k < layout.harmonics().size(); ++k) {
    const int n = layout.harmonics()[k];
    EXPECT_NEAR(coefficients(layout.cos_index(k)), expected(n), 2e-6 * A) << "harmonic " << n;
    if (n > 0) {
      EXPECT_NEAR(coefficients(layout.sin_index(k)), 0.0, 1e-9 * A);
    }
  }
  // The contact is open over (pi - alpha) / pi of the period.
  const double open = (t.force.col(1).array() == 0.0).cast<double>().mean();
  EXPECT_NEAR(open, (kPi - a) / kPi, 2.0 / layout.samples());
}

TEST(Jenkins, InPhaseNormalLoadVariationFollowsTheClosedFormLoop) {
  // u_t = a cos(theta), N = N0 + kn b cos(theta) (in phase, never open since kn b < N0), deep
  // slip. Piecewise closed form of the periodic loop, from theta = 0 (slipping forward):
  //   stick   (0, th1):   T = mu N(0) - kt a (1 - cos),      cos th1 = (kt a - 2 mu N0 - mu kn b)
  //                                                                   / (kt a + mu kn b)
  //   slip    (th1, pi):  T = -mu N(theta)
  //   stick   (pi, th2):  T = -mu N(pi) + kt a (1 + cos),    cos th2 = (2 mu N0 - mu kn b - kt a)
  //                                                                   / (kt a - mu kn b)
  //   slip    (th2, 2pi): T = +mu N(theta)
  const double kt = 1e5, mu = 0.3, n0 = 2.0, kn = 1e4, b = 1e-4, a = 1e-4;
  auto normal = [&](double th) { return n0 + kn * b * std::cos(th); };
  const double th1 = std::acos((kt * a - 2 * mu * n0 - mu * kn * b) / (kt * a + mu * kn * b));
  const double th2 =
      2 * kPi - std::acos((2 * mu * n0 - mu * kn * b - kt * a) / (kt * a - mu * kn * b));
  auto friction = [&](double th) {
    if (th < th1) return mu * normal(0) - kt * a * (1 - std::cos(th));
    if (th < kPi) return -mu * normal(th);
    if (th < th2) return -mu * normal(kPi) + kt * a * (1 + std::cos(th));
    return mu * normal(th);
  };
  auto h = test::make_law("jenkins_1d", "{kt: 1.0e5, mu: 0.3, normal_load: 2.0, kn: 1.0e4}");
  HarmonicLayout layout({0, 1, 2, 3}, 8192);
  PeriodicTracer tracer(*h.law, layout);
  const int c = layout.coefficient_count();
  Eigen::VectorXd u = Eigen::VectorXd::Zero(2 * c);
  u(layout.cos_index(1)) = a;
  u(c + layout.cos_index(1)) = b;
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kNone, t, &error)) << error;
  double worst = 0, energy = 0, exact_energy = 0;
  const int n = layout.samples();
  for (int j = 0; j < n; ++j) {
    worst = std::max(worst, std::abs(t.force(j, 0) - friction(2 * kPi * j / n)));
    const int jn = (j + 1) % n;
    energy +=
        0.5 * (t.force(j, 0) + t.force(jn, 0)) * (t.displacement(jn, 0) - t.displacement(j, 0));
  }
  // Energy of the closed form by fine midpoint quadrature of T du = T (-a sin) dtheta.
  const int m = 2000000;
  for (int i = 0; i < m; ++i) {
    const double th = 2 * kPi * (i + 0.5) / m;
    exact_energy += friction(th) * (-a * std::sin(th)) * 2 * kPi / m;
  }
  // The return mapping is exact at the samples (the reversals fall on samples 0 and N/2).
  EXPECT_LT(worst, 1e-12) << "worst sample error " << worst << " N";
  EXPECT_NEAR(energy, exact_energy, 1e-6 * exact_energy);  // trapezoid error ~1e-7
  EXPECT_GT(exact_energy, 0.0);
}

TEST(Jenkins, GapAndPreloadTogetherAreRefused) {
  try {
    test::make_law("jenkins_1d", "{kt: 1.0e5, mu: 0.3, kn: 2.0e5, gap: 1.0e-5, normal_load: 1}");
    FAIL() << "a gap with a preload must be refused";
  } catch (const PluginError& e) {
    EXPECT_NE(std::string(e.what()).find("either normal_load (preload) or gap"), std::string::npos);
  }
}

TEST(Jenkins, JacobianFollowsTheWarmUpSlipToAStaticOffset) {
  // A mean offset far beyond mu N / kt slips once during the first pass, then the small
  // oscillation sticks forever: the forces depend on U through that warm-up slip, and the
  // Jacobian must too (e.g. d mean force / d offset = 0), checked by central differences.
  auto h = test::make_law("jenkins_1d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  HarmonicLayout layout({0, 1, 2}, 64);
  PeriodicTracer tracer(*h.law, layout);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(layout.coefficient_count());
  u(0) = 1e-3;  // static offset, 80 times mu N / kt
  u(1) = 4e-6;  // cosine amplitude below the reversal threshold 2 mu N / kt
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
  EXPECT_TRUE(t.periodic);
  const Eigen::MatrixXd fd = central_differences(tracer, u);
  EXPECT_NEAR(fd(0, 0), 0.0, 1e-6 * 2e5);  // the mean force stays at mu N whatever U0
  EXPECT_LT((t.jacobian - fd).cwiseAbs().maxCoeff(), 1e-6 * fd.cwiseAbs().maxCoeff());
}

TEST(Jenkins, FiniteDifferenceModeAgreesWithAnalytic) {
  auto h = test::make_law("jenkins_1d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  HarmonicLayout layout({1, 3, 5}, 64);
  PeriodicTracer tracer(*h.law, layout);
  const Eigen::VectorXd u = random_motion(layout.coefficient_count(), 4e-5, 11);
  ContactTrace analytic, fd;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, analytic, &error));
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kFiniteDifference, fd, &error));
  EXPECT_TRUE(fd.used_finite_differences);
  const double scale = analytic.jacobian.cwiseAbs().maxCoeff();
  EXPECT_LT((analytic.jacobian - fd.jacobian).cwiseAbs().maxCoeff(), 1e-5 * scale);
}

TEST(Jenkins, ALawWithoutTangentsFallsBackToFiniteDifferences) {
  const Registry test_plugins({FRICHB_TEST_PLUGIN_DIR});
  auto plugin = test_plugins.load("tangentless_jenkins", FRICHB_KIND_CONTACT_LAW);
  const ParamValues values = validate_params(YAML::Load("{kt: 2.0e5, slip_force: 2.5}"),
                                             plugin->schema(), "params", YamlContext{"<test>"});
  ContactLawInstance tangentless(plugin, values);
  EXPECT_EQ(tangentless.traits().provides_tangent, 0);
  auto reference = test::make_law("jenkins_1d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  HarmonicLayout layout({0, 1, 2, 3}, 64);
  PeriodicTracer fallback(tangentless, layout), analytic(*reference.law, layout);
  const Eigen::VectorXd u = random_motion(layout.coefficient_count(), 4e-5, 5);
  ContactTrace a, b;
  std::string error;
  ASSERT_TRUE(fallback.trace(u, JacobianMode::kAnalytic, a, &error)) << error;
  ASSERT_TRUE(analytic.trace(u, JacobianMode::kAnalytic, b, &error)) << error;
  EXPECT_TRUE(a.used_finite_differences);
  EXPECT_FALSE(b.used_finite_differences);
  EXPECT_LT((a.force_coefficients - b.force_coefficients).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((a.jacobian - b.jacobian).cwiseAbs().maxCoeff(),
            1e-5 * b.jacobian.cwiseAbs().maxCoeff());
}

TEST(Jenkins, SlippingMotionBecomesPeriodicInTwoPasses) {
  auto h = test::make_law("jenkins_1d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  HarmonicLayout layout({0, 1}, 64);
  PeriodicTracer tracer(*h.law, layout);
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(cosine_motion(layout, 1e-4), JacobianMode::kAnalytic, t, &error));
  EXPECT_TRUE(t.periodic);
  EXPECT_LE(t.passes, 3);
}

}  // namespace
}  // namespace frichb::core
