// One run of a scene: its stages composed (run.hpp).
#include "frichb/core/commands/run.hpp"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <numbers>
#include <optional>
#include <sstream>

#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/report/output.hpp"
#include "frichb/core/report/run_report.hpp"
#include "frichb/core/scene/plugin_checks.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/support/interrupt.hpp"

#include "frichb/core/support/format.hpp"

namespace frichb::core {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Total physical memory of the machine in bytes, or 0 when unknown.
double physical_memory_bytes() {
  const long pages = sysconf(_SC_PHYS_PAGES);
  const long page = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? static_cast<double>(pages) * static_cast<double>(page) : 0.0;
}

// Progress of the trace in the log: every 5 % of the sweep, and the start point.
class TraceProgress {
 public:
  TraceProgress(const Scene& scene, Eigen::Index n, spdlog::level::level_enum level)
      : scene_(scene), n_(n), level_(level) {}
  bool operator()(const ContinuationPoint& p, std::size_t index) {
    if (interrupted()) return false;
    const auto& C = scene_.continuation;
    const double f = p.y(n_) / C.to_rad_per_s();
    const double done = std::clamp((f - C.from) / (C.to - C.from), 0.0, 1.0);
    if (done - last_report_ >= 0.05 || index == 0) {
      last_report_ = done;
      spdlog::log(level_, "  [{:3.0f}%] point {:5d}  {:.6g} {}  Newton {}  step {:.3g}", 100 * done,
                  index, f, unit_name(C.unit), p.newton_iterations, p.step);
    }
    return true;
  }

 private:
  const Scene& scene_;
  Eigen::Index n_;
  spdlog::level::level_enum level_;
  double last_report_ = -1.0;
};

}  // namespace

namespace {

// Samples per harmonic below which a law traced at the samples alone puts a peak more than
// 1 % off: on the 2-DOF damper (jenkins_1d, harmonics to 7) the peak is 1.3 % high at 48
// samples (6.9 per harmonic), 0.7 % at 64 (9.1) and 0.1 % at 128, against 512 samples; the
// quick-start oscillator passes 1 % at 24 samples (3.4 per harmonic). Laws traced along the
// motion are within 0.3 % at 16 samples for 5 harmonics (coupled_3d on its ellipse).
constexpr int kSampleOnlySamplesPerHarmonic = 10;

void warn_of_few_samples(const Scene& scene, const HarmonicBalanceModel& model) {
  const auto& hb = scene.harmonic_balance;
  const auto& harmonics = model.layout().harmonics();
  if (harmonics.empty()) return;
  const int highest = *std::max_element(harmonics.begin(), harmonics.end());
  const int samples = hb.samples_per_period * hb.trace_oversampling;
  const int wanted = kSampleOnlySamplesPerHarmonic * highest;
  if (samples >= wanted) return;
  for (const auto& contact : model.contacts()) {
    if (hb.trace_along_motion && contact.law->traces_motion()) continue;
    spdlog::warn(
        "{}: harmonic_balance.samples_per_period = {}{} for harmonics up to {}: contact '{}' "
        "({}) is traced at the samples alone, whose peaks pass 1 % of error below about {} "
        "samples per harmonic (the 2-DOF damper's peak is 1.3 % high at 48 samples for 7 "
        "harmonics); use at least {} samples per period",
        scene.file.string(), hb.samples_per_period,
        hb.trace_oversampling > 1 ? " x trace_oversampling " + std::to_string(hb.trace_oversampling)
                                  : std::string(),
        highest, contact.name, contact.law->plugin().name(), kSampleOnlySamplesPerHarmonic,
        (wanted + hb.trace_oversampling - 1) / hb.trace_oversampling);
    return;
  }
}

}  // namespace

