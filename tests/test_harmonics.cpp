#include "frichb/core/numerics/harmonics.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <numbers>
#include <random>

namespace frichb::core {
namespace {

Eigen::VectorXd random_coefficients(const HarmonicLayout& layout, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> dist(-1.0, 1.0);
  Eigen::VectorXd c(layout.coefficient_count());
  for (auto& x : c) x = dist(gen);
  return c;
}

TEST(HarmonicLayout, PacksCosineAndSinePerKeptHarmonic) {
  HarmonicLayout layout({3, 0, 1}, 16);
  EXPECT_EQ(layout.harmonics(), (std::vector<int>{0, 1, 3}));
  EXPECT_EQ(layout.coefficient_count(), 5);
  EXPECT_EQ(layout.cos_index(0), 0);
  EXPECT_EQ(layout.sin_index(0), -1);
  EXPECT_EQ(layout.cos_index(2), 3);
  EXPECT_EQ(layout.sin_index(2), 4);
}

TEST(HarmonicLayout, RefusesTooFewSamples) {
  try {
    HarmonicLayout layout({0, 1, 5}, 10);
    FAIL() << "N = 10 < 11 must be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("2 * max_harmonic + 1 = 11"), std::string::npos);
  }
  EXPECT_NO_THROW(HarmonicLayout({0, 1, 5}, 11));
}

TEST(Aft, TimeSamplesEqualTheFourierSeries) {
  HarmonicLayout layout({0, 1, 2, 5, 7}, 32);
  Aft aft(layout);
  const Eigen::VectorXd c = random_coefficients(layout, 1);
  Eigen::VectorXd samples(32);
  aft.to_time(c.data(), samples.data());
  for (int j = 0; j < 32; ++j) {
    const double theta = 2 * std::numbers::pi * j / 32;
    double direct = c(0);
    const int harmonics[] = {1, 2, 5, 7};
    for (int k = 0; k < 4; ++k)
      direct += c(1 + 2 * k) * std::cos(harmonics[k] * theta) +
                c(2 + 2 * k) * std::sin(harmonics[k] * theta);
    EXPECT_NEAR(samples(j), direct, 1e-13);
  }
}

TEST(Aft, RoundTripIsExact) {
  for (int n : {15, 16, 64, 255}) {
    HarmonicLayout layout({0, 1, 2, 3, 4, 5, 6, 7}, n);
    Aft aft(layout);
    const Eigen::VectorXd c = random_coefficients(layout, static_cast<unsigned>(n));
    Eigen::VectorXd samples(n), back(layout.coefficient_count());
    aft.to_time(c.data(), samples.data());
    aft.to_coefficients(samples.data(), back.data());
    EXPECT_LT((back - c).cwiseAbs().maxCoeff(), 1e-12) << "N = " << n;
  }
}

TEST(Aft, ProjectionDropsHarmonicsNotKept) {
  HarmonicLayout layout({1, 3}, 64);
  Aft aft(layout);
  Eigen::VectorXd samples(64), c(4);
  for (int j = 0; j < 64; ++j) {
    const double theta = 2 * std::numbers::pi * j / 64;
    samples(j) =
        0.7 + 2.0 * std::cos(theta) + 5.0 * std::sin(2 * theta) - 0.5 * std::sin(3 * theta);
  }
  aft.to_coefficients(samples.data(), c.data());
  EXPECT_NEAR(c(0), 2.0, 1e-13);
  EXPECT_NEAR(c(1), 0.0, 1e-13);
  EXPECT_NEAR(c(2), 0.0, 1e-13);
  EXPECT_NEAR(c(3), -0.5, 1e-13);
}

// The Hurwitz zeta function against its closed forms at non-positive integers,
// zeta(-n, a) = -B_{n+1}(a) / (n + 1), the Riemann value zeta(-3/2) and the recurrence
// zeta(s, a) = a^(-s) + zeta(s, a + 1) at the fractional orders the onset correction uses.
TEST(HurwitzZeta, MeetsItsClosedFormsAndRecurrence) {
  for (double a : {0.0, 0.1, 0.37, 0.5, 0.9, 1.0}) {
    EXPECT_NEAR(hurwitz_zeta(0.0, a), a == 0.0 ? -0.5 : 0.5 - a, 1e-13) << a;
    EXPECT_NEAR(hurwitz_zeta(-1.0, a), -(a * a - a + 1.0 / 6) / 2, 1e-13) << a;
    EXPECT_NEAR(hurwitz_zeta(-2.0, a), -(a * a * a - 1.5 * a * a + 0.5 * a) / 3, 1e-13) << a;
  }
  EXPECT_NEAR(hurwitz_zeta(-1.5, 1.0), -0.025485201889833036, 1e-13);
  EXPECT_NEAR(hurwitz_zeta(-0.5, 1.0), -0.207886224977354566, 1e-13);
  EXPECT_NEAR(hurwitz_zeta(-1.5, 0.0), hurwitz_zeta(-1.5, 1.0), 1e-13);
  for (double a : {0.05, 0.3, 0.77})
    for (double s : {-1.5, -0.5, -2.5})
      EXPECT_NEAR(hurwitz_zeta(s, a), std::pow(a, -s) + hurwitz_zeta(s, a + 1.0), 1e-12)
          << "s " << s << " a " << a;
}

}  // namespace
}  // namespace frichb::core
