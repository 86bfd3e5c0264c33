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
#include "frichb/core/model/mistuned_disk.hpp"
#include "frichb/core/model/stability.hpp"
#include "frichb/core/scene/plugin_checks.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/support/interrupt.hpp"
#include "frichb/core/support/output.hpp"

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
  TraceProgress(const Scene& scene, Eigen::Index n, spdlog::level::level_enum level,
                const RunOptions& options)
      : scene_(scene), n_(n), level_(level), stop_(options.stop), on_point_(options.on_point) {}
  bool operator()(const ContinuationPoint& p, std::size_t index) {
    if (on_point_) on_point_(index, p.y(n_) / (2 * std::numbers::pi));
    if (stop_.stop_requested()) return false;
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
  StopToken stop_;
  std::function<void(std::size_t, double)> on_point_;
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

// The warning of a law traced at too few samples per harmonic, "" when none is due.
std::string few_samples_warning(const Scene& scene, const HarmonicBalanceModel& model) {
  const auto& hb = scene.harmonic_balance;
  const auto& harmonics = model.layout().harmonics();
  if (harmonics.empty()) return "";
  const int highest = *std::max_element(harmonics.begin(), harmonics.end());
  const int samples = hb.samples_per_period * hb.trace_oversampling;
  const int wanted = kSampleOnlySamplesPerHarmonic * highest;
  if (samples >= wanted) return "";
  for (const auto& contact : model.contacts()) {
    if (hb.trace_along_motion && contact.law->traces_motion()) continue;
    return fmt::format(
        "{}: harmonic_balance.samples_per_period = {}{} for harmonics up to {}: contact '{}' "
        "({}) is traced at the samples alone, whose peaks pass 1 % of error below about {} "
        "samples per harmonic (the 2-DOF damper's peak is 1.3 % high at 48 samples for 7 "
        "harmonics); use at least {} samples per period",
        scene.file.string(), hb.samples_per_period,
        hb.trace_oversampling > 1 ? " x trace_oversampling " + std::to_string(hb.trace_oversampling)
                                  : std::string(),
        highest, contact.name, contact.law->plugin().name(), kSampleOnlySamplesPerHarmonic,
        (wanted + hb.trace_oversampling - 1) / hb.trace_oversampling);
  }
  return "";
}

}  // namespace

namespace {

// The warnings a run's results call for: micro-folds, an ill-conditioned Newton matrix,
// contact traces that did not become periodic, contact traces by finite differences.
std::vector<std::string> result_warnings(const Scene& scene, const RunResult& run) {
  std::vector<std::string> warnings;
  const auto& summary = run.summary;
  const std::string unit = unit_name(scene.continuation.unit);
  const TurningPoints& folds = run.table.turning_points;
  if (folds.micro_folds > 0)
    warnings.push_back(fmt::format(
        "{}: {} of the {} turning points come in clusters narrower than {} {} (near {} {}): "
        "micro-folds of the time grid of a non-smooth contact force, not physics; they "
        "shrink as harmonic_balance.samples_per_period grows (the outermost folds of a "
        "cluster are the physical ones)",
        scene.file.string(), folds.micro_folds, summary.turning_points,
        format_number(folds.cluster_width), unit, format_number(folds.first_cluster), unit));
  const double worst = summary.max_condition;
  if (!summary.points.empty() && worst > 0.0 && !(worst <= kIllConditioned)) {
    const Eigen::Index n = run.prepared.model->equation_count();
    const double at =
        summary.points[summary.max_condition_point].y(n) / scene.continuation.to_rad_per_s();
    warnings.push_back(fmt::format(
        "{}: the Newton matrix is ill-conditioned at {} {} (condition estimate {:.3g}: "
        "about {:.0f} of 16 digits lost in a Newton update); check for a rigid-body mode "
        "or a contact far stiffer than the structure, or set "
        "continuation.displacement_scale",
        scene.file.string(), format_number(at), unit, worst, std::min(16.0, std::log10(worst))));
  }
  const auto& stats = run.prepared.model->stats();
  if (stats.non_periodic_traces > 0)
    warnings.push_back(fmt::format(
        "{}: {} contact traces did not become periodic within "
        "harmonic_balance.max_trace_passes = {} passes (each costs that many passes; last: "
        "{}); a contact whose state contracts by little per period (a multiplier of the "
        "pass's monodromy near 1: a direction it barely slips in) where the Newton steps onto "
        "the periodic state kept overshooting, or one with no periodic state (a multiplier "
        "beyond 1, or a limit cycle over several periods): raise max_trace_passes if the "
        "curve changes, or raise trace_oversampling",
        scene.file.string(), stats.non_periodic_traces, scene.harmonic_balance.max_trace_passes,
        stats.last_trace_diagnostic));
  if (stats.contacts_with_fd_jacobian &&
      run.prepared.model->jacobian_mode() == JacobianMode::kAnalytic)
    warnings.push_back(
        fmt::format("{} contact traces used finite differences (a law without tangents)",
                    stats.contacts_with_fd_jacobian));
  return warnings;
}

}  // namespace