PreparedRun prepare_run(const Scene& scene, int contact_threads) {
  PreparedRun start;
  const YamlContext ctx{scene.file.string()};
  YAML::Node root = scene.root;  // non-const: a missing key then gives an undefined node
  {
    // The time-frequency tables of the AFT hold samples x coefficients doubles: checked before
    // they are allocated.
    const auto& hb = scene.harmonic_balance;
    const double samples = static_cast<double>(hb.samples_per_period) * hb.trace_oversampling;
    const double coefficients = 2.0 * static_cast<double>(hb.harmonics.size());
    const double needed = samples * coefficients * sizeof(double);
    const double available = physical_memory_bytes();
    if (available > 0 && needed > 0.5 * available)
      ctx.fail(root["harmonic_balance"] ? root["harmonic_balance"] : root, "harmonic_balance",
               "the model does not fit in this machine's memory: " +
                   std::to_string(hb.harmonics.size()) + " harmonics at " +
                   format_number(samples, 8) + " samples per period need " +
                   format_number(needed / (1 << 30), 3) +
                   " GiB of time-frequency tables; keep fewer harmonics, samples_per_period or "
                   "contacts");
  }
  try {
    start.structure =
        std::make_unique<StructureInstance>(scene.structure.plugin, scene.structure.values);
    check_scene_against_plugins(scene, *start.structure);
    start.model = std::make_unique<HarmonicBalanceModel>(scene, *start.structure);
    start.model->set_contact_threads(contact_threads);
  } catch (const PluginError& e) {
    fail_plugin_refusal(ctx, root["structure"], "structure.params",
                        scene.structure.plugin->schema(), e.what());
  } catch (const std::bad_alloc&) {
    ctx.fail(root["harmonic_balance"] ? root["harmonic_balance"] : root, "harmonic_balance",
             "the model does not fit in this machine's memory (an allocation failed while "
             "building it): keep fewer harmonics, samples_per_period or contacts");
  }
  auto& model = start.model;
  const Eigen::Index n = model->equation_count();
  // A static harmonic needs a grounded structure: a rigid-body mode has no static receptance.
  const auto& kept = model->layout().harmonics();
  if (std::find(kept.begin(), kept.end(), 0) != kept.end()) {
    const Eigen::VectorXd& w0 = model->structure().natural_frequencies(0);
    if (w0.size() && w0.minCoeff() <= 1e-8 * std::max(1.0, w0.maxCoeff()))
      ctx.fail(root["structure"], "structure",
               "the structure has a rigid-body mode (natural frequency " +
                   format_number(w0.minCoeff() / (2 * std::numbers::pi)) +
                   " Hz) and harmonic 0 is kept: its static response is unbounded; ground the "
                   "structure or drop harmonic 0");
  }

  warn_of_few_samples(scene, *model);
  start.setup = derive_continuation(scene, *model);
  {
    // The linear solver's own matrices, by the path the continuation will take.
    const LinearSolverChoice choice =
        choose_linear_solver(start.setup.options, n, model->has_jacobian_operator());
    const double needed =
        linear_solver_bytes(start.setup.options, choice.kind, n, model->component_count(),
                            static_cast<Eigen::Index>(model->layout().harmonics().size()));
    const double available = physical_memory_bytes();
    if (available > 0 && needed > 0.8 * available)
      ctx.fail(root["contacts"] ? root["contacts"] : root, "contacts",
               "the scene has " + std::to_string(n) + " unknowns: its Newton matrices (" +
                   std::string(to_string(choice.kind)) + ", " + choice.reason + ") need " +
                   format_number(needed / (1 << 30), 3) + " GiB, more than 80 % of this " +
                   "machine's " + format_number(available / (1 << 30), 3) +
                   " GiB; keep fewer harmonics or contacts");
  }
  return start;
}

void check_run_start(const Scene& scene) {
  prepare_run(scene, 1);
}

int run_scene(const RunRequest& request) {
  Scene scene;
  std::unique_ptr<Registry> registry;
  if (!load_bound_scene(request.scene_file, scene, registry)) return kExitInvalidInput;
  if (request.validate_only) {
    // Everything `run` checks before its first Newton iteration.
    try {
      check_run_start(scene);
    } catch (const SceneError& e) {
      spdlog::error("{}", e.what());
      return kExitInvalidInput;
    } catch (const std::exception& e) {
      spdlog::error("{}: {}", scene.file.string(), e.what());
      return kExitInternal;
    }
    // A patch is listed once, as its entry's name and its pair count.
    std::string contacts;
    const ContactPatch* listed_patch = nullptr;
    for (const auto& c : scene.contacts) {
      if (c.patch && c.patch.get() == listed_patch) continue;
      listed_patch = c.patch.get();
      const std::string name = c.patch ? c.name.substr(0, c.name.rfind('.')) + " (patch of " +
                                             std::to_string(c.patch->pairs.size()) + " node pairs, "
                                       : c.name + " (";
      contacts += (contacts.empty() ? "" : ", ") + name + c.plugin->name() + " " +
                  c.plugin->descriptor().version + ")";
    }
    spdlog::info("{}: valid; structure '{}' {}; contacts: {}", request.scene_file.string(),
                 scene.structure.plugin->name(), scene.structure.plugin->descriptor().version,
                 contacts.empty() ? "none" : contacts);
    // Loading a plugin runs its code: the files the run loads, each once.
    std::vector<std::string> files = {scene.structure.plugin->file().string()};
    for (const auto& c : scene.contacts)
      if (std::find(files.begin(), files.end(), c.plugin->file().string()) == files.end())
        files.push_back(c.plugin->file().string());
    for (const auto& f : files) spdlog::info("  loads {}", f);
    return kExitOk;
  }
  if (scene.root["study"])
    spdlog::info(
        "{} has a study: section; `frichb run` traces the scene as written, "
        "`frichb study` runs the sweep",
        request.scene_file.string());
  fs::path out_dir = request.output_directory;
  if (out_dir.empty()) out_dir = fs::path("out") / scene.file.stem();
  return run_bound_scene(scene, out_dir).exit_code;
}

