// frichb-trace-study: measured figures of the periodic contact tracing, printed as Markdown
// tables (a timed CLI run, not a test): passes for the state to repeat against the slip
// ratio, energy error against samples per period (plain and oversampled), and the time per
// trace per contact point of every shipped law, value only and with the Jacobian.
#include <yaml-cpp/yaml.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "frichb/core/numerics/harmonics.hpp"
#include "frichb/core/plugin_host/periodic_trace.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/plugin_host/schema.hpp"

using namespace frichb::core;

namespace {

struct Law {
  ParamValues values;
  std::unique_ptr<ContactLawInstance> instance;
};

Law make(const Registry& registry, const char* name, const char* params) {
  auto plugin = registry.load(name, FRICHB_KIND_CONTACT_LAW);
  Law law;
  law.values =
      validate_params(YAML::Load(params), plugin->schema(), "params", YamlContext{"study"});
  law.instance = std::make_unique<ContactLawInstance>(plugin, law.values);
  return law;
}

// Tangential ellipse a (cos, b/a sin) (t1, t2 when used), nothing normal.
Eigen::VectorXd ellipse(const PeriodicTracer& t, double a, double b) {
  const auto& layout = t.layout();
  const int c = layout.coefficient_count();
  Eigen::VectorXd u = Eigen::VectorXd::Zero(t.unknown_count());
  std::size_t k1 = 0;
  while (layout.harmonics()[k1] != 1) ++k1;
  u(layout.cos_index(k1)) = a;
  if (t.dimension() > 1 && t.components()[1] == 1) u(c + layout.sin_index(k1)) = b;
  return u;
}

template <class F>
double seconds_per_call(F&& f, int repeats) {
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < repeats; ++i) f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / repeats;
}

}  // namespace

