#include "frichb/core/run.hpp"

#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <numbers>
#include <optional>
#include <sstream>

#include "frichb/core/continuation.hpp"
#include "frichb/core/dense_lu.hpp"
#include "frichb/core/harmonic_balance.hpp"
#include "frichb/core/harmonics.hpp"
#include "frichb/core/interrupt.hpp"
#include "frichb/core/linear_resonances.hpp"
#include "frichb/core/output.hpp"
#include "frichb/core/response.hpp"
#include "frichb/core/scene.hpp"
#include "frichb/core/version.hpp"

namespace frichb::core {

namespace fs = std::filesystem;

namespace {

// Where the response curve's wall time went, for users sizing a study: the continuation's
// evaluations and LU factorisations (ContinuationSummary::profile), the parts of all the
// model's evaluations (EvaluationStats, including the start point and the output pass), and
// the process's peak resident memory (getrusage; for the whole process, so a study's threads
// share it).
nlohmann::json profile_json(const ContinuationSummary& summary, const EvaluationStats& stats) {
  const SolveProfile& p = summary.profile;
  const double other = summary.wall_seconds - p.evaluation_seconds - p.factorisation_seconds;
  rusage usage{};
  nlohmann::json peak_memory = nullptr;
  if (getrusage(RUSAGE_SELF, &usage) == 0)
    peak_memory = static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: kilobytes
  return {{"continuation",
           {{"wall_s", summary.wall_seconds},
            {"evaluations", p.evaluations},
            {"evaluation_s", p.evaluation_seconds},
            {"residual_only_evaluations", p.residual_only_evaluations},
            {"factorisations", p.factorisations},
            {"factorisation_s", p.factorisation_seconds},
            {"chord_points", summary.chord_points},
            {"chord_iterations", summary.chord_iterations},
            {"chord_fallbacks", summary.chord_fallbacks},
            {"other_s", std::max(0.0, other)}}},
          {"model_evaluations",
           {{"contact_traces_s", stats.contact_seconds},
            {"receptance_s", stats.receptance_seconds},
            {"jacobian_assembly_s", stats.assembly_seconds}}},
          {"dense_solver", dense_solver_description()},
          {"peak_memory_mib", peak_memory}};
}

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string unit_name(FrequencyUnit u) {
  return u == FrequencyUnit::kHz ? "Hz" : "rad/s";
}

std::string format_number(double x, int precision = 6) {
  std::ostringstream os;
  os.precision(precision);
  os << x;
  return os.str();
}

struct NodeColumns {
  std::string name;
  std::vector<Eigen::Index> kept;  // kept indices of the node's DOFs
};

nlohmann::json plugin_json(const LoadedPlugin& p) {
  const auto& d = p.descriptor();
  return {{"name", d.name},
          {"kind", to_string(p.kind())},
          {"version", d.version},
          {"abi", std::to_string(d.abi_major) + "." + std::to_string(d.abi_minor)},
          {"build", d.build_tag},
          {"file", p.file().string()}};
}

std::string response_plot_script(const Scene& scene, const std::vector<NodeColumns>& nodes) {
  std::ostringstream gp;
  gp << "# gnuplot script written by frichb; run `gnuplot response.gp` to remake response.png\n"
     << "set terminal pngcairo size 1000,640 noenhanced\n"
     << "set output 'response.png'\n"
     << "set datafile separator ','\n"
     << "set title "
     << gnuplot_string((scene.name.empty() ? scene.file.stem().string() : scene.name) +
                       ": forced response")
     << "\n"
     << "set xlabel 'frequency [" << unit_name(scene.continuation.unit) << "]'\n"
     << "set ylabel 'amplitude [m]'\nset grid\nset key top right\n";
  const int xcol = scene.continuation.unit == FrequencyUnit::kHz ? 2 : 3;
  gp << "plot ";
  for (std::size_t i = 0; i < nodes.size(); ++i)
    gp << (i ? ", \\\n     " : "") << "'response.csv' using " << xcol << ":"
       << "(column(" << gnuplot_string(nodes[i].name + "_amplitude_m")
       << ")) with linespoints pt 7 ps 0.4 title " << gnuplot_string(nodes[i].name);
  gp << "\n";
  return gp.str();
}

std::string loop_plot_script(const std::string& csv, const std::string& title, int dims) {
  std::ostringstream gp;
  gp << "set terminal pngcairo size 800,600 noenhanced\n"
     << "set output " << gnuplot_string(fs::path(csv).replace_extension(".png").filename().string())
     << "\n"
     << "set datafile separator ','\nset grid\n"
     << "set title " << gnuplot_string(title) << "\n"
     << "set xlabel 'relative displacement u_t1 [m]'\nset ylabel 'friction force T1 [N]'\n"
     << "plot " << gnuplot_string(fs::path(csv).filename().string()) << " using 2:" << (2 + dims)
     << " with lines lw 2 title 'loop'\n";
  return gp.str();
}

// Golden-section refinement of the highest point `top` of a traced curve over the frequency
// between its two neighbours. Each probe solves the equations at a fixed frequency from the
// curve's linear interpolation. Returns (amplitude, omega) or nothing when the curve turns
// around the top point, the top point is an end of the curve, or a probe fails.
std::optional<std::pair<double, double>> refine_peak(const HarmonicBalanceModel& model,
                                                     const std::vector<ContinuationPoint>& points,
                                                     std::size_t top,
                                                     const std::vector<Eigen::Index>& kept,
                                                     AmplitudeSampler& sampler,
                                                     const ContinuationOptions& options) {
  if (top == 0 || top + 1 >= points.size() || kept.empty()) return std::nullopt;
  const Eigen::Index n = model.equation_count();
  const Eigen::VectorXd& before = points[top - 1].y;
  const Eigen::VectorXd& at = points[top].y;
  const Eigen::VectorXd& after = points[top + 1].y;
  if ((at(n) - before(n)) * (after(n) - at(n)) <= 0) return std::nullopt;  // a fold
  auto guess = [&](double w) {
    const Eigen::VectorXd& a = (w - at(n)) * (before(n) - at(n)) > 0 ? before : after;
    const double s = (w - at(n)) / (a(n) - at(n));
    Eigen::VectorXd y = (1 - s) * at + s * a;
    y(n) = w;
    return y;
  };
  bool failed = false;
  auto amplitude = [&](double w) {
    Eigen::VectorXd y = guess(w);
    if (n > 0) {
      const NewtonResult solved = solve_fixed_parameter(model, y, options);
      if (!solved.converged) {
        failed = true;
        return 0.0;
      }
      y = solved.y;
    }
    return sampler.peak_amplitude(model.kept_response(y), kept);
  };
  const double inv_phi = (std::sqrt(5.0) - 1) / 2;
  double a = before(n), b = after(n);
  double c = b - inv_phi * (b - a), d = a + inv_phi * (b - a);
  double fc = amplitude(c), fd = amplitude(d);
  for (int i = 0; i < 80 && !failed && std::abs(b - a) > 1e-10 * std::abs(at(n)); ++i) {
    if (fc > fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - inv_phi * (b - a);
      fc = amplitude(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + inv_phi * (b - a);
      fd = amplitude(d);
    }
  }
  if (failed) return std::nullopt;
  return fc > fd ? std::make_pair(fc, c) : std::make_pair(fd, d);
}

// A Newton matrix whose condition estimate exceeds this has lost 10 of 16 digits: warned.
constexpr double kIllConditioned = 1e10;

// Turning points of the traced curve (sign changes of the tangent's frequency component) in
// the scene's unit, and the micro-folds among them: turning points within
// kMicroFoldWidth of the sweep span of the next one along the curve. A penalty contact's
// sampled force is piecewise smooth (a sample entering contact bends the residual), and near
// a fold of a lightly damped resonance these bends fold the curve back and forth over a
// fraction of a hertz; the clusters narrow as samples_per_period grows (docs/validation.md).
struct TurningPointReport {
  std::vector<double> frequencies;
  int micro_folds = 0;         // turning points that belong to a cluster
  double cluster_width = 0.0;  // the clustering distance, in the scene's unit
  double first_cluster = 0.0;  // where the first cluster is
};
constexpr double kMicroFoldWidth = 1e-3;

TurningPointReport report_turning_points(const ContinuationSummary& summary, Eigen::Index n,
                                         double unit, double span) {
  TurningPointReport report;
  for (std::size_t i = 1; i < summary.points.size(); ++i)
    if (summary.points[i - 1].tangent(n) * summary.points[i].tangent(n) < 0.0)
      report.frequencies.push_back(summary.points[i].y(n) / unit);
  report.cluster_width = kMicroFoldWidth * span;
  const auto& f = report.frequencies;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const bool near_previous = i > 0 && std::abs(f[i] - f[i - 1]) < report.cluster_width;
    const bool near_next = i + 1 < f.size() && std::abs(f[i + 1] - f[i]) < report.cluster_width;
    if (!near_previous && !near_next) continue;
    if (report.micro_folds == 0) report.first_cluster = f[i];
    ++report.micro_folds;
  }
  return report;
}

// What a user can change when the curve ends early, by reason (printed and in summary.json).
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
    case TerminationType::kMaxPoints:
      return "the curve needs more than continuation.max_points = " + std::to_string(C.max_points) +
             " points (" + std::to_string(summary.turning_points) +
             " turning points so far): raise max_points, or continuation.step.max to take "
             "longer steps where the curve is smooth" +
             many_folds;
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

// Share of a contact force's energy (over the kept harmonics from 1 up) above which its
// highest kept harmonic is warned about: the force's spectrum is cut where it still matters.
constexpr double kHighestHarmonicShare = 0.02;

// At the curve's highest point (of the first response node, column 3 of `rows`), the largest
// share of any contact force component's energy that its highest kept harmonic carries.
nlohmann::json harmonic_truncation(const Scene& scene, const HarmonicBalanceModel& model,
                                   const ContinuationSummary& summary,
                                   const std::vector<std::vector<double>>& rows) {
  const auto& kept = model.layout().harmonics();
  const int highest = kept.back();
  if (rows.empty() || model.contacts().empty() || highest < 2) return nullptr;
  std::size_t top = 0;
  for (std::size_t i = 1; i < rows.size(); ++i)
    if (rows[i][3] > rows[top][3]) top = i;
  const Eigen::Index n = model.equation_count();
  double worst = 0.0;
  std::string where;
  for (std::size_t c = 0; c < model.contacts().size(); ++c) {
    ContactTrace trace;
    if (!model.trace_contact(c, summary.points[top].y, trace, nullptr)) continue;
    if (highest > (static_cast<int>(trace.force.rows()) - 1) / 2) continue;
    const auto& comps = model.contacts()[c].tracer->components();
    const ForceHarmonics table = force_harmonics(trace.force, comps, highest);
    for (std::size_t a = 0; a < comps.size(); ++a) {
      double total = 0.0;
      for (int h : kept)
        if (h > 0) total += std::pow(table.amplitude[a][static_cast<std::size_t>(h)], 2);
      const double top_share =
          total > 0 ? std::pow(table.amplitude[a][static_cast<std::size_t>(highest)], 2) / total
                    : 0.0;
      if (top_share > worst) {
        worst = top_share;
        static const char* axes[] = {"t1", "t2", "n"};
        where = model.contacts()[c].name + " (" + axes[comps[a]] + ")";
      }
    }
  }
  const double unit = scene.continuation.to_rad_per_s();
  const double at = summary.points[top].y(n) / unit;
  if (worst > kHighestHarmonicShare)
    spdlog::warn(
        "{}: at the curve's highest point ({} {}) harmonic {} carries {:.1f} % of the force "
        "energy of contact {}: the kept harmonics cut the force's spectrum where it still "
        "matters; keep more harmonics (harmonic_balance.max_harmonic) and compare the peak",
        scene.file.string(), format_number(at), unit_name(scene.continuation.unit), highest,
        100 * worst, where);
  return {{"frequency", at},
          {"highest_harmonic", highest},
          {"largest_energy_share", worst},
          {"contact", where},
          {"warning_above", kHighestHarmonicShare}};
}

// Total physical memory of the machine in bytes, or 0 when unknown.
double physical_memory_bytes() {
  const long pages = sysconf(_SC_PHYS_PAGES);
  const long page = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? static_cast<double>(pages) * static_cast<double>(page) : 0.0;
}

// The start of a run, up to its first Newton iteration: the structure and the model built
// (every DOF, frame and sector count checked, the modal bases fetched), the contact-free
// response checked over the sweep, the memory the Newton matrices need checked against the
// machine's, the scaling and the continuation options.
struct RunStart {
  std::unique_ptr<StructureInstance> structure;
  std::unique_ptr<HarmonicBalanceModel> model;
  ContinuationOptions options;
  double peak = 0.0;                        // largest contact-free displacement over the sweep, m
  double u_unit = 0.0;                      // displacement scale of the arclength, m
  double span = 0.0;                        // the sweep's width in the scene's unit
  std::vector<LinearResonance> resonances;  // of the free and the stuck structure, in the window
};

// The advance in lambda at a resonance, in half-power half-widths, and its growth with the
// distance d from the centre. Approaching from d, a step ends no nearer than 0.2 d - 0.1 on the
// same side, or past the centre by at most 0.1 - 0.2 d (only from d < 0.5): the last point
// before the centre and the first one past it are never both farther than 0.1 / 1.2 = 0.083
// half-widths from it, where a single mode's amplitude is
// within 0.35 % of its peak (1 / sqrt(1 + 0.083^2)). Moving away, the advance grows faster
// (0.1 + 2 d): the peak is behind, its flank drawn by a point at 0.3, 1, 3, 9 ... half-widths.
constexpr double kCentreStepInHalfWidths = 0.1;
constexpr double kApproachGrowth = 0.8;
constexpr double kLeavingGrowth = 2.0;

// The step bands of the linear resonances (linear_resonances.hpp): the continuation bounds its
// advance in frequency near each, so that no resonance is stepped over.
std::vector<ContinuationOptions::StepBand> resonance_bands(
    const std::vector<LinearResonance>& resonances) {
  std::vector<ContinuationOptions::StepBand> bands;
  bands.reserve(resonances.size());
  for (const LinearResonance& r : resonances)
    bands.push_back(
        {r.centre, kCentreStepInHalfWidths * r.half_width, kApproachGrowth, kLeavingGrowth});
  return bands;
}

nlohmann::json resonances_json(const std::vector<LinearResonance>& resonances, double unit) {
  nlohmann::json out = nlohmann::json::array();
  for (const LinearResonance& r : resonances) {
    out.push_back({{"system", system_name(r.system)},
                   {"harmonic", r.harmonic},
                   {"harmonic_index", r.harmonic_index},
                   {"centre", r.centre / unit},
                   {"half_width", r.half_width / unit},
                   {"damping_ratio", r.damping_ratio},
                   {"step", kCentreStepInHalfWidths * r.half_width / unit}});
  }
  return out;
}

// Bytes the continuation holds per Newton matrix entry: the Jacobian, its LU factors and the
// bordered Keller matrix, (n + 1)^2 doubles each.
constexpr double kNewtonMatrixBytesPerEntry = 3.0 * sizeof(double);

RunStart start_run(const Scene& scene, int contact_threads) {
  RunStart start;
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
  const auto& C = scene.continuation;
  const double unit = C.to_rad_per_s();
  const double w_from = C.from * unit, w_to = C.to * unit;
  const Eigen::Index n = model->equation_count();
  {
    const double needed =
        kNewtonMatrixBytesPerEntry * static_cast<double>(n + 1) * static_cast<double>(n + 1);
    const double available = physical_memory_bytes();
    if (available > 0 && needed > 0.8 * available)
      ctx.fail(root["contacts"] ? root["contacts"] : root, "contacts",
               "the scene has " + std::to_string(n) + " unknowns: its Newton matrices need " +
                   format_number(needed / (1 << 30), 3) +
                   " GiB, more than 80 % of this "
                   "machine's " +
                   format_number(available / (1 << 30), 3) +
                   " GiB; keep fewer harmonics or contacts");
  }

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

  // Scaling: frequency in the scene's unit; displacements so that the contact-free peak
  // over the sweep is kTallness times as tall as the sweep is wide. Friction peaks are
  // lower than the contact-free one, so a tall box keeps the arclength resolving them;
  // a taller one costs points on curves that do climb (gaps closing, light friction).
  constexpr double kTallness = 5.0;
  double peak = 0.0;
  for (int i = 0; i <= 256; ++i) {
    const double w = w_from + (w_to - w_from) * i / 256.0;
    const Eigen::VectorXd u0 = model->linear_response(w);
    if (!u0.allFinite())
      ctx.fail(root["structure"], "structure",
               "the contact-free response is not finite at " + format_number(w / unit) + " " +
                   unit_name(C.unit) +
                   " (harmonic 0 with a rigid-body mode, or an undamped resonance): ground the "
                   "structure, drop harmonic 0, or add damping");
    if (u0.size()) peak = std::max(peak, u0.cwiseAbs().maxCoeff());
  }
  if (peak == 0.0) peak = 1e-6;
  start.peak = peak;
  start.span = std::abs(C.to - C.from);
  start.u_unit = C.displacement_scale > 0 ? C.displacement_scale : peak / (kTallness * start.span);

  ContinuationOptions& options = start.options;
  options.lambda_start = w_from;
  options.lambda_end = w_to;
  // The curve stays within a quarter of the window's span around it (and at positive
  // frequency): one that comes back that far past its start has walked its branch
  // backwards (or the branch overhangs the window by that much) and ends with a reason.
  constexpr double kBoundsMargin = 0.25;
  const double margin = kBoundsMargin * std::abs(w_to - w_from);
  options.lambda_min = std::max(0.0, std::min(w_from, w_to) - margin);
  options.lambda_max = std::max(w_from, w_to) + margin;
  options.initial_step = C.initial_step;
  options.min_step = C.min_step;
  options.max_step = C.max_step;
  options.target_newton_iterations = C.target_newton_iterations;
  options.max_points = C.max_points;
  options.max_wall_seconds = C.max_wall_seconds;
  options.reuse_factorisation_from = C.reuse_factorisation_from;
  options.turning_point_control = C.turning_point_control;
  options.steep_branch_alpha = C.steep_branch_alpha;
  options.newton.max_iterations = C.max_newton_iterations;
  options.newton.residual_tolerance = C.tolerance;
  options.newton.step_tolerance = C.tolerance;
  start.resonances = linear_resonances(scene, *model, options.lambda_min, options.lambda_max);
  options.step_bands = resonance_bands(start.resonances);
  options.unknown_scale = Eigen::VectorXd::Constant(n + 1, start.u_unit);
  options.unknown_scale(n) = unit;
  options.residual_scale = Eigen::VectorXd::Constant(n, peak);
  return start;
}

}  // namespace

void check_run_start(const Scene& scene) {
  start_run(scene, 1);
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
    std::string contacts;
    for (const auto& c : scene.contacts)
      contacts += (contacts.empty() ? "" : ", ") + c.name + " (" + c.plugin->name() + " " +
                  c.plugin->descriptor().version + ")";
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
    RunStart prepared;
    try {
      prepared = start_run(scene, run_options.contact_threads);
    } catch (const SceneError& e) {
      return fail(kExitInvalidInput, "invalid_input", e.what());
    }
    timing["setup_s"] = seconds_since(t_start);
    const auto& model = prepared.model;
    const ContinuationOptions options = prepared.options;
    const double peak = prepared.peak, u_unit = prepared.u_unit, span = prepared.span;
    const auto& C = scene.continuation;
    const double unit = C.to_rad_per_s();
    const double w_from = C.from * unit, w_to = C.to * unit;
    const Eigen::Index n = model->equation_count();
    spdlog::log(routine,
                "scene '{}': {} contact(s), {} unknowns ({} harmonics, {} samples), {} {} -> {} {}",
                scene.name.empty() ? scene.file.stem().string() : scene.name,
                model->contacts().size(), n, model->layout().harmonics().size(),
                model->layout().samples(), C.from, unit_name(C.unit), C.to, unit_name(C.unit));

    Eigen::VectorXd y0(n + 1);
    y0.head(n) = model->linear_response(w_from);
    y0(n) = w_from;
    // Start point: from the contact-free response; when Newton cannot get from there to
    // the solution (a contact far stiffer than the structure, stuck at a tiny fraction of
    // the free motion), from rest, then from the free response scaled down.
    const NewtonResult first = n > 0 ? solve_fixed_parameter(*model, y0, options) : NewtonResult{};
    if (first.converged) y0 = first.y;  // trace_curve then starts from the solution itself
    if (n > 0 && !first.converged) {
      for (const double shrink : {0.0, 1e-3, 1e-6}) {
        Eigen::VectorXd guess = y0;
        guess.head(n) *= shrink;
        const NewtonResult start = solve_fixed_parameter(*model, guess, options);
        if (start.converged) {
          spdlog::log(routine, "start point found from {} the contact-free response",
                      shrink == 0 ? std::string("zero instead of") : format_number(shrink) + " x");
          y0 = start.y;
          break;
        }
      }
    }

    const auto t_cont = Clock::now();
    double last_report = -1.0;
    auto progress = [&](const ContinuationPoint& p, std::size_t index) {
      if (interrupted()) return false;
      const double f = p.y(n) / unit;
      const double done = std::clamp((f - C.from) / (C.to - C.from), 0.0, 1.0);
      if (done - last_report >= 0.05 || index == 0) {
        last_report = done;
        spdlog::log(routine, "  [{:3.0f}%] point {:5d}  {:.6g} {}  Newton {}  step {:.3g}",
                    100 * done, index, f, unit_name(C.unit), p.newton_iterations, p.step);
      }
      return true;
    };
    // A scene without contacts is linear: its response is sampled on the frequency axis at
    // the largest step instead of traced (there is nothing to continue).
    ContinuationSummary summary;
    if (n == 0) {
      // The largest step, shortened near each resonance as the continuation's bands do.
      std::vector<double> ws = {w_from};
      const double largest = C.max_step * unit, direction = w_to > w_from ? 1.0 : -1.0;
      while (direction * (w_to - ws.back()) > 1e-12 * std::abs(w_to)) {
        const double advance = std::min(largest, options.band_advance(ws.back(), direction));
        ws.push_back(direction * (w_to - ws.back()) <= advance ? w_to
                                                               : ws.back() + direction * advance);
      }
      for (std::size_t i = 0; i < ws.size(); ++i) {
        ContinuationPoint p;
        p.y = Eigen::VectorXd::Constant(1, ws[i]);
        p.tangent = Eigen::VectorXd::Constant(1, w_to > w_from ? 1.0 : -1.0);
        p.step = i ? std::abs(ws[i] - ws[i - 1]) / unit : 0.0;
        summary.points.push_back(p);
      }
      summary.termination = TerminationType::kReachedEnd;
      summary.message = "linear scene (no contacts): sampled every " + format_number(C.max_step) +
                        " " + unit_name(C.unit) + ", finer near " +
                        std::to_string(options.step_bands.size()) + " resonance(s)";
    } else {
      summary = trace_curve(*model, y0, options, progress);
    }
    timing["continuation_s"] = seconds_since(t_cont);
    if (interrupted())
      return fail(interrupted_exit_code(), "interrupted",
                  scene.file.string() + ": interrupted by signal " +
                      std::to_string(interrupt_signal()) + " at point " +
                      std::to_string(summary.points.size()) + "; no output written");
    if (summary.reached_end())
      spdlog::log(routine,
                  "reached {} {} with {} points ({} rejected steps, {} turning points) in {:.3f} s",
                  C.to, unit_name(C.unit), summary.points.size(), summary.rejected_steps,
                  summary.turning_points, summary.wall_seconds);
    else
      spdlog::error("{}: the response curve ended early: {} ({}); {}", scene.file.string(),
                    to_string(summary.termination), summary.message, suggestion(summary, scene));

    // ---- post-processing ----
    const auto t_post = Clock::now();
    std::vector<NodeColumns> nodes;
    for (const auto& name : scene.output.response) {
      NodeColumns nc{name, {}};
      for (std::size_t d : scene.structure.find(name)->dofs)
        nc.kept.push_back(model->kept_index(d));
      nodes.push_back(nc);
    }
    const auto& harmonics = model->layout().harmonics();
    AmplitudeSampler sampler(harmonics, std::max(256, 8 * model->layout().samples()));
    std::vector<std::string> header = {"point", "frequency_hz", "omega_rad_s"};
    for (const auto& nc : nodes) {
      header.push_back(nc.name + "_amplitude_m");
      for (int h : harmonics) header.push_back(nc.name + "_h" + std::to_string(h) + "_m");
    }
    header.insert(header.end(), {"newton_iterations", "step", "condition"});
    std::vector<std::vector<double>> rows;
    nlohmann::json peaks = nlohmann::json::object();
    std::vector<double> peak_amp(nodes.size(), -1.0), peak_w(nodes.size(), 0.0);
    for (std::size_t i = 0; i < summary.points.size(); ++i) {
      const auto& p = summary.points[i];
      const double w = p.y(n);
      const auto x = model->kept_response(p.y);
      std::vector<double> row = {static_cast<double>(i), w / (2 * std::numbers::pi), w};
      for (std::size_t k = 0; k < nodes.size(); ++k) {
        const double amp = sampler.peak_amplitude(x, nodes[k].kept);
        row.push_back(amp);
        if (amp > peak_amp[k]) {
          peak_amp[k] = amp;
          peak_w[k] = w;
        }
        for (double a : AmplitudeSampler::harmonic_amplitudes(x, nodes[k].kept)) row.push_back(a);
      }
      row.push_back(p.newton_iterations);
      row.push_back(p.step);
      row.push_back(std::isfinite(p.condition) ? p.condition : 0.0);  // 0: not estimated
      rows.push_back(std::move(row));
    }

    // The highest point of each node's curve, refined between its neighbours.
    std::vector<bool> refined(nodes.size(), false);
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      std::size_t top = 0;
      for (std::size_t i = 1; i < rows.size(); ++i)
        if (rows[i][3 + k * (1 + harmonics.size())] > rows[top][3 + k * (1 + harmonics.size())])
          top = i;
      const auto refined_peak =
          refine_peak(*model, summary.points, top, nodes[k].kept, sampler, options);
      if (refined_peak && refined_peak->first >= peak_amp[k]) {
        peak_amp[k] = refined_peak->first;
        peak_w[k] = refined_peak->second;
        refined[k] = true;
      }
    }
    const nlohmann::json truncation = harmonic_truncation(scene, *model, summary, rows);
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      if (peak_amp[k] < 0) {  // no point on the curve: no peak
        peaks[nodes[k].name] = nullptr;
        continue;
      }
      peaks[nodes[k].name] = {{"amplitude_m", peak_amp[k]},
                              {"frequency_hz", peak_w[k] / (2 * std::numbers::pi)},
                              {"omega_rad_s", peak_w[k]},
                              {"refined", refined[k]}};
      outcome.peaks.push_back({nodes[k].name, peak_amp[k], peak_w[k], refined[k]});
    }

    // ---- outputs ----
    const bool plots = run_options.plots < 0 ? scene.output.plots : run_options.plots != 0;
    write_csv(out->path("response.csv"), header, rows);

    // Friction loops: every crossing of each requested frequency, solved exactly there.
    nlohmann::json loops = nlohmann::json::array();
    for (double f_req : scene.output.friction_loops_at) {
      const double w_req = f_req * unit;
      int crossing = 0;
      for (std::size_t i = 1; i < summary.points.size(); ++i) {
        const double wa = summary.points[i - 1].y(n), wb = summary.points[i].y(n);
        if ((wa - w_req) * (wb - w_req) > 0 || wa == wb) continue;
        if (wb == w_req && i + 1 < summary.points.size()) continue;  // counted at the next pair
        const double s = (w_req - wa) / (wb - wa);
        Eigen::VectorXd guess = (1 - s) * summary.points[i - 1].y + s * summary.points[i].y;
        guess(n) = w_req;
        const NewtonResult solved = solve_fixed_parameter(*model, guess, options);
        if (!solved.converged) {
          spdlog::warn("friction loop at {} {}: Newton did not converge ({})", f_req,
                       unit_name(C.unit), solved.message);
          continue;
        }
        ++crossing;
        for (std::size_t c = 0; c < model->contacts().size(); ++c) {
          ContactTrace trace;
          std::string error;
          if (!model->trace_contact(c, solved.y, trace, &error)) {
            spdlog::warn("friction loop: {}", error);
            continue;
          }
          const auto& contact = model->contacts()[c];
          const auto& comps = contact.tracer->components();
          static const char* names[] = {"t1", "t2", "n"};
          std::vector<std::string> lh = {"phase"};
          for (int a : comps) lh.push_back(std::string("u_") + names[a] + "_m");
          for (int a : comps) lh.push_back(std::string("f_") + names[a] + "_N");
          std::vector<std::vector<double>> lrows;
          const int samples = static_cast<int>(trace.displacement.rows());
          for (int j = 0; j <= samples; ++j) {  // closed loop: repeat the first sample
            const int jj = j % samples;
            std::vector<double> r = {static_cast<double>(j) / samples};
            for (Eigen::Index a = 0; a < trace.displacement.cols(); ++a)
              r.push_back(trace.displacement(jj, a));
            for (Eigen::Index a = 0; a < trace.force.cols(); ++a) r.push_back(trace.force(jj, a));
            lrows.push_back(std::move(r));
          }
          const std::string base = "loops/" + contact.name + "_" + format_number(f_req, 10) +
                                   unit_name(C.unit).substr(0, 2) + "_" + std::to_string(crossing);
          const fs::path csv = out->path(base + ".csv");
          write_csv(csv, lh, lrows);
          // Energy dissipated per cycle: the closed integral of f . du over the loop.
          double energy = 0;
          for (int j = 0; j < samples; ++j) {
            const int jn = (j + 1) % samples;
            for (Eigen::Index a = 0; a < trace.force.cols(); ++a)
              energy += 0.5 * (trace.force(j, a) + trace.force(jn, a)) *
                        (trace.displacement(jn, a) - trace.displacement(j, a));
          }
          // Harmonics of the contact force (thesis Fig. 5.6): at least up to 10, and up to
          // the highest kept harmonic, as far as the samples resolve them.
          const int shown =
              std::min((samples - 1) / 2, std::max(10, scene.harmonic_balance.harmonics.back()));
          const ForceHarmonics force_table = force_harmonics(trace.force, comps, shown);
          write_csv(out->path(base + "_harmonics.csv"), force_table.header, force_table.rows);
          nlohmann::json force_amplitudes = nlohmann::json::object();
          for (std::size_t a = 0; a < comps.size(); ++a)
            force_amplitudes[names[comps[a]]] = force_table.amplitude[a];
          loops.push_back({{"contact", contact.name},
                           {"frequency", f_req},
                           {"crossing", crossing},
                           {"file", base + ".csv"},
                           {"harmonics_file", base + "_harmonics.csv"},
                           {"force_harmonic_amplitudes_N", force_amplitudes},
                           {"dissipated_energy_per_cycle_J", energy},
                           {"trace_passes", trace.passes}});
          if (plots) {
            const fs::path gp = out->path(base + ".gp");
            write_text(gp, loop_plot_script(csv.string(),
                                            contact.name + " at " + format_number(f_req) + " " +
                                                unit_name(C.unit),
                                            static_cast<int>(comps.size())));
            run_gnuplot(gp);
          }
        }
      }
      if (crossing == 0)
        spdlog::warn("friction loop at {} {}: the response curve does not reach it", f_req,
                     unit_name(C.unit));
    }
    if (plots && !rows.empty()) {  // no points: no empty plot
      const fs::path gp = out->path("response.gp");
      write_text(gp, response_plot_script(scene, nodes));
      run_gnuplot(gp);
    }
    timing["post_and_output_s"] = seconds_since(t_post);
    timing["total_s"] = seconds_since(t_start);

    nlohmann::json plugins = nlohmann::json::array();
    plugins.push_back(plugin_json(*scene.structure.plugin));
    std::vector<std::string> listed = {scene.structure.plugin->name()};
    for (const auto& c : scene.contacts)
      if (std::find(listed.begin(), listed.end(), c.plugin->name()) == listed.end()) {
        listed.push_back(c.plugin->name());
        plugins.push_back(plugin_json(*c.plugin));
      }
    const auto& stats = model->stats();
    const TurningPointReport folds = report_turning_points(summary, n, unit, span);
    if (folds.micro_folds > 0)
      spdlog::warn(
          "{}: {} of the {} turning points come in clusters narrower than {} {} (near {} {}): "
          "micro-folds of the time grid of a non-smooth contact force, not physics; they "
          "shrink as harmonic_balance.samples_per_period grows (the outermost folds of a "
          "cluster are the physical ones)",
          scene.file.string(), folds.micro_folds, summary.turning_points,
          format_number(folds.cluster_width), unit_name(C.unit), format_number(folds.first_cluster),
          unit_name(C.unit));
    nlohmann::json condition = nullptr;
    if (!summary.points.empty() && summary.max_condition > 0.0) {
      const double worst = summary.max_condition;
      const double at = summary.points[summary.max_condition_point].y(n) / unit;
      condition = {{"max", std::isfinite(worst) ? nlohmann::json(worst) : nlohmann::json()},
                   {"frequency", at},
                   {"digits_lost", std::isfinite(worst) ? std::log10(worst) : 16.0}};
      if (!(worst <= kIllConditioned))
        spdlog::warn(
            "{}: the Newton matrix is ill-conditioned at {} {} (condition estimate {:.3g}: "
            "about {:.0f} of 16 digits lost in a Newton update); check for a rigid-body mode "
            "or a contact far stiffer than the structure, or set "
            "continuation.displacement_scale",
            scene.file.string(), format_number(at), unit_name(C.unit), worst,
            std::min(16.0, std::log10(worst)));
    }
    nlohmann::json last = nullptr;
    if (!summary.points.empty()) {
      const auto& p = summary.points.back();
      last = {{"frequency", p.y(n) / unit},
              {"omega_rad_s", p.y(n)},
              {"scaled_residual", p.residual_norm},
              {"newton_iterations", p.newton_iterations}};
    }
    nlohmann::json doc = {
        {"frichb_version", version()},
        {"scene", {{"file", scene.file.string()}, {"name", scene.name}}},
        {"termination",
         {{"reason", to_string(summary.termination)},
          {"reached_end", summary.reached_end()},
          {"message", summary.message},
          {"suggestion", suggestion(summary, scene)},
          {"last_point", last}}},
        {"points", summary.points.size()},
        {"rejected_steps", summary.rejected_steps},
        {"turning_points", summary.turning_points},
        {"turning_point_frequencies", folds.frequencies},
        {"micro_folds", folds.micro_folds},
        {"newton_condition", condition},
        {"fine_control_restarts", summary.fine_control_restarts},
        {"steep_branch_caps", summary.steep_branch_caps},
        {"residual_floor_points", summary.residual_floor_points},
        {"corners", summary.corners},
        {"kink_steps", summary.kink_steps},
        {"reversed_tangents", summary.reversed_tangents},
        {"newton_iterations", summary.total_newton_iterations},
        {"residual_evaluations", stats.residual_evaluations},
        {"jacobian_evaluations", stats.jacobian_evaluations},
        {"jacobian",
         {{"mode",
           model->jacobian_mode() == JacobianMode::kAnalytic ? "analytic" : "finite_difference"},
          {"contact_traces_with_finite_differences", stats.contacts_with_fd_jacobian}}},
        {"non_periodic_traces", stats.non_periodic_traces},
        {"resonance_bands", resonances_json(prepared.resonances, unit)},
        {"harmonic_truncation", truncation},
        {"unknowns", n},
        {"scaling", {{"displacement_m", u_unit}, {"residual_m", peak}}},
        {"peak", peaks},
        {"friction_loops", loops},
        {"wall_time_s", timing},
        {"profile", profile_json(summary, stats)},
        {"plugins", plugins},
        {"validated_scene", scene_to_json(scene)}};
    if (!stats.last_trace_diagnostic.empty())
      doc["last_trace_diagnostic"] = stats.last_trace_diagnostic;
    if (!run_options.study_context.is_null()) doc["study"] = run_options.study_context;
    if (!scene_overrides().empty()) {
      nlohmann::json set = nlohmann::json::object();
      for (const auto& o : scene_overrides()) set[o.path] = scene_override_json(o);
      doc["command_line_overrides"] = set;
    }
    if (stats.non_periodic_traces > 0)
      spdlog::warn(
          "{}: {} contact traces did not become periodic within "
          "harmonic_balance.max_trace_passes = {} passes (each costs that many passes; last: "
          "{}); a contact that sticks and slips in a limit cycle of its own, or a tolerance "
          "too tight for it: raise max_trace_passes if the curve changes, or raise "
          "trace_oversampling",
          scene.file.string(), stats.non_periodic_traces, scene.harmonic_balance.max_trace_passes,
          stats.last_trace_diagnostic);
    if (stats.contacts_with_fd_jacobian && model->jacobian_mode() == JacobianMode::kAnalytic)
      spdlog::warn("{} contact traces used finite differences (a law without tangents)",
                   stats.contacts_with_fd_jacobian);
    if (interrupted())
      return fail(interrupted_exit_code(), "interrupted",
                  scene.file.string() + ": interrupted by signal " +
                      std::to_string(interrupt_signal()) + " while writing; no output written");
    write_json(out->path("summary.json"), doc);
    out->commit();
    outcome.wrote_output = true;
    outcome.exit_code = summary.reached_end() ? kExitOk : kExitIncomplete;
    outcome.termination = to_string(summary.termination);
    outcome.message = summary.message;
    outcome.points = summary.points.size();
    outcome.wall_seconds = seconds_since(t_start);
    spdlog::log(routine, "wrote {} ({} points; total {:.3f} s)", out_dir.string(), rows.size(),
                outcome.wall_seconds);
    return outcome;
  } catch (const OutputError& e) {
    return fail(e.user_error() ? kExitInvalidInput : kExitOutput, "output_error",
                scene.file.string() + ": writing the outputs: " + e.what());
  } catch (const std::exception& e) {
    return fail(kExitInternal, "internal_error", scene.file.string() + ": " + e.what());
  }
}

}  // namespace frichb::core
