// Floquet multipliers of harmonic-balance solutions (model/stability.hpp) against independent
// oracles: the closed form of a linear system (a contact stuck throughout), and the monodromy of
// a fine time integration of the nonlinear equations, differenced, on its own periodic orbit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/model/stability.hpp"
#include "frichb/core/scene/scene.hpp"
#include "test_support.hpp"

namespace frichb::core {
namespace {

const std::string kTwoDof = std::string(FRICHB_SOURCE_DIR) + "/configs/two_dof_blade_damper.yaml";

// The scene's 2-DOF chain (configs/two_dof_blade_damper.yaml) in physical coordinates: mass,
// stiffness without the contact, and the damping its modal ratios define.
struct Chain {
  Eigen::Matrix2d mass, stiffness, damping;
};

Chain two_dof_chain() {
  Chain c;
  c.mass << 0.12, 0, 0, 0.01;
  c.stiffness << 4.0e5 + 2.5e5, -2.5e5, -2.5e5, 2.5e5;
  Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::Matrix2d> modes(c.stiffness, c.mass);
  const Eigen::Matrix2d& phi = modes.eigenvectors();  // mass-normalised
  const Eigen::Vector2d w = modes.eigenvalues().cwiseSqrt();
  const Eigen::Matrix2d modal = (2 * 0.002 * w).asDiagonal();
  c.damping = c.mass * phi * modal * phi.transpose() * c.mass;
  return c;
}

struct SolvedPoint {
  Scene scene;
  std::unique_ptr<StructureInstance> structure;
  std::unique_ptr<HarmonicBalanceModel> model;
  Eigen::VectorXd y;
};

// The solution at `hz` of the scene `file` (the 2-DOF scene by default), traced from the start
// of its sweep.
std::unique_ptr<SolvedPoint> solve_at(const std::vector<SceneOverride>& overrides, double hz,
                                      const std::string& file = kTwoDof) {
  auto p = std::make_unique<SolvedPoint>();
  p->scene = load_scene(file, overrides);
  bind_plugins(p->scene, test::built_plugins());
  p->structure =
      std::make_unique<StructureInstance>(p->scene.structure.plugin, p->scene.structure.values);
  p->model = std::make_unique<HarmonicBalanceModel>(p->scene, *p->structure);
  const auto curve = test::trace_hz(*p->model, p->scene.continuation.from, hz, 2.0);
  EXPECT_TRUE(curve.reached_end()) << curve.message;
  p->y = curve.points.back().y;
  return p;
}

// Multipliers sorted by modulus, then by argument (a conjugate pair: positive first).
std::vector<std::complex<double>> ordered(std::vector<std::complex<double>> mu) {
  std::sort(mu.begin(), mu.end(), [](const auto& a, const auto& b) {
    if (std::abs(std::abs(a) - std::abs(b)) > 1e-12 * std::abs(a)) return std::abs(a) > std::abs(b);
    return std::arg(a) > std::arg(b);
  });
  return mu;
}

// A contact that never slips is a spring kt between the damper and the ground plus a slider
// whose offset is neutral: the physical multipliers are exp(lambda T) of the linear system
// M x'' + C x' + (K + kt e2 e2^T) x = 0 (its eigenvalues by Eigen's general solver), and one
// multiplier of exactly 1 is set apart. The step is second order: 128 -> 256 samples cuts the
// error about 4 times.
TEST(FloquetMultipliers, StuckContactGivesTheLinearSystemsExponentials) {
  const double hz = 260.0, kt = 2.0e5;
  const Chain chain = two_dof_chain();
  Eigen::Matrix2d k = chain.stiffness;
  k(1, 1) += kt;
  Eigen::Matrix4d a = Eigen::Matrix4d::Zero();
  a.topRightCorner<2, 2>().setIdentity();
  a.bottomLeftCorner<2, 2>() = -chain.mass.inverse() * k;
  a.bottomRightCorner<2, 2>() = -chain.mass.inverse() * chain.damping;
  const Eigen::Vector4cd lambda = a.eigenvalues();
  std::vector<std::complex<double>> exact;
  for (Eigen::Index i = 0; i < 4; ++i) exact.push_back(std::exp(lambda(i) / hz));
  exact = ordered(exact);

  double errors[2] = {0, 0}, modulus_errors[2] = {0, 0};
  int run = 0;
  for (const char* samples : {"128", "256"}) {
    const auto point = solve_at({{"contacts.platform_friction.params.normal_load", "1.0e6"},
                                 {"harmonic_balance.samples_per_period", samples}},
                                hz);
    const FloquetMultipliers f = floquet_multipliers(*point->model, point->y);
    ASSERT_TRUE(f.failure.empty()) << f.failure;
    ASSERT_EQ(f.neutral.size(), 1u);
    EXPECT_LT(std::abs(f.neutral[0] - 1.0), 1e-9);
    const auto mu = ordered(f.multipliers);
    ASSERT_EQ(mu.size(), 4u);
    for (std::size_t i = 0; i < 4; ++i) {
      errors[run] = std::max(errors[run], std::abs(mu[i] - exact[i]));
      modulus_errors[run] =
          std::max(modulus_errors[run], std::abs(std::abs(mu[i]) / std::abs(exact[i]) - 1));
      std::printf("%s samples: mu %+.10f %+.10fi  exact %+.10f %+.10fi\n", samples, mu[i].real(),
                  mu[i].imag(), exact[i].real(), exact[i].imag());
    }
    EXPECT_TRUE(f.stable());
    ++run;
  }
  std::printf(
      "largest error: %.3e at 128 samples, %.3e at 256 (ratio %.2f); of the moduli, "
      "relative: %.3e and %.3e\n",
      errors[0], errors[1], errors[0] / errors[1], modulus_errors[0], modulus_errors[1]);
  // The moduli (what stability reads) to 1.4e-5 at 256 samples; the phases carry the step's
  // second-order error (4.6e-3 at 256 samples on the higher mode).
  EXPECT_LT(modulus_errors[1], 1e-4);
  EXPECT_LT(errors[1], 1e-2);
  EXPECT_GT(errors[0] / errors[1], 3.5);
  EXPECT_LT(errors[0] / errors[1], 4.5);
}

// The shooting oracle: the scene's structure in its modal coordinates (all the provider's
// modes, as frichb timesim) integrated by velocity Verlet with each contact's law stepped
// sample by sample (its plain step(), not the step along the motion the harmonic balance
// uses), state s = [q, q', q'' (modes each), the laws' states, each contact's u_prev (3)].
// The periodic orbit is solved by Newton's method on P(s) - s = 0 (P: one period), its
// Jacobian M - I with the monodromy M by central differences of P, so that an unstable orbit
// is found as well as a stable one.
class ShootingOracle {
 public:
  ShootingOracle(const SolvedPoint& point, int steps_per_period)
      : model_(*point.model), steps_(steps_per_period) {
    const auto& basis = model_.structure().basis(0);
    phi_ = basis.rows.real();
    damping_ = basis.damping;
    stiffness_ = basis.frequencies.array().square();
    gather_ = Eigen::MatrixXcd(model_.gather(0)).real();
    modes_ = phi_.cols();
    w_ = point.y(point.y.size() - 1);
    Eigen::Index offset = 3 * modes_;
    for (const auto& c : model_.contacts()) {
      state_offset_.push_back(offset);
      offset += c.law->traits().state_size;
    }
    for (std::size_t c = 0; c < model_.contacts().size(); ++c) {
      prev_offset_.push_back(offset);
      offset += 3;
    }
    size_ = offset;
    start_ = on_harmonic_orbit(point.y);
  }
  Eigen::Index size() const { return size_; }
  const Eigen::VectorXd& start() const { return start_; }

