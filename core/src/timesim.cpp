#include "frichb/core/timesim.hpp"

#include <spdlog/spdlog.h>

#include <cmath>
#include <numbers>

#include "frichb/core/harmonic_balance.hpp"
#include "frichb/core/output.hpp"
#include "frichb/core/run.hpp"
#include "frichb/core/scene.hpp"

namespace frichb::core {

namespace fs = std::filesystem;

int run_timesim(const TimesimRequest& request) {
  const std::string file = request.scene_file.string();
  Scene scene;
  std::unique_ptr<Registry> registry;
  if (!load_bound_scene(request.scene_file, scene, registry)) return kExitInvalidInput;
  if (scene.cyclic.enabled()) {
    spdlog::error(
        "{}: cyclic: timesim integrates one structure in time; a cyclic scene is not "
        "supported",
        file);
    return kExitInvalidInput;
  }
  try {
    StructureInstance structure(scene.structure.plugin, scene.structure.values);
    const HarmonicBalanceModel model(scene, structure);
    const auto& basis = model.structure().basis(0);
    if (basis.rows.imag().cwiseAbs().maxCoeff() > 0)
      throw std::runtime_error("the provider's modes are complex: not a plain structure");
    const Eigen::MatrixXd phi = basis.rows.real();  // kept x modes
    const Eigen::MatrixXd& damping = basis.damping;
    const Eigen::VectorXd stiffness = basis.frequencies.array().square();
    const Eigen::MatrixXd gather = model.gather(0).real();  // components x kept
    const auto& harmonics = model.layout().harmonics();
    const double w = 2 * std::numbers::pi * request.frequency_hz;
    const int n_steps = request.steps_per_period;
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
    int periods = 0, settled = 0;
    bool periodic = false;
    while (periods < request.max_periods && !periodic) {
      for (int s = 0; s < n_steps; ++s) {
        q += dt * qd + 0.5 * dt * dt * a;
        t += dt;
        contact_forces(phi * q, fc);
        const Eigen::VectorXd a_next = acceleration(q, qd + dt * a, t);
        qd += 0.5 * dt * (a + a_next);
        a = a_next;
        period.row(s) = (phi * q).transpose();
      }
      ++periods;
      if (!period.allFinite()) throw std::runtime_error("the integration diverged (NaN or Inf)");
      const double change = (period - last).cwiseAbs().maxCoeff();
      const double scale = std::max(period.cwiseAbs().maxCoeff(), 1e-300);
      settled = change <= 1e-8 * scale ? settled + 1 : 0;
      periodic = settled >= 3;
      last = period;
    }

    // Post-processing of the last period at the response nodes.
    fs::path out_dir = request.output_directory;
    if (out_dir.empty())
      out_dir = fs::path("out") / (request.scene_file.stem().string() + "-timesim");
    StagedOutput out(out_dir, {"timesim.csv", "summary.json"});
    std::vector<std::string> header = {"time_s"};
    nlohmann::json nodes = nlohmann::json::object();
    std::vector<Eigen::Index> columns;
    for (const auto& name : scene.output.response) {
      const auto* node = scene.structure.find(name);
      Eigen::VectorXd norm2 = Eigen::VectorXd::Zero(n_steps);
      double half_p2p = 0;
      std::vector<double> harmonic_amplitude(harmonics.size(), 0.0);
      for (std::size_t d = 0; d < node->dofs.size(); ++d) {
        const Eigen::Index col = model.kept_index(node->dofs[d]);
        columns.push_back(col);
        header.push_back(name + (node->dofs.size() > 1 ? "_" + std::to_string(d) : "") + "_m");
        norm2 += period.col(col).cwiseAbs2();
        half_p2p =
            std::max(half_p2p, 0.5 * (period.col(col).maxCoeff() - period.col(col).minCoeff()));
        for (std::size_t k = 0; k < harmonics.size(); ++k) {
          std::complex<double> sum = 0;
          for (int s = 0; s < n_steps; ++s)
            sum += period(s, col) *
                   std::polar(1.0, -2 * std::numbers::pi * harmonics[k] * (s + 1) / n_steps);
          const double amp = std::abs(sum) / n_steps * (harmonics[k] == 0 ? 1.0 : 2.0);
          harmonic_amplitude[k] = std::hypot(harmonic_amplitude[k], amp);
        }
      }
      nlohmann::json h = nlohmann::json::object();
      for (std::size_t k = 0; k < harmonics.size(); ++k)
        h[std::to_string(harmonics[k])] = harmonic_amplitude[k];
      nodes[name] = {{"amplitude_m", std::sqrt(norm2.maxCoeff())},
                     {"half_peak_to_peak_m", half_p2p},
                     {"harmonic_amplitudes_m", h}};
    }
    std::vector<std::vector<double>> rows;
    for (int s = 0; s < n_steps; ++s) {
      std::vector<double> row = {(s + 1) * dt};
      for (Eigen::Index col : columns) row.push_back(period(s, col));
      rows.push_back(std::move(row));
    }
    write_csv(out.path("timesim.csv"), header, rows);
    write_json(out.path("summary.json"), {{"frichb_version", version()},
                                          {"scene", file},
                                          {"frequency_hz", request.frequency_hz},
                                          {"steps_per_period", n_steps},
                                          {"periods", periods},
                                          {"periodic", periodic},
                                          {"response", nodes}});
    out.commit();
    spdlog::info("{}: {} periods at {} Hz ({}), wrote {}", file, periods, request.frequency_hz,
                 periodic ? "periodic" : "NOT periodic yet", out_dir.string());
    return periodic ? kExitOk : kExitIncomplete;
  } catch (const SceneError& e) {
    spdlog::error("{}", e.what());
    return kExitInvalidInput;
  } catch (const std::exception& e) {
    spdlog::error("{}: {}", file, e.what());
    return kExitInternal;
  }
}

}  // namespace frichb::core
