// Helpers shared by the test suites: plugins through the real loader, temporary scenes.
#pragma once

#include <yaml-cpp/yaml.h>

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include <random>

#include <numbers>

#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/plugin_host/periodic_trace.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/plugin_host/schema.hpp"
#include "frichb/core/solver/continuation.hpp"

namespace frichb::test {

inline const core::Registry& built_plugins() {
  static const core::Registry registry({FRICHB_PLUGIN_DIR});
  return registry;
}

// A contact law made by its plugin from YAML params, e.g. "{kt: 1, mu: 0.3, normal_load: 2}".
struct LawHandle {
  core::ParamValues values;
  std::unique_ptr<core::ContactLawInstance> law;
};
inline LawHandle make_law(const std::string& name, const std::string& params_yaml) {
  auto plugin = built_plugins().load(name, FRICHB_KIND_CONTACT_LAW);
  LawHandle h;
  h.values = core::validate_params(YAML::Load(params_yaml), plugin->schema(), "params",
                                   core::YamlContext{"<test>"});
  h.law = std::make_unique<core::ContactLawInstance>(plugin, h.values);
  return h;
}

// A fresh temporary folder, removed with the object.
class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    path_ = std::filesystem::temp_directory_path() /
            ("frichb_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path write(const std::string& name, const std::string& text) const {
    const auto p = path_ / name;
    std::ofstream(p) << text;
    return p;
  }

 private:
  std::filesystem::path path_;
};

// Uniformly random coefficients in [-scale, scale] (a random multiharmonic motion).
inline Eigen::VectorXd random_motion(Eigen::Index size, double scale, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> dist(-scale, scale);
  Eigen::VectorXd u(size);
  for (auto& x : u) x = dist(gen);
  return u;
}

// Central differences of the traced force coefficients with respect to the displacement
// coefficients: the independent oracle of the analytic contact Jacobian.
inline Eigen::MatrixXd central_differences(core::PeriodicTracer& tracer, const Eigen::VectorXd& u) {
  const Eigen::Index p = u.size();
  Eigen::MatrixXd j(p, p);
  const double h = 1e-7 * u.cwiseAbs().maxCoeff();
  core::ContactTrace plus, minus;
  std::string error;
  for (Eigen::Index q = 0; q < p; ++q) {
    Eigen::VectorXd up = u, um = u;
    up(q) += h;
    um(q) -= h;
    EXPECT_TRUE(tracer.trace(up, core::JacobianMode::kNone, plus, &error)) << error;
    EXPECT_TRUE(tracer.trace(um, core::JacobianMode::kNone, minus, &error)) << error;
    j.col(q) = (plus.force_coefficients - minus.force_coefficients) / (2 * h);
  }
  return j;
}

// Traces the response curve of `model` from its contact-free solution at from_hz to to_hz,
// arclength steps of `step` with the frequency in Hz and the displacements in micrometres.
inline core::ContinuationSummary trace_hz(const core::HarmonicBalanceModel& model, double from_hz,
                                          double to_hz, double step) {
  const Eigen::Index n = model.equation_count();
  core::ContinuationOptions o;
  o.lambda_start = 2 * std::numbers::pi * from_hz;
  o.lambda_end = 2 * std::numbers::pi * to_hz;
  o.initial_step = o.max_step = step;
  o.min_step = 1e-8;
  o.unknown_scale = Eigen::VectorXd::Constant(n + 1, 1e-6);
  o.unknown_scale(n) = 2 * std::numbers::pi;
  o.residual_scale = Eigen::VectorXd::Constant(n, 1e-6);
  Eigen::VectorXd y0(n + 1);
  y0 << model.linear_response(o.lambda_start), o.lambda_start;
  return core::trace_curve(model, y0, o);
}

}  // namespace frichb::test
