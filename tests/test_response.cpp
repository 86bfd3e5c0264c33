// Whole response curves against linear oracles (a contact that never slips is the stuck
// linear system, mu = 0 the free one), and the residual's Jacobian (including d/dw) against
// central differences.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>

#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/solver/continuation.hpp"
#include "test_support.hpp"

namespace frichb::core {
namespace {

using cd = std::complex<double>;

struct Built {
  Scene scene;
  std::unique_ptr<StructureInstance> structure;
  std::unique_ptr<HarmonicBalanceModel> model;
};

Built build(const std::filesystem::path& file) {
  Built b;
  b.scene = load_scene(file);
  bind_plugins(b.scene, test::built_plugins());
  b.structure =
      std::make_unique<StructureInstance>(b.scene.structure.plugin, b.scene.structure.values);
  b.model = std::make_unique<HarmonicBalanceModel>(b.scene, *b.structure);
  return b;
}

ContinuationSummary sweep(const Built& b, double from_rad, double to_rad, double step) {
  const Eigen::Index n = b.model->equation_count();
  ContinuationOptions o;
  o.lambda_start = from_rad;
  o.lambda_end = to_rad;
  o.initial_step = step;
  o.min_step = 1e-8;
  o.max_step = step;
  o.unknown_scale = Eigen::VectorXd::Constant(n + 1, 1e-6);
  o.unknown_scale(n) = 1.0;
  o.residual_scale = Eigen::VectorXd::Constant(n, 1e-6);
  o.newton.residual_tolerance = 1e-10;
  o.newton.step_tolerance = 1e-10;
  Eigen::VectorXd y0(n + 1);
  y0.head(n) = b.model->linear_response(from_rad);
  y0(n) = from_rad;
  return trace_curve(*b.model, y0, o);
}

// 1 DOF: m = 0.1 kg, k = 4e5 N/m, modal damping 0.5 %, contact kt = 2e5 N/m to ground.
std::string one_dof_scene(const std::string& law_params) {
  return R"(
structure:
  provider: lumped
  params:
    masses: [0.1]
    springs: [{between: [ground, 0], k: 4.0e5}]
    modal_damping: [0.005]
  dofs: {blade: 0}
excitation: [{dof: blade, amplitude: 2.0, harmonic: 1}]
contacts:
  - {name: c, law: jenkins_1d, between: [ground, blade], params: )" +
         law_params + R"(}
harmonic_balance: {max_harmonic: 5, samples_per_period: 64}
continuation:
  frequency: {from: 250, to: 450, unit: Hz}
output: {response: [blade]}
)";
}

void expect_linear_frf(const std::string& law_params, double contact_stiffness) {
  test::TempDir dir;
  Built b = build(dir.write("scene.yaml", one_dof_scene(law_params)));
  const double m = 0.1, k = 4e5, zeta = 0.005;
  const double c = 2 * zeta * std::sqrt(k / m) * m;
  const auto summary = sweep(b, 2 * M_PI * 250, 2 * M_PI * 450, 20.0);
  ASSERT_TRUE(summary.reached_end()) << summary.message;
  ASSERT_GT(summary.points.size(), 20u);
  const Eigen::Index blade = b.model->kept_index(0);
  for (const auto& p : summary.points) {
    const double w = p.y(b.model->equation_count());
    const cd expected = 2.0 / cd(k + contact_stiffness - m * w * w, c * w);
    const auto x = b.model->kept_response(p.y);
    const auto& h = b.model->layout().harmonics();
    for (std::size_t i = 0; i < h.size(); ++i) {
      if (h[i] == 1)
        EXPECT_LT(std::abs(x[i](blade) - expected), 1e-8 * std::abs(expected)) << "w = " << w;
      else
        EXPECT_LT(std::abs(x[i](blade)), 1e-8 * std::abs(expected)) << "harmonic " << h[i];
    }
  }
}

TEST(ResponseOracle, SliderThatNeverSlipsIsTheStuckLinearSystem) {
  expect_linear_frf("{kt: 2.0e5, mu: 0.5, normal_load: 1.0e9}", 2e5);
}

TEST(ResponseOracle, ZeroFrictionIsTheFreeLinearSystem) {
  expect_linear_frf("{kt: 2.0e5, mu: 0.0, normal_load: 5.0}", 0.0);
}

// 2 DOF chain ground-k1-blade-k2-damper with viscous dampers; the contact joins the damper to
// the ground. Stuck: the linear system with kt added on the damper DOF, solved directly.
const char* kTwoDof = R"(
structure:
  provider: lumped
  params:
    masses: [0.12, 0.01]
    springs: [{between: [ground, 0], k: 4.0e5}, {between: [0, 1], k: 2.5e5}]
    dampers: [{between: [ground, 0], c: 2.0}, {between: [0, 1], c: 0.5}]
  dofs: {blade: 0, damper: 1}
excitation: [{dof: blade, amplitude: 2.0, harmonic: 1, phase_deg: 30}]
contacts:
  - {name: platform, law: jenkins_1d, between: [ground, damper], params: LAW}
harmonic_balance: {harmonics: [0, 1, 3, 5], samples_per_period: 64, jacobian: JAC}
continuation:
  frequency: {from: 150, to: 700, unit: Hz}
output: {response: [blade, damper]}
)";

