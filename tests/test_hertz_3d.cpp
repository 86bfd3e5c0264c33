// The hertz_3d law (Hertz stiffnesses kt = c_t sqrt(p), N = c_n p^1.5, coupled friction
// circle, separation) through the real loader and the periodic tracer: the normal force
// against its closed form, the analytic Jacobian and the step tangents against central
// differences, finiteness at zero penetration, the thesis's Fig. 3.6 comparison with
// constant stiffnesses, mu = 0 and frame invariance.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <numbers>
#include <random>

#include "frichb/core/plugin_host/periodic_trace.hpp"
#include "test_support.hpp"

namespace frichb::core {
namespace {

using test::central_differences;
using test::random_motion;

constexpr double kPi = std::numbers::pi;

// Index of the cosine / sine coefficient of harmonic n in component a of U.
int cos_at(const HarmonicLayout& layout, int a, int n) {
  for (std::size_t k = 0; k < layout.harmonics().size(); ++k)
    if (layout.harmonics()[k] == n) return a * layout.coefficient_count() + layout.cos_index(k);
  throw std::invalid_argument("harmonic not kept");
}
int sin_at(const HarmonicLayout& layout, int a, int n) {
  for (std::size_t k = 0; k < layout.harmonics().size(); ++k)
    if (layout.harmonics()[k] == n) return a * layout.coefficient_count() + layout.sin_index(k);
  throw std::invalid_argument("harmonic not kept");
}

// The regularised normal force above eps: N = c_n (p^1.5 - eps^1.5 / 8).
double hertz_normal(double cn, double eps, double p) {
  return cn * (std::pow(p, 1.5) - std::pow(eps, 1.5) / 8);
}

// ---------------------------------------------------------------------------------------
// (1) Normal force proportional to penetration^1.5, zero (with T = 0) when open.

struct NormalCase {
  const char* params;
  double gap, p0;
};

void PrintTo(const NormalCase& c, std::ostream* os) {
  *os << c.params;
}

class HertzNormalForce : public ::testing::TestWithParam<NormalCase> {};

TEST_P(HertzNormalForce, IsCoefficientTimesPenetrationToTheThreeHalves) {
  const NormalCase c = GetParam();
  const double cn = 3e9, eps = 1e-9;
  auto h = test::make_law("hertz_3d", c.params);
  HarmonicLayout layout({0, 1, 2, 3}, 96);
  PeriodicTracer tracer(*h.law, layout);
  ASSERT_EQ(tracer.components(), (std::vector<int>{0, 1, 2}));
  Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * layout.coefficient_count());
  u(sin_at(layout, 0, 1)) = 8e-6;
  u(cos_at(layout, 1, 2)) = 5e-6;
  u(cos_at(layout, 2, 0)) = 1e-6;  // normal mean
  u(cos_at(layout, 2, 1)) = 4e-6;  // normal first harmonic: opens part of the period
  u(sin_at(layout, 2, 3)) = 0.7e-6;
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
  int open = 0, closed = 0;
  for (int j = 0; j < layout.samples(); ++j) {
    const double p = t.displacement(j, 2) + c.p0 - c.gap;
    if (p <= 0) {
      ++open;
      EXPECT_EQ(t.force(j, 2), 0.0) << "sample " << j;
      EXPECT_EQ(t.force(j, 0), 0.0) << "sample " << j;
      EXPECT_EQ(t.force(j, 1), 0.0) << "sample " << j;
    } else if (p > eps) {
      ++closed;
      const double expected = hertz_normal(cn, eps, p);
      EXPECT_NEAR(t.force(j, 2), expected, 1e-12 * expected) << "sample " << j;
    }
  }
  EXPECT_GT(open, 5);
  EXPECT_GT(closed, 5);
  // The host subtracts the force at u = 0: N(p0) when p0 > 0, nothing with a gap.
  const double n_ref = c.p0 > 0 ? hertz_normal(cn, eps, c.p0) : 0.0;
  EXPECT_NEAR(tracer.reference_force()(2), n_ref, 1e-12 * n_ref);
  EXPECT_EQ(tracer.reference_force().head<2>().norm(), 0.0);
  // The mean coefficient is the samples' mean less the reference, up to the quadrature's
  // corrections at the contact changes (docs/theory.md, "Onsets"; 1e-5 to 6e-5 of the mean here).
  const double mean_n = t.force.col(2).mean();
  EXPECT_NEAR(t.force_coefficients(cos_at(layout, 2, 0)), mean_n - n_ref, 3e-4 * mean_n);
}

INSTANTIATE_TEST_SUITE_P(
    GapOrStaticPenetration, HertzNormalForce,
    ::testing::Values(
        NormalCase{"{normal_coefficient: 3.0e9, tangential_coefficient: 2.0e9, mu: 0.3}", 0, 0},
        NormalCase{"{normal_coefficient: 3.0e9, tangential_coefficient: 2.0e9, mu: 0.3, "
                   "gap: 2.0e-6}",
                   2e-6, 0},
        NormalCase{"{normal_coefficient: 3.0e9, tangential_coefficient: 2.0e9, mu: 0.3, "
                   "static_penetration: 2.5e-6}",
                   0, 2.5e-6}));

TEST(Hertz3d, GapAndStaticPenetrationTogetherAreRefused) {
  try {
    test::make_law("hertz_3d",
                   "{normal_coefficient: 1, tangential_coefficient: 1, mu: 0.3, gap: 1.0e-6, "
                   "static_penetration: 1.0e-6}");
    FAIL() << "a gap with a static penetration must be refused";
  } catch (const PluginError& e) {
    EXPECT_NE(std::string(e.what()).find("either gap or static_penetration"), std::string::npos);
  }
}

// ---------------------------------------------------------------------------------------
// (2) Analytic Jacobian vs central differences: slip and partial separation.

TEST(Hertz3d, AnalyticJacobianEqualsCentralDifferencesWithSlipAndSeparation) {
  const double eps = 1e-9, mu = 0.5;
  auto h = test::make_law("hertz_3d",
                          "{normal_coefficient: 2.0e9, tangential_coefficient: 1.5e9, mu: 0.5}");
  HarmonicLayout layout({0, 1, 2, 3}, 128);
  PeriodicTracer tracer(*h.law, layout);
  const int c = layout.coefficient_count();
  for (unsigned seed : {1u, 2u, 3u}) {
    Eigen::VectorXd u = random_motion(3 * c, 1e-5, seed);
    u.segment(2 * c, c) = random_motion(c, 2e-6, seed + 100);
    u(cos_at(layout, 2, 0)) = 3e-6;
    u(cos_at(layout, 2, 1)) = 5e-6;
    ContactTrace t;
    std::string error;
    ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
    ASSERT_FALSE(t.used_finite_differences);
    ASSERT_TRUE(t.periodic);
    // The scenario: open part of the period, slip part of it, and no sample within the
    // regularisation zone or near the opening kink (the differences move samples by ~1e-12).
    int open = 0, slip = 0;
    double closest = 1.0;
    for (int j = 0; j < layout.samples(); ++j) {
      const double p = t.displacement(j, 2);
      closest = std::min(closest, std::abs(p));
      if (p <= 0) ++open;
      const double n = t.force(j, 2);
      if (n > 0 && std::abs(std::hypot(t.force(j, 0), t.force(j, 1)) - mu * n) < 1e-12 * n) ++slip;
    }
    EXPECT_GT(open, 0) << "seed " << seed;
    EXPECT_LT(open, layout.samples()) << "seed " << seed;
    EXPECT_GT(slip, 0) << "seed " << seed;
    ASSERT_GT(closest, 2 * eps) << "seed " << seed;
    const Eigen::MatrixXd fd = central_differences(tracer, u);
    const double scale = fd.cwiseAbs().maxCoeff();
    const double err = (t.jacobian - fd).cwiseAbs().maxCoeff();
    std::cout << "[ hertz_3d ] seed " << seed << ": open " << open << "/" << layout.samples()
              << ", slip " << slip << ", min |p| " << closest
              << " m, max |J - FD| / max |FD| = " << err / scale << "\n";
    EXPECT_GT(scale, 1e5);
    EXPECT_LT(err, 1e-6 * scale) << "seed " << seed;
  }
}

// At zero preload the contact opens while slipping (the stick radius mu N / kt of Hertz
// vanishes with the penetration), and the opening kink's jump of dT/ds vanishes with it: its
// derivatives must too, wherever rounding leaves the located opening (p a hair below or above
// 0). Phases of the normal motion shifted over a sample step move the openings across it.
TEST(Hertz3d, AnalyticJacobianEqualsCentralDifferencesWhereTheContactOpensInSlip) {
  auto h = test::make_law("hertz_3d",
                          "{normal_coefficient: 1.0e9, tangential_coefficient: 2.0e9, mu: 0.5}");
  HarmonicLayout layout({0, 1, 2, 3, 4, 5}, 128);
  PeriodicTracer tracer(*h.law, layout);
  ASSERT_TRUE(tracer.along_motion());
  double worst = 0;
  for (int shift = 0; shift < 8; ++shift) {
    const double phase = 2 * kPi / 128 * shift / 8.0;
    Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * layout.coefficient_count());
    u(cos_at(layout, 0, 1)) = 1e-5;
    u(sin_at(layout, 1, 1)) = 8e-6;
    u(cos_at(layout, 1, 2)) = 2e-6;
    u(cos_at(layout, 2, 0)) = -3e-6;
    u(cos_at(layout, 2, 1)) = 6e-6 * std::cos(phase);
    u(sin_at(layout, 2, 1)) = 6e-6 * std::sin(phase);
    u(sin_at(layout, 2, 2)) = 1e-6;
    ContactTrace t;
    std::string error;
    ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
    ASSERT_TRUE(t.periodic);
    EXPECT_GE(t.kinks, 2) << "shift " << shift;  // at least one opening and one closing
    const Eigen::MatrixXd fd = central_differences(tracer, u);
    const double scale = fd.cwiseAbs().maxCoeff();
    const double err = (t.jacobian - fd).cwiseAbs().maxCoeff() / scale;
    worst = std::max(worst, err);
    EXPECT_LT(err, 1e-6) << "shift " << shift;
  }
  std::cout << "[ hertz_3d ] opening in slip: max |J - FD| / max |FD| = " << worst << "\n";
}

