#include "frichb/core/commands/convergence.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numbers>
#include <optional>
#include <set>
#include <sstream>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/commands/timesim.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/support/format.hpp"
#include "frichb/core/support/interrupt.hpp"

namespace frichb::core {

namespace fs = std::filesystem;

namespace {

using Setting = ConvergenceSetting;
using Row = ConvergenceRow;

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

// The scene re-read with the setting's harmonic-balance keys, run and handed to the request's
// writer. A setting the scene refuses (e.g. a key out of range) gives a row with invalid_input.
Row run_setting(const Scene& base, const Registry& registry, const Setting& s,
                const std::string& node, const RunWriter& write_run, const fs::path& runs_folder,
                const StopToken& stop) {
  Row row{s, {}};
  try {
    YAML::Node document = reread_scene_document(base);
    YAML::Node hb = document["harmonic_balance"];
    hb.remove("max_harmonic");
    hb["harmonics"] = s.harmonics;
    hb["samples_per_period"] = s.samples;
    hb["trace_oversampling"] = s.oversampling;
    Scene scene = load_scene_variant(document, base);
    bind_plugins(scene, registry);
    RunOptions options;
    options.stop = stop;
    options.quiet = true;
    options.plots = 0;
    options.compare_with_tuned = false;  // the settings' curves alone are compared
    options.study_context = {{"convergence_setting", s.id}};
    const RunWriter nowhere = [](const RunResult&, const fs::path&) {};
    row.outcome = run_member(scene, runs_folder / s.id, options, write_run ? write_run : nowhere);
    if (!write_run) row.outcome.wrote_output = false;
  } catch (const std::exception& e) {  // this setting only (e.g. a key out of range)
    row.outcome.exit_code = kExitInvalidInput;
    row.outcome.termination = "invalid_input";
    row.outcome.message = e.what();
    spdlog::warn("{}: {}", s.id, e.what());
  }
  for (const auto& p : row.outcome.peaks)
    if (p.node == node) {
      row.amplitude_m = p.amplitude_m;
      row.frequency_hz = p.omega_rad_s / (2 * std::numbers::pi);
    }
  return row;
}

// Runs every setting serially, in order, until a stop on `stop` (then fewer rows).
std::vector<Row> run_settings(const Scene& base, const Registry& registry,
                              const std::vector<Setting>& settings, const std::string& node,
                              const RunWriter& write_run, const fs::path& runs_folder,
                              const StopToken& stop) {
  std::vector<Row> rows;
  for (std::size_t i = 0; i < settings.size(); ++i) {
    if (stop.stop_requested()) return rows;
    Row row = run_setting(base, registry, settings[i], node, write_run, runs_folder, stop);
    spdlog::info("[{}/{}] {}: {} unknowns, peak {} m at {} Hz, {:.3f} s ({})", i + 1,
                 settings.size(), row.setting.id, row.outcome.unknowns,
                 format_number(row.amplitude_m), format_number(row.frequency_hz, 8),
                 row.outcome.wall_seconds, row.outcome.termination);
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

// The time-integration reference at the reference setting's peak frequency.
ConvergenceTimesim timesim_reference(const ConvergenceRequest& request, const Scene& base,
                                     const std::string& node, const Row& reference) {
  ConvergenceTimesim timesim;
  if (!request.time_integration || base.cyclic.enabled() || !std::isfinite(reference.frequency_hz))
    return timesim;
  try {
    TimesimOptions options;
    options.frequency_hz = reference.frequency_hz;
    options.steps_per_period = request.timesim_steps_per_period;
    options.stop = request.stop;
    const TimesimResult result = simulate_in_time(base, options);
    if (result.outcome.status >= 128) return timesim;  // stopped: the caller says so
    timesim.run = true;
    timesim.frequency_hz = reference.frequency_hz;
    for (const auto& n : result.nodes)
      if (n.node == node) timesim.amplitude_m = n.amplitude_m;
    timesim.periodic = result.periodic;
    timesim.periods = result.periods;
    timesim.steps_per_period = options.steps_per_period;
    timesim.wall_seconds = result.wall_seconds;
    spdlog::info("time integration at {} Hz: amplitude {} m ({} periods, {:.1f} s)",
                 format_number(reference.frequency_hz, 8), format_number(timesim.amplitude_m),
                 result.periods, result.wall_seconds);
  } catch (const std::exception& e) {
    spdlog::warn("time-integration reference skipped: {}", e.what());
  }
  return timesim;
}

}  // namespace

ConvergenceResult study_convergence(const ConvergenceRequest& request) {
  const BoundScene bound = load_bound_scene(request.scene);
  const Scene& base = bound.scene;
  const std::string file = base.file.string();
  if (request.harmonics.empty() || request.samples.empty() || request.oversampling.empty())
    throw SceneError(file, 0, 0, "",
                     "convergence: give at least one harmonic count, sample count and "
                     "oversampling");
  if (base.output.response.empty())
    throw SceneError(file, 0, 0, "output.response",
                     "convergence needs a response node (output.response)");
  const Ladder ladder = build_ladder(request, base);
  if (!ladder.valid())
    throw SceneError(file, 0, 0, "",
                     "convergence: the finest setting (H = " + std::to_string(ladder.h_max) +
                         ", N = " + std::to_string(ladder.n_max) + ", oversampling " +
                         std::to_string(ladder.o_max) +
                         ") is not valid: N must be >= 2H + 1 and every excited harmonic kept");
  ConvergenceResult result;
  result.scene_file = base.file;
  result.scene_name = base.name;
  result.node = base.output.response.front();
  result.plots = base.output.plots;
  const std::set<int> factors(request.oversampling.begin(), request.oversampling.end());
  result.oversampling.assign(factors.begin(), factors.end());
  spdlog::info("convergence of {}: {} settings, reference H = {}, N = {}, oversampling {}", file,
               ladder.settings.size(), ladder.h_max, ladder.n_max, ladder.o_max);
  const bool written = request.stage_runs && request.write_run;
  const fs::path runs_folder = written ? request.stage_runs() : fs::path();
  result.rows = run_settings(base, *bound.registry, ladder.settings, result.node,
                             written ? request.write_run : RunWriter(), runs_folder, request.stop);
  auto interrupted_after = [&](const std::string& what) {
    result.outcome = {
        request.stop.exit_code(), "interrupted", request.stop.reason() + " " + what, {}};
    return std::move(result);
  };
  if (request.stop.stop_requested()) {
    // A setting stopped while it ran is not a row of the table.
    std::size_t done = result.rows.size();
    if (done > 0 && result.rows.back().outcome.exit_code >= 128) --done;
    return interrupted_after("after " + std::to_string(done) + " of " +
                             std::to_string(ladder.settings.size()) + " settings");
  }
  result.timesim = timesim_reference(request, base, result.node, result.rows.back());
  if (request.stop.stop_requested())
    return interrupted_after("during the time-integration reference");
  const ConvergenceRow& reference = result.rows.back();
  for (auto& r : result.rows) {
    const bool is_reference = &r == &reference;
    r.amplitude_error = is_reference ? 0.0 : relative_error(r.amplitude_m, reference.amplitude_m);
    r.frequency_error = is_reference ? 0.0 : relative_error(r.frequency_hz, reference.frequency_hz);
    r.amplitude_error_vs_timesim = relative_error(r.amplitude_m, result.timesim.compared());
  }
  result.incomplete_settings = static_cast<int>(
      std::count_if(result.rows.begin(), result.rows.end(),
                    [](const ConvergenceRow& r) { return r.outcome.exit_code != kExitOk; }));
  if (result.incomplete_settings > 0)
    result.outcome = {kExitIncomplete,
                      "settings_incomplete",
                      std::to_string(result.incomplete_settings) + " of " +
                          std::to_string(result.rows.size()) + " settings ended early",
                      {}};
  spdlog::info("{} settings, {} ended early", result.rows.size(), result.incomplete_settings);
  return result;
}

}  // namespace frichb::core