std::string two_dof(const std::string& law, const std::string& jacobian = "analytic") {
  std::string s = kTwoDof;
  s.replace(s.find("LAW"), 3, law);
  s.replace(s.find("JAC"), 3, jacobian);
  return s;
}

TEST(ResponseOracle, TwoDofStuckEqualsDirectSolveOfTheDynamicStiffness) {
  test::TempDir dir;
  Built b = build(dir.write("scene.yaml", two_dof("{kt: 2.0e5, mu: 0.5, normal_load: 1.0e9}")));
  Eigen::Matrix2d M, K, C;
  M << 0.12, 0, 0, 0.01;
  K << 4e5 + 2.5e5, -2.5e5, -2.5e5, 2.5e5 + 2e5;
  C << 2.5, -0.5, -0.5, 0.5;
  const auto summary = sweep(b, 2 * M_PI * 150, 2 * M_PI * 700, 40.0);
  ASSERT_TRUE(summary.reached_end()) << summary.message;
  for (const auto& p : summary.points) {
    const double w = p.y(b.model->equation_count());
    const Eigen::Matrix2cd D = K.cast<cd>() - w * w * M.cast<cd>() + cd(0, w) * C.cast<cd>();
    const Eigen::Vector2cd f(std::polar(2.0, M_PI / 6), 0.0);
    const Eigen::Vector2cd expected = D.lu().solve(f);
    const auto x = b.model->kept_response(p.y);
    for (int dof = 0; dof < 2; ++dof) {
      const auto got = x[1](b.model->kept_index(static_cast<std::size_t>(dof)));
      EXPECT_LT(std::abs(got - expected(dof)), 1e-8 * expected.norm()) << "w = " << w;
    }
  }
}

