#include "frichb/conformance/contact_law_checks.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
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

// The law under test: its plugin, the given parameters and an instance made from them.
struct Subject {
  std::shared_ptr<const LoadedPlugin> plugin;
  YAML::Node params;
  Law law;
  bool has_mu = false, has_kt = false, has_n0 = false;
  double real(const char* name) const { return real_param(*plugin, law, name); }
  const ContactLawInstance& instance() const { return *law.instance; }
};

// Loads the plugin and makes the law; on failure, the report gets the failed check saying
// why (loads_through_the_registry, is_a_contact_law or given_parameters_validate).
std::optional<Subject> load_subject(const std::filesystem::path& plugin_file,
                                    const ContactLawOptions& options, ContactLawReport& report) {
  auto fail = [&](const std::string& name, const std::string& why) {
    report.checks.push_back({name, CheckStatus::kFailed, why});
    return std::nullopt;
  };
  Subject subject;
  try {
    subject.plugin = core::load_plugin_file(plugin_file);
  } catch (const std::exception& e) {
    return fail("loads_through_the_registry", e.what());
  }
  const LoadedPlugin& plugin = *subject.plugin;
  report.plugin_name = plugin.name();
  if (plugin.kind() != FRICHB_KIND_CONTACT_LAW)
    return fail("is_a_contact_law",
                "plugin kind is " + std::string(core::to_string(plugin.kind())));
  try {
    subject.params = YAML::Load(options.params_yaml);
    subject.law = make_law(subject.plugin, subject.params);
  } catch (const std::exception& e) {
    return fail("given_parameters_validate", e.what());
  }
  subject.has_mu = has_real(plugin, "mu");
  subject.has_kt = has_real(plugin, "kt");
  subject.has_n0 = has_real(plugin, "normal_load");
  return subject;
}

// Schema manners: every finite bound of a top-level number is enforced by validation.
CheckResult schema_check(const Subject& subject) {
  CheckResult c{"schema_refuses_out_of_range_values", CheckStatus::kPassed, ""};
  int tried = 0, refused = 0;
  for (const auto& spec : subject.plugin->schema()) {
    if (spec.type != FRICHB_PARAM_REAL && spec.type != FRICHB_PARAM_INTEGER) continue;
    for (int side = 0; side < 2; ++side) {
      const double bound = side == 0 ? spec.min_value : spec.max_value;
      if (!std::isfinite(bound)) continue;
      const bool exclusive = side == 0 ? spec.min_exclusive : spec.max_exclusive;
      const double step = std::max(1.0, std::abs(bound));
      const double bad = exclusive ? bound : (side == 0 ? bound - step : bound + step);
      ++tried;
      try {
        core::validate_params(with(subject.params, spec.name, bad), subject.plugin->schema(),
                              "params", core::YamlContext{"<conformance>"});
      } catch (const core::SceneError& e) {
        if (std::string(e.what()).find(spec.name) != std::string::npos) ++refused;
      }
    }
  }
  c.figure = format("%.0f of %.0f out-of-range values refused naming the key", refused, tried);
  if (refused != tried) c.status = CheckStatus::kFailed;
  return c;
}

// The amplitude of the test motion: the option, else 5 mu N / kt (deep slip), else 1e-3.
double test_amplitude(const Subject& subject, const ContactLawOptions& options) {
  if (options.amplitude <= 0) {
    const double mu = subject.has_mu ? subject.real("mu") : 0;
    const double kt = subject.has_kt ? subject.real("kt") : 0;
    const double n0 = subject.has_n0 ? subject.real("normal_load") : 0;
    return (mu * n0 > 0 && kt > 0) ? 5 * mu * n0 / kt : 1e-3;
  }
  return options.amplitude;
}

HarmonicLayout test_layout(const ContactLawOptions& options) {
  std::vector<int> harmonics;
  for (int h = 0; h <= options.max_harmonic; ++h) harmonics.push_back(h);
  return {harmonics, options.samples_per_period};
}

// The period the physics checks look at: a random motion at the test amplitude and the
// law's trace over it (`base`), with the figures the checks share.
struct Period {
  Period(const Subject& subject, const ContactLawOptions& options)
      : amplitude(test_amplitude(subject, options)),
        layout(test_layout(options)),
        tracer(subject.instance(), layout),
        u(random_motion(tracer, amplitude, options.seed)) {}