// The Hertz force is C1 where the contact opens (N ~ p^2 and kt ~ p in the regularisation,
// so both T and N and their rates vanish there): the opening kink's jump of dF/ds is 0 for
// every input, and so are its derivatives. Wherever rounding leaves the located opening (p a
// hair below 0 or at 0), the step must report them as 0, not the 0/0 of the slip's turning
// rate mu N a' = mu N kt (u_t' . e_a) / (mu N) evaluated just past contact.
TEST(Hertz3d, TheOpeningKinkInSlipHasNoJumpAndNoJumpDerivatives) {
  auto h = test::make_law("hertz_3d",
                          "{normal_coefficient: 1.0e9, tangential_coefficient: 2.0e9, mu: 0.5}");
  const ContactLawInstance& law = *h.law;
  ASSERT_TRUE(law.traces_motion());
  const double cn = 1e9, ct = 2e9, mu = 0.5, eps = 1e-9;
  int openings = 0;
  double worst_jump = 0, worst_derivative = 0;
  for (int k = 0; k < 200; ++k) {
    const double p0 = 3e-7, p1 = -4e-7 * (1 + 1e-3 * k);
    const std::array<double, 3> u_prev{1e-5, 2e-6, p0}, u_now{9e-6, 2.5e-6 + 1e-9 * k, p1};
    std::array<double, 3> rate_prev{}, rate_now{};
    for (int i = 0; i < 3; ++i) {
      rate_prev[i] = 1.1 * (u_now[i] - u_prev[i]);
      rate_now[i] = 0.9 * (u_now[i] - u_prev[i]);
    }
    // The slider on the friction circle, behind u_t against the motion (slipping).
    const double radius =
        mu * cn * (std::pow(p0, 1.5) - std::pow(eps, 1.5) / 8) / (ct * std::sqrt(p0));
    const double dx = u_now[0] - u_prev[0], dy = u_now[1] - u_prev[1], len = std::hypot(dx, dy);
    const std::array<double, 2> w{u_prev[0] - radius * dx / len, u_prev[1] - radius * dy / len};
    std::array<double, 3> force{};
    std::array<double, 2> state{};
    std::array<double, 9> fu{}, fup{}, mfp{}, mfn{};
    std::array<double, 6> fs{}, su{}, sup{}, msp{}, msn{};
    std::array<double, 4> ss{};
    frichb_step_tangents tangents{fu.data(), fup.data(), fs.data(),
                                  su.data(), sup.data(), ss.data()};
    frichb_motion_tangents motion_tangents{mfp.data(), mfn.data(), msp.data(), msn.data()};
    std::array<double, 4> fraction{};
    std::array<double, 12> jump{};
    std::array<double, 4 * 14> dfraction{};
    std::array<double, 12 * 14> djump{};
    std::array<double, 12> onset{};
    std::array<double, 4> onset_power{}, onset_side{};
    std::array<double, 12 * 14> donset{};
    frichb_force_kinks kinks{sizeof(frichb_force_kinks),
                             4,
                             0,
                             fraction.data(),
                             jump.data(),
                             dfraction.data(),
                             djump.data(),
                             onset.data(),
                             onset_power.data(),
                             onset_side.data(),
                             donset.data()};
    const frichb_step_motion motion{sizeof(frichb_step_motion), rate_prev.data(), rate_now.data()};
    std::string error;
    ASSERT_TRUE(law.step_along(w.data(), u_prev.data(), u_now.data(), motion, force.data(),
                               state.data(), &tangents, &motion_tangents, &kinks, &error))
        << error;
    EXPECT_EQ(force[2], 0.0);  // open at the step's end
    for (std::size_t q = 0; q < kinks.count; ++q) {
      ++openings;
      // Slipping into the opening: its onset is mu N's, along the force.
      EXPECT_EQ(onset_power[q], 1.5);
      EXPECT_EQ(onset_side[q], -1.0);
      EXPECT_NEAR(std::hypot(onset[q * 3], onset[q * 3 + 1]), mu * onset[q * 3 + 2],
                  1e-12 * onset[q * 3 + 2]);
      EXPECT_NEAR(onset[q * 3 + 2], cn * std::pow(std::abs(rate_now[2] + rate_prev[2]) / 2, 1.5),
                  0.2 * onset[q * 3 + 2]);
      for (std::size_t a = 0; a < 3; ++a) {
        worst_jump = std::max(worst_jump, std::abs(jump[q * 3 + a]));
        for (std::size_t i = 0; i < 14; ++i)
          worst_derivative = std::max(worst_derivative, std::abs(djump[(q * 3 + a) * 14 + i]));
      }
    }
  }
  // The force's rates in the step are ~ kt |u'| ~ 1e6 N/m * 1e-6 m = 1 N per step; their
  // derivatives ~ 1e6 N/m per step.
  std::cout << "[ hertz_3d ] " << openings << " openings in slip: max |jump| " << worst_jump
            << " N, max |d jump / d input| " << worst_derivative << "\n";
  EXPECT_EQ(openings, 200);
  EXPECT_LT(worst_jump, 1e-9);
  EXPECT_LT(worst_derivative, 1e-3);
}