  // One excitation period from s.
  Eigen::VectorXd period(Eigen::VectorXd s) const {
    const double dt = 2 * std::numbers::pi / w_ / steps_;
    Eigen::VectorXd q = s.head(modes_), v = s.segment(modes_, modes_),
                    a = s.segment(2 * modes_, modes_);
    Eigen::VectorXd f;
    for (int k = 1; k <= steps_; ++k) {
      q += dt * v + 0.5 * dt * dt * a;
      contact_forces(q, s, f);
      const Eigen::VectorXd a_next = acceleration(q, v + dt * a, k * dt, f);
      v += 0.5 * dt * (a + a_next);
      a = a_next;
    }
    s.head(modes_) = q;
    s.segment(modes_, modes_) = v;
    s.segment(2 * modes_, modes_) = a;
    return s;
  }

  // M = dP/ds by central differences, steps relative to each block's size in s.
  Eigen::MatrixXd monodromy(const Eigen::VectorXd& s) const {
    Eigen::MatrixXd m(size_, size_);
    const double q = std::max(s.head(modes_).cwiseAbs().maxCoeff(), 1e-12);
    for (Eigen::Index i = 0; i < size_; ++i) {
      const double scale = i < modes_       ? q
                           : i < 2 * modes_ ? q * w_
                           : i < 3 * modes_ ? q * w_ * w_
                                            : std::max(std::abs(s(i)), q * 1e-3);
      const double delta = 1e-7 * scale;
      Eigen::VectorXd plus = s, minus = s;
      plus(i) += delta;
      minus(i) -= delta;
      m.col(i) = (period(plus) - period(minus)) / (2 * delta);
    }
    return m;
  }