TEST(ResidualJacobian, EqualsCentralDifferencesIncludingFrequency) {
  test::TempDir dir;
  Built b = build(dir.write("scene.yaml", two_dof("{kt: 2.0e5, mu: 0.5, normal_load: 5.0}")));
  const Eigen::Index n = b.model->equation_count();
  // A slipping state: twice the stuck-free linear response at 400 Hz, plus a 3rd harmonic.
  Eigen::VectorXd y(n + 1);
  const double w = 2 * M_PI * 400;
  y.head(n) = 2.0 * b.model->linear_response(w);
  y(3) = 0.2 * y(1);
  y(n) = w;
  Eigen::VectorXd e, ep, em;
  Eigen::MatrixXd jac;
  std::string message;
  ASSERT_TRUE(b.model->evaluate(y, e, &jac, &message)) << message;
  Eigen::MatrixXd fd(n, n + 1);
  for (Eigen::Index q = 0; q <= n; ++q) {
    const double h = q < n ? 1e-7 * y.head(n).cwiseAbs().maxCoeff() : 1e-6 * w;
    Eigen::VectorXd yp = y, ym = y;
    yp(q) += h;
    ym(q) -= h;
    ASSERT_TRUE(b.model->evaluate(yp, ep, nullptr, &message));
    ASSERT_TRUE(b.model->evaluate(ym, em, nullptr, &message));
    fd.col(q) = (ep - em) / (2 * h);
  }
  EXPECT_LT((jac.leftCols(n) - fd.leftCols(n)).cwiseAbs().maxCoeff(),
            1e-6 * fd.leftCols(n).cwiseAbs().maxCoeff());
  EXPECT_LT((jac.col(n) - fd.col(n)).cwiseAbs().maxCoeff(), 1e-6 * fd.col(n).cwiseAbs().maxCoeff());
  // The point really slips: the contact Jacobian is not that of a stuck spring.
  EXPECT_GT((jac.leftCols(n) - Eigen::MatrixXd::Identity(n, n)).cwiseAbs().maxCoeff(), 1e-3);
}

TEST(ResidualJacobian, ManyContactsOfSeveralSizesEqualCentralDifferences) {
  // Three 3-DOF blades in a ring joined by coupled 3D shroud contacts (3 components each, kn
  // > 0: variable normal load), plus a 2D contact of blade 0 with the ground (2 components):
  // the Jacobian is assembled block by block, one block per contact, and must equal central
  // differences of the whole residual in every row and column.
  test::TempDir dir;
  const char* scene = R"(
structure:
  provider: lumped
  params:
    masses: [0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1]
    springs:
      - {between: [ground, 0], k: 4.0e5}
      - {between: [ground, 1], k: 5.0e5}
      - {between: [ground, 2], k: 6.0e5}
      - {between: [ground, 3], k: 4.2e5}
      - {between: [ground, 4], k: 5.2e5}
      - {between: [ground, 5], k: 6.2e5}
      - {between: [ground, 6], k: 4.4e5}
      - {between: [ground, 7], k: 5.4e5}
      - {between: [ground, 8], k: 6.4e5}
    modal_damping: [0.01]
  dofs: {b0: [0, 1, 2], b1: [3, 4, 5], b2: [6, 7, 8]}
excitation:
  - {dof: b0, amplitude: 2.0, direction: [1, 1, 1]}
  - {dof: b1, amplitude: 2.0, phase_deg: 120, direction: [1, 1, 1]}
  - {dof: b2, amplitude: 2.0, phase_deg: 240, direction: [1, 1, 1]}
contacts:
  - {name: s01, law: coupled_3d, between: [b0, b1], params: {kt: 2.0e5, kn: 1.0e5, mu: 0.5, normal_load: 5.0},
     frame: {tangent1: [0, 1, 0], tangent2: [0, 0, 1], normal: [-1, 0, 0]}}
  - {name: s12, law: coupled_3d, between: [b1, b2], params: {kt: 2.0e5, kn: 1.0e5, mu: 0.5, normal_load: 5.0},
     frame: {tangent1: [0, 1, 0], tangent2: [0, 0, 1], normal: [-1, 0, 0]}}
  - {name: root, law: uncoupled_2d, between: [ground, b0], params: {kt: 1.0e5, mu: 0.3, normal_load: 3.0},
     frame: {tangent1: [1, 0, 0], tangent2: [0, 1, 0], normal: [0, 0, 1]}}
  - {name: s20, law: coupled_3d, between: [b2, b0], params: {kt: 2.0e5, kn: 1.0e5, mu: 0.5, normal_load: 5.0},
     frame: {tangent1: [0, 1, 0], tangent2: [0, 0, 1], normal: [-1, 0, 0]}}
harmonic_balance: {harmonics: [0, 1, 2, 3], samples_per_period: 64}
continuation:
  frequency: {from: 250, to: 350, unit: Hz}
)";
  Built b = build(dir.write("scene.yaml", scene));
  const Eigen::Index n = b.model->equation_count();
  ASSERT_EQ(n, (3 * 3 + 2) * 7);
  Eigen::VectorXd y(n + 1);
  const double w = 2 * M_PI * 300;
  y.head(n) = 3.0 * b.model->linear_response(w);  // every contact slips over part of the period
  y(n) = w;
  Eigen::VectorXd e, ep, em;
  Eigen::MatrixXd jac;
  std::string message;
  ASSERT_TRUE(b.model->evaluate(y, e, &jac, &message)) << message;
  Eigen::MatrixXd fd(n, n + 1);
  for (Eigen::Index q = 0; q <= n; ++q) {
    const double h = q < n ? 1e-7 * y.head(n).cwiseAbs().maxCoeff() : 1e-6 * w;
    Eigen::VectorXd yp = y, ym = y;
    yp(q) += h;
    ym(q) -= h;
    ASSERT_TRUE(b.model->evaluate(yp, ep, nullptr, &message));
    ASSERT_TRUE(b.model->evaluate(ym, em, nullptr, &message));
    fd.col(q) = (ep - em) / (2 * h);
  }
  EXPECT_LT((jac - fd).cwiseAbs().maxCoeff(), 1e-6 * fd.cwiseAbs().maxCoeff());
  // The contacts couple: off-diagonal blocks between contacts are not zero (the receptance
  // joins them), and the contact blocks differ from stuck springs.
  EXPECT_GT(jac.block(0, 3 * 7, 3 * 7, 3 * 7).cwiseAbs().maxCoeff(), 1e-3);
  // Tracing the four contacts on 2 and on 4 threads gives the same residual and Jacobian,
  // to the bit: each contact is traced alone, whichever thread traces it.
  for (int threads : {2, 4}) {
    b.model->set_contact_threads(threads);
    Eigen::VectorXd e_threads;
    Eigen::MatrixXd jac_threads;
    ASSERT_TRUE(b.model->evaluate(y, e_threads, &jac_threads, &message)) << message;
    EXPECT_EQ(e_threads, e) << threads << " threads";
    EXPECT_EQ(jac_threads, jac) << threads << " threads";
  }
  b.model->set_contact_threads(1);
}

