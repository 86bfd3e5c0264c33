#include "frichb/conformance/contact_law_checks.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <thread>

#include "frichb/core/numerics/harmonics.hpp"
#include "frichb/core/plugin_host/periodic_trace.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/plugin_host/schema.hpp"
#include "frichb/plugin/sdk.hpp"

namespace frichb::conformance {

namespace {

using core::ContactLawInstance;
using core::ContactTrace;
using core::HarmonicLayout;
using core::JacobianMode;
using core::LoadedPlugin;
using core::ParamValues;
using core::PeriodicTracer;

std::string format(const char* pattern, double a, double b = 0.0) {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, pattern, a, b);
  return buffer;
}

struct Law {
  ParamValues values;
  std::unique_ptr<ContactLawInstance> instance;
};

Law make_law(const std::shared_ptr<const LoadedPlugin>& plugin, const YAML::Node& params) {
  Law law;
  law.values = core::validate_params(params, plugin->schema(), "params",
                                     core::YamlContext{"<conformance params>"});
  law.instance = std::make_unique<ContactLawInstance>(plugin, law.values);
  return law;
}

bool has_real(const LoadedPlugin& plugin, const char* name) {
  for (const auto& s : plugin.schema())
    if (std::string(s.name) == name && s.type == FRICHB_PARAM_REAL) return true;
  return false;
}

double real_param(const LoadedPlugin& plugin, const Law& law, const char* name) {
  return sdk::Params(plugin.schema().data(), plugin.schema().size(), law.values.data()).real(name);
}

// The law with one parameter overridden, or no law when its schema refuses the value.
std::optional<Law> make_law_with(const std::shared_ptr<const LoadedPlugin>& plugin,
                                 const YAML::Node& params, const char* key, double value);

YAML::Node with(const YAML::Node& base, const char* key, double value) {
  YAML::Node copy = YAML::Clone(base);
  copy[key] = value;
  return copy;
}

std::optional<Law> make_law_with(const std::shared_ptr<const LoadedPlugin>& plugin,
                                 const YAML::Node& params, const char* key, double value) {
  try {
    return make_law(plugin, with(params, key, value));
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// Random multiharmonic motion over the used components: harmonic n gets amplitude ~ a / n;
// the normal component moves less (a fifth) so that a preloaded contact mostly stays closed.
Eigen::VectorXd random_motion(const PeriodicTracer& tracer, double amplitude, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> dist(-1.0, 1.0);
  const auto& layout = tracer.layout();
  const int c = layout.coefficient_count();
  Eigen::VectorXd u(tracer.unknown_count());
  for (int a = 0; a < tracer.dimension(); ++a) {
    const double scale = tracer.components()[static_cast<std::size_t>(a)] == 2 ? 0.2 : 1.0;
    for (std::size_t k = 0; k < layout.harmonics().size(); ++k) {
      const int n = std::max(1, layout.harmonics()[k]);
      const double amp = scale * amplitude / n * (layout.harmonics()[k] == 0 ? 0.1 : 1.0);
      u(a * c + layout.cos_index(k)) = amp * dist(gen);
      if (layout.harmonics()[k] > 0) u(a * c + layout.sin_index(k)) = amp * dist(gen);
    }
  }
  return u;
}

struct Step {
  Eigen::Vector3d u_prev, u_now;
  Eigen::VectorXd state_prev;
};

// The steps of a traced period, as inputs for step-level checks.
std::vector<Step> steps_of(const PeriodicTracer& tracer, const ContactTrace& t,
                           const ContactLawInstance& law) {
  const int n = static_cast<int>(t.displacement.rows());
  const int s = law.traits().state_size;
  std::vector<Step> steps;
  for (int j = 0; j < n; ++j) {
    const int jp = (j + n - 1) % n;
    Step st;
    st.u_prev.setZero();
    st.u_now.setZero();
    for (int a = 0; a < tracer.dimension(); ++a) {
      st.u_now(tracer.components()[static_cast<std::size_t>(a)]) = t.displacement(j, a);
      st.u_prev(tracer.components()[static_cast<std::size_t>(a)]) = t.displacement(jp, a);
    }
    st.state_prev = s ? Eigen::VectorXd(t.state.row(jp).transpose()) : Eigen::VectorXd();
    steps.push_back(st);
  }
  return steps;
}

struct StepResult {
  Eigen::Vector3d force;
  Eigen::VectorXd state;
  // Tangents, column-major by input: [u_now (3) | u_prev (3) | state_prev (S)], rows
  // [force (3); state (S)].
  Eigen::MatrixXd tangent;
  bool ok = true;
};

StepResult evaluate(const ContactLawInstance& law, const Step& st, bool with_tangent) {
  const int s = law.traits().state_size;
  using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const int s1 = std::max(s, 1);
  RowMat fun = RowMat::Zero(3, 3), fup = RowMat::Zero(3, 3), fs = RowMat::Zero(3, s1),
         sun = RowMat::Zero(s1, 3), sup = RowMat::Zero(s1, 3), ss = RowMat::Zero(s1, s1);
  frichb_step_tangents tangents{fun.data(), fup.data(), fs.data(),
                                sun.data(), sup.data(), ss.data()};
  StepResult r;
  r.state.resize(s);
  std::string error;
  Eigen::VectorXd state_prev = st.state_prev;
  r.ok = law.step(state_prev.data(), st.u_prev.data(), st.u_now.data(), r.force.data(),
                  r.state.data(), with_tangent ? &tangents : nullptr, &error);
  if (with_tangent) {
    r.tangent = Eigen::MatrixXd::Zero(3 + s, 6 + s);
    r.tangent.block(0, 0, 3, 3) = fun;
    r.tangent.block(0, 3, 3, 3) = fup;
    r.tangent.block(0, 6, 3, s) = fs.leftCols(s);
    r.tangent.block(3, 0, s, 3) = sun.topRows(s);
    r.tangent.block(3, 3, s, 3) = sup.topRows(s);
    r.tangent.block(3, 6, s, s) = ss.topLeftCorner(s, s);
  }
  return r;
}

Eigen::VectorXd outputs(const StepResult& r) {
  Eigen::VectorXd v(3 + r.state.size());
  v << r.force, r.state;
  return v;
}

CheckResult tangent_check(const ContactLawInstance& law, const std::vector<Step>& steps,
                          double amplitude, double tolerance) {
  CheckResult c{"tangent_vs_central_differences", CheckStatus::kSkipped, ""};
  if (!law.traits().provides_tangent) {
    c.figure = "the law provides no tangents (the core differentiates it numerically)";
    return c;
  }
  const int s = law.traits().state_size;
  double max_error = 0, max_entry = 0;
  int checked = 0;
  for (const Step& st : steps) {
    const StepResult a = evaluate(law, st, true);
    const Eigen::VectorXd f0 = outputs(a);
    Eigen::MatrixXd central(3 + s, 6 + s);
    bool kink = false;
    for (int q = 0; q < 6 + s && !kink; ++q) {
      Step plus = st, minus = st;
      double& xp = q < 3 ? plus.u_now(q) : (q < 6 ? plus.u_prev(q - 3) : plus.state_prev(q - 6));
      double& xm = q < 3 ? minus.u_now(q) : (q < 6 ? minus.u_prev(q - 3) : minus.state_prev(q - 6));
      const double h = 1e-7 * std::max(amplitude, std::abs(xp));
      xp += h;
      xm -= h;
      const Eigen::VectorXd fp = outputs(evaluate(law, plus, false));
      const Eigen::VectorXd fm = outputs(evaluate(law, minus, false));
      const Eigen::VectorXd forward = (fp - f0) / h, backward = (f0 - fm) / h;
      central.col(q) = (fp - fm) / (2 * h);
      // One-sided differences that disagree mean a kink within h: not a place to compare.
      const double scale =
          std::max({forward.cwiseAbs().maxCoeff(), backward.cwiseAbs().maxCoeff(), 1e-300});
      if ((forward - backward).cwiseAbs().maxCoeff() > 1e-4 * scale) kink = true;
    }
    if (kink) continue;
    ++checked;
    max_error = std::max(max_error, (a.tangent - central).cwiseAbs().maxCoeff());
    max_entry = std::max(max_entry, central.cwiseAbs().maxCoeff());
  }
  const double relative = max_entry > 0 ? max_error / max_entry : max_error;
  c.figure = format("max relative error %.2e over %.0f smooth steps", relative, checked);
  const bool enough = checked >= static_cast<int>(steps.size()) / 4;
  if (!enough) c.figure += " (too few steps away from kinks)";
  c.status = relative <= tolerance && enough ? CheckStatus::kPassed : CheckStatus::kFailed;
  return c;
}

CheckResult value_only_check(const ContactLawInstance& law, const std::vector<Step>& steps) {
  CheckResult c{"value_only_equals_value_with_tangent", CheckStatus::kPassed, ""};
  double diff = 0;
  for (const Step& st : steps) {
    const StepResult a = evaluate(law, st, true), b = evaluate(law, st, false);
    diff = std::max(diff, (outputs(a) - outputs(b)).cwiseAbs().maxCoeff());
  }
  c.figure = format("max difference %.2e", diff);
  if (diff != 0.0) c.status = CheckStatus::kFailed;
  return c;
}

double tangential_norm(const ContactTrace& t, const PeriodicTracer& tracer, int j) {
  double sum = 0;
  for (int a = 0; a < tracer.dimension(); ++a)
    if (tracer.components()[static_cast<std::size_t>(a)] < 2) sum += t.force(j, a) * t.force(j, a);
  return std::sqrt(sum);
}

int normal_column(const PeriodicTracer& tracer) {
  const auto& comps = tracer.components();
  const auto it = std::find(comps.begin(), comps.end(), 2);
  return it == comps.end() ? -1 : static_cast<int>(it - comps.begin());
}

bool trace(PeriodicTracer& tracer, const Eigen::VectorXd& u, ContactTrace& t) {
  std::string error;
  return tracer.trace(u, JacobianMode::kNone, t, &error);
}

}  // namespace

int ContactLawReport::count(CheckStatus s) const {
  int n = 0;
  for (const auto& c : checks) n += c.status == s;
  return n;
}

const CheckResult* ContactLawReport::find(const std::string& name) const {
  for (const auto& c : checks)
    if (c.name == name) return &c;
  return nullptr;
}

ContactLawReport check_contact_law(const std::filesystem::path& plugin_file,
                                   const ContactLawOptions& options) {
  ContactLawReport report;
  report.file = plugin_file;
  auto fail = [&](const std::string& name, const std::string& why) {
    report.checks.push_back({name, CheckStatus::kFailed, why});
    return report;
  };
  std::shared_ptr<const LoadedPlugin> plugin;
  try {
    plugin = core::load_plugin_file(plugin_file);
  } catch (const std::exception& e) {
    return fail("loads_through_the_registry", e.what());
  }
  report.plugin_name = plugin->name();
  if (plugin->kind() != FRICHB_KIND_CONTACT_LAW)
    return fail("is_a_contact_law",
                "plugin kind is " + std::string(core::to_string(plugin->kind())));
  YAML::Node params;
  Law law;
  try {
    params = YAML::Load(options.params_yaml);
    law = make_law(plugin, params);
  } catch (const std::exception& e) {
    return fail("given_parameters_validate", e.what());
  }

  // schema manners: every finite bound of a top-level number is enforced by validation.
  {
    CheckResult c{"schema_refuses_out_of_range_values", CheckStatus::kPassed, ""};
    int tried = 0, refused = 0;
    for (const auto& spec : plugin->schema()) {
      if (spec.type != FRICHB_PARAM_REAL && spec.type != FRICHB_PARAM_INTEGER) continue;
      for (int side = 0; side < 2; ++side) {
        const double bound = side == 0 ? spec.min_value : spec.max_value;
        if (!std::isfinite(bound)) continue;
        const bool exclusive = side == 0 ? spec.min_exclusive : spec.max_exclusive;
        const double step = std::max(1.0, std::abs(bound));
        const double bad = exclusive ? bound : (side == 0 ? bound - step : bound + step);
        ++tried;
        try {
          core::validate_params(with(params, spec.name, bad), plugin->schema(), "params",
                                core::YamlContext{"<conformance>"});
        } catch (const core::SceneError& e) {
          if (std::string(e.what()).find(spec.name) != std::string::npos) ++refused;
        }
      }
    }
    c.figure = format("%.0f of %.0f out-of-range values refused naming the key", refused, tried);
    if (refused != tried) c.status = CheckStatus::kFailed;
    report.checks.push_back(c);
  }

  const ContactLawInstance& instance = *law.instance;
  const bool has_mu = has_real(*plugin, "mu"), has_kt = has_real(*plugin, "kt"),
             has_n0 = has_real(*plugin, "normal_load");
  double amplitude = options.amplitude;
  if (amplitude <= 0) {
    const double mu = has_mu ? real_param(*plugin, law, "mu") : 0;
    const double kt = has_kt ? real_param(*plugin, law, "kt") : 0;
    const double n0 = has_n0 ? real_param(*plugin, law, "normal_load") : 0;
    amplitude = (mu * n0 > 0 && kt > 0) ? 5 * mu * n0 / kt : 1e-3;
  }
  std::vector<int> harmonics;
  for (int h = 0; h <= options.max_harmonic; ++h) harmonics.push_back(h);
  const HarmonicLayout layout(harmonics, options.samples_per_period);
  PeriodicTracer tracer(instance, layout);
  const Eigen::VectorXd u = random_motion(tracer, amplitude, options.seed);
  ContactTrace base;
  {
    std::string error;
    if (!tracer.trace(u, JacobianMode::kNone, base, &error)) return fail("traces_a_period", error);
  }
  const int n = layout.samples(), d = tracer.dimension(), nc = normal_column(tracer);
  const double force_scale = std::max(base.force.cwiseAbs().maxCoeff(), 1e-300);
  const std::vector<Step> steps = steps_of(tracer, base, instance);

  report.checks.push_back(value_only_check(instance, steps));
  report.checks.push_back(tangent_check(instance, steps, amplitude, options.jacobian_tolerance));

  {  // separation
    CheckResult c{"separation_gives_zero_force_and_tangent", CheckStatus::kSkipped,
                  "the law does not use the normal direction"};
    if (instance.traits().uses_normal) {
      Step st;
      st.u_now = Eigen::Vector3d(amplitude, 0.5 * amplitude, -1e3 * amplitude);
      st.u_prev = Eigen::Vector3d(0.9 * amplitude, 0.4 * amplitude, -1e3 * amplitude);
      st.state_prev = Eigen::VectorXd::Zero(instance.traits().state_size);
      instance.initial_state(st.state_prev.data());
      const StepResult r = evaluate(instance, st, instance.traits().provides_tangent != 0);
      const double f = r.force.cwiseAbs().maxCoeff();
      const double t = r.tangent.size() ? r.tangent.topRows(3).cwiseAbs().maxCoeff() : 0.0;
      c.figure = format("|f| = %.2e, |df/d(u, state)| = %.2e at u_n = -1e3 amplitude", f, t);
      c.status = r.ok && f == 0.0 && t == 0.0 ? CheckStatus::kPassed : CheckStatus::kFailed;
    }
    report.checks.push_back(c);
  }
  {  // N >= 0
    CheckResult c{"normal_force_nonnegative", CheckStatus::kSkipped,
                  "the law does not use the normal direction"};
    if (nc >= 0) {
      const double lowest = base.force.col(nc).minCoeff();
      c.figure = format("min N = %.3e N", lowest);
      c.status = lowest >= 0 ? CheckStatus::kPassed : CheckStatus::kFailed;
    }
    report.checks.push_back(c);
  }
  {  // Coulomb bound
    CheckResult c{"coulomb_bound", CheckStatus::kSkipped, "no parameter `mu`"};
    if (has_mu && (nc >= 0 || has_n0)) {
      const double mu = real_param(*plugin, law, "mu");
      double worst = 0;  // largest |T| / (mu N) with tolerance
      bool ok = true;
      for (int j = 0; j < n; ++j) {
        const double normal = nc >= 0 ? base.force(j, nc) : real_param(*plugin, law, "normal_load");
        double t = tangential_norm(base, tracer, j);
        if (options.per_component_bound) {
          t = 0;
          for (int a = 0; a < d; ++a)
            if (tracer.components()[static_cast<std::size_t>(a)] < 2)
              t = std::max(t, std::abs(base.force(j, a)));
        }
        const double limit = mu * normal;
        if (t > limit * (1 + 1e-9) + 1e-12 * force_scale) ok = false;
        if (limit > 0) worst = std::max(worst, t / limit);
      }
      c.figure = format(options.per_component_bound ? "max |T_i| / (mu N) = %.6f (per component)"
                                                    : "max |T| / (mu N) = %.6f",
                        worst);
      c.status = ok ? CheckStatus::kPassed : CheckStatus::kFailed;
    } else if (has_mu) {
      c.figure = "constant normal load without a `normal_load` parameter";
    }
    report.checks.push_back(c);
  }
  {  // dissipation
    CheckResult c{"dissipation_nonnegative", CheckStatus::kPassed, ""};
    double energy = 0;
    for (int j = 0; j < n; ++j) {
      const int jn = (j + 1) % n;
      for (int a = 0; a < d; ++a)
        energy += 0.5 * (base.force(j, a) + base.force(jn, a)) *
                  (base.displacement(jn, a) - base.displacement(j, a));
    }
    c.figure = format("energy per cycle %.4e J", energy);
    if (energy < -1e-9 * force_scale * amplitude) c.status = CheckStatus::kFailed;
    report.checks.push_back(c);
  }
  {  // periodicity
    CheckResult c{"periodicity", base.periodic ? CheckStatus::kPassed : CheckStatus::kFailed,
                  format("state repeated after %.0f passes", base.passes)};
    if (!base.periodic) c.figure = base.diagnostic;
    report.checks.push_back(c);
  }
  {  // mu = 0
    CheckResult c{"zero_friction_gives_no_tangential_force", CheckStatus::kSkipped,
                  "no parameter `mu`"};
    if (has_mu) {
      const auto frictionless = make_law_with(plugin, params, "mu", 0.0);
      ContactTrace t;
      if (!frictionless) {
        c.figure = "the schema does not allow mu = 0";
      } else if (PeriodicTracer t0(*frictionless->instance, layout); trace(t0, u, t)) {
        double largest = 0;
        for (int j = 0; j < n; ++j) largest = std::max(largest, tangential_norm(t, tracer, j));
        c.figure = format("max |T| = %.2e N", largest);
        c.status = largest <= 1e-14 * force_scale ? CheckStatus::kPassed : CheckStatus::kFailed;
      } else {
        c.status = CheckStatus::kFailed;
        c.figure = "trace failed";
      }
    }
    report.checks.push_back(c);
  }
  {  // full stick
    CheckResult c{"full_stick_is_the_linear_spring", CheckStatus::kSkipped,
                  "needs parameters `kt` and `normal_load`"};
    if (has_kt && has_n0) {
      const auto stuck =
          make_law_with(plugin, params, "normal_load", 1e12 * std::max(1.0, force_scale));
      ContactTrace t;
      const double kt = real_param(*plugin, law, "kt");
      if (!stuck) {
        c.figure = "the schema does not allow a normal_load of 1e12 force scales";
      } else if (PeriodicTracer ts(*stuck->instance, layout); trace(ts, u, t)) {
        double err = 0;
        for (int j = 0; j < n; ++j)
          for (int a = 0; a < d; ++a)
            if (tracer.components()[static_cast<std::size_t>(a)] < 2)
              err = std::max(err, std::abs(t.force(j, a) - kt * t.displacement(j, a)));
        const double rel = err / (kt * amplitude);
        c.figure = format("max |T - kt u| / (kt amplitude) = %.2e", rel);
        c.status = rel <= 1e-9 ? CheckStatus::kPassed : CheckStatus::kFailed;
      } else {
        c.status = CheckStatus::kFailed;
        c.figure = "trace failed";
      }
    }
    report.checks.push_back(c);
  }
  {  // odd symmetry: negating the tangential motion negates the tangential force
    CheckResult c{"odd_symmetry", CheckStatus::kPassed, ""};
    Eigen::VectorXd mirrored = u;
    const int cc = layout.coefficient_count();
    for (int a = 0; a < d; ++a)
      if (tracer.components()[static_cast<std::size_t>(a)] < 2) mirrored.segment(a * cc, cc) *= -1;
    ContactTrace t;
    double err = 0;
    if (trace(tracer, mirrored, t)) {
      for (int a = 0; a < d; ++a) {
        const double sign = tracer.components()[static_cast<std::size_t>(a)] < 2 ? -1.0 : 1.0;
        err = std::max(err, (t.force.col(a) - sign * base.force.col(a)).cwiseAbs().maxCoeff());
      }
      c.figure = format("max deviation %.2e relative", err / force_scale);
      if (err > 1e-10 * force_scale) c.status = CheckStatus::kFailed;
    } else {
      c.status = CheckStatus::kFailed;
      c.figure = "trace failed";
    }
    report.checks.push_back(c);
  }
  {  // frame invariance of 2D tangential laws
    CheckResult c{"frame_invariance", CheckStatus::kSkipped, "1D tangential law"};
    if (instance.traits().tangential_dimensions == 2) {
      const double angle = 0.7, co = std::cos(angle), si = std::sin(angle);
      const int cc = layout.coefficient_count();
      Eigen::VectorXd rotated = u;
      rotated.segment(0, cc) = co * u.segment(0, cc) - si * u.segment(cc, cc);
      rotated.segment(cc, cc) = si * u.segment(0, cc) + co * u.segment(cc, cc);
      ContactTrace t;
      if (trace(tracer, rotated, t)) {
        double err = 0;
        for (int j = 0; j < n; ++j) {
          const double t1 = co * base.force(j, 0) - si * base.force(j, 1);
          const double t2 = si * base.force(j, 0) + co * base.force(j, 1);
          err = std::max({err, std::abs(t.force(j, 0) - t1), std::abs(t.force(j, 1) - t2)});
        }
        c.figure = format("rotation by 0.7 rad: max deviation %.2e relative", err / force_scale);
        c.status = err <= 1e-10 * force_scale ? CheckStatus::kPassed : CheckStatus::kFailed;
        if (options.per_component_bound) {
          c.status = CheckStatus::kSkipped;
          c.figure += " (not expected of a per-component law)";
        }
      } else {
        c.status = CheckStatus::kFailed;
        c.figure = "trace failed";
      }
    }
    report.checks.push_back(c);
  }
  {  // determinism across repeats and threads
    CheckResult c{"deterministic_across_repeats_and_threads", CheckStatus::kPassed, ""};
    ContactTrace again;
    bool same = trace(tracer, u, again) && again.force == base.force;
    std::vector<ContactTrace> results(2);
    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < results.size(); ++i)
      threads.emplace_back([&, i] {
        PeriodicTracer own(instance, layout);
        trace(own, u, results[i]);
      });
    for (auto& th : threads) th.join();
    for (const auto& r : results) same = same && r.force == base.force;
    c.figure = "1 repeat and 2 threads on one instance, bitwise";
    if (!same) c.status = CheckStatus::kFailed;
    report.checks.push_back(c);
  }
  return report;
}

std::string format_report(const ContactLawReport& report) {
  std::string out = "conformance of '" + report.plugin_name + "' (" + report.file.string() + ")\n";
  for (const auto& c : report.checks) {
    const char* tag = c.status == CheckStatus::kPassed   ? "PASS"
                      : c.status == CheckStatus::kFailed ? "FAIL"
                                                         : "SKIP";
    out += std::string("  ") + tag + "  " + c.name + "  " + c.figure + "\n";
  }
  out += std::to_string(report.count(CheckStatus::kPassed)) + " passed, " +
         std::to_string(report.count(CheckStatus::kFailed)) + " failed, " +
         std::to_string(report.count(CheckStatus::kSkipped)) + " skipped\n";
  return out;
}

}  // namespace frichb::conformance