// The normal force of a contact that closes and opens, N = c_n p^1.5 with p = a cos(theta -
// phi) - g, against its Fourier integrals (independent: the substitution theta - phi =
// +-(theta_c - tau^2) makes the integrand smooth at the contact points, then Simpson's rule
// on 20000 intervals). N is C1 where the contact changes: the samples' trapezoidal sum errs
// there by a term of order h^2.5 that oscillates as the contact point moves across a sample,
// which the onsets the law reports remove; what is left is of order h^3.5.
TEST(Hertz3d, NormalForceHarmonicsOfAClosingGapMeetTheirIntegralsAtAnyPhase) {
  const double cn = 1e8, gap = 5e-5, a = 3.3e-4;
  auto h = test::make_law("hertz_3d",
                          "{normal_coefficient: 1.0e8, tangential_coefficient: 2.0e8, mu: 0.0, "
                          "gap: 5.0e-5, regularization: 1.0e-12}");
  const std::vector<int> harmonics{0, 1, 2, 3, 4, 5};
  const double theta_c = std::acos(gap / a);
  // Coefficients of N for phase phi = 0 (cosine series: N is even in theta).
  std::vector<double> exact(harmonics.size());
  const int intervals = 20000;
  const double top = std::sqrt(theta_c);
  for (std::size_t k = 0; k < harmonics.size(); ++k) {
    double sum = 0;
    for (int i = 0; i <= intervals; ++i) {
      const double tau = top * i / intervals, x = theta_c - tau * tau;
      const double p = std::max(0.0, a * std::cos(x) - gap);
      const double f = 2 * cn * p * std::sqrt(p) * std::cos(harmonics[k] * x) * 2 * tau;
      sum += f * (i == 0 || i == intervals ? 1 : (i % 2 ? 4 : 2));
    }
    const double integral = sum * top / intervals / 3;
    exact[k] = integral / (harmonics[k] == 0 ? 2 * kPi : kPi);
  }
  const double largest = std::abs(exact[1]);
  auto worst_error = [&](int samples, int shifts) {
    HarmonicLayout layout(harmonics, samples);
    PeriodicTracer tracer(*h.law, layout);
    double worst = 0;
    for (int q = 0; q < shifts; ++q) {
      const double phi = 2 * kPi / samples * q / shifts;
      Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * layout.coefficient_count());
      u(cos_at(layout, 2, 1)) = a * std::cos(phi);
      u(sin_at(layout, 2, 1)) = a * std::sin(phi);
      ContactTrace t;
      std::string error;
      EXPECT_TRUE(tracer.trace(u, JacobianMode::kNone, t, &error)) << error;
      for (std::size_t k = 0; k < harmonics.size(); ++k) {
        const int n = harmonics[k];
        const double c = exact[k] * std::cos(n * phi), sn = exact[k] * std::sin(n * phi);
        worst = std::max(worst, std::abs(t.force_coefficients(cos_at(layout, 2, n)) - c));
        if (n > 0)
          worst = std::max(worst, std::abs(t.force_coefficients(sin_at(layout, 2, n)) - sn));
      }
    }
    return worst / largest;
  };
  const double e64 = worst_error(64, 8), e128 = worst_error(128, 8), e256 = worst_error(256, 8),
               e512 = worst_error(512, 8);
  const double order = std::log2(e64 / e512) / 3;
  std::printf(
      "[ hertz_3d ] closing gap, N harmonics against their integrals: 64 %.2e, 128 %.2e, "
      "256 %.2e, 512 %.2e (worst of 8 phases); order %.2f\n",
      e64, e128, e256, e512, order);
  EXPECT_LT(e256, 5e-7);
  EXPECT_GT(order, 3.0);
}