RunOutcome run_bound_scene(const Scene& scene, const fs::path& out_dir,
                           const RunOptions& run_options) {
  const auto t_start = Clock::now();
  const auto routine = run_options.quiet ? spdlog::level::debug : spdlog::level::info;
  RunOutcome outcome;
  auto fail = [&](int code, const char* termination, const std::string& message) {
    outcome.exit_code = code;
    outcome.termination = termination;
    outcome.message = message;
    outcome.wall_seconds = seconds_since(t_start);
    spdlog::error("{}", message);
    return outcome;
  };
  auto interrupted_while = [&](const std::string& when) {
    return fail(interrupted_exit_code(), "interrupted",
                scene.file.string() + ": interrupted by signal " +
                    std::to_string(interrupt_signal()) + " " + when + "; no output written");
  };
  nlohmann::json timing;
  try {
    // The output folder is taken first: a path that cannot hold the results, or a folder
    // another run is writing, stops the run before any work.
    std::optional<StagedOutput> out;
    try {
      out.emplace(out_dir, std::vector<std::string>{"response.csv", "response.gp", "response.png",
                                                    "summary.json", "loops"});
    } catch (const OutputError& e) {
      return fail(e.user_error() ? kExitInvalidInput : kExitOutput, "output_error", e.what());
    }
    PreparedRun prepared;
    try {
      prepared = prepare_run(scene, run_options.contact_threads);
    } catch (const SceneError& e) {
      return fail(kExitInvalidInput, "invalid_input", e.what());
    }
    timing["setup_s"] = seconds_since(t_start);
    const HarmonicBalanceModel& model = *prepared.model;
    const ContinuationOptions& options = prepared.setup.options;
    const auto& C = scene.continuation;
    const Eigen::Index n = model.equation_count();
    spdlog::log(routine,
                "scene '{}': {} contact(s), {} unknowns ({} harmonics, {} samples), {} {} -> {} {}",
                scene.name.empty() ? scene.file.stem().string() : scene.name,
                model.contacts().size(), n, model.layout().harmonics().size(),
                model.layout().samples(), C.from, unit_name(C.unit), C.to, unit_name(C.unit));

    const Eigen::VectorXd y0 = find_start_point(model, options, routine);
    const auto t_cont = Clock::now();
    const ContinuationSummary summary =
        trace_response(scene, model, options, y0, TraceProgress(scene, n, routine));
    timing["continuation_s"] = seconds_since(t_cont);
    if (interrupted())
      return interrupted_while("at point " + std::to_string(summary.points.size()));
    if (summary.reached_end())
      spdlog::log(routine,
                  "reached {} {} with {} points ({} rejected steps, {} turning points) in {:.3f} s",
                  C.to, unit_name(C.unit), summary.points.size(), summary.rejected_steps,
                  summary.turning_points, summary.wall_seconds);
    else
      spdlog::error("{}: the response curve ended early: {} ({}); {}", scene.file.string(),
                    to_string(summary.termination), summary.message, suggestion(summary, scene));

    const auto t_post = Clock::now();
    spdlog::log(routine, "refining the peaks{}",
                scene.output.friction_loops_at.empty() && scene.output.contact_states_at.empty()
                    ? std::string()
                    : ", then solving at the frequencies of the friction loops and contact states");
    const ResponseTable table = tabulate_response(scene, model, options, summary);
    if (interrupted()) return interrupted_while("while refining the peaks");
    for (const auto& peak : table.peaks)
      if (peak) outcome.peaks.push_back(*peak);
    const std::vector<FrictionLoop> loops = solve_friction_loops(scene, model, options, summary);
    const RunRecord record{scene, model, prepared.setup, summary, table, loops};
    const bool plots = run_options.plots < 0 ? scene.output.plots : run_options.plots != 0;
    const nlohmann::json loop_entries = write_curve_files(*out, record, plots);
    const std::vector<FrictionLoop> states =
        solve_contact_traces(scene, model, options, summary, scene.output.contact_states_at);
    if (interrupted()) return interrupted_while("while solving the friction loops");
    const nlohmann::json state_entries = write_contact_states(*out, record, states, plots);
    timing["post_and_output_s"] = seconds_since(t_post);
    timing["total_s"] = seconds_since(t_start);
    warn_about_results(record);
    nlohmann::json doc = run_summary(record, loop_entries, timing, run_options.study_context);
    doc["contact_states"] = state_entries;
    if (interrupted()) return interrupted_while("while writing");
    write_json(out->path("summary.json"), doc);
    out->commit();
    outcome.wrote_output = true;
    outcome.exit_code = summary.reached_end() ? kExitOk : kExitIncomplete;
    outcome.termination = to_string(summary.termination);
    outcome.message = summary.message;
    outcome.points = summary.points.size();
    outcome.wall_seconds = seconds_since(t_start);
    spdlog::log(routine, "wrote {} ({} points; total {:.3f} s)", out_dir.string(),
                table.rows.size(), outcome.wall_seconds);
    return outcome;
  } catch (const OutputError& e) {
    return fail(e.user_error() ? kExitInvalidInput : kExitOutput, "output_error",
                scene.file.string() + ": writing the outputs: " + e.what());
  } catch (const std::exception& e) {
    return fail(kExitInternal, "internal_error", scene.file.string() + ": " + e.what());
  }
}

}  // namespace frichb::core