std::string suggestion(const ContinuationSummary& summary, const Scene& scene) {
  const auto& C = scene.continuation;
  const std::string many_folds =
      summary.turning_points >= 4
          ? "; " + std::to_string(summary.turning_points) +
                " turning points: where they cluster (summary.json micro_folds), raise "
                "harmonic_balance.samples_per_period"
          : "";
  switch (summary.termination) {
    case TerminationType::kReachedEnd:
      return "";
    case TerminationType::kMaxPoints: {
      // A step covers at most step.max of frequency (lambda is scaled by the scene's unit):
      // the rest of the window needs at least that many more points.
      const std::string unit = " " + unit_name(C.unit);
      const double last =
          summary.points.empty()
              ? C.from
              : summary.points.back().y(summary.points.back().y.size() - 1) / C.to_rad_per_s();
      const double remaining = std::abs(C.to - last);
      const auto points = static_cast<double>(summary.points.size());
      const double more = std::ceil(remaining / C.max_step);
      // Rounded up to two significant digits, with a quarter more for the peaks' flanks.
      const double total = points + 1.25 * more;
      const double digits = std::pow(10.0, std::floor(std::log10(total)) - 1);
      return "the curve reached " + format_number(last) + unit + " of " + format_number(C.from) +
             ".." + format_number(C.to) + unit + " in " + std::to_string(summary.points.size()) +
             " points (" + format_number(std::abs(last - C.from) / std::max(1.0, points), 3) +
             unit + " a point on average, " + std::to_string(summary.turning_points) +
             " turning points); a step covers at most continuation.step.max = " +
             format_number(C.max_step) + unit + " of frequency, so the remaining " +
             format_number(remaining, 4) + unit + " need at least " + format_number(more, 8) +
             " more points: raise continuation.max_points to about " +
             format_number(std::ceil(total / digits) * digits, 8) + ", or step.max" + many_folds;
    }
    case TerminationType::kStepTooSmall:
      return std::string(
                 "the corrector failed down to continuation.step.min: look at the last point "
                 "(a contact changing regime, a fold); try more samples_per_period or "
                 "trace_oversampling (a smoother residual), or a smaller step.min") +
             (C.turning_point_control ? "" : ", or turning_point_control: true") + many_folds;
    case TerminationType::kTimeLimit:
      return "raise continuation.max_wall_seconds, or reduce harmonics or samples_per_period";
    case TerminationType::kLeftBounds:
      return "the curve came back a quarter of the window past the start of the sweep: it "
             "walked its branch backwards after a kink or fold it could not pass forwards (the "
             "points after that fold retrace the branch), or the branch overhangs the window "
             "(widen continuation.frequency); try more samples_per_period" +
             many_folds;
    case TerminationType::kStartFailed:
      return "no solution was found at the start frequency: start the sweep further from "
             "resonance, or lower the excitation";
    case TerminationType::kEvaluationFailed:
      return "a contact law or the structure failed at the start point: see the message";
    case TerminationType::kCancelled:
      return "cancelled";
    case TerminationType::kInvalidOptions:
      return "check the continuation section (steps, tolerance)";
  }
  return "";
}

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
    start.structure = instantiate_structure(scene);
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

  if (scene.output.stability && scene.cyclic.enabled()) {
    // The whole disk's variational system (model/stability.hpp).
    const int nb = scene.cyclic.sectors;
    Eigen::Index modes = 0, states = 0;
    for (int h = 0; 2 * h <= nb; ++h)
      modes += static_cast<Eigen::Index>(model->structure().mode_count(h)) *
               (h == 0 || 2 * h == nb ? 1 : 2);
    for (const auto& contact : model->contacts()) states += contact.law->traits().state_size;
    const Eigen::Index unknowns = 2 * modes + nb * (model->component_count() + states);
    if (unknowns > kMaxStabilityDimension)
      ctx.fail(root["output"]["stability"], "output.stability",
               "the stability of this cyclic scene integrates the whole disk: " +
                   std::to_string(unknowns) +
                   " unknowns (modes twice, contact components and "
                   "states of every sector), above the " +
                   std::to_string(kMaxStabilityDimension) + " its dense monodromy allows");
  }
  if (std::string warning = few_samples_warning(scene, *model); !warning.empty()) {
    spdlog::warn("{}", warning);
    start.warnings.push_back(std::move(warning));
  }
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