int main() {
  const Registry registry({FRICHB_PLUGIN_DIR});
  const double kt = 2e5, slip = 0.5 * 5.0, delta = slip / kt;  // mu N / kt = 1.25e-5 m
  std::string error;

  std::printf("## Passes until the state repeats, against the slip ratio a / (mu N / kt)\n\n");
  std::printf(
      "Motion: ellipse a (cos, 0.5 sin) (1D laws: a cos); kt = 2e5 N/m, mu N = 2.5 N, "
      "256 samples. Passes counted with the derivative (Jacobian request).\n\n");
  std::printf("| a / (mu N/kt) | jenkins_1d | uncoupled_2d | coupled_3d |\n|---|---|---|---|\n");
  const char* params = "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}";
  Law laws[] = {make(registry, "jenkins_1d", params), make(registry, "uncoupled_2d", params),
                make(registry, "coupled_3d", params)};
  const HarmonicLayout layout({0, 1, 2, 3, 4, 5}, 256);
  for (double ratio : {0.5, 0.9, 1.1, 1.5, 2.0, 4.0, 10.0, 100.0}) {
    std::printf("| %.1f |", ratio);
    for (auto& law : laws) {
      PeriodicTracer tracer(*law.instance, layout);
      ContactTrace t;
      tracer.trace(ellipse(tracer, ratio * delta, 0.5 * ratio * delta), JacobianMode::kAnalytic, t,
                   &error);
      std::printf(" %d%s |", t.passes, t.periodic ? "" : " (not periodic)");
    }
    std::printf("\n");
  }

  std::printf("\n## Energy per cycle against samples per period (coupled_3d, circular motion)\n\n");
  std::printf(
      "Circle of radius a = 1.5 mu N / kt: the continuous closed form is "
      "2 pi mu N sqrt(a^2 - (mu N/kt)^2), here from the first force harmonics, "
      "pi a (c1(T2) - s1(T1)). Along the motion: the default trace; sample-only step with "
      "oversampling k: traced on k N samples.\n\n");
  std::printf(
      "| N | along: relative error | time per trace | with Jacobian | sample-only k = 1 | "
      "time per trace | with Jacobian | sample-only k = 4 | time per trace |\n"
      "|---|---|---|---|---|---|---|---|---|\n");
  const double a = 1.5 * delta;
  const double exact = 2 * std::numbers::pi * slip * std::sqrt(a * a - delta * delta);
  auto harmonic_energy = [&](const PeriodicTracer& tracer, const ContactTrace& t) {
    const auto& l = tracer.layout();
    const int c = l.coefficient_count();
    std::size_t k1 = 0;
    while (l.harmonics()[k1] != 1) ++k1;
    return std::numbers::pi * a *
           (t.force_coefficients(c + l.cos_index(k1)) - t.force_coefficients(l.sin_index(k1)));
  };
  for (int n : {64, 128, 256, 512, 1024, 2048}) {
    std::printf("| %d |", n);
    for (int variant = 0; variant < 3; ++variant) {
      const int k = variant == 2 ? 4 : 1;
      const HarmonicLayout l({0, 1, 2, 3}, n * k);
      TraceOptions options;
      options.along_motion = variant == 0;
      PeriodicTracer tracer(*laws[2].instance, l, options);
      ContactTrace t;
      const Eigen::VectorXd u = ellipse(tracer, a, a);
      const double s =
          seconds_per_call([&] { tracer.trace(u, JacobianMode::kNone, t, &error); }, 20);
      const double e = std::abs(harmonic_energy(tracer, t) - exact) / exact;
      std::printf(" %.2e | %.1f us |", e, 1e6 * s);
      if (variant < 2) {
        const double sj =
            seconds_per_call([&] { tracer.trace(u, JacobianMode::kAnalytic, t, &error); }, 10);
        std::printf(" %.1f us |", 1e6 * sj);
      }
    }
    std::printf("\n");
  }

  std::printf("\n## Force-harmonic error against samples per period, every law\n\n");
  std::printf(
      "Slipping ellipse a = 3 mu N / kt (b = a / 2); error of the force coefficients "
      "(harmonics 0..5, max over components, relative to the largest) against a trace "
      "on 32768 samples.\n\n| law | N = 64 | N = 256 | N = 1024 | N = 4096 |\n"
      "|---|---|---|---|---|\n");
  const char* all_params[][2] = {
      {"jenkins_1d", params},
      {"uncoupled_2d", params},
      {"coupled_3d", params},
      {"hertz_3d",
       "{normal_coefficient: 1.0e9, tangential_coefficient: 1.0e9, mu: 0.5, "
       "static_penetration: 1.0e-5}"}};
  for (const auto& lp : all_params) {
    Law law = make(registry, lp[0], lp[1]);
    auto coefficients = [&](int n) {
      const HarmonicLayout l({0, 1, 2, 3, 4, 5}, n);
      PeriodicTracer tracer(*law.instance, l);
      ContactTrace t;
      tracer.trace(ellipse(tracer, 3 * delta, 1.5 * delta), JacobianMode::kNone, t, &error);
      return Eigen::VectorXd(t.force_coefficients);
    };
    const Eigen::VectorXd reference = coefficients(32768);
    std::printf("| %s |", lp[0]);
    for (int n : {64, 256, 1024, 4096})
      std::printf(" %.2e |", (coefficients(n) - reference).cwiseAbs().maxCoeff() /
                                 reference.cwiseAbs().maxCoeff());
    std::printf("\n");
  }

  std::printf("\n## Time per trace per contact point (256 samples, harmonics 0..5, slipping)\n\n");
  std::printf(
      "| law | value only | with analytic Jacobian | with local finite differences |\n"
      "|---|---|---|---|\n");
  struct Case {
    const char* name;
    const char* params;
  } cases[] = {{"jenkins_1d", params},
               {"uncoupled_2d", params},
               {"coupled_3d", params},
               {"coupled_3d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0, kn: 1.0e6}"},
               {"hertz_3d",
                "{normal_coefficient: 1.0e9, tangential_coefficient: 1.0e9, mu: 0.5, "
                "static_penetration: 1.0e-5}"}};
  for (const auto& c : cases)
    for (const bool along : {true, false}) {
      Law law = make(registry, c.name, c.params);
      TraceOptions options;
      options.along_motion = along;
      PeriodicTracer tracer(*law.instance, layout, options);
      if (!along && !law.instance->traces_motion()) continue;
      Eigen::VectorXd u = ellipse(tracer, 3 * delta, 1.5 * delta);
      ContactTrace t;
      double times[3];
      const JacobianMode modes[] = {JacobianMode::kNone, JacobianMode::kAnalytic,
                                    JacobianMode::kFiniteDifference};
      for (int m = 0; m < 3; ++m)
        times[m] = seconds_per_call([&] { tracer.trace(u, modes[m], t, &error); }, m == 2 ? 5 : 50);
      std::printf("| %s%s%s | %.1f us | %.1f us | %.1f us |\n", c.name,
                  tracer.components().back() == 2 ? " (normal used)" : "",
                  law.instance->traces_motion()
                      ? (along ? ", along the motion" : ", sample-only step")
                      : "",
                  1e6 * times[0], 1e6 * times[1], 1e6 * times[2]);
    }
  return 0;
}