  // The periodic orbit by Newton's method from `s`; the iterations taken (0: none converged).
  int shoot(Eigen::VectorXd& s) const {
    for (int iteration = 1; iteration <= 12; ++iteration) {
      const Eigen::VectorXd r = period(s) - s;
      const double scale = std::max(s.head(modes_).cwiseAbs().maxCoeff(), 1e-300);
      if (r.head(modes_).cwiseAbs().maxCoeff() < 1e-11 * scale) return iteration;
      const Eigen::MatrixXd j = monodromy(s) - Eigen::MatrixXd::Identity(size_, size_);
      s -= j.colPivHouseholderQr().solve(r);
    }
    return 0;
  }

 private:
  // The state at t = 0 on the harmonic-balance orbit (the laws' states from their traces).
  Eigen::VectorXd on_harmonic_orbit(const Eigen::VectorXd& y) const {
    const auto x = model_.kept_response(y);
    const auto& harmonics = model_.layout().harmonics();
    Eigen::VectorXd kept = Eigen::VectorXd::Zero(phi_.rows()), rate = kept;
    for (std::size_t k = 0; k < harmonics.size(); ++k) {
      kept += x[k].real();
      rate += (std::complex<double>(0, harmonics[k] * w_) * x[k]).real();
    }
    const auto qr = phi_.colPivHouseholderQr();
    Eigen::VectorXd s = Eigen::VectorXd::Zero(size_);
    s.head(modes_) = qr.solve(kept);
    s.segment(modes_, modes_) = qr.solve(rate);
    for (std::size_t c = 0; c < model_.contacts().size(); ++c) {
      ContactTrace trace;
      std::string error;
      EXPECT_TRUE(model_.trace_contact(c, y, trace, &error)) << error;
      const auto n = static_cast<Eigen::Index>(trace.state.cols());
      s.segment(state_offset_[c], n) = trace.state.row(trace.state.rows() - 1).transpose();
      s.segment<3>(prev_offset_[c]) = local_motion(c, s.head(modes_));
    }
    Eigen::VectorXd probe = s, f;
    contact_forces(s.head(modes_), probe, f);
    s.segment(2 * modes_, modes_) = acceleration(s.head(modes_), s.segment(modes_, modes_), 0.0, f);
    return s;
  }
  Eigen::Vector3d local_motion(std::size_t c, const Eigen::VectorXd& q) const {
    const auto& contact = model_.contacts()[c];
    const Eigen::VectorXd u = gather_ * (phi_ * q);
    Eigen::Vector3d local = Eigen::Vector3d::Zero();
    const auto& components = contact.tracer->components();
    for (std::size_t a = 0; a < components.size(); ++a)
      local(components[a]) = u(contact.offset + static_cast<Eigen::Index>(a));
    return local;
  }
  // Steps every contact to the motion of q: their states and u_prev in s, the forces
  // (components, less the reference force) in f.
  void contact_forces(const Eigen::VectorXd& q, Eigen::VectorXd& s, Eigen::VectorXd& f) const {
    f.setZero(gather_.rows());
    for (std::size_t c = 0; c < model_.contacts().size(); ++c) {
      const auto& contact = model_.contacts()[c];
      const int n = contact.law->traits().state_size;
      const Eigen::Vector3d now = local_motion(c, q), prev = s.segment<3>(prev_offset_[c]);
      Eigen::VectorXd next(n);
      double force[3];
      std::string error;
      EXPECT_TRUE(contact.law->step(s.data() + state_offset_[c], prev.data(), now.data(), force,
                                    next.data(), nullptr, &error))
          << error;
      s.segment(state_offset_[c], n) = next;
      s.segment<3>(prev_offset_[c]) = now;
      const auto& components = contact.tracer->components();
      for (std::size_t a = 0; a < components.size(); ++a)
        f(contact.offset + static_cast<Eigen::Index>(a)) =
            force[components[a]] - contact.tracer->reference_force()(components[a]);
    }
  }
  Eigen::VectorXd acceleration(const Eigen::VectorXd& q, const Eigen::VectorXd& v, double t,
                               const Eigen::VectorXd& f) const {
    Eigen::VectorXd load = -gather_.transpose() * f;
    const auto& harmonics = model_.layout().harmonics();
    for (std::size_t k = 0; k < harmonics.size(); ++k)
      load += (model_.excitation(k) * std::polar(1.0, harmonics[k] * w_ * t)).real();
    return phi_.transpose() * load - damping_ * v - stiffness_.cwiseProduct(q);
  }