RunResult run_scene(const SceneInput& input, const RunOptions& options) {
  auto bound = std::make_shared<const BoundScene>(load_bound_scene(input));
  const Scene& scene = bound->scene;
  if (scene.root["study"])
    spdlog::info(
        "{} has a study: section; `frichb run` traces the scene as written, "
        "`frichb study` runs the sweep",
        scene.file.string());
  RunResult result = trace_scene(scene, options);
  result.bound = std::move(bound);
  return result;
}

namespace {

RunResult trace_stages(const Scene& scene, const RunOptions& run_options);

// Every blade's peak of a mistuned disk's run against the tuned disk's, traced now.
MistuningComparison compare_with_tuned(const Scene& scene, const RunResult& mistuned,
                                       const RunOptions& run_options) {
  const MistuningSpec& m = *scene.mistuning;
  MistuningComparison out;
  out.deviations = m.deviations;
  RunOptions quiet = run_options;
  quiet.quiet = true;
  quiet.on_point = nullptr;
  spdlog::log(run_options.quiet ? spdlog::level::debug : spdlog::level::info,
              "tracing the tuned disk (its cyclic sector) for the amplification");
  const RunResult tuned = trace_stages(*m.tuned, quiet);
  out.tuned_termination = to_string(tuned.summary.termination);
  out.tuned_points = tuned.summary.points.size();
  out.tuned_seconds = tuned.wall_seconds;
  const auto hz = [](const NodePeak& p) { return p.omega_rad_s / (2 * std::numbers::pi); };
  for (const auto& name : m.tuned->output.response) {
    BladePeaks b;
    b.node = name;
    for (const auto& p : tuned.peaks)
      if (p.node == name) {
        b.tuned_amplitude_m = p.amplitude_m;
        b.tuned_frequency_hz = hz(p);
      }
    for (int j = 0; j < m.sectors; ++j) {
      const std::string on_blade = MistuningSpec::on_blade(name, j);
      double amplitude = 0, frequency = 0;
      bool solved = false;
      for (const auto& p : mistuned.peaks)
        if (p.node == on_blade) {
          amplitude = p.amplitude_m;
          frequency = hz(p);
          solved = p.refined;
        }
      b.amplitude_m.push_back(amplitude);
      b.frequency_hz.push_back(frequency);
      b.solved.push_back(solved);
      if (amplitude > 0 &&
          (b.worst_blade < 0 || amplitude > b.amplitude_m[static_cast<std::size_t>(b.worst_blade)]))
        b.worst_blade = j;
    }
    if (b.worst_blade >= 0 && b.tuned_amplitude_m > 0)
      b.amplification =
          b.amplitude_m[static_cast<std::size_t>(b.worst_blade)] / b.tuned_amplitude_m;
    out.nodes.push_back(std::move(b));
  }
  return out;
}

// Every stage of trace_scene.
RunResult trace_stages(const Scene& scene, const RunOptions& run_options) {
  const auto t_start = Clock::now();
  const auto routine = run_options.quiet ? spdlog::level::debug : spdlog::level::info;
  RunResult result;
  result.scene = &scene;
  result.options = run_options;
  auto interrupted_while = [&](const std::string& when) {
    result.outcome = {
        run_options.stop.exit_code(), "interrupted", run_options.stop.reason() + " " + when, {}};
    result.wall_seconds = seconds_since(t_start);
    return std::move(result);
  };
  result.prepared = prepare_run(scene, run_options.contact_threads);
  result.prepared.setup.options.newton.stop = run_options.stop;
  result.outcome.warnings = result.prepared.warnings;
  result.setup_seconds = seconds_since(t_start);
  const HarmonicBalanceModel& model = *result.prepared.model;
  const ContinuationOptions& options = result.prepared.setup.options;
  const auto& C = scene.continuation;
  const Eigen::Index n = model.equation_count();
  spdlog::log(routine,
              "scene '{}': {} contact(s), {} unknowns ({} harmonics, {} samples), {} {} -> {} {}",
              scene.name.empty() ? scene.file.stem().string() : scene.name, model.contacts().size(),
              n, model.layout().harmonics().size(), model.layout().samples(), C.from,
              unit_name(C.unit), C.to, unit_name(C.unit));

  const Eigen::VectorXd y0 = find_start_point(model, options, routine);
  const auto t_cont = Clock::now();
  result.summary =
      trace_response(scene, model, options, y0, TraceProgress(scene, n, routine, run_options));
  const ContinuationSummary& summary = result.summary;
  result.continuation_seconds = seconds_since(t_cont);
  if (run_options.stop.stop_requested())
    return interrupted_while("at point " + std::to_string(summary.points.size()));
  if (summary.reached_end()) {
    spdlog::log(routine,
                "reached {} {} with {} points ({} rejected steps, {} turning points) in {:.3f} s",
                C.to, unit_name(C.unit), summary.points.size(), summary.rejected_steps,
                summary.turning_points, summary.wall_seconds);
  } else {
    result.outcome = {kExitIncomplete,
                      to_string(summary.termination),
                      summary.message + "; " + suggestion(summary, scene),
                      {}};
    spdlog::error("{}: the response curve ended early: {} ({}); {}", scene.file.string(),
                  to_string(summary.termination), summary.message, suggestion(summary, scene));
  }

  const auto t_post = Clock::now();
  spdlog::log(routine, "refining the peaks{}",
              scene.output.friction_loops_at.empty() && scene.output.contact_states_at.empty()
                  ? std::string()
                  : ", then solving at the frequencies of the friction loops and contact states");
  result.table = tabulate_response(scene, model, options, summary);
  if (run_options.stop.stop_requested()) return interrupted_while("while refining the peaks");
  for (const auto& peak : result.table.peaks)
    if (peak) result.peaks.push_back(*peak);
  result.loops = solve_friction_loops(scene, model, options, summary);
  result.states =
      solve_contact_traces(scene, model, options, summary, scene.output.contact_states_at);
  if (run_options.stop.stop_requested())
    return interrupted_while("while solving the friction loops");
  if (scene.mistuning && scene.mistuning->tuned && run_options.compare_with_tuned) {
    result.mistuning = compare_with_tuned(scene, result, run_options);
    if (run_options.stop.stop_requested()) return interrupted_while("while tracing the tuned disk");
    for (const auto& b : result.mistuning->nodes)
      spdlog::log(routine,
                  "{}: worst blade {} at {:.6g} m, tuned peak {:.6g} m: amplification {:.4f}",
                  b.node, b.worst_blade,
                  b.worst_blade >= 0 ? b.amplitude_m[static_cast<std::size_t>(b.worst_blade)] : 0.0,
                  b.tuned_amplitude_m, b.amplification);
  }
  result.post_seconds = seconds_since(t_post);
  for (auto& warning : result_warnings(scene, result)) {
    spdlog::warn("{}", warning);
    result.outcome.warnings.push_back(std::move(warning));
  }
  result.wall_seconds = seconds_since(t_start);
  return result;
}

}  // namespace

