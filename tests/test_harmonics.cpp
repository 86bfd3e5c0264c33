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

}  // namespace
}  // namespace frichb::core