  double amplitude;
  HarmonicLayout layout;
  PeriodicTracer tracer;
  Eigen::VectorXd u;
  ContactTrace base;
  int n = 0, d = 0, nc = -1;  // samples, used components, column of the normal (-1: none)
  double force_scale = 0;     // the largest force of `base`
  std::vector<Step> steps;    // the steps of `base`
  bool tangential(int a) const { return tracer.components()[static_cast<std::size_t>(a)] < 2; }
};

// Traces the period; when the law fails, the report gets a failed traces_a_period.
std::unique_ptr<Period> trace_period(const Subject& subject, const ContactLawOptions& options,
                                     ContactLawReport& report) {
  auto p = std::make_unique<Period>(subject, options);
  std::string error;
  if (!p->tracer.trace(p->u, JacobianMode::kNone, p->base, &error)) {
    report.checks.push_back({"traces_a_period", CheckStatus::kFailed, error});
    return nullptr;
  }
  p->n = p->layout.samples();
  p->d = p->tracer.dimension();
  p->nc = normal_column(p->tracer);
  p->force_scale = std::max(p->base.force.cwiseAbs().maxCoeff(), 1e-300);
  p->steps = steps_of(p->tracer, p->base, subject.instance());
  return p;
}

CheckResult separation_check(const ContactLawInstance& instance, double amplitude) {
  CheckResult c{"separation_gives_zero_force_and_tangent", CheckStatus::kSkipped,
                "the law does not use the normal direction"};
  if (!instance.traits().uses_normal) return c;
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
  return c;
}

CheckResult normal_force_check(const Period& p) {
  CheckResult c{"normal_force_nonnegative", CheckStatus::kSkipped,
                "the law does not use the normal direction"};
  if (p.nc < 0) return c;
  const double lowest = p.base.force.col(p.nc).minCoeff();
  c.figure = format("min N = %.3e N", lowest);
  c.status = lowest >= 0 ? CheckStatus::kPassed : CheckStatus::kFailed;
  return c;
}

// |T| <= mu N on every sample (|T_i| <= mu N with `per_component`), N from the normal force
// or, for a constant normal load, from `normal_load`.
CheckResult coulomb_check(const Subject& subject, const Period& p, bool per_component) {
  CheckResult c{"coulomb_bound", CheckStatus::kSkipped, "no parameter `mu`"};
  if (!subject.has_mu) return c;
  if (p.nc < 0 && !subject.has_n0) {
    c.figure = "constant normal load without a `normal_load` parameter";
    return c;
  }
  const double mu = subject.real("mu");
  double worst = 0;  // largest |T| / (mu N) with tolerance
  bool ok = true;
  for (int j = 0; j < p.n; ++j) {
    const double normal = p.nc >= 0 ? p.base.force(j, p.nc) : subject.real("normal_load");
    double t = tangential_norm(p.base, p.tracer, j);
    if (per_component) {
      t = 0;
      for (int a = 0; a < p.d; ++a)
        if (p.tangential(a)) t = std::max(t, std::abs(p.base.force(j, a)));
    }
    const double limit = mu * normal;
    if (t > limit * (1 + 1e-9) + 1e-12 * p.force_scale) ok = false;
    if (limit > 0) worst = std::max(worst, t / limit);
  }
  c.figure = format(
      per_component ? "max |T_i| / (mu N) = %.6f (per component)" : "max |T| / (mu N) = %.6f",
      worst);
  c.status = ok ? CheckStatus::kPassed : CheckStatus::kFailed;
  return c;
}

CheckResult dissipation_check(const Period& p) {
  CheckResult c{"dissipation_nonnegative", CheckStatus::kPassed, ""};
  const double energy = p.base.energy_per_cycle;
  c.figure = format("energy per cycle %.4e J", energy);
  if (energy < -1e-9 * p.force_scale * p.amplitude) c.status = CheckStatus::kFailed;
  return c;
}

CheckResult periodicity_check(const Period& p) {
  CheckResult c{"periodicity", p.base.periodic ? CheckStatus::kPassed : CheckStatus::kFailed,
                format("state repeated after %.0f passes", p.base.passes)};
  if (!p.base.periodic) c.figure = p.base.diagnostic;
  return c;
}

CheckResult zero_friction_check(const Subject& subject, const Period& p) {
  CheckResult c{"zero_friction_gives_no_tangential_force", CheckStatus::kSkipped,
                "no parameter `mu`"};
  if (!subject.has_mu) return c;
  const auto frictionless = make_law_with(subject.plugin, subject.params, "mu", 0.0);
  ContactTrace t;
  if (!frictionless) {
    c.figure = "the schema does not allow mu = 0";
  } else if (PeriodicTracer t0(*frictionless->instance, p.layout); trace(t0, p.u, t)) {
    double largest = 0;
    for (int j = 0; j < p.n; ++j) largest = std::max(largest, tangential_norm(t, p.tracer, j));
    c.figure = format("max |T| = %.2e N", largest);
    c.status = largest <= 1e-14 * p.force_scale ? CheckStatus::kPassed : CheckStatus::kFailed;
  } else {
    c.status = CheckStatus::kFailed;
    c.figure = "trace failed";
  }
  return c;
}

