// frichb-bench, part 2: the cost of the harmonic-balance Jacobian against the number of
// contacts and harmonics, on a generated shroud ring.
//
// The ring: P blades, each a 3-DOF lumped node (0.1 kg per DOF on springs of 4e5, 5e5 and
// 6e5 N/m to the ground, 0.5 % modal damping), the shroud of blade i in coupled_3d contact
// with that of blade i+1 (mod P; one blade: with the ground), kt = 2e5, kn = 1e5 N/m,
// mu = 0.5, N0 = 5 N. A travelling-wave excitation (engine order 1: 2 N per direction with
// phase 360 i / P degrees) moves every contact. The state: three times the contact-free
// response at 300 Hz, so that every contact slips over part of the period.
//
// Benchmarks BM_Jacobian/<method>/<contacts>/<harmonics> (harmonics 0..H kept, 256 samples):
//   residual   the residual alone (no Jacobian)
//   analytic   residual and Jacobian, contact tangents from the laws in the same pass (AFT)
//   local_fd   residual and Jacobian, each contact's block by finite differences of its trace
//   global_fd  the thesis's baseline: every unknown perturbed and the whole residual
//              re-evaluated. Where that takes longer than a few seconds, a sample of columns
//              is timed and the time scaled to all n + 1 columns (the label says so).
// Not a test: timings are reported, never asserted; ratios come from one run
// (scripts/performance_report.py, docs/performance.md).
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <unistd.h>

#include <Eigen/Dense>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <string>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/report/run_report.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/solver/continuation.hpp"

