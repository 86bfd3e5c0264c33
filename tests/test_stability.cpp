// Floquet multipliers of harmonic-balance solutions (model/stability.hpp) against independent
// oracles: the closed form of a linear system (a contact stuck throughout), and the monodromy of
// a fine time integration of the nonlinear equations, differenced, on its own periodic orbit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <sstream>

#include "fe_lattice.hpp"
#include "frichb/core/commands/run.hpp"
#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/model/reduced_structure.hpp"
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
                                      const std::string& file = kTwoDof,
                                      const Registry& plugins = test::built_plugins()) {
  auto p = std::make_unique<SolvedPoint>();
  p->scene = load_scene(file, overrides);
  bind_plugins(p->scene, plugins);
  p->structure =
      std::make_unique<StructureInstance>(p->scene.structure.plugin, p->scene.structure.values);
  p->model = std::make_unique<HarmonicBalanceModel>(p->scene, *p->structure);
  const auto curve = test::trace_hz(*p->model, p->scene.continuation.from, hz, 2.0);
  EXPECT_TRUE(curve.reached_end()) << curve.message;
  p->y = curve.points.back().y;
  return p;
}

// The built plugins and the test-only ones (hardening_spring).
const Registry& with_test_plugins() {
  static const Registry registry({FRICHB_PLUGIN_DIR, FRICHB_TEST_PLUGIN_DIR});
  return registry;
}

// A Duffing oscillator: 0.1 kg on 4e5 N/m (318 Hz), 1 % modal damping, a cubic spring
// k3 u^3 to the ground, 2 N of harmonic force. Its curve bends to higher frequency and folds
// twice; the smooth force makes the harmonic balance converge fast in the harmonics.
std::string duffing_scene(const test::TempDir& dir) {
  return dir
      .write("duffing.yaml", R"(name: duffing
structure:
  provider: lumped
  params:
    masses: [0.1]
    springs:
      - {between: [ground, 0], k: 4.0e5}
    modal_damping: [0.01]
  dofs: {mass: 0}
excitation:
  - {dof: mass, amplitude: 2.0, harmonic: 1}
contacts:
  - name: hardening
    law: hardening_spring
    between: [ground, mass]
    frame: {tangent1: [1.0]}
    params: {k: 0.0, k3: 2.0e12}
harmonic_balance:
  max_harmonic: 7
  samples_per_period: 128
continuation:
  frequency: {from: 250, to: 450, unit: Hz}
output:
  response: [mass]
)")
      .string();
}