// ---------------------------------------------------------------------------------------
// Step-level tangents, all six blocks, against central differences of one step, inside the
// regularisation zone and above it, sticking and slipping.

struct StepResult {
  std::array<double, 3> force{};
  std::array<double, 2> state{};
  std::array<double, 9> fu{}, fup{};
  std::array<double, 6> fs{}, su{}, sup{};
  std::array<double, 4> ss{};
};

StepResult step(const ContactLawInstance& law, const std::array<double, 2>& w_prev,
                const std::array<double, 3>& u_now) {
  StepResult r;
  const std::array<double, 3> u_prev{0.3e-6, -0.2e-6, 0.1e-6};
  frichb_step_tangents tg{r.fu.data(), r.fup.data(), r.fs.data(),
                          r.su.data(), r.sup.data(), r.ss.data()};
  std::string error;
  EXPECT_TRUE(law.step(w_prev.data(), u_prev.data(), u_now.data(), r.force.data(), r.state.data(),
                       &tg, &error))
      << error;
  return r;
}

bool all_finite(const StepResult& r) {
  auto finite = [](const auto& a) {
    for (double x : a)
      if (!std::isfinite(x)) return false;
    return true;
  };
  return finite(r.force) && finite(r.state) && finite(r.fu) && finite(r.fup) && finite(r.fs) &&
         finite(r.su) && finite(r.sup) && finite(r.ss);
}