namespace {

using namespace frichb::core;

std::string ring_scene(int blades, int harmonics, bool analytic) {
  std::ostringstream s;
  s << "name: shroud_ring_" << blades << "\nstructure:\n  provider: lumped\n  params:\n"
    << "    masses: [";
  for (int i = 0; i < 3 * blades; ++i) s << (i ? ", " : "") << "0.1";
  s << "]\n    springs:\n";
  for (int i = 0; i < blades; ++i)
    for (int d = 0; d < 3; ++d)
      s << "      - {between: [ground, " << 3 * i + d << "], k: " << (4 + d) << ".0e5}\n";
  s << "    modal_damping: [0.005]\n  dofs: {";
  for (int i = 0; i < blades; ++i)
    s << (i ? ", " : "") << "b" << i << ": [" << 3 * i << ", " << 3 * i + 1 << ", " << 3 * i + 2
      << "]";
  s << "}\nexcitation:\n";
  for (int i = 0; i < blades; ++i)
    for (int d = 0; d < 3; ++d)
      s << "  - {dof: b" << i << ", amplitude: 2.0, phase_deg: " << 360.0 * i / blades
        << ", direction: [" << (d == 0 ? 1 : 0) << ", " << (d == 1 ? 1 : 0) << ", "
        << (d == 2 ? 1 : 0) << "]}\n";
  s << "contacts:\n";
  for (int i = 0; i < blades; ++i) {
    s << "  - name: shroud" << i << "\n    law: coupled_3d\n    between: [b" << i << ", "
      << (blades == 1 ? std::string("ground") : "b" + std::to_string((i + 1) % blades)) << "]\n"
      << "    frame: {tangent1: [0, 1, 0], tangent2: [0, 0, 1], normal: [-1, 0, 0]}\n"
      << "    params: {kt: 2.0e5, kn: 1.0e5, mu: 0.5, normal_load: 5.0}\n";
  }
  s << "harmonic_balance:\n  max_harmonic: " << harmonics << "\n  samples_per_period: 256\n"
    << "  jacobian: " << (analytic ? "analytic" : "finite_difference") << "\n"
    << "continuation:\n  frequency: {from: 250, to: 350, unit: Hz}\n";
  return s.str();
}

struct Ring {
  Scene scene;
  std::unique_ptr<StructureInstance> structure;
  std::unique_ptr<HarmonicBalanceModel> model;
  Eigen::VectorXd y;
};

std::unique_ptr<Ring> make_ring(int blades, int harmonics, bool analytic) {
  static const Registry registry({FRICHB_PLUGIN_DIR});
  auto r = std::make_unique<Ring>();
  r->scene = load_scene(YAML::Load(ring_scene(blades, harmonics, analytic)), "shroud_ring.yaml");
  bind_plugins(r->scene, registry);
  r->structure =
      std::make_unique<StructureInstance>(r->scene.structure.plugin, r->scene.structure.values);
  r->model = std::make_unique<HarmonicBalanceModel>(r->scene, *r->structure);
  // FRICHB_BENCH_CONTACT_THREADS (default 1): threads tracing the contacts; 0 = one per core.
  if (const char* v = std::getenv("FRICHB_BENCH_CONTACT_THREADS"))
    r->model->set_contact_threads(std::atoi(v));
  const Eigen::Index n = r->model->equation_count();
  const double w = 2 * std::numbers::pi * 300.0;
  r->y.resize(n + 1);
  r->y.head(n) = 3.0 * r->model->linear_response(w);
  r->y(n) = w;
  return r;
}

// Peak resident memory of the process so far, MiB (getrusage: kilobytes on Linux).
double peak_memory_mib() {
  rusage usage{};
  return getrusage(RUSAGE_SELF, &usage) == 0 ? static_cast<double>(usage.ru_maxrss) / 1024.0 : 0.0;
}

void fail(benchmark::State& state, const std::string& message) {
  state.SkipWithError(message.c_str());
}

void BM_Jacobian(benchmark::State& state, const std::string& method, int contacts, int harmonics) {
  const auto ring = make_ring(contacts, harmonics, method != "local_fd");
  const auto& model = *ring->model;
  const Eigen::Index n = model.equation_count();
  Eigen::VectorXd e;
  Eigen::MatrixXd jacobian;
  std::string message;
  if (method == "residual" || method == "analytic" || method == "local_fd") {
    Eigen::MatrixXd* j = method == "residual" ? nullptr : &jacobian;
    for (auto _ : state) {
      if (!model.evaluate(ring->y, e, j, &message)) return fail(state, message);
      benchmark::DoNotOptimize(e.data());
    }
  } else {  // global_fd: one residual per perturbed unknown (forward differences)
    Eigen::VectorXd e0, yp;
    // Columns timed: all of them up to FRICHB_BENCH_FD_COLUMNS (default 256), else that many
    // spread over the unknowns (each column costs one residual, whatever the unknown).
    Eigen::Index sample = 256;
    if (const char* v = std::getenv("FRICHB_BENCH_FD_COLUMNS")) sample = std::max(1, std::atoi(v));
    const Eigen::Index columns = std::min<Eigen::Index>(n + 1, sample);
    jacobian.resize(n, columns);
    for (auto _ : state) {
      const auto t0 = std::chrono::steady_clock::now();
      if (!model.evaluate(ring->y, e0, nullptr, &message)) return fail(state, message);
      yp = ring->y;
      for (Eigen::Index k = 0; k < columns; ++k) {
        const Eigen::Index i = k * (n + 1) / columns;  // spread over the unknowns
        const double h = 1e-7 * std::max(1e-6, std::abs(yp(i)));
        yp(i) += h;
        if (!model.evaluate(yp, e, nullptr, &message)) return fail(state, message);
        jacobian.col(k) = (e - e0) / h;
        yp(i) = ring->y(i);
      }
      benchmark::DoNotOptimize(jacobian.data());
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      state.SetIterationTime(seconds * static_cast<double>(n + 2) /
                             static_cast<double>(columns + 1));
    }
    if (columns < n + 1)
      state.SetLabel("scaled from " + std::to_string(columns) + " of " + std::to_string(n + 1) +
                     " columns");
  }
  state.counters["unknowns"] = static_cast<double>(n);
  state.counters["contacts"] = contacts;
  state.counters["harmonics"] = harmonics;
}

// One Newton iteration of the continuation's solver on the ring, and where its time goes.
// solve_fixed_parameter runs K = 3 iterations without line search from the slipping state, so
// that it makes K + 1 evaluations (residual and Jacobian) and K LU factorisations; one
// iteration is one evaluation, one factorisation with its solve, and the solver's own work
// (scaling, copies). Counters (milliseconds per iteration, from the solver's profile and the
// model's EvaluationStats): evaluation and its parts (contact traces = AFT with the contacts'
// Jacobian blocks, receptance = Rc_n at the contacts, assembly = I + Rc dF/dU),
// factorisation, other; floor = contact traces + receptance + factorisation, the parts no
// formulation of Newton's method avoids; ratio = iteration / floor.
void BM_NewtonIteration(benchmark::State& state, int contacts, int harmonics) {
  const auto ring = make_ring(contacts, harmonics, true);
  const auto& model = *ring->model;
  ContinuationOptions options;
  options.newton.max_iterations = 3;
  options.newton.max_line_search_halvings = 0;
  options.newton.residual_tolerance = 1e-300;  // never converged: every iteration is run
  options.newton.step_tolerance = 1e-300;
  SolveProfile total;
  EvaluationStats before = model.stats(), after;
  double wall = 0.0;
  for (auto _ : state) {
    before = model.stats();
    const auto t0 = std::chrono::steady_clock::now();
    const NewtonResult result = solve_fixed_parameter(model, ring->y, options);
    wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    benchmark::DoNotOptimize(result.y.data());
    after = model.stats();
    total.evaluations += result.profile.evaluations;
    total.evaluation_seconds += result.profile.evaluation_seconds;
    total.factorisations += result.profile.factorisations;
    total.factorisation_seconds += result.profile.factorisation_seconds;
  }
  const double evaluations = static_cast<double>(total.evaluations);
  const double iterations = static_cast<double>(total.factorisations);
  if (iterations == 0.0) return fail(state, "no Newton iteration ran");
  // Per-evaluation means of the model's parts (the last batch; every batch is the same work).
  const double batch_evaluations =
      static_cast<double>(after.residual_evaluations - before.residual_evaluations);
  const double per_eval = 1e3 / batch_evaluations;
  const double contact_ms = (after.contact_seconds - before.contact_seconds) * per_eval;
  const double receptance_ms = (after.receptance_seconds - before.receptance_seconds) * per_eval;
  const double assembly_ms = (after.assembly_seconds - before.assembly_seconds) * per_eval;
  const double evaluation_ms = 1e3 * total.evaluation_seconds / evaluations;
  const double factorisation_ms = 1e3 * total.factorisation_seconds / iterations;
  // One iteration: the wall time less the solve's first evaluation, over the iterations.
  const double iteration_ms =
      1e3 *
      (wall - total.evaluation_seconds / evaluations * static_cast<double>(state.iterations())) /
      iterations;
  const double floor_ms = contact_ms + receptance_ms + factorisation_ms;
  state.counters["unknowns"] = static_cast<double>(model.equation_count());
  state.counters["iteration_ms"] = iteration_ms;
  state.counters["evaluation_ms"] = evaluation_ms;
  state.counters["contact_ms"] = contact_ms;
  state.counters["receptance_ms"] = receptance_ms;
  state.counters["assembly_ms"] = assembly_ms;
  state.counters["factorisation_ms"] = factorisation_ms;
  state.counters["other_ms"] = iteration_ms - evaluation_ms - factorisation_ms;
  state.counters["floor_ms"] = floor_ms;
  state.counters["iteration_per_floor"] = iteration_ms / floor_ms;
  state.counters["peak_memory_mib"] = peak_memory_mib();
}

// The full response curve of the ring (100 contact pairs, H = 5, 256 samples), as
// `frichb run` computes it: set-up, continuation with the thesis's step control, peak
// refinement and output files (no plots), in a temporary folder. Counters from its
// summary.json: points, Newton iterations, evaluations, factorisations, the profile's parts
// (seconds), peak memory. FRICHB_BENCH_CURVE_CONTACTS overrides the contacts,
// FRICHB_BENCH_KEEP_CURVE=1 keeps the run's folder (its path is the label).
// `variant`: "chord" the defaults with the dense LU; "newton" also turns the chord corrector
// off (continuation.reuse_factorisation_from = 0), so that every corrector iteration is a
// Newton iteration with its factorisation; "gmres" the defaults with
// continuation.linear_solver = gmres (GMRES on kept factorisations); "matrix_free" with
// continuation.linear_solver = matrix_free (GMRES on the Jacobian operator, never formed).
void BM_ResponseCurve(benchmark::State& state, int contacts, int harmonics,
                      const std::string& variant) {
  static const Registry registry({FRICHB_PLUGIN_DIR});
  std::string text = ring_scene(contacts, harmonics, true);
  text += "output:\n  response: [b0]\n  plots: false\n";
  YAML::Node root = YAML::Load(text);
  if (variant == "newton") root["continuation"]["reuse_factorisation_from"] = 0;
  root["continuation"]["linear_solver"] =
      variant == "gmres" || variant == "matrix_free" ? variant : std::string("dense_lu");
  // The window around the ring's first (normal-direction) resonance, about 318 Hz free;
  // FRICHB_BENCH_CURVE_HZ="from,to" overrides it.
  double from = 300.0, to = 340.0;
  if (const char* v = std::getenv("FRICHB_BENCH_CURVE_HZ")) std::sscanf(v, "%lf,%lf", &from, &to);
  root["continuation"]["frequency"]["from"] = from;
  root["continuation"]["frequency"]["to"] = to;
  Scene scene = load_scene(root, "shroud_ring.yaml");
  bind_plugins(scene, registry);
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() / ("frichb-bench-curve-" + std::to_string(getpid()));
  RunOutcome outcome;
  RunOptions options;
  options.quiet = true;
  options.plots = 0;
  for (auto _ : state) {
    std::filesystem::remove_all(out);
    outcome = run_bound_scene(scene, out, options);
  }
  if (!outcome.wrote_output) return fail(state, outcome.message);
  std::ifstream in(out / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(in);
  const bool keep = std::getenv("FRICHB_BENCH_KEEP_CURVE") != nullptr;
  if (!keep) std::filesystem::remove_all(out);
  const auto& profile = summary["profile"];
  state.counters["points"] = summary["points"].get<double>();
  state.counters["newton_iterations"] = summary["newton_iterations"].get<double>();
  state.counters["unknowns"] = summary["unknowns"].get<double>();
  state.counters["evaluations"] = profile["continuation"]["evaluations"].get<double>();
  state.counters["evaluation_s"] = profile["continuation"]["evaluation_s"].get<double>();
  state.counters["factorisations"] = profile["continuation"]["factorisations"].get<double>();
  state.counters["factorisation_s"] = profile["continuation"]["factorisation_s"].get<double>();
  state.counters["other_s"] = profile["continuation"]["other_s"].get<double>();
  state.counters["contact_s"] = profile["model_evaluations"]["contact_traces_s"].get<double>();
  state.counters["receptance_s"] = profile["model_evaluations"]["receptance_s"].get<double>();
  state.counters["assembly_s"] = profile["model_evaluations"]["jacobian_assembly_s"].get<double>();
  state.counters["peak_memory_mib"] = profile["peak_memory_mib"].get<double>();
  state.counters["residual_only_evaluations"] =
      profile["continuation"]["residual_only_evaluations"].get<double>();
  state.counters["chord_points"] = profile["continuation"]["chord_points"].get<double>();
  state.counters["chord_iterations"] = profile["continuation"]["chord_iterations"].get<double>();
  state.counters["chord_fallbacks"] = profile["continuation"]["chord_fallbacks"].get<double>();
  state.counters["krylov_solves"] = profile["linear_solver"]["krylov_solves"].get<double>();
  state.counters["krylov_iterations"] = profile["linear_solver"]["krylov_iterations"].get<double>();
  state.counters["krylov_s"] = profile["linear_solver"]["krylov_s"].get<double>();
  state.counters["krylov_fallbacks"] = profile["linear_solver"]["krylov_fallbacks"].get<double>();
  const auto& last = summary["termination"]["last_point"];
  state.counters["last_hz"] = last.is_null() ? 0.0 : last["frequency"].get<double>();
  state.counters["to_hz"] = to;
  state.SetLabel(summary["termination"]["reason"].get<std::string>() +
                 (keep ? " " + out.string() : std::string()));
}

// Registered at start-up: the grid of the issue. FRICHB_BENCH_MAX_CONTACTS (default 500)
// bounds the contact counts, and FRICHB_BENCH_MAX_JACOBIAN_GIB (default 4) the size of one
// dense Jacobian: the 500-contact Jacobian at H = 10 is 31500 x 31501 doubles (7.4 GiB) and
// is left out by default.
const bool registered = [] {
  int max_contacts = 500;
  if (const char* v = std::getenv("FRICHB_BENCH_MAX_CONTACTS")) max_contacts = std::atoi(v);
  double max_jacobian_gib = 4.0;
  if (const char* v = std::getenv("FRICHB_BENCH_MAX_JACOBIAN_GIB")) max_jacobian_gib = std::atof(v);
  for (const char* method : {"residual", "analytic", "local_fd", "global_fd"})
    for (int contacts : {1, 10, 50, 200, 500}) {
      if (contacts > max_contacts) continue;
      for (int harmonics : {1, 5, 10}) {
        const double unknowns = 3.0 * contacts * (2 * harmonics + 1);
        if (unknowns * (unknowns + 1) * 8.0 > max_jacobian_gib * 1073741824.0) continue;
        const std::string name = std::string("BM_Jacobian/") + method + "/" +
                                 std::to_string(contacts) + "/" + std::to_string(harmonics);
        auto* b = benchmark::RegisterBenchmark(
            name.c_str(), [method = std::string(method), contacts, harmonics](benchmark::State& s) {
              BM_Jacobian(s, method, contacts, harmonics);
            });
        b->Unit(benchmark::kMillisecond);
        if (std::string(method) == "global_fd") b->UseManualTime()->Iterations(1);
      }
    }
  int curve_contacts = 100;
  if (const char* v = std::getenv("FRICHB_BENCH_CURVE_CONTACTS")) curve_contacts = std::atoi(v);
  for (const std::string variant : {"chord", "newton", "gmres", "matrix_free"}) {
    const std::string curve =
        "BM_ResponseCurve/" + std::to_string(curve_contacts) + "/5/" + variant;
    benchmark::RegisterBenchmark(curve.c_str(),
                                 [curve_contacts, variant](benchmark::State& s) {
                                   BM_ResponseCurve(s, curve_contacts, 5, variant);
                                 })
        ->Unit(benchmark::kSecond)
        ->UseRealTime()
        ->Iterations(1);
  }
  // Newton iterations: bounded by FRICHB_BENCH_MAX_UNKNOWNS (default 7000), since a dense
  // factorisation costs n^3 (12 600 unknowns: minutes per iteration on two cores).
  long max_unknowns = 7000;
  if (const char* v = std::getenv("FRICHB_BENCH_MAX_UNKNOWNS")) max_unknowns = std::atol(v);
  for (int contacts : {1, 10, 50, 100, 200, 500}) {
    if (contacts > max_contacts && contacts != 100) continue;
    for (int harmonics : {1, 5, 10}) {
      if (3L * contacts * (2 * harmonics + 1) > max_unknowns) continue;
      const std::string name =
          "BM_NewtonIteration/" + std::to_string(contacts) + "/" + std::to_string(harmonics);
      benchmark::RegisterBenchmark(name.c_str(),
                                   [contacts, harmonics](benchmark::State& s) {
                                     BM_NewtonIteration(s, contacts, harmonics);
                                   })
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
    }
  }
  return true;
}();

}  // namespace