// A normal load of 1e12 force scales keeps the contact stuck: T = kt u on every sample.
CheckResult full_stick_check(const Subject& subject, const Period& p) {
  CheckResult c{"full_stick_is_the_linear_spring", CheckStatus::kSkipped,
                "needs parameters `kt` and `normal_load`"};
  if (!subject.has_kt || !subject.has_n0) return c;
  const auto stuck = make_law_with(subject.plugin, subject.params, "normal_load",
                                   1e12 * std::max(1.0, p.force_scale));
  ContactTrace t;
  const double kt = subject.real("kt");
  if (!stuck) {
    c.figure = "the schema does not allow a normal_load of 1e12 force scales";
  } else if (PeriodicTracer ts(*stuck->instance, p.layout); trace(ts, p.u, t)) {
    double err = 0;
    for (int j = 0; j < p.n; ++j)
      for (int a = 0; a < p.d; ++a)
        if (p.tangential(a))
          err = std::max(err, std::abs(t.force(j, a) - kt * t.displacement(j, a)));
    const double rel = err / (kt * p.amplitude);
    c.figure = format("max |T - kt u| / (kt amplitude) = %.2e", rel);
    c.status = rel <= 1e-9 ? CheckStatus::kPassed : CheckStatus::kFailed;
  } else {
    c.status = CheckStatus::kFailed;
    c.figure = "trace failed";
  }
  return c;
}

// Negating the tangential motion negates the tangential force.
CheckResult odd_symmetry_check(Period& p) {
  CheckResult c{"odd_symmetry", CheckStatus::kPassed, ""};
  Eigen::VectorXd mirrored = p.u;
  const int cc = p.layout.coefficient_count();
  for (int a = 0; a < p.d; ++a)
    if (p.tangential(a)) mirrored.segment(a * cc, cc) *= -1;
  ContactTrace t;
  double err = 0;
  if (trace(p.tracer, mirrored, t)) {
    for (int a = 0; a < p.d; ++a) {
      const double sign = p.tangential(a) ? -1.0 : 1.0;
      err = std::max(err, (t.force.col(a) - sign * p.base.force.col(a)).cwiseAbs().maxCoeff());
    }
    c.figure = format("max deviation %.2e relative", err / p.force_scale);
    if (err > 1e-10 * p.force_scale) c.status = CheckStatus::kFailed;
  } else {
    c.status = CheckStatus::kFailed;
    c.figure = "trace failed";
  }
  return c;
}

// Rotating the tangential motion of a 2D tangential law rotates its tangential force.
CheckResult frame_invariance_check(const ContactLawInstance& instance, Period& p,
                                   bool per_component) {
  CheckResult c{"frame_invariance", CheckStatus::kSkipped, "1D tangential law"};
  if (instance.traits().tangential_dimensions != 2) return c;
  const double angle = 0.7, co = std::cos(angle), si = std::sin(angle);
  const int cc = p.layout.coefficient_count();
  Eigen::VectorXd rotated = p.u;
  rotated.segment(0, cc) = co * p.u.segment(0, cc) - si * p.u.segment(cc, cc);
  rotated.segment(cc, cc) = si * p.u.segment(0, cc) + co * p.u.segment(cc, cc);
  ContactTrace t;
  if (!trace(p.tracer, rotated, t)) {
    c.status = CheckStatus::kFailed;
    c.figure = "trace failed";
    return c;
  }
  double err = 0;
  for (int j = 0; j < p.n; ++j) {
    const double t1 = co * p.base.force(j, 0) - si * p.base.force(j, 1);
    const double t2 = si * p.base.force(j, 0) + co * p.base.force(j, 1);
    err = std::max({err, std::abs(t.force(j, 0) - t1), std::abs(t.force(j, 1) - t2)});
  }
  c.figure = format("rotation by 0.7 rad: max deviation %.2e relative", err / p.force_scale);
  c.status = err <= 1e-10 * p.force_scale ? CheckStatus::kPassed : CheckStatus::kFailed;
  if (per_component) {
    c.status = CheckStatus::kSkipped;
    c.figure += " (not expected of a per-component law)";
  }
  return c;
}