// The point nearest `hz` on the `branch`-th stretch of the whole curve of the scene `file`
// (0: from the start to the first turning point, 1: to the second, ...).
std::unique_ptr<SolvedPoint> solve_on_branch(const std::string& file,
                                             const std::vector<SceneOverride>& overrides,
                                             int branch, double hz) {
  auto p = std::make_unique<SolvedPoint>();
  p->scene = load_scene(file, overrides);
  bind_plugins(p->scene, with_test_plugins());
  p->structure =
      std::make_unique<StructureInstance>(p->scene.structure.plugin, p->scene.structure.values);
  p->model = std::make_unique<HarmonicBalanceModel>(p->scene, *p->structure);
  const auto curve =
      test::trace_hz(*p->model, p->scene.continuation.from, p->scene.continuation.to, 2.0);
  EXPECT_TRUE(curve.reached_end()) << curve.message;
  const auto w = [&](std::size_t i) { return curve.points[i].y(curve.points[i].y.size() - 1); };
  int stretch = 0;
  double best = 1e300;
  for (std::size_t i = 1; i + 1 < curve.points.size(); ++i) {
    if ((w(i) - w(i - 1)) * (w(i + 1) - w(i)) < 0) ++stretch;
    const double distance = std::abs(w(i) / (2 * std::numbers::pi) - hz);
    if (stretch == branch && distance < best) {
      best = distance;
      p->y = curve.points[i].y;
    }
  }
  EXPECT_LT(best, 1.0) << "no point near " << hz << " Hz on stretch " << branch;
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
//
// Forcing::kExcitation integrates the scene's equations (oracle B: the true periodic orbit).
// Forcing::kHarmonicBalanceOrbit replaces the excitation by the load p(t) that makes the
// harmonic-balance orbit itself a solution (its modal acceleration, damping and stiffness
// terms and its contact forces, the laws stepped along it on the fine grid until periodic):
// the monodromy of that system on its periodic orbit is that of the variational equations
// along the harmonic-balance orbit, integrated finely (oracle A, free of the harmonic
// truncation). Both need the kept DOFs to determine the modal coordinates.
class ShootingOracle {
 public:
  enum class Forcing { kExcitation, kHarmonicBalanceOrbit };
  ShootingOracle(const SolvedPoint& point, int steps_per_period,
                 Forcing forcing = Forcing::kExcitation)
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
    if (forcing == Forcing::kHarmonicBalanceOrbit) follow_harmonic_orbit(point.y);
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
      const Eigen::VectorXd a_next = acceleration(q, v + dt * a, k, f);
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
      if (n > 0)
        s.segment(state_offset_[c], n) = trace.state.row(trace.state.rows() - 1).transpose();
      s.segment<3>(prev_offset_[c]) = local_motion(c, s.head(modes_));
    }
    Eigen::VectorXd probe = s, f;
    contact_forces(s.head(modes_), probe, f);
    s.segment(2 * modes_, modes_) = acceleration(s.head(modes_), s.segment(modes_, modes_), 0, f);
    return s;
  }
  // The modal displacement, velocity and acceleration of the harmonic-balance orbit at t.
  struct OrbitPoint {
    Eigen::VectorXd q, v, a;
  };
  OrbitPoint orbit_at(const std::vector<Eigen::VectorXcd>& x, double t) const {
    const auto& harmonics = model_.layout().harmonics();
    Eigen::VectorXd kept = Eigen::VectorXd::Zero(phi_.rows()), rate = kept, acceleration = kept;
    for (std::size_t k = 0; k < harmonics.size(); ++k) {
      const std::complex<double> iw(0, harmonics[k] * w_);
      const Eigen::VectorXcd at = x[k] * std::polar(1.0, harmonics[k] * w_ * t);
      kept += at.real();
      rate += (iw * at).real();
      acceleration += (iw * iw * at).real();
    }
    const auto qr = phi_.colPivHouseholderQr();
    EXPECT_EQ(qr.rank(), modes_) << "the kept DOFs do not determine the modal coordinates";
    return {qr.solve(kept), qr.solve(rate), qr.solve(acceleration)};
  }
  // Oracle A: the load of every step that makes the harmonic-balance orbit a solution, and the
  // start on it with the laws' periodic states on the fine grid.
  void follow_harmonic_orbit(const Eigen::VectorXd& y) {
    const auto x = model_.kept_response(y);
    const double dt = 2 * std::numbers::pi / w_ / steps_;
    std::vector<OrbitPoint> orbit;
    orbit.reserve(static_cast<std::size_t>(steps_));
    for (int k = 0; k < steps_; ++k) orbit.push_back(orbit_at(x, k * dt));
    Eigen::VectorXd s = start_, f;
    std::vector<Eigen::VectorXd> forces(static_cast<std::size_t>(steps_));
    const Eigen::Index laws = size_ - 3 * modes_;
    for (int pass = 0; pass < 20; ++pass) {
      const Eigen::VectorXd before = s.tail(laws);
      for (int k = 1; k <= steps_; ++k) {
        contact_forces(orbit[static_cast<std::size_t>(k % steps_)].q, s, f);
        forces[static_cast<std::size_t>(k % steps_)] = f;
      }
      if ((s.tail(laws) - before).cwiseAbs().maxCoeff() <=
          1e-14 * std::max(1.0, before.cwiseAbs().maxCoeff()))
        break;
    }
    reference_load_.resize(static_cast<std::size_t>(steps_));
    for (int k = 0; k < steps_; ++k) {
      const auto& o = orbit[static_cast<std::size_t>(k)];
      reference_load_[static_cast<std::size_t>(k)] =
          o.a + damping_ * o.v + stiffness_.cwiseProduct(o.q) +
          phi_.transpose() * (gather_.transpose() * forces[static_cast<std::size_t>(k)]);
    }
    start_.tail(laws) = s.tail(laws);
    start_.head(modes_) = orbit[0].q;
    start_.segment(modes_, modes_) = orbit[0].v;
    start_.segment(2 * modes_, modes_) = orbit[0].a;
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
  // The modal acceleration at step k of a period.
  Eigen::VectorXd acceleration(const Eigen::VectorXd& q, const Eigen::VectorXd& v, int step,
                               const Eigen::VectorXd& f) const {
    if (!reference_load_.empty())
      return reference_load_[static_cast<std::size_t>(step % steps_)] -
             phi_.transpose() * (gather_.transpose() * f) - damping_ * v -
             stiffness_.cwiseProduct(q);
    const double t = 2 * std::numbers::pi / w_ / steps_ * step;
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
  std::vector<Eigen::VectorXd> reference_load_;  // oracle A: the modal load of every step
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

// The largest relative distance between two sets of multipliers, each of `a` to its nearest
// in `b` (both complete: the multipliers a conjugate pair or a real pair shares).
double multiplier_distance(const std::vector<std::complex<double>>& a,
                           const std::vector<std::complex<double>>& b, std::size_t count) {
  double worst = 0.0;
  for (std::size_t i = 0; i < std::min(count, a.size()); ++i) {
    double nearest = 1e300;
    for (const auto& m : b) nearest = std::min(nearest, std::abs(a[i] - m));
    worst = std::max(worst, nearest / std::abs(a[i]));
  }
  return worst;
}

// The harmonic-balance multipliers of `point` and the shooting oracle's, on `steps` a period,
// printed side by side under `label`.
struct ShootingComparison {
  FloquetMultipliers harmonic_balance;
  std::vector<std::complex<double>> shooting;
  double relative_difference = 0.0;  // of the largest moduli
};

ShootingComparison compare_with_shooting(
    const SolvedPoint& point, int steps, const char* label,
    ShootingOracle::Forcing forcing = ShootingOracle::Forcing::kExcitation) {
  ShootingComparison c;
  c.harmonic_balance = floquet_multipliers(*point.model, point.y);
  EXPECT_TRUE(c.harmonic_balance.failure.empty()) << c.harmonic_balance.failure;
  const ShootingOracle oracle(point, steps, forcing);
  Eigen::VectorXd orbit = oracle.start();
  const int iterations = oracle.shoot(orbit);
  EXPECT_GT(iterations, 0) << "shooting did not converge";
  c.shooting = shooting_multipliers(oracle, orbit);
  const double largest = std::abs(c.shooting.front());
  c.relative_difference = std::abs(c.harmonic_balance.largest_modulus - largest) / largest;
  const bool fine = forcing == ShootingOracle::Forcing::kHarmonicBalanceOrbit;
  const char* oracle_name = fine ? "fine variational" : "shooting";
  std::printf(
      "%s: largest |mu| %.6f (harmonic balance, %d steps), %.6f (%s, %d steps, %d Newton "
      "iterations); relative difference %.2e\n",
      label, c.harmonic_balance.largest_modulus, c.harmonic_balance.steps, largest, oracle_name,
      steps, iterations, c.relative_difference);
  print_multipliers("HB", c.harmonic_balance.multipliers, 4);
  print_multipliers(oracle_name, c.shooting, 4);
  return c;
}

// At the friction peak of the 2-DOF scene the damper slips twice a period: no neutral
// multiplier, and the largest multiplier of the harmonic-balance orbit against that of the
// shooting oracle's orbit. The orbits differ by the harmonic truncation and the integrators'
// steps. Measured: 3.7e-4 (H = 7, 128 samples, against 4096 Verlet steps a period). The
// oracle's own steps are first order where the contact switches (its Jenkins steps switch at
// samples): its largest multiplier moves by 3e-3 from 2048 to 8192 steps a period, so the
// exact flows along the orbit (below) are the tighter check of a stick-slip contact.
TEST(FloquetMultipliers, SlippingDamperAgreesWithShooting) {
  const auto point = solve_at({}, 298.0);
  const auto c = compare_with_shooting(*point, 4096, "slipping damper at 298 Hz");
  EXPECT_TRUE(c.harmonic_balance.neutral.empty());
  EXPECT_LT(c.relative_difference, 1e-3);
  EXPECT_TRUE(c.harmonic_balance.stable());
}

// Oracle A for the smooth Duffing law: the variational equations along the same
// harmonic-balance orbit, integrated on 16 times its samples by another integrator (Verlet,
// the law's plain steps, the monodromy by differences), so that the harmonic truncation is out
// of the comparison; on the middle branch at 340 Hz (unstable). For a law that switches
// between stick and slip that integrator is only first order (the linearised force jumps
// between its samples): the Jenkins contact has its own oracle A below.
TEST(FloquetMultipliers, FineIntegrationAlongTheSameOrbitAgrees) {
  test::TempDir dir;
  const auto duffing = solve_on_branch(duffing_scene(dir), {}, 1, 340.0);
  const auto d = compare_with_shooting(*duffing, 16 * 128, "Duffing middle branch at 340 Hz",
                                       ShootingOracle::Forcing::kHarmonicBalanceOrbit);
  EXPECT_LT(d.relative_difference, 1e-3);
  EXPECT_FALSE(d.harmonic_balance.stable());
  EXPECT_GT(std::abs(d.shooting.front()), 1.0);
}

// Oracle A for a Jenkins contact that slips twice a period, exact along the harmonic-balance
// orbit: between its switches the linearised contact is a spring kt to a fixed slider (stuck)
// or no force at all (slipping, the slider following the motion), so the monodromy is the
// product of the exact flows of the two linear systems (matrix exponentials by eigenvectors)
// over the stick and slip intervals. The switches are those of the orbit's own motion u(t):
// the contact sticks where u turns (u' = 0) and slips again once u has come back 2 mu N / kt.
// The slider's perturbation restarts at the motion's at each stick (it followed it while
// slipping), and the force's perturbation drops to 0 at each slip: no other jump enters at
// first order, as the force itself is continuous.
//
// With a residual flexibility c between the contact and the structure (u = P q - c f), the
// stuck contact is kt in series with c: the stick flow's spring is kt / (1 + kt c); the
// switches, the restart (the force's perturbation is 0 while slipping, so du = P dq) and the
// drop are as without it.
std::vector<std::complex<double>> jenkins_exact_multipliers(const SolvedPoint& point, double kt,
                                                            double slip_force,
                                                            double compliance = 0.0) {
  const HarmonicBalanceModel& model = *point.model;
  const auto& basis = model.structure().basis(0);
  const Eigen::MatrixXd phi = basis.rows.real();
  const Eigen::MatrixXd gather = Eigen::MatrixXcd(model.gather(0)).real();
  EXPECT_EQ(gather.rows(), 1);
  const Eigen::RowVectorXd p = gather * phi;
  const Eigen::Index n = phi.cols();
  const double w = point.y(point.y.size() - 1), period = 2 * std::numbers::pi / w;
  const auto x = model.kept_response(point.y);
  const auto& harmonics = model.layout().harmonics();
  // u and du/dt of the contact along the orbit.
  const auto motion = [&](double t, int derivative) {
    std::complex<double> sum = 0;
    for (std::size_t k = 0; k < harmonics.size(); ++k) {
      const std::complex<double> iw(0, harmonics[k] * w);
      sum += (gather.row(0).cast<std::complex<double>>() * x[k])(0) * std::exp(iw * t) *
             (derivative == 1 ? iw : 1.0);
    }
    return sum.real();
  };
  // The root of g in [a, b] (a sign change), by bisection to rounding.
  const auto root = [](auto g, double a, double b) {
    const double ga = g(a);
    for (int i = 0; i < 100 && b - a > 1e-15 * std::abs(b); ++i) {
      const double mid = 0.5 * (a + b);
      ((g(mid) > 0) == (ga > 0) ? a : b) = mid;
    }
    return 0.5 * (a + b);
  };
  // The law along u(t), exactly: stuck, the force kt (u - z) until it reaches mu N; slipping
  // in direction s until u turns (u' s = 0), where it sticks with z = u - s mu N / kt. Swept
  // over three periods from a stuck, unloaded start on a grid of 8192 a period (each event
  // refined by bisection); the events of the third period are the periodic switches.
  const int grid = 8192;
  const double dt = period / grid;
  struct Event {
    double t;
    bool sticks;  // slip to stick; else stick to slip
  };
  std::vector<Event> events;
  bool stuck = true;
  double z = motion(0.0, 0), direction = 1.0;
  for (int i = 0; i < 3 * grid; ++i) {
    const double a = i * dt, b = a + dt;
    if (stuck) {
      const double fb = kt * (motion(b, 0) - z);
      if (std::abs(fb) < slip_force) continue;
      direction = fb > 0 ? 1.0 : -1.0;
      const double t =
          root([&](double t0) { return kt * (motion(t0, 0) - z) - direction * slip_force; }, a, b);
      stuck = false;
      if (a >= 2 * period) events.push_back({t, false});
    } else if (motion(b, 1) * direction < 0) {
      const double t = root([&](double t0) { return motion(t0, 1); }, a, b);
      z = motion(t, 0) - direction * slip_force / kt;
      stuck = true;
      if (a >= 2 * period) events.push_back({t, true});
    }
  }
  const auto first_stick =
      std::find_if(events.begin(), events.end(), [](const Event& e) { return e.sticks; });
  EXPECT_TRUE(first_stick != events.end() && events.size() >= 2)
      << "the contact does not stick and slip";
  if (first_stick == events.end() || events.size() < 2) return {};
  std::rotate(events.begin(), first_stick, events.end());
  // The flows: stuck on (q, q', z), slipping on (q, q').
  const Eigen::MatrixXd omega2 = basis.frequencies.array().square().matrix().asDiagonal();
  Eigen::MatrixXd slip = Eigen::MatrixXd::Zero(2 * n, 2 * n),
                  stick = Eigen::MatrixXd::Zero(2 * n + 1, 2 * n + 1);
  slip.topRightCorner(n, n).setIdentity();
  slip.bottomLeftCorner(n, n) = -omega2;
  slip.bottomRightCorner(n, n) = -basis.damping;
  stick.topLeftCorner(2 * n, 2 * n) = slip;
  const double spring = kt / (1.0 + kt * compliance);
  stick.block(n, 0, n, n) -= spring * p.transpose() * p;
  stick.block(n, 2 * n, n, 1) = spring * p.transpose();
  const auto flow = [](const Eigen::MatrixXd& a, double tau) {
    Eigen::EigenSolver<Eigen::MatrixXd> eig(a);
    const Eigen::MatrixXcd v = eig.eigenvectors();
    const Eigen::VectorXcd e = (eig.eigenvalues() * tau).array().exp();
    return Eigen::MatrixXd((v * e.asDiagonal() * v.inverse()).real());
  };
  Eigen::MatrixXd restart = Eigen::MatrixXd::Zero(2 * n + 1, 2 * n),
                  drop = Eigen::MatrixXd::Zero(2 * n, 2 * n + 1);
  restart.topRows(2 * n).setIdentity();
  restart.block(2 * n, 0, 1, n) = p;
  drop.leftCols(2 * n).setIdentity();
  // From the first stick of the period round to it again, slipping just before.
  Eigen::MatrixXd monodromy = Eigen::MatrixXd::Identity(2 * n, 2 * n);
  for (std::size_t e = 0; e < events.size(); ++e) {
    const double tau =
        std::fmod(events[(e + 1) % events.size()].t - events[e].t + 2 * period, period);
    if (events[e].sticks) {
      monodromy = drop * flow(stick, tau) * restart * monodromy;
      EXPECT_TRUE(e + 1 == events.size() || !events[e + 1].sticks);
    } else {
      monodromy = flow(slip, tau) * monodromy;
    }
  }
  const Eigen::VectorXcd mu = monodromy.eigenvalues();
  std::vector<std::complex<double>> out(mu.begin(), mu.end());
  std::sort(out.begin(), out.end(),
            [](const auto& a, const auto& b) { return std::abs(a) > std::abs(b); });
  return out;
}

// The 2-DOF damper, sticking and slipping two or four times a period at 298, 330 and 350 Hz,
// against the exact flows along its own orbit. The largest multiplier's modulus agrees to
// 1e-3 from 256 samples (measured at 128 samples: 1.2e-4, 8.7e-4 and 3.4e-3, the law's
// sample-by-sample trace then shaping the orbit's switches), and all four multipliers,
// phases included, converge with the samples.
TEST(FloquetMultipliers, SlippingDamperAgreesWithExactFlowsBetweenItsSwitches) {
  for (const double hz : {298.0, 330.0, 350.0}) {
    std::vector<double> all;
    for (const char* samples : {"128", "256", "512"}) {
      const auto point = solve_at({{"harmonic_balance.samples_per_period", samples}}, hz);
      const FloquetMultipliers f = floquet_multipliers(*point->model, point->y);
      ASSERT_TRUE(f.failure.empty()) << f.failure;
      EXPECT_TRUE(f.neutral.empty());
      EXPECT_TRUE(f.stable());
      const auto exact = jenkins_exact_multipliers(*point, 2.0e5, 0.5 * 5.0);
      ASSERT_EQ(exact.size(), 4u);
      const double largest = std::abs(f.largest_modulus - std::abs(exact[0])) / std::abs(exact[0]);
      all.push_back(multiplier_distance(exact, f.multipliers, 4));
      std::printf(
          "%.0f Hz, %s samples (%d steps split at a switch): largest |mu| %.6f, exact "
          "%.6f (%.2e); all four to %.2e\n",
          hz, samples, f.split_steps, f.largest_modulus, std::abs(exact[0]), largest, all.back());
      print_multipliers("HB", f.multipliers, 4);
      print_multipliers("exact", exact, 4);
      if (std::string(samples) != "128") {
        EXPECT_LT(largest, 1e-3) << hz << " Hz, " << samples << " samples";
      }
    }
    EXPECT_LT(all[2], all[0] / 4) << hz << " Hz";
    EXPECT_LT(all[2], 5e-4) << hz << " Hz";
  }
}

// A contact on a residual flexibility, slipping: an FE sector (tests/fe_lattice.hpp, taken as
// the whole structure: 1 sector, 19 DOFs, 16 modes, first at 425.5 Hz) with 5 modes and the
// static residual flexibility of the other 11, a Jenkins contact from the blade tip to the
// ground (kt 2e5 N/m, mu N 0.25 N), which sticks and slips twice a period on the resonance. The
// harmonic-balance multipliers against the exact flows between the orbit's switches with the
// stuck contact in series with the flexibility c = G F G^T at the tip (gathered here from the
// provider's F); and against the same flows without c, which they must miss. Measured: all ten
// multipliers to 3.1e-4 and 7.5e-5 at 256 and 512 samples on 360 Hz (1.7e-4 and 1.1e-5 on
// 424 Hz), the flows without c 2.9e-2 (1.5e-3, where the contact sticks for less) away.
TEST(FloquetMultipliers, ContactOnAResidualFlexibilityAgreesWithExactFlowsBetweenItsSwitches) {
  if (!test::built_plugins().contains("fe_sector")) GTEST_SKIP() << "fe_sector not built";
  test::TempDir dir;
  const test::Sector sector(3, 4, 4, true, 5);
  const auto mass = dir.write("m.mtx", test::market(sector.m, false));
  const auto stiffness = dir.write("k.mtx", test::market(sector.k, true));
  constexpr double kt = 2.0e5, slip_force = 0.25;
  auto scene = [&](int samples) {
    std::ostringstream s;
    s << "structure:\n  provider: fe_sector\n  params: {mass: '" << mass.string()
      << "', stiffness: '" << stiffness.string()
      << "', sectors: 1, left_dofs: " << test::list(sector.left)
      << ", right_dofs: " << test::list(sector.right)
      << ", modes: 5, modal_damping: [0.01]}\n  dofs: {tip: " << sector.n - 1 << "}\n"
      << "excitation: [{dof: tip, amplitude: 1.0}]\n"
      << "contacts:\n  - {name: root, law: jenkins_1d, between: [tip, ground], frame: "
         "{tangent1: [1.0]}, params: {kt: "
      << kt << ", mu: 0.5, normal_load: " << 2 * slip_force << "}}\n"
      << "harmonic_balance: {harmonics: [0, 1, 2, 3, 4, 5, 6, 7], samples_per_period: " << samples
      << "}\ncontinuation: {frequency: {from: 300, to: 800}}\n"
      << "output: {response: [tip], stability: true}\n";
    return dir.write("flexible_" + std::to_string(samples) + ".yaml", s.str()).string();
  };
  for (const double hz : {360.0, 424.0}) {
    std::vector<double> all;
    for (const int samples : {256, 512}) {
      const auto point = solve_at({}, hz, scene(samples));
      const HarmonicBalanceModel& model = *point->model;
      const ReducedStructure whole(*point->structure, model.structure().kept_dofs(), {0});
      ASSERT_GT(whole.basis(0).residual_flexibility.size(), 0);
      const Eigen::MatrixXd g = Eigen::MatrixXcd(model.gather(0)).real();
      const double c = (g * whole.basis(0).residual_flexibility.real() * g.transpose())(0, 0);
      const FloquetMultipliers f = floquet_multipliers(model, point->y);
      ASSERT_TRUE(f.failure.empty()) << f.failure;
      EXPECT_TRUE(f.neutral.empty());
      EXPECT_GT(f.split_steps, 0);
      const auto exact = jenkins_exact_multipliers(*point, kt, slip_force, c);
      const auto stiff = jenkins_exact_multipliers(*point, kt, slip_force);
      ASSERT_EQ(exact.size(), 10u);
      all.push_back(multiplier_distance(exact, f.multipliers, 10));
      const double largest = std::abs(f.largest_modulus - std::abs(exact[0])) / std::abs(exact[0]);
      const double without = multiplier_distance(stiff, f.multipliers, 10);
      std::printf(
          "%.0f Hz, %d samples, kt c = %.3f (%d steps split at a switch): largest |mu| %.6f, "
          "exact %.6f (%.2e); all ten to %.2e; the flows without c %.2e away\n",
          hz, samples, kt * c, f.split_steps, f.largest_modulus, std::abs(exact[0]), largest,
          all.back(), without);
      EXPECT_LT(largest, 1e-3) << hz << " Hz, " << samples << " samples";
      if (samples == 512) {
        EXPECT_GT(without, 10 * all.back()) << hz << " Hz";
      }
    }
    EXPECT_LT(all[1], all[0] / 3) << hz << " Hz";
  }
  // A model built without output.stability reduced F as it fetched it: refused, not computed
  // as if there were none.
  const auto unprepared = solve_at({{"output.stability", "false"}}, 360.0, scene(256));
  const FloquetMultipliers refused = floquet_multipliers(*unprepared->model, unprepared->y);
  EXPECT_NE(refused.failure.find("output.stability"), std::string::npos) << refused.failure;
  EXPECT_TRUE(refused.multipliers.empty());
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
  // Oracle A: along the same orbit, 16 times its 256 samples.
  const auto a = compare_with_shooting(*point, 16 * 256, "Hertz gap at 450 Hz",
                                       ShootingOracle::Forcing::kHarmonicBalanceOrbit);
  EXPECT_GT(std::abs(a.shooting.front()), 1.0);
  EXPECT_LT(a.relative_difference, 1e-3);
}

// The whole curve of configs/stress/hertz_gap_folds.yaml with output.stability: stable up to the
// branch point at 435 Hz on the upper branch, a fold at each turning point (the curve's own,
// with the multiplier nearest +1 there), and stable again from the lower fold on; the branch
// points located between their points where a multiplier crosses the unit circle; the table's
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
    if (c.kind != "fold") {
      // Located by bisection between its two points, where the multiplier crosses the circle.
      ASSERT_TRUE(c.located.has_value());
      const double hz = c.located->omega_rad_s / (2 * std::numbers::pi);
      const double a = table.rows[c.point - 1][1], b = table.rows[c.point][1];
      std::printf("  located at %.4f Hz (between %.4f and %.4f): |multiplier| %.7f\n", hz, a, b,
                  std::abs(c.located->multiplier));
      EXPECT_GE(hz, std::min(a, b));
      EXPECT_LE(hz, std::max(a, b));
      EXPECT_GE(std::abs(c.located->multiplier), 1.0);
      EXPECT_LT(std::abs(c.located->multiplier), 1.0 + 1e-4);
    } else {
      EXPECT_FALSE(c.located.has_value());
    }
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

// configs/stress/gap_closing_folds.yaml as shipped (coupled law, a gap closing, 128 samples):
// the stability changes at the curve's two turning points alone, the branch between them
// unstable, with no change of stability from point to point on the upper branch (a contact
// that sticks, slips and opens there: the steps are split at its switches).
TEST(FloquetMultipliers, GapClosingCurveChangesStabilityAtItsFoldsAlone) {
  const std::string file =
      std::string(FRICHB_SOURCE_DIR) + "/configs/stress/gap_closing_folds.yaml";
  RunOptions options;
  options.plots = 0;
  options.quiet = true;
  const RunResult run = run_scene(SceneInput{file, {}, false}, options);
  ASSERT_EQ(run.outcome.status, 0) << run.outcome.message;
  const auto& table = run.table;
  ASSERT_EQ(table.turning_points.frequencies.size(), 2u);
  ASSERT_EQ(table.stability_changes.size(), 2u);
  for (const auto& c : table.stability_changes) {
    std::printf("%s at point %zu, %.4f Hz: multiplier %+.6f, stable after: %d\n", c.kind.c_str(),
                c.point, table.rows[c.point][1], c.multiplier.real(), c.stable ? 1 : 0);
    EXPECT_EQ(c.kind, "fold");
  }
  EXPECT_FALSE(table.stability_changes[0].stable);
  EXPECT_TRUE(table.stability_changes[1].stable);
  EXPECT_GT(table.unstable_points, 0);
  std::printf("%d unstable points of %zu\n", table.unstable_points, table.rows.size());
}

// A cyclic scene asking for stability is refused where it asks, naming the key (the stability
// of a sector model against other nodal diameters is not computed).
// The stability of a cyclic scene delays each sector's copy of the contacts by s m / nb of the
// period: a period's samples times the engine order that is not a multiple of the sectors is
// refused at the key.
TEST(FloquetMultipliers, CyclicSceneWhoseSectorDelaysAreNotWholeSamplesIsRefusedAtTheKey) {
  const std::string file = std::string(FRICHB_SOURCE_DIR) + "/configs/bladed_disk_lumped_eo3.yaml";
  YAML::Node document = load_scene_yaml(file);
  document["output"]["stability"] = true;
  load_scene(YAML::Load(YAML::Dump(document)), file);  // 256 samples, m 3, nb 8: accepted
  document["harmonic_balance"]["samples_per_period"] = 100;
  try {
    load_scene(YAML::Load(YAML::Dump(document)), file);  // with line marks
    FAIL() << "a cyclic scene with sector delays of fractional samples was accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.key_path(), "output.stability");
    EXPECT_EQ(e.file(), file);
    EXPECT_GT(e.line(), 0);
    EXPECT_NE(std::string(e.what()).find("multiple of cyclic.sectors"), std::string::npos)
        << e.what();
  }
}

// Oracle B on a smooth system, in the number of harmonics: the Duffing oscillator on its upper
// branch at 340 Hz (stable: a complex pair, whose modulus Liouville's formula fixes at
// exp(-2 pi zeta f0 / f) whatever the orbit, so the whole multipliers are compared) and on its
// middle branch at 340 Hz (unstable: a real pair). Where the harmonic-balance orbit matches the
// shooting orbit (8192 Verlet steps) to 1e-4, the multipliers match to 1e-3.
TEST(FloquetMultipliers, DuffingConvergesInHarmonicsToShooting) {
  test::TempDir dir;
  const std::string file = duffing_scene(dir);
  for (const int branch : {0, 1}) {
    std::printf("Duffing near 340 Hz, %s branch\n  H  orbit vs shooting  multipliers vs shooting\n",
                branch == 0 ? "upper" : "middle");
    double at_five = 1.0;
    for (const char* h : {"1", "3", "5", "7", "9"}) {
      const auto point =
          solve_on_branch(file, {{"harmonic_balance.max_harmonic", h}}, branch, 340.0);
      const double w = point->y(point->y.size() - 1);
      // The shooting orbit at the traced point's frequency, against the harmonic-balance orbit
      // at t = 0: [q, q'/w] relative to the amplitude of the fundamental.
      const ShootingOracle oracle(*point, 8192);
      Eigen::VectorXd orbit = oracle.start();
      ASSERT_GT(oracle.shoot(orbit), 0) << "shooting did not converge at H = " << h;
      const Eigen::Vector2d state(orbit(0), orbit(1) / w),
          hb(oracle.start()(0), oracle.start()(1) / w);
      const double orbit_difference = (state - hb).cwiseAbs().maxCoeff() / state.norm();
      const FloquetMultipliers f = floquet_multipliers(*point->model, point->y);
      ASSERT_TRUE(f.failure.empty()) << f.failure;
      const double difference =
          multiplier_distance(shooting_multipliers(oracle, orbit), f.multipliers, 2);
      std::printf("  %s  %.2e           %.2e  (%.3f Hz, largest |mu| %.6f, stable %d)\n", h,
                  orbit_difference, difference, w / (2 * std::numbers::pi), f.largest_modulus,
                  f.stable() ? 1 : 0);
      EXPECT_EQ(f.stable(), branch == 0) << "H = " << h;
      if (orbit_difference <= 1e-4) {
        EXPECT_LT(difference, 1e-3) << "H = " << h;
      }
      if (std::string(h) == "5") at_five = orbit_difference;
    }
    EXPECT_LT(at_five, 1e-4);
    // What is left at H >= 5 is the variational step's, second order in the samples.
    double previous = 0.0;
    for (const char* samples : {"128", "256", "512"}) {
      const auto point = solve_on_branch(file,
                                         {{"harmonic_balance.max_harmonic", "7"},
                                          {"harmonic_balance.samples_per_period", samples}},
                                         branch, 340.0);
      const ShootingOracle oracle(*point, 8192);
      Eigen::VectorXd orbit = oracle.start();
      ASSERT_GT(oracle.shoot(orbit), 0);
      const double difference =
          multiplier_distance(shooting_multipliers(oracle, orbit),
                              floquet_multipliers(*point->model, point->y).multipliers, 2);
      std::printf(
          "  H = 7, %s samples: multipliers vs shooting %.2e%s\n", samples, difference,
          previous > 0 ? (" (ratio " + std::to_string(previous / difference) + ")").c_str() : "");
      if (previous > 0) {
        EXPECT_GT(previous / difference, 3.0) << samples;
      }
      previous = difference;
    }
  }
}

}  // namespace
}  // namespace frichb::core