TEST(Hertz3d, StepTangentsEqualCentralDifferencesInAndAboveTheRegularisation) {
  // eps = 1e-6 m so that a difference step of 1e-13 m resolves the regularised branch.
  const double eps = 1e-6, mu = 0.5;
  auto h = test::make_law("hertz_3d",
                          "{normal_coefficient: 1.0e9, tangential_coefficient: 1.0e9, mu: 0.5, "
                          "regularization: 1.0e-6}");
  const double dh = 1e-13;
  int sticks = 0, slips = 0;
  for (double p : {0.5 * eps, 0.9 * eps, 3 * eps, 40 * eps}) {
    for (const std::array<double, 2>& d :
         {std::array<double, 2>{5e-9, 3e-9}, std::array<double, 2>{4e-6, -3e-6}}) {
      const std::array<double, 2> w_prev{1e-6, -2e-6};
      const std::array<double, 3> u{w_prev[0] + d[0], w_prev[1] + d[1], p};
      const StepResult r = step(*h.law, w_prev, u);
      const bool slipping =
          std::abs(std::hypot(r.force[0], r.force[1]) - mu * r.force[2]) < 1e-12 * r.force[2];
      (slipping ? slips : sticks) += 1;
      double err_f = 0, scale_f = 0, err_s = 0;
      // Columns over u_now (3) then w_prev (2).
      for (int q = 0; q < 5; ++q) {
        auto up = u, um = u;
        auto wp = w_prev, wm = w_prev;
        if (q < 3) {
          up[q] += dh;
          um[q] -= dh;
        } else {
          wp[q - 3] += dh;
          wm[q - 3] -= dh;
        }
        const StepResult a = step(*h.law, wp, up), b = step(*h.law, wm, um);
        for (int i = 0; i < 3; ++i) {
          const double fd = (a.force[i] - b.force[i]) / (2 * dh);
          const double an = q < 3 ? r.fu[i * 3 + q] : r.fs[i * 2 + (q - 3)];
          err_f = std::max(err_f, std::abs(fd - an));
          scale_f = std::max(scale_f, std::abs(fd));
        }
        for (int k = 0; k < 2; ++k) {
          const double fd = (a.state[k] - b.state[k]) / (2 * dh);
          const double an = q < 3 ? r.su[k * 3 + q] : r.ss[k * 2 + (q - 3)];
          err_s = std::max(err_s, std::abs(fd - an));
        }
      }
      EXPECT_LT(err_f, 1e-6 * scale_f) << "p = " << p << ", slip " << slipping;
      EXPECT_LT(err_s, 1e-6) << "p = " << p << ", slip " << slipping;  // dw/du is O(1)
      for (double x : r.fup) EXPECT_EQ(x, 0.0);
      for (double x : r.sup) EXPECT_EQ(x, 0.0);
    }
  }
  EXPECT_GT(sticks, 0);
  EXPECT_GT(slips, 0);
}