// The same forces, bitwise, from a repeated trace and from two threads on one instance.
CheckResult determinism_check(const ContactLawInstance& instance, Period& p) {
  CheckResult c{"deterministic_across_repeats_and_threads", CheckStatus::kPassed, ""};
  ContactTrace again;
  bool same = trace(p.tracer, p.u, again) && again.force == p.base.force;
  std::vector<ContactTrace> results(2);
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < results.size(); ++i)
    threads.emplace_back([&, i] {
      PeriodicTracer own(instance, p.layout);
      trace(own, p.u, results[i]);
    });
  for (auto& th : threads) th.join();
  for (const auto& r : results) same = same && r.force == p.base.force;
  c.figure = "1 repeat and 2 threads on one instance, bitwise";
  if (!same) c.status = CheckStatus::kFailed;
  return c;
}

// The force harmonics of the test motion converge at the declared order in the sample
// spacing: errors at N/4, N/2 and N samples against 8 N, and their fitted slope.
CheckResult order_check(const ContactLawInstance& instance, const Period& p,
                        const ContactLawOptions& options) {
  CheckResult c{"force_harmonics_converge_at_declared_order", CheckStatus::kSkipped,
                "no declared order (--order)"};
  if (!(options.order > 0)) return c;
  auto coefficients = [&](int samples, Eigen::VectorXd& out) {
    const HarmonicLayout layout(p.layout.harmonics(), samples);
    PeriodicTracer tracer(instance, layout);
    ContactTrace t;
    if (!trace(tracer, p.u, t)) return false;
    out = t.force_coefficients;
    return true;
  };
  const int n = p.layout.samples();
  Eigen::VectorXd reference, at;
  if (!coefficients(8 * n, reference)) {
    c.status = CheckStatus::kFailed;
    c.figure = "the reference trace failed";
    return c;
  }
  const double scale = std::max(reference.cwiseAbs().maxCoeff(), 1e-300);
  std::vector<double> samples, errors;
  std::string figure = "errors";
  for (int m : {n / 4, n / 2, n}) {
    if (!coefficients(m, at)) {
      c.status = CheckStatus::kFailed;
      c.figure = "the trace on " + std::to_string(m) + " samples failed";
      return c;
    }
    const double e = (at - reference).cwiseAbs().maxCoeff() / scale;
    figure += format(" %.2e", e);
    // Errors within rounding of the reference say nothing of the order.
    if (e > 1e-12) {
      samples.push_back(m);
      errors.push_back(e);
    }
  }
  if (samples.size() < 2) {
    c.status = CheckStatus::kPassed;
    c.figure = figure + ": at rounding already";
    return c;
  }
  // Least-squares slope of log(error) against log(samples).
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    mx += std::log(samples[i]) / static_cast<double>(samples.size());
    my += std::log(errors[i]) / static_cast<double>(samples.size());
  }
  double sxy = 0, sxx = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    sxy += (std::log(samples[i]) - mx) * (std::log(errors[i]) - my);
    sxx += (std::log(samples[i]) - mx) * (std::log(samples[i]) - mx);
  }
  const double order = -sxy / sxx;
  c.figure = figure + format(" at N/4, N/2, N: order %.2f (declared %.2f)", order, options.order);
  c.status = order >= options.order - 0.25 ? CheckStatus::kPassed : CheckStatus::kFailed;
  return c;
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
  const std::optional<Subject> subject = load_subject(plugin_file, options, report);
  if (!subject) return report;
  report.checks.push_back(schema_check(*subject));
  const std::unique_ptr<Period> period = trace_period(*subject, options, report);
  if (!period) return report;
  Period& p = *period;
  const ContactLawInstance& instance = subject->instance();
  const bool per_component = options.per_component_bound;
  report.checks.push_back(value_only_check(instance, p.steps));
  report.checks.push_back(
      tangent_check(instance, p.steps, p.amplitude, options.jacobian_tolerance));
  report.checks.push_back(separation_check(instance, p.amplitude));
  report.checks.push_back(normal_force_check(p));
  report.checks.push_back(coulomb_check(*subject, p, per_component));
  report.checks.push_back(dissipation_check(p));
  report.checks.push_back(periodicity_check(p));
  report.checks.push_back(zero_friction_check(*subject, p));
  report.checks.push_back(full_stick_check(*subject, p));
  report.checks.push_back(odd_symmetry_check(p));
  report.checks.push_back(frame_invariance_check(instance, p, per_component));
  report.checks.push_back(determinism_check(instance, p));
  report.checks.push_back(order_check(instance, p, options));
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