  const HarmonicBalanceModel& model_;
  int steps_;
  Eigen::MatrixXd phi_, damping_, gather_;
  Eigen::VectorXd stiffness_;
  Eigen::Index modes_ = 0, size_ = 0;
  std::vector<Eigen::Index> state_offset_, prev_offset_;
  double w_ = 0;
  Eigen::VectorXd start_;
};

// The multipliers of the shooting oracle's orbit: its monodromy's eigenvalues, largest first.
std::vector<std::complex<double>> shooting_multipliers(const ShootingOracle& oracle,
                                                       const Eigen::VectorXd& orbit) {
  const Eigen::VectorXcd mu = oracle.monodromy(orbit).eigenvalues();
  std::vector<std::complex<double>> out(mu.begin(), mu.end());
  std::sort(out.begin(), out.end(),
            [](const auto& a, const auto& b) { return std::abs(a) > std::abs(b); });
  return out;
}

void print_multipliers(const char* label, const std::vector<std::complex<double>>& mu,
                       std::size_t count) {
  for (std::size_t i = 0; i < std::min(count, mu.size()); ++i)
    std::printf("  %s %+.6f %+.6fi |%.6f|\n", label, mu[i].real(), mu[i].imag(), std::abs(mu[i]));
}

// The harmonic-balance multipliers of `point` and the shooting oracle's, on `steps` a period,
// printed side by side under `label`.
struct ShootingComparison {
  FloquetMultipliers harmonic_balance;
  std::vector<std::complex<double>> shooting;
  double relative_difference = 0.0;  // of the largest moduli
};

ShootingComparison compare_with_shooting(const SolvedPoint& point, int steps, const char* label) {
  ShootingComparison c;
  c.harmonic_balance = floquet_multipliers(*point.model, point.y);
  EXPECT_TRUE(c.harmonic_balance.failure.empty()) << c.harmonic_balance.failure;
  const ShootingOracle oracle(point, steps);
  Eigen::VectorXd orbit = oracle.start();
  const int iterations = oracle.shoot(orbit);
  EXPECT_GT(iterations, 0) << "shooting did not converge";
  c.shooting = shooting_multipliers(oracle, orbit);
  const double largest = std::abs(c.shooting.front());
  c.relative_difference = std::abs(c.harmonic_balance.largest_modulus - largest) / largest;
  std::printf(
      "%s: largest |mu| %.6f (harmonic balance, %d steps), %.6f (shooting, %d Newton "
      "iterations); relative difference %.2e\n",
      label, c.harmonic_balance.largest_modulus, c.harmonic_balance.steps, largest, iterations,
      c.relative_difference);
  print_multipliers("HB", c.harmonic_balance.multipliers, 4);
  print_multipliers("shooting", c.shooting, 4);
  return c;
}

// At the friction peak of the 2-DOF scene the damper slips twice a period: no neutral
// multiplier, and the largest multiplier of the harmonic-balance orbit against that of the
// shooting oracle's orbit. The orbits differ by the harmonic truncation and the integrators'
// steps. Measured: 6.8e-6 (H = 7, 128 steps, against 4096 Verlet steps a period).
TEST(FloquetMultipliers, SlippingDamperAgreesWithShooting) {
  const auto point = solve_at({}, 298.0);
  const auto c = compare_with_shooting(*point, 4096, "slipping damper at 298 Hz");
  EXPECT_TRUE(c.harmonic_balance.neutral.empty());
  EXPECT_LT(c.relative_difference, 1e-3);
  EXPECT_TRUE(c.harmonic_balance.stable());
}

// configs/stress/hertz_gap_folds.yaml on its upper branch at 450 Hz, below the fold at 474 Hz:
// the normal impacts modulate the contact's tangential stiffness, and a real multiplier has
// left the unit circle through +1 at 435 Hz (a branch point: the unexcited tangential motion
// grows). Shooting finds the same unstable orbit and multiplier (measured: 1.0e-4).
TEST(FloquetMultipliers, HertzGapUpperBranchIsUnstableAsShootingFinds) {
  const auto point =
      solve_at({}, 450.0, std::string(FRICHB_SOURCE_DIR) + "/configs/stress/hertz_gap_folds.yaml");
  const auto c = compare_with_shooting(*point, 8192, "Hertz gap at 450 Hz");
  EXPECT_FALSE(c.harmonic_balance.stable());
  EXPECT_GT(std::abs(c.shooting.front()), 1.0);
  EXPECT_LT(c.relative_difference, 1e-3);
}

// The whole curve of configs/stress/hertz_gap_folds.yaml with output.stability: stable up to the
// branch point at 435 Hz on the upper branch, a fold at each turning point (the curve's own,
// with the multiplier nearest +1 there), and stable again from the lower fold on; the table's
// columns agree with the summary, and the highest stable point is below the branch point.
TEST(FloquetMultipliers, HertzGapCurveNamesItsBifurcations) {
  const std::string file = std::string(FRICHB_SOURCE_DIR) + "/configs/stress/hertz_gap_folds.yaml";
  RunOptions options;
  options.plots = 0;
  options.quiet = true;
  const RunResult run = run_scene(SceneInput{file, {{"output.stability", "true"}}, false}, options);
  ASSERT_EQ(run.outcome.status, 0) << run.outcome.message;
  const auto& table = run.table;
  const auto column = [&](const std::string& name) {
    return static_cast<std::size_t>(std::find(table.header.begin(), table.header.end(), name) -
                                    table.header.begin());
  };
  const std::size_t stable = column("stable"), largest = column("largest_multiplier");
  ASSERT_LT(largest, table.header.size());
  const auto& turning = table.turning_points.frequencies;
  ASSERT_EQ(turning.size(), 2u);
  std::vector<std::string> kinds;
  for (const auto& c : table.stability_changes) {
    kinds.push_back(c.kind);
    std::printf("%s at point %zu, %.4f Hz: multiplier %+.6f %+.6fi, stable after: %d\n",
                c.kind.c_str(), c.point, table.rows[c.point][1], c.multiplier.real(),
                c.multiplier.imag(), c.stable ? 1 : 0);
    EXPECT_EQ(table.rows[c.point][stable] == 1.0, c.stable);
    if (c.kind == "fold") {
      const double hz = table.rows[c.point][1];
      EXPECT_TRUE(std::abs(hz - turning[0]) < 1e-9 * hz || std::abs(hz - turning[1]) < 1e-9 * hz)
          << hz;
      EXPECT_NEAR(c.multiplier.real(), 1.0, 0.03);  // the truncated orbit's (H = 5)
    }
  }
  EXPECT_EQ(std::count(kinds.begin(), kinds.end(), "fold"), 2);
  ASSERT_FALSE(table.stability_changes.empty());
  const auto& first = table.stability_changes.front();
  EXPECT_EQ(first.kind, "branch_point");
  EXPECT_NEAR(table.rows[first.point][1], 435.0, 1.0);
  for (std::size_t i = 0; i < first.point; ++i) EXPECT_EQ(table.rows[i][stable], 1.0) << i;
  EXPECT_TRUE(table.stability_changes.back().stable);
  EXPECT_EQ(table.stability_changes.back().kind, "fold");
  ASSERT_TRUE(table.stable_peaks[0].has_value());
  EXPECT_LT(table.stable_peaks[0]->point, first.point);
  EXPECT_LT(table.stable_peaks[0]->amplitude_m, run.peaks[0].amplitude_m);
}

// A cyclic scene asking for stability is refused where it asks, naming the key (the stability
// of a sector model against other nodal diameters is not computed).
TEST(FloquetMultipliers, CyclicSceneIsRefusedAtTheKey) {
  const std::string file = std::string(FRICHB_SOURCE_DIR) + "/configs/bladed_disk_lumped_eo3.yaml";
  YAML::Node document = load_scene_yaml(file);
  document["output"]["stability"] = true;
  try {
    load_scene(YAML::Load(YAML::Dump(document)), file);  // with line marks
    FAIL() << "a cyclic scene with output.stability was accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.key_path(), "output.stability");
    EXPECT_EQ(e.file(), file);
    EXPECT_GT(e.line(), 0);
  }
}

}  // namespace
}  // namespace frichb::core