// ---------------------------------------------------------------------------------------
// (3) Near and at zero penetration: finite tangents; N and kn continuous at eps.

TEST(Hertz3d, TangentsAreFiniteAtZeroPenetrationAndTheRegularisationIsContinuous) {
  const double cn = 2e9, ct = 1.5e9, eps = 1e-9;
  auto h = test::make_law("hertz_3d",
                          "{normal_coefficient: 2.0e9, tangential_coefficient: 1.5e9, mu: 0.5}");
  for (double p : {0.0, 0.5 * eps, eps, 2 * eps}) {
    for (const std::array<double, 2>& ut :
         {std::array<double, 2>{0, 0}, std::array<double, 2>{1e-15, -1e-15},
          std::array<double, 2>{3e-6, 1e-6}}) {
      const StepResult r = step(*h.law, {0, 0}, {ut[0], ut[1], p});
      EXPECT_TRUE(all_finite(r)) << "p = " << p << ", u_t = " << ut[0];
      if (p == 0) {  // open: no force, released slider
        EXPECT_EQ(r.force[2], 0.0);
        EXPECT_EQ(r.state[0], ut[0]);
      }
    }
  }
  // Continuity at eps of N and kn = dN/du_n (from either side), and their values there:
  // N(eps) = 7/8 c_n eps^1.5, kn(eps) = 1.5 c_n sqrt(eps), kt(eps) = c_t sqrt(eps).
  const double below = eps * (1 - 1e-14), above = eps * (1 + 1e-14);
  const StepResult lo = step(*h.law, {0, 0}, {0, 0, below});
  const StepResult hi = step(*h.law, {0, 0}, {0, 0, above});
  const StepResult at = step(*h.law, {0, 0}, {0, 0, eps});
  const double n_eps = 0.875 * cn * std::pow(eps, 1.5), kn_eps = 1.5 * cn * std::sqrt(eps);
  EXPECT_NEAR(lo.force[2], hi.force[2], 1e-12 * n_eps);
  EXPECT_NEAR(lo.fu[8], hi.fu[8], 1e-12 * kn_eps);
  EXPECT_NEAR(at.force[2], n_eps, 1e-12 * n_eps);
  EXPECT_NEAR(at.fu[8], kn_eps, 1e-12 * kn_eps);
  EXPECT_NEAR(lo.fu[0], hi.fu[0], 1e-12 * ct * std::sqrt(eps));  // kt while sticking
  EXPECT_NEAR(at.fu[0], ct * std::sqrt(eps), 1e-12 * ct * std::sqrt(eps));
  // The stiffness derivative at p -> 0+ is bounded: d kt / dp = 1.5 c_t / sqrt(eps).
  const double tiny = 1e-6 * eps;
  const StepResult z = step(*h.law, {0, 0}, {1e-18, 0, tiny});
  EXPECT_NEAR(z.fu[0 * 3 + 2], 1e-18 * 1.5 * ct / std::sqrt(eps),
              1e-5 * 1e-18 * ct / std::sqrt(eps));
  EXPECT_LT(z.fu[8], 2 * 1.5 * cn * 1.5 * tiny / std::sqrt(eps));  // kn -> 0 continuously
}

