// Harmonic balance against time integration of the same 1-DOF friction oscillator, with the
// same contact-law plugin stepping the contact: the steady-state amplitude agrees within 0.1 %
// at converged HB settings, stuck (300 Hz), near the friction peak (345 Hz) and above (400 Hz).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/model/response.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/solver/continuation.hpp"
#include "test_support.hpp"

namespace frichb::core {
namespace {

constexpr double kMass = 0.1, kStiffness = 4e5, kZeta = 0.005, kForce = 2.0;
const double kDamping = 2 * kZeta * std::sqrt(kStiffness / kMass) * kMass;
const char* kLaw = "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}";

// Velocity Verlet with the contact force from the law's step at each new position; returns
// the half peak-to-peak of x over the last period after `periods` periods from rest. (Not
// max |x|: a contact that slipped during the transient and then sticks keeps its slider at
// an offset, a static shift that the full-stick convention of HB does not reproduce.)
double time_integration_amplitude(const ContactLawInstance& law, double frequency_hz, int periods,
                                  int steps_per_period) {
  const double w = 2 * std::numbers::pi * frequency_hz;
  const double dt = 2 * std::numbers::pi / w / steps_per_period;
  double x = 0, v = 0, state = 0, next_state = 0, t = 0;
  double u_prev[3] = {0, 0, 0}, u_now[3] = {0, 0, 0}, f[3] = {0, 0, 0};
  std::string error;
  auto contact = [&](double position) {
    u_now[0] = position;
    EXPECT_TRUE(law.step(&state, u_prev, u_now, f, &next_state, nullptr, &error)) << error;
    state = next_state;
    u_prev[0] = position;
    return f[0];
  };
  double force = contact(0.0);
  double a = (kForce * std::cos(w * t) - kDamping * v - kStiffness * x - force) / kMass;
  double highest = -1e300, lowest = 1e300;
  for (int p = 0; p < periods; ++p) {
    for (int s = 0; s < steps_per_period; ++s) {
      x += dt * v + 0.5 * dt * dt * a;
      t += dt;
      force = contact(x);
      const double v_pred = v + dt * a;
      const double a_next =
          (kForce * std::cos(w * t) - kDamping * v_pred - kStiffness * x - force) / kMass;
      v += 0.5 * dt * (a + a_next);
      a = a_next;
      if (p == periods - 1) {
        highest = std::max(highest, x);
        lowest = std::min(lowest, x);
      }
    }
  }
  return 0.5 * (highest - lowest);
}

double harmonic_balance_amplitude(double frequency_hz) {
  test::TempDir dir;
  const auto file = dir.write("scene.yaml", std::string(R"(
structure:
  provider: lumped
  params: {masses: [0.1], springs: [{between: [ground, 0], k: 4.0e5}], modal_damping: [0.005]}
  dofs: {blade: 0}
excitation: [{dof: blade, amplitude: 2.0}]
contacts: [{name: c, law: jenkins_1d, between: [ground, blade], params: )") +
                                                kLaw + R"(}]
harmonic_balance: {max_harmonic: 21, samples_per_period: 512}
continuation: {frequency: {from: 250, to: 450}}
)");
  Scene scene = load_scene(file);
  bind_plugins(scene, test::built_plugins());
  StructureInstance structure(scene.structure.plugin, scene.structure.values);
  HarmonicBalanceModel model(scene, structure);
  const auto summary = test::trace_hz(model, 250, frequency_hz, 5.0);
  EXPECT_TRUE(summary.reached_end()) << summary.message;
  AmplitudeSampler sampler(model.layout().harmonics(), 4096);
  return sampler.peak_amplitude(model.kept_response(summary.points.back().y),
                                {model.kept_index(0)});
}

class HarmonicBalanceVersusTimeIntegration : public ::testing::TestWithParam<double> {};

TEST_P(HarmonicBalanceVersusTimeIntegration, SteadyStateAmplitudeAgreesWithinOnePercent) {
  const double f = GetParam();
  auto law = test::make_law("jenkins_1d", kLaw);
  // 400 periods: the free decay time 1 / (zeta w) is under 40 periods, friction only adds.
  const double reference = time_integration_amplitude(*law.law, f, 400, 4000);
  const double hb = harmonic_balance_amplitude(f);
  std::printf("%g Hz: HB %.6e m, time integration %.6e m, difference %.3f %%\n", f, hb, reference,
              100 * (hb - reference) / reference);
  EXPECT_NEAR(hb, reference, 1e-3 * reference)
      << "HB " << hb << " m, time integration " << reference << " m at " << f << " Hz";
}

INSTANTIATE_TEST_SUITE_P(StuckPeakAndAbove, HarmonicBalanceVersusTimeIntegration,
                         ::testing::Values(300.0, 345.0, 400.0));

}  // namespace
}  // namespace frichb::core
