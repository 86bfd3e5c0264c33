// frichb-bench: Google Benchmark timings of the harmonic-balance residual and of one Newton
// iteration with the quasi-analytical contact Jacobian versus local finite differences, on
// the shipped 2-DOF scene (configs/two_dof_blade_damper.yaml) at a slipping state.
// Not a test: run `build/bin/frichb-bench` and read the ratios from one run.
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <memory>
#include <numbers>

#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/scene/scene.hpp"

namespace {

using namespace frichb::core;

struct Case {
  Scene scene;
  std::unique_ptr<StructureInstance> structure;
  std::unique_ptr<HarmonicBalanceModel> model;
  Eigen::VectorXd y;
};

std::unique_ptr<Case> make_case(bool analytic) {
  static const Registry registry({FRICHB_PLUGIN_DIR});
  auto c = std::make_unique<Case>();
  c->scene = load_scene(FRICHB_SOURCE_DIR "/configs/two_dof_blade_damper.yaml");
  c->scene.harmonic_balance.analytic_jacobian = analytic;
  bind_plugins(c->scene, registry);
  c->structure =
      std::make_unique<StructureInstance>(c->scene.structure.plugin, c->scene.structure.values);
  c->model = std::make_unique<HarmonicBalanceModel>(c->scene, *c->structure);
  const Eigen::Index n = c->model->equation_count();
  const double w = 2 * std::numbers::pi * 300.0;
  c->y.resize(n + 1);
  c->y.head(n) = 3.0 * c->model->linear_response(w);  // well into slip
  c->y(n) = w;
  return c;
}

void BM_Residual(benchmark::State& state) {
  auto c = make_case(true);
  Eigen::VectorXd e;
  std::string message;
  for (auto _ : state) {
    c->model->evaluate(c->y, e, nullptr, &message);
    benchmark::DoNotOptimize(e.data());
  }
}

void newton_iteration(benchmark::State& state, bool analytic) {
  auto c = make_case(analytic);
  const Eigen::Index n = c->model->equation_count();
  Eigen::VectorXd e;
  Eigen::MatrixXd jacobian;
  std::string message;
  for (auto _ : state) {
    c->model->evaluate(c->y, e, &jacobian, &message);
    Eigen::VectorXd step = jacobian.leftCols(n).partialPivLu().solve(-e);
    benchmark::DoNotOptimize(step.data());
  }
  state.counters["unknowns"] = static_cast<double>(n);
}

void BM_NewtonIteration_Analytic(benchmark::State& state) {
  newton_iteration(state, true);
}
void BM_NewtonIteration_FiniteDifference(benchmark::State& state) {
  newton_iteration(state, false);
}

}  // namespace

BENCHMARK(BM_Residual)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_NewtonIteration_Analytic)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_NewtonIteration_FiniteDifference)->Unit(benchmark::kMicrosecond);
BENCHMARK_MAIN();