// ---------------------------------------------------------------------------------------
// (4) Thesis Fig. 3.6: X = sin + 0.5 sin 2 + 0.4 sin 3, Y = 0.6 cos, Z = 0.4 + 0.6 sin(. + pi/4)
// with Kt = sqrt(Z), Kn = 3 sqrt(Z) / 2 (N = Z^1.5), mu = 0.4, against constant stiffnesses.

struct Loop {
  double area = 0;    // |closed integral of T1 dT2| in the (T1, T2) plane, N^2
  double energy = 0;  // closed integral of T . du_t, J: the dissipated energy per cycle
};
Loop loop_of(const Eigen::MatrixXd& u, const Eigen::MatrixXd& f) {
  Loop l;
  const Eigen::Index n = u.rows();
  for (Eigen::Index j = 0; j < n; ++j) {
    const Eigen::Index k = (j + 1) % n;
    l.area += 0.5 * (f(j, 0) * f(k, 1) - f(k, 0) * f(j, 1));
    l.energy += 0.5 * (f(j, 0) + f(k, 0)) * (u(k, 0) - u(j, 0)) +
                0.5 * (f(j, 1) + f(k, 1)) * (u(k, 1) - u(j, 1));
  }
  l.area = std::abs(l.area);
  return l;
}

// The constant-stiffness coupled law (friction circle, N = max(0, kn Z)), its own loop:
// the oracle that does not go through the plugin. Three passes from w = 0 (it separates, so
// the second pass is already periodic).
Eigen::MatrixXd constant_stiffness_trace(const Eigen::MatrixXd& u, double kt, double kn,
                                         double mu) {
  Eigen::MatrixXd f = Eigen::MatrixXd::Zero(u.rows(), 3);
  double w1 = 0, w2 = 0;
  for (int pass = 0; pass < 3; ++pass) {
    for (Eigen::Index j = 0; j < u.rows(); ++j) {
      const double n = std::max(0.0, kn * u(j, 2));
      double t1 = 0, t2 = 0;
      if (n <= 0) {
        w1 = u(j, 0);
        w2 = u(j, 1);
      } else {
        t1 = kt * (u(j, 0) - w1);
        t2 = kt * (u(j, 1) - w2);
        const double m = std::hypot(t1, t2);
        if (m > mu * n) {
          t1 *= mu * n / m;
          t2 *= mu * n / m;
          w1 = u(j, 0) - t1 / kt;
          w2 = u(j, 1) - t2 / kt;
        }
      }
      f.row(j) << t1, t2, n;
    }
  }
  return f;
}

TEST(Hertz3d, ThesisFigure36PassesThroughTheOriginWithALargerLoop) {
  auto h =
      test::make_law("hertz_3d", "{normal_coefficient: 1, tangential_coefficient: 1, mu: 0.4}");
  HarmonicLayout layout({0, 1, 2, 3}, 2048);
  PeriodicTracer tracer(*h.law, layout);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * layout.coefficient_count());
  u(sin_at(layout, 0, 1)) = 1.0;
  u(sin_at(layout, 0, 2)) = 0.5;
  u(sin_at(layout, 0, 3)) = 0.4;
  u(cos_at(layout, 1, 1)) = 0.6;
  u(cos_at(layout, 2, 0)) = 0.4;
  u(cos_at(layout, 2, 1)) = 0.6 * std::sin(kPi / 4);  // 0.6 sin(theta + pi/4)
  u(sin_at(layout, 2, 1)) = 0.6 * std::cos(kPi / 4);
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
  ASSERT_TRUE(t.periodic);
  // Sample 0 is theta = 0: X = 0, Y = 0.6, Z = 0.4 + 0.6 sin(pi/4).
  EXPECT_NEAR(t.displacement(0, 2), 0.4 + 0.6 * std::sin(kPi / 4), 1e-12);

  // Separation: T = 0 and N = 0 where Z < 0 (the loop passes through the origin).
  int through_origin = 0;
  for (int j = 0; j < layout.samples(); ++j)
    if (t.force(j, 0) == 0.0 && t.force(j, 1) == 0.0 && t.force(j, 2) == 0.0) {
      ++through_origin;
      EXPECT_LE(t.displacement(j, 2), 0.0);
    }
  // Z < 0 while sin(theta + pi/4) < -2/3: a fraction 1/2 - asin(2/3)/pi = 0.268 of the period.
  EXPECT_NEAR(through_origin, (0.5 - std::asin(2.0 / 3.0) / kPi) * layout.samples(), 2);

  // Constant reference: the mean over the whole period of eq. 3.2's stiffnesses (0 where
  // Z < 0), kt = <sqrt(max(Z, 0))>, kn = 3 kt / 2, with the same contact point (N0 = 0).
  double kt_mean = 0;
  for (int j = 0; j < layout.samples(); ++j)
    kt_mean += std::sqrt(std::max(0.0, t.displacement(j, 2)));
  kt_mean /= layout.samples();
  const Eigen::MatrixXd fc = constant_stiffness_trace(t.displacement, kt_mean, 1.5 * kt_mean, 0.4);
  const Loop variable = loop_of(t.displacement, t.force);
  const Loop constant = loop_of(t.displacement, fc);
  const double area_ratio = variable.area / constant.area;
  const double energy_ratio = variable.energy / constant.energy;
  std::cout << "[ hertz_3d ] Fig. 3.6: mean kt = " << kt_mean << " N/m, kn = " << 1.5 * kt_mean
            << " N/m; (T1,T2) loop area variable " << variable.area << ", constant "
            << constant.area << ", ratio " << area_ratio << "; energy per cycle variable "
            << variable.energy << " J, constant " << constant.energy << " J, ratio " << energy_ratio
            << "\n";
  // The thesis reads ~1.5 for the area ratio; this reference gives 1.62 and the
  // choice of means moves it (closed-part means: 0.87), hence a band, not a value.
  EXPECT_GT(area_ratio, 1.2);
  EXPECT_LT(area_ratio, 1.8);
  EXPECT_GT(energy_ratio, 1.0);  // the variable-stiffness contact dissipates more
  EXPECT_GT(variable.energy, 0.0);
}

