#include "frichb/core/commands/timesim.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/model/mistuned_disk.hpp"
#include "frichb/core/scene/plugin_checks.hpp"
#include "frichb/core/support/exit_codes.hpp"

namespace frichb::core {

namespace fs = std::filesystem;

namespace {

// A response node over the last integrated period (`period`: [step, kept DOF], sample s at
// (s + 1) T / steps): its samples, amplitude, half peak-to-peak and harmonic amplitudes.
TimesimNodeResult node_over_period(const Scene& scene, const HarmonicBalanceModel& model,
                                   const std::string& name, const Eigen::MatrixXd& period,
                                   const std::vector<int>& harmonics) {
  const auto* node = scene.structure.find(name);
  if (!node)
    throw SceneError(scene.file.string(), 0, 0, "output.response",
                     "'" + name + "' is not a key of structure.dofs");
  const auto n_steps = static_cast<int>(period.rows());
  TimesimNodeResult r;
  r.node = name;
  Eigen::VectorXd norm2 = Eigen::VectorXd::Zero(n_steps);
  r.harmonic_amplitudes_m.assign(harmonics.size(), 0.0);
  for (std::size_t d = 0; d < node->dofs.size(); ++d) {
    const Eigen::Index col = model.kept_index(node->dofs[d]);
    const auto x = period.col(col);
    r.samples_m.emplace_back(x.begin(), x.end());
    norm2 += x.cwiseAbs2();
    r.half_peak_to_peak_m = std::max(r.half_peak_to_peak_m, 0.5 * (x.maxCoeff() - x.minCoeff()));
    for (std::size_t k = 0; k < harmonics.size(); ++k) {
      std::complex<double> sum = 0;
      for (int s = 0; s < n_steps; ++s)
        sum += x(s) * std::polar(1.0, -2 * std::numbers::pi * harmonics[k] * (s + 1) / n_steps);
      const double amp = std::abs(sum) / n_steps * (harmonics[k] == 0 ? 1.0 : 2.0);
      r.harmonic_amplitudes_m[k] = std::hypot(r.harmonic_amplitudes_m[k], amp);
    }
  }
  r.amplitude_m = std::sqrt(norm2.maxCoeff());
  return r;
}

}  // namespace

TimesimResult simulate_in_time(const Scene& scene, const TimesimOptions& options) {
  const auto started = std::chrono::steady_clock::now();
  const std::string file = scene.file.string();
  if (scene.cyclic.enabled())
    throw SceneError(file, 0, 0, "cyclic",
                     "timesim integrates one structure in time; a cyclic scene is not supported");
  if (!(std::isfinite(options.frequency_hz) && options.frequency_hz > 0))
    throw std::invalid_argument("timesim: frequency_hz must be finite and > 0, not " +
                                std::to_string(options.frequency_hz));
  if (options.steps_per_period < 1 || options.max_periods < 1)
    throw std::invalid_argument("timesim: steps_per_period and max_periods must be >= 1");
  if (!scene.structure.plugin)
    throw std::invalid_argument("timesim: the scene's plugins are not bound (bind_plugins)");
  for (const auto& c : scene.contacts)
    if (!c.plugin)
      throw std::invalid_argument("timesim: the scene's plugins are not bound (bind_plugins)");

  const auto instance = instantiate_structure(scene);
  StructureModel& structure = *instance;
  check_scene_against_plugins(scene, structure);
  const HarmonicBalanceModel model(scene, structure);
  const auto& basis = model.structure().basis(0);
  if (basis.rows.imag().cwiseAbs().maxCoeff() > 0)
    throw std::runtime_error("the provider's modes are complex: not a plain structure");
  const Eigen::MatrixXd phi = basis.rows.real();  // kept x modes
  const Eigen::MatrixXd& damping = basis.damping;
  const Eigen::VectorXd stiffness = basis.frequencies.array().square();
  const Eigen::MatrixXd gather = Eigen::MatrixXcd(model.gather(0)).real();  // components x kept
  const auto& harmonics = model.layout().harmonics();
  const double w = 2 * std::numbers::pi * options.frequency_hz;
  const int n_steps = options.steps_per_period;
  const double dt = 2 * std::numbers::pi / w / n_steps;

  // Contact states, one law step per time step.
  struct Contact {
    const ContactLawInstance* law;
    std::vector<int> components;
    Eigen::Vector3d reference;
    int offset;
    Eigen::VectorXd state, next;
    Eigen::Vector3d u_prev = Eigen::Vector3d::Zero();
  };
  std::vector<Contact> contacts;
  for (const auto& c : model.contacts()) {
    Contact k{c.law.get(), c.tracer->components(), c.tracer->reference_force(), c.offset, {}, {}};
    k.state.resize(c.law->traits().state_size);
    k.next.resize(k.state.size());
    c.law->initial_state(k.state.data());
    contacts.push_back(std::move(k));
  }
  const Eigen::Index n_comp = gather.rows();
  auto contact_forces = [&](const Eigen::VectorXd& x, Eigen::VectorXd& f) {
    const Eigen::VectorXd u = gather * x;
    f.setZero(n_comp);
    std::string error;
    for (auto& c : contacts) {
      Eigen::Vector3d now = Eigen::Vector3d::Zero(), force;
      for (std::size_t a = 0; a < c.components.size(); ++a)
        now(c.components[a]) = u(c.offset + static_cast<Eigen::Index>(a));
      if (!c.law->step(c.state.data(), c.u_prev.data(), now.data(), force.data(), c.next.data(),
                       nullptr, &error))
        throw std::runtime_error(error);
      c.state.swap(c.next);
      c.u_prev = now;
      for (std::size_t a = 0; a < c.components.size(); ++a)
        f(c.offset + static_cast<Eigen::Index>(a)) =
            force(c.components[a]) - c.reference(c.components[a]);
    }
  };
  auto external = [&](double t) {
    Eigen::VectorXd f = Eigen::VectorXd::Zero(phi.rows());
    for (std::size_t k = 0; k < harmonics.size(); ++k)
      f += (model.excitation(k) * std::polar(1.0, harmonics[k] * w * t)).real();
    return f;
  };
  const Eigen::Index m = phi.cols();
  Eigen::VectorXd q = Eigen::VectorXd::Zero(m), qd = q, fc;
  double t = 0;
  contact_forces(phi * q, fc);
  auto acceleration = [&](const Eigen::VectorXd& qq, const Eigen::VectorXd& vv, double time) {
    return Eigen::VectorXd(phi.transpose() * (external(time) - gather.transpose() * fc) -
                           damping * vv - stiffness.cwiseProduct(qq));
  };
  Eigen::VectorXd a = acceleration(q, qd, t);
  Eigen::MatrixXd period(n_steps, phi.rows()), last(n_steps, phi.rows());
  TimesimResult result;
  int settled = 0;
  while (result.periods < options.max_periods && !result.periodic) {
    if (options.stop.stop_requested()) {
      result.scene_file = scene.file;
      result.options = options;
      result.outcome = {
          options.stop.exit_code(),
          "interrupted",
          options.stop.reason() + " after " + std::to_string(result.periods) + " periods",
          {}};
      return result;
    }
    for (int s = 0; s < n_steps; ++s) {
      q += dt * qd + 0.5 * dt * dt * a;
      t += dt;
      contact_forces(phi * q, fc);
      const Eigen::VectorXd a_next = acceleration(q, qd + dt * a, t);
      qd += 0.5 * dt * (a + a_next);
      a = a_next;
      period.row(s) = (phi * q).transpose();
    }
    ++result.periods;
    if (!period.allFinite()) throw std::runtime_error("the integration diverged (NaN or Inf)");
    const double change = (period - last).cwiseAbs().maxCoeff();
    const double scale = std::max(period.cwiseAbs().maxCoeff(), 1e-300);
    settled = change <= 1e-8 * scale ? settled + 1 : 0;
    result.periodic = settled >= 3;
    last = period;
  }

  // Post-processing of the last period at the response nodes.
  result.harmonics = harmonics;
  result.time_s.resize(static_cast<std::size_t>(n_steps));
  for (int s = 0; s < n_steps; ++s) result.time_s[static_cast<std::size_t>(s)] = (s + 1) * dt;
  for (const auto& name : scene.output.response)
    result.nodes.push_back(node_over_period(scene, model, name, period, harmonics));
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  result.scene_file = scene.file;
  result.options = options;
  if (!result.periodic)
    result.outcome = {kExitIncomplete,
                      "not_periodic",
                      "the response did not repeat within " + std::to_string(options.max_periods) +
                          " periods (max_periods)",
                      {}};
  return result;
}

TimesimResult integrate_scene(const TimesimRequest& request) {
  const BoundScene bound = load_bound_scene(request.scene);
  TimesimResult result = simulate_in_time(bound.scene, request.integration);
  if (result.outcome.status >= 128) return result;  // stopped: the adapter says so
  spdlog::info("{}: {} periods at {} Hz ({})", result.scene_file.string(), result.periods,
               request.integration.frequency_hz, result.periodic ? "periodic" : "NOT periodic yet");
  return result;
}

}  // namespace frichb::core