TEST(ResponseCurve, AnalyticAndFiniteDifferenceJacobiansTraceTheSameCurve) {
  test::TempDir dir;
  const std::string law = "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}";
  Built a = build(dir.write("a.yaml", two_dof(law, "analytic")));
  Built f = build(dir.write("f.yaml", two_dof(law, "finite_difference")));
  EXPECT_EQ(a.model->jacobian_mode(), JacobianMode::kAnalytic);
  EXPECT_EQ(f.model->jacobian_mode(), JacobianMode::kFiniteDifference);
  const auto sa = sweep(a, 2 * M_PI * 150, 2 * M_PI * 700, 20.0);
  const auto sf = sweep(f, 2 * M_PI * 150, 2 * M_PI * 700, 20.0);
  ASSERT_TRUE(sa.reached_end());
  ASSERT_TRUE(sf.reached_end());
  // Compare the final points (both land exactly on 700 Hz) and the peak blade amplitude.
  const Eigen::Index n = a.model->equation_count();
  EXPECT_LT((sa.points.back().y - sf.points.back().y).head(n).cwiseAbs().maxCoeff(),
            1e-7 * sa.points.back().y.head(n).cwiseAbs().maxCoeff());
  // Both converge like Newton: the finite-difference Jacobian is accurate to ~1e-6, so the
  // iteration counts agree within a few.
  EXPECT_LE(std::abs(sa.total_newton_iterations - sf.total_newton_iterations),
            sa.total_newton_iterations / 5 + 3);
}

}  // namespace
}  // namespace frichb::core
