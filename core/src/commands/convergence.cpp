#include "frichb/core/commands/convergence.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <numbers>
#include <optional>
#include <set>
#include <sstream>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/commands/timesim.hpp"
#include "frichb/core/report/failure.hpp"
#include "frichb/core/report/output.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/support/interrupt.hpp"
#include "frichb/core/support/version.hpp"

namespace frichb::core {

namespace fs = std::filesystem;

namespace {

struct Setting {
  int max_harmonic = 0, samples = 0, oversampling = 1;
  std::vector<int> harmonics;
  std::string id;
};

struct Row {
  Setting setting;
  RunOutcome outcome;
  long unknowns = 0;
  double amplitude = NAN, frequency = NAN;  // peak of the study node, m and Hz
};

// The kept harmonics for a largest harmonic H, following the scene's pattern: odd only when
// the scene keeps only odd ones; from 0 when the scene keeps 0; otherwise from 1.
std::vector<int> harmonics_like(const std::vector<int>& scene, int max_harmonic) {
  const bool odd_only = std::all_of(scene.begin(), scene.end(), [](int n) { return n % 2 == 1; });
  const bool with_zero = std::find(scene.begin(), scene.end(), 0) != scene.end();
  std::vector<int> kept;
  for (int n = with_zero ? 0 : 1; n <= max_harmonic; ++n)
    if (!odd_only || n % 2 == 1) kept.push_back(n);
  return kept;
}

std::string number(double x, int precision = 6) {
  std::ostringstream os;
  os << std::setprecision(precision) << x;
  return os.str();
}

std::string cell(double x) {
  return std::isfinite(x) ? number(x, 12) : std::string();
}

double relative_error(double value, double reference) {
  if (!std::isfinite(value) || !std::isfinite(reference) || reference == 0) return NAN;
  return std::abs(value - reference) / std::abs(reference);
}

// The settings of a study, coarse to fine, the reference (the finest) last.
struct Ladder {
  std::vector<Setting> settings;
  int h_max = 0, n_max = 0, o_max = 0;  // the reference's H, N and oversampling
  bool is_reference(const Setting& s) const {
    return s.max_harmonic == h_max && s.samples == n_max && s.oversampling == o_max;
  }
  // The finest setting is valid (N >= 2H + 1, every excited harmonic kept).
  bool valid() const { return !settings.empty() && is_reference(settings.back()); }
};

// Every combination of the requested H, N and o that is a valid setting for `base`: N >= 2H + 1,
// o in [1, 64], every excited harmonic kept. The reference goes last.
Ladder build_ladder(const ConvergenceRequest& request, const Scene& base) {
  std::set<int> excited;
  for (const auto& e : base.excitation) excited.insert(e.harmonic);
  Ladder ladder;
  ladder.h_max = *std::max_element(request.harmonics.begin(), request.harmonics.end());
  ladder.n_max = *std::max_element(request.samples.begin(), request.samples.end());
  ladder.o_max = *std::max_element(request.oversampling.begin(), request.oversampling.end());
  for (int o : std::set<int>(request.oversampling.begin(), request.oversampling.end()))
    for (int h : std::set<int>(request.harmonics.begin(), request.harmonics.end()))
      for (int n : std::set<int>(request.samples.begin(), request.samples.end())) {
        if (h < 1 || n < 2 * static_cast<long long>(h) + 1 || o < 1 || o > 64) continue;
        Setting s{h, n, o, harmonics_like(base.harmonic_balance.harmonics, h), ""};
        if (!std::all_of(excited.begin(), excited.end(), [&](int e) {
              return std::find(s.harmonics.begin(), s.harmonics.end(), e) != s.harmonics.end();
            }))
          continue;
        s.id = "H" + std::to_string(h) + "_N" + std::to_string(n) + "_o" + std::to_string(o);
        ladder.settings.push_back(std::move(s));
      }
  std::stable_partition(ladder.settings.begin(), ladder.settings.end(),
                        [&](const Setting& s) { return !ladder.is_reference(s); });
  return ladder;
}

// The scene re-read with the setting's harmonic-balance keys, run into runs/<id>. A setting
// the scene refuses (e.g. a key out of range) gives a row with invalid_input.
Row run_setting(const Scene& base, const Registry& registry, const Setting& s,
                const std::string& node, const StagedOutput& out) {
  Row row{s, {}, 0, NAN, NAN};
  try {
    YAML::Node document = load_scene_document(base.file);
    YAML::Node hb = document["harmonic_balance"];
    hb.remove("max_harmonic");
    hb["harmonics"] = s.harmonics;
    hb["samples_per_period"] = s.samples;
    hb["trace_oversampling"] = s.oversampling;
    Scene scene = load_scene(document, base.file);
    bind_plugins(scene, registry);
    RunOptions options;
    options.quiet = true;
    options.plots = 0;
    options.study_context = {{"convergence_setting", s.id}};
    row.outcome = run_bound_scene(scene, out.path("runs") / s.id, options);
  } catch (const std::exception& e) {  // this setting only (e.g. a key out of range)
    row.outcome.exit_code = kExitInvalidInput;
    row.outcome.termination = "invalid_input";
    row.outcome.message = e.what();
    spdlog::warn("{}: {}", s.id, e.what());
  }
  for (const auto& p : row.outcome.peaks)
    if (p.node == node) {
      row.amplitude = p.amplitude_m;
      row.frequency = p.omega_rad_s / (2 * std::numbers::pi);
    }
  if (row.outcome.wrote_output) {
    std::ifstream in(out.path("runs") / s.id / "summary.json");
    row.unknowns = nlohmann::json::parse(in).value("unknowns", 0L);
  }
  return row;
}

// Runs every setting serially, in order; no rows when a signal stopped the study.
std::optional<std::vector<Row>> run_settings(const Scene& base, const Registry& registry,
                                             const std::vector<Setting>& settings,
                                             const std::string& node, const StagedOutput& out) {
  std::vector<Row> rows;
  for (std::size_t i = 0; i < settings.size(); ++i) {
    if (interrupted()) {
      spdlog::error("{}: interrupted by signal {} after {} of {} settings; no output written",
                    base.file.string(), interrupt_signal(), i, settings.size());
      return std::nullopt;
    }
    Row row = run_setting(base, registry, settings[i], node, out);
    spdlog::info("[{}/{}] {}: {} unknowns, peak {} m at {} Hz, {:.3f} s ({})", i + 1,
                 settings.size(), row.setting.id, row.unknowns, number(row.amplitude),
                 number(row.frequency, 8), row.outcome.wall_seconds, row.outcome.termination);
    rows.push_back(std::move(row));
  }
  const Row& reference = rows.back();
  if (reference.outcome.exit_code != kExitOk)
    spdlog::warn(
        "the reference setting {} did not reach the end of its sweep ({}): its peak, and so "
        "every error, is only as good as the part of the curve it traced",
        reference.setting.id, reference.outcome.termination);
  return rows;
}

// The time-integration reference at the reference setting's peak frequency: its record for
// convergence.json (null when not run) and its amplitude (NaN unless periodic).
struct TimesimReference {
  nlohmann::json record = nullptr;
  double amplitude = NAN;
};

TimesimReference timesim_reference(const ConvergenceRequest& request, const Scene& base,
                                   const std::string& node, const Row& reference) {
  TimesimReference timesim;
  if (!request.time_integration || base.cyclic.enabled() || !std::isfinite(reference.frequency))
    return timesim;
  try {
    TimesimOptions options;
    options.frequency_hz = reference.frequency;
    options.steps_per_period = request.timesim_steps_per_period;
    const TimesimResult result = simulate_in_time(base, options);
    for (const auto& n : result.nodes)
      if (n.node == node) timesim.amplitude = n.amplitude_m;
    timesim.record = {{"frequency_hz", reference.frequency},
                      {"amplitude_m", timesim.amplitude},
                      {"periodic", result.periodic},
                      {"periods", result.periods},
                      {"steps_per_period", options.steps_per_period},
                      {"wall_s", result.wall_seconds}};
    if (!result.periodic) timesim.amplitude = NAN;
    spdlog::info("time integration at {} Hz: amplitude {} m ({} periods, {:.1f} s)",
                 number(reference.frequency, 8), number(timesim.amplitude), result.periods,
                 result.wall_seconds);
  } catch (const std::exception& e) {
    spdlog::warn("time-integration reference skipped: {}", e.what());
  }
  return timesim;
}

// A row's relative errors: against the reference setting (0 for the reference itself) and
// against the time-integration amplitude; NaN where there is nothing to compare.
struct Errors {
  double amplitude = NAN, frequency = NAN, timesim = NAN;
};

Errors errors_of(const Row& r, const Row& reference, double timesim_amplitude) {
  const bool ref = &r == &reference;
  return {ref ? 0.0 : relative_error(r.amplitude, reference.amplitude),
          ref ? 0.0 : relative_error(r.frequency, reference.frequency),
          relative_error(r.amplitude, timesim_amplitude)};
}

std::string csv_line(const Row& r, const Errors& e) {
  std::ostringstream csv;
  csv << r.setting.id << "," << r.setting.max_harmonic << "," << r.setting.samples << ","
      << r.setting.oversampling << "," << r.unknowns << "," << r.outcome.termination << ","
      << cell(r.amplitude) << "," << cell(r.frequency) << "," << cell(e.amplitude) << ","
      << cell(e.frequency) << "," << cell(e.timesim) << "," << cell(r.outcome.wall_seconds) << "\n";
  return csv.str();
}

std::string markdown_line(const Row& r, const Errors& e, bool ref) {
  auto sci = [](double x) { return std::isfinite(x) ? number(x, 3) : std::string("-"); };
  std::ostringstream md;
  md << "| " << r.setting.max_harmonic << " | " << r.setting.samples << " | "
     << r.setting.oversampling << " | " << r.unknowns << " | " << number(r.amplitude, 6) << " | "
     << number(r.frequency, 7) << " | " << (ref ? "reference" : sci(e.amplitude)) << " | "
     << (ref ? "reference" : sci(e.frequency)) << " | " << sci(e.timesim) << " | "
     << number(r.outcome.wall_seconds, 3) << " | " << r.outcome.termination << " |\n";
  return md.str();
}

nlohmann::json json_row(const Row& r, const Errors& e) {
  nlohmann::json j = {{"setting", r.setting.id},
                      {"harmonics", r.setting.harmonics},
                      {"samples_per_period", r.setting.samples},
                      {"trace_oversampling", r.setting.oversampling},
                      {"unknowns", r.unknowns},
                      {"termination", r.outcome.termination},
                      {"message", r.outcome.message},
                      {"wall_s", r.outcome.wall_seconds}};
  if (std::isfinite(r.amplitude)) {
    j["peak_amplitude_m"] = r.amplitude;
    j["peak_frequency_hz"] = r.frequency;
  }
  if (std::isfinite(e.amplitude)) j["amplitude_error"] = e.amplitude;
  if (std::isfinite(e.frequency)) j["frequency_error"] = e.frequency;
  if (std::isfinite(e.timesim)) j["amplitude_error_vs_timesim"] = e.timesim;
  return j;
}

// convergence.csv, convergence.md and convergence.json: one row per setting, errors against
// the last row (the reference).
void write_tables(const StagedOutput& out, const Scene& base, const std::string& node,
                  const std::vector<Row>& rows, const TimesimReference& timesim, int incomplete) {
  const Row& reference = rows.back();
  std::ostringstream csv, md;
  csv << "setting,max_harmonic,samples_per_period,trace_oversampling,unknowns,termination,"
         "peak_amplitude_m,peak_frequency_hz,amplitude_error,frequency_error,"
         "amplitude_error_vs_timesim,wall_s\n";
  md << "| H | N | oversampling | unknowns | peak amplitude [m] | peak frequency [Hz] | "
        "amplitude error | frequency error | error vs time integration | wall time [s] | "
        "termination |\n"
     << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  nlohmann::json table = nlohmann::json::array();
  for (const Row& r : rows) {
    const Errors e = errors_of(r, reference, timesim.amplitude);
    csv << csv_line(r, e);
    md << markdown_line(r, e, &r == &reference);
    table.push_back(json_row(r, e));
  }
  write_text(out.path("convergence.csv"), csv.str());
  write_text(out.path("convergence.md"), md.str());
  write_json(out.path("convergence.json"),
             {{"frichb_version", version()},
              {"scene", {{"file", base.file.string()}, {"name", base.name}}},
              {"node", node},
              {"reference", reference.setting.id},
              {"time_integration", timesim.record},
              {"settings", table},
              {"incomplete_settings", incomplete},
              {"note",
               "errors are relative to the reference setting (the finest), and to the "
               "time-integration amplitude at the reference's peak frequency; wall times "
               "are of serial runs on this machine"}});
}

// convergence.gp and, through gnuplot, convergence.png: error against wall time, log-log;
// one series per oversampling factor.
void write_plot(const StagedOutput& out, const ConvergenceRequest& request, const Scene& base,
                const std::string& reference_id, double timesim_amplitude) {
  std::ostringstream gp;
  gp << "# gnuplot script written by frichb convergence; `gnuplot convergence.gp`\n"
     << "set terminal pngcairo size 1200,520 noenhanced\nset output 'convergence.png'\n"
     << "set datafile separator ','\nset logscale xy\nset grid\nset key bottom left\n"
     << "set xlabel 'wall time of the run [s]'\nset multiplot layout 1,2 title "
     << gnuplot_string((base.name.empty() ? base.file.stem().string() : base.name) +
                       ": error against run time (reference " + reference_id + ")")
     << "\n";
  const char* columns[] = {"amplitude_error", "frequency_error"};
  const char* titles[] = {"peak amplitude error (relative)", "peak frequency error (relative)"};
  for (int k = 0; k < 2; ++k) {
    gp << "set ylabel '" << titles[k] << "'\nplot ";
    bool first = true;
    for (int o : std::set<int>(request.oversampling.begin(), request.oversampling.end())) {
      gp << (first ? "" : ", \\\n     ") << "'convergence.csv' using (column(4) == " << o
         << " && column('" << columns[k] << "') > 0 ? column('wall_s') : 1/0):(column('"
         << columns[k] << "')) with points pt 7 ps 1.2 title 'oversampling " << o << "'";
      first = false;
    }
    if (k == 0 && std::isfinite(timesim_amplitude))
      gp << ", \\\n     'convergence.csv' using (column('wall_s')):(column("
            "'amplitude_error_vs_timesim') > 0 ? column('amplitude_error_vs_timesim') : "
            "1/0) with points pt 6 ps 1.2 title 'vs time integration'";
    gp << "\n";
  }
  gp << "unset multiplot\n";
  write_text(out.path("convergence.gp"), gp.str());
  run_gnuplot(out.path("convergence.gp"));
}

// Runs the ladder and writes its outputs into `out_dir` (staged, committed at the end).
int run_ladder(const ConvergenceRequest& request, const Scene& base, const Registry& registry,
               const Ladder& ladder, const fs::path& out_dir) {
  const std::string node = base.output.response.front();
  StagedOutput out(out_dir, {"convergence.csv", "convergence.json", "convergence.md",
                             "convergence.gp", "convergence.png", "runs"});
  spdlog::info("convergence of {}: {} settings, reference H = {}, N = {}, oversampling {} -> {}",
               base.file.string(), ladder.settings.size(), ladder.h_max, ladder.n_max, ladder.o_max,
               out_dir.string());
  const auto rows = run_settings(base, registry, ladder.settings, node, out);
  if (!rows) return interrupted_exit_code();
  const int incomplete = static_cast<int>(std::count_if(
      rows->begin(), rows->end(), [](const Row& r) { return r.outcome.exit_code != kExitOk; }));
  const TimesimReference timesim = timesim_reference(request, base, node, rows->back());
  write_tables(out, base, node, *rows, timesim, incomplete);
  if (base.output.plots) write_plot(out, request, base, rows->back().setting.id, timesim.amplitude);
  if (interrupted()) {  // a signal while gnuplot ran: nothing is committed
    spdlog::error("interrupted by signal {}; no output written", interrupt_signal());
    return interrupted_exit_code();
  }
  out.commit();
  spdlog::info("wrote {} ({} settings, {} ended early)", out_dir.string(), rows->size(),
               incomplete);
  return incomplete ? kExitIncomplete : kExitOk;
}

}  // namespace

int run_convergence(const ConvergenceRequest& request) {
  Scene base;
  std::unique_ptr<Registry> registry;
  if (!load_bound_scene(request.scene_file, base, registry)) return kExitInvalidInput;
  if (request.harmonics.empty() || request.samples.empty() || request.oversampling.empty()) {
    spdlog::error("convergence: give at least one harmonic count, sample count and oversampling");
    return kExitInvalidInput;
  }
  if (base.output.response.empty()) {
    spdlog::error("{}: convergence needs a response node (output.response)",
                  request.scene_file.string());
    return kExitInvalidInput;
  }
  const Ladder ladder = build_ladder(request, base);
  if (!ladder.valid()) {
    spdlog::error(
        "convergence: the finest setting (H = {}, N = {}, oversampling {}) is not valid: N must "
        "be >= 2H + 1 and every excited harmonic kept",
        ladder.h_max, ladder.n_max, ladder.o_max);
    return kExitInvalidInput;
  }
  fs::path out_dir = request.output_directory;
  if (out_dir.empty()) out_dir = fs::path("out") / (base.file.stem().string() + "-convergence");
  try {
    return run_ladder(request, base, *registry, ladder, out_dir);
  } catch (...) {
    return report_failure(request.scene_file.string());
  }
}

}  // namespace frichb::core