// ---------------------------------------------------------------------------------------
// (5) mu = 0 gives no tangential force; rotating the tangential motion rotates the force.

TEST(Hertz3d, ZeroFrictionGivesNoTangentialForce) {
  auto h = test::make_law("hertz_3d",
                          "{normal_coefficient: 2.0e9, tangential_coefficient: 1.5e9, mu: 0.0}");
  HarmonicLayout layout({0, 1, 2, 3}, 64);
  PeriodicTracer tracer(*h.law, layout);
  const int c = layout.coefficient_count();
  Eigen::VectorXd u = random_motion(3 * c, 1e-5, 21);
  u(cos_at(layout, 2, 0)) = 3e-6;
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kAnalytic, t, &error)) << error;
  EXPECT_EQ(t.force.leftCols(2).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT(t.force.col(2).maxCoeff(), 0.0);
  EXPECT_EQ(t.jacobian.topRows(2 * c).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Hertz3d, TangentialForceRotatesWithTheTangentialMotion) {
  auto h = test::make_law("hertz_3d",
                          "{normal_coefficient: 2.0e9, tangential_coefficient: 1.5e9, mu: 0.5}");
  HarmonicLayout layout({0, 1, 2, 3}, 128);
  PeriodicTracer tracer(*h.law, layout);
  const int c = layout.coefficient_count();
  Eigen::VectorXd u = random_motion(3 * c, 1e-5, 4);
  u(cos_at(layout, 2, 0)) = 3e-6;
  u(cos_at(layout, 2, 1)) = 5e-6;
  ContactTrace t;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kNone, t, &error)) << error;
  const double scale = t.force.leftCols(2).cwiseAbs().maxCoeff();
  ASSERT_GT(scale, 0.0);
  for (double angle : {0.3, 2.0, -1.1}) {
    const double ca = std::cos(angle), sa = std::sin(angle);
    Eigen::VectorXd ur = u;
    ur.segment(0, c) = ca * u.segment(0, c) - sa * u.segment(c, c);
    ur.segment(c, c) = sa * u.segment(0, c) + ca * u.segment(c, c);
    ContactTrace tr;
    ASSERT_TRUE(tracer.trace(ur, JacobianMode::kNone, tr, &error)) << error;
    for (int j = 0; j < layout.samples(); ++j) {
      EXPECT_NEAR(tr.force(j, 0), ca * t.force(j, 0) - sa * t.force(j, 1), 1e-12 * scale);
      EXPECT_NEAR(tr.force(j, 1), sa * t.force(j, 0) + ca * t.force(j, 1), 1e-12 * scale);
      EXPECT_NEAR(tr.force(j, 2), t.force(j, 2), 1e-12 * t.force.col(2).maxCoeff());
    }
  }
}

}  // namespace
}  // namespace frichb::core