RunResult trace_scene(const Scene& scene, const RunOptions& run_options) {
  try {
    return trace_stages(scene, run_options);
  } catch (const PluginError& e) {
    // A plugin that fails while the scene is traced (its input was accepted): an internal
    // failure, not invalid input.
    throw std::runtime_error(e.what());
  }
}

RunOutcome run_member(const Scene& scene, const fs::path& folder, const RunOptions& options,
                      const RunWriter& write) {
  const auto t_start = Clock::now();
  RunOutcome outcome;
  auto fail = [&](int code, const char* termination, const std::string& message) {
    outcome.exit_code = code;
    outcome.termination = termination;
    outcome.message = message;
    outcome.wall_seconds = seconds_since(t_start);
    spdlog::error("{}", message);
    return outcome;
  };
  try {
    const RunResult result = trace_scene(scene, options);
    if (result.outcome.status >= 128)
      return fail(result.outcome.status, "interrupted",
                  scene.file.string() + ": " + result.outcome.message + "; no output written");
    outcome.termination = to_string(result.summary.termination);
    outcome.message = result.summary.message;
    outcome.points = result.summary.points.size();
    outcome.unknowns = static_cast<long>(result.prepared.model->equation_count());
    outcome.peaks = result.peaks;
    if (result.mistuning)
      for (const auto& b : result.mistuning->nodes)
        outcome.amplification.push_back({b.node, b.amplification, b.worst_blade});
    write(result, folder);
    outcome.wrote_output = true;
    outcome.exit_code = result.outcome.status;
    outcome.wall_seconds = seconds_since(t_start);
    return outcome;
  } catch (const SceneError& e) {
    return fail(kExitInvalidInput, "invalid_input", e.what());
  } catch (const OutputError& e) {
    return fail(e.user_error() ? kExitInvalidInput : kExitOutput, "output_error",
                scene.file.string() + ": writing the outputs: " + e.what());
  } catch (const Interrupted& e) {
    return fail(128 + e.signal(), "interrupted", scene.file.string() + ": " + e.what());
  } catch (const std::exception& e) {
    return fail(kExitInternal, "internal_error", scene.file.string() + ": " + e.what());
  }
}

}  // namespace frichb::core
