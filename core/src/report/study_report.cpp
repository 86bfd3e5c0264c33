#include "frichb/core/report/study_report.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "frichb/core/support/format.hpp"
#include "frichb/core/support/version.hpp"

namespace frichb::core {

namespace {

// The CSV cell of a number (empty when not finite: a failed run has no peak).
std::string cell(double x) {
  return std::isfinite(x) ? format_number(x, 12) : std::string();
}

// A CSV field: quoted when it holds a comma, a quote or a line break.
std::string csv_text(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c == '\n' ? ' ' : c);
  return q + "\"";
}

// study.csv's text and study.json's runs.
struct StudyIndex {
  std::string csv;
  nlohmann::json runs = nlohmann::json::array();
};

StudyIndex study_index(const StudyResult& r) {
  const StudySpec& study = r.study;
  const auto& runs = r.runs;
  const double unit = r.unit == FrequencyUnit::kHz ? 2 * std::numbers::pi : 1.0;
  const std::string fcol = r.unit == FrequencyUnit::kHz ? "hz" : "rad_s";
  // study.csv: one row per run.
  std::ostringstream csv;
  csv << "run";
  for (const auto& s : study.sweeps) csv << "," << csv_text(s.path);
  csv << ",exit_code,termination,points";
  for (const auto& node : r.response)
    csv << "," << node << "_peak_amplitude_m," << node << "_peak_frequency_" << fcol;
  csv << ",wall_s\n";
  StudyIndex index;
  for (const auto& run : runs) {
    const RunOutcome& o = run.outcome;
    csv << run.id;
    for (double x : run.values) csv << "," << cell(x);
    csv << "," << o.exit_code << "," << o.termination << "," << o.points;
    nlohmann::json peaks = nlohmann::json::object();
    for (const auto& node : r.response) {
      double amp = std::numeric_limits<double>::quiet_NaN(), w = amp;
      for (const auto& p : o.peaks)
        if (p.node == node) {
          amp = p.amplitude_m;
          w = p.omega_rad_s;
        }
      csv << "," << cell(amp) << "," << cell(w / unit);
      if (std::isfinite(amp))
        peaks[node] = {{"amplitude_m", amp}, {"frequency", w / unit}, {"omega_rad_s", w}};
    }
    csv << "," << cell(o.wall_seconds) << "\n";
    nlohmann::json params = nlohmann::json::object();
    for (std::size_t s = 0; s < study.sweeps.size(); ++s)
      params[study.sweeps[s].path] = run.values[s];
    index.runs.push_back({{"run", run.id},
                          {"folder", o.wrote_output ? "runs/" + run.id : ""},
                          {"parameters", params},
                          {"exit_code", o.exit_code},
                          {"termination", o.termination},
                          {"message", o.message},
                          {"points", o.points},
                          {"peak", peaks},
                          {"wall_s", o.wall_seconds}});
  }
  index.csv = csv.str();
  return index;
}

// study.json: the study's settings, every run's index entry and the optimum.
nlohmann::json study_json(const StudyResult& r, const StudyIndex& index) {
  const StudySpec& study = r.study;
  nlohmann::json sweeps = nlohmann::json::array();
  for (const auto& s : study.sweeps) sweeps.push_back({{"path", s.path}, {"values", s.values}});
  nlohmann::json optimum = nullptr;
  if (r.optimum < r.runs.size())
    optimum = {{"run", r.runs[r.optimum].id},
               {"node", study.node},
               {"parameters", index.runs[r.optimum]["parameters"]},
               {"peak_amplitude_m", r.optimum_amplitude_m},
               {"among", "runs that reached the end of their sweep"}};
  return {{"frichb_version", version()},
          {"scene", {{"file", r.scene_file.string()}, {"name", r.scene_name}}},
          {"sweeps", sweeps},
          {"combine", study.zip ? "zip" : "grid"},
          {"processes", r.processes},
          {"threads_per_process", r.threads},
          {"node", study.node},
          {"frequency_unit", unit_name(r.unit)},
          {"runs", index.runs},
          {"failed_runs", r.failed_runs},
          {"optimum", optimum},
          {"wall_s", r.wall_seconds}};
}

// overlay.gp/png: the response curves of study.node, one line per run that wrote its output
// (nothing when none did).
void write_overlay_plot(const StudyResult& r, const std::string& title, StagedOutput& out) {
  const StudySpec& study = r.study;
  const auto& runs = r.runs;
  std::ostringstream gp;
  gp << "# gnuplot script written by frichb study; `gnuplot overlay.gp` remakes it\n"
     << "set terminal pngcairo size 1100,700 noenhanced\nset output 'overlay.png'\n"
     << "set datafile separator ','\nset grid\nset key outside right top\n"
     << "set title " << gnuplot_string(title + ": " + study.node + " over the study") << "\n"
     << "set xlabel 'frequency [" << unit_name(r.unit) << "]'\n"
     << "set ylabel 'amplitude [m]'\n"
     << "set palette defined (0 '#1f4fbf', 0.5 '#2ca02c', 1 '#d62728')\nunset colorbox\n"
     << "plot ";
  bool first = true;
  const int xcol = r.unit == FrequencyUnit::kHz ? 2 : 3;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    if (!runs[i].outcome.wrote_output) continue;
    std::string label;
    for (std::size_t s = 0; s < study.sweeps.size(); ++s)
      label += (s ? ", " : "") +
               study.sweeps[s].path.substr(study.sweeps[s].path.find_last_of('.') + 1) + "=" +
               format_number(runs[i].values[s]);
    gp << (first ? "" : ", \\\n     ") << gnuplot_string("runs/" + runs[i].id + "/response.csv")
       << " using " << xcol << ":(column(" << gnuplot_string(study.node + "_amplitude_m")
       << ")) with lines lw 1.5 lc palette frac "
       << (runs.size() > 1 ? static_cast<double>(i) / static_cast<double>(runs.size() - 1) : 0.0)
       << " title " << gnuplot_string(label);
    first = false;
  }
  gp << "\n";
  if (!first) {
    write_text(out.path("overlay.gp"), gp.str());
    run_gnuplot(out.path("overlay.gp"), out.stop());
  }
}

// The plot command of peak.gp when the grid has more than one axis: the first axis on x, one
// line per combination of the sweeps of the other axes.
std::string peak_plot_per_combination(const StudyResult& r, std::size_t first_axis, int peak_col) {
  const StudySpec& study = r.study;
  std::vector<std::vector<double>> others;
  for (const auto& run : r.runs) {
    std::vector<double> rest(run.values.begin() + static_cast<std::ptrdiff_t>(first_axis),
                             run.values.end());
    if (std::find(others.begin(), others.end(), rest) == others.end()) others.push_back(rest);
  }
  std::ostringstream pk;
  pk << "plot ";
  for (std::size_t g = 0; g < others.size(); ++g) {
    std::string cond = "1", label;
    for (std::size_t s = first_axis; s < study.sweeps.size(); ++s) {
      const double value = others[g][s - first_axis];
      cond += " && abs(column(" + std::to_string(s + 2) + ") - (" + format_scene_value(value) +
              ")) <= 1e-9 * (1 + abs(" + format_scene_value(value) + "))";
      label += (s > first_axis ? ", " : "") +
               study.sweeps[s].path.substr(study.sweeps[s].path.find_last_of('.') + 1) + "=" +
               format_number(value);
    }
    pk << (g ? ", \\\n     " : "") << "'study.csv' using 2:((" << cond << ") ? column(" << peak_col
       << ") : 1/0) with linespoints pt 7 lw 2 title " << gnuplot_string(label);
  }
  pk << "\n";
  return pk.str();
}

// peak.gp/png: the peak amplitude of study.node (from study.csv) against the first swept value.
void write_peak_plot(const StudyResult& r, const std::string& title, StagedOutput& out) {
  const StudySpec& study = r.study;
  const auto& response = r.response;
  const auto& s0 = study.sweeps.front();
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  for (double x : s0.values) {
    lo = std::min(lo, x);
    hi = std::max(hi, x);
  }
  std::ostringstream pk;
  pk << "# gnuplot script written by frichb study; `gnuplot peak.gp` remakes it\n"
     << "set terminal pngcairo size 900,600 noenhanced\nset output 'peak.png'\n"
     << "set datafile separator ','\nset grid\nset key outside right top\n"
     << "set title " << gnuplot_string(title + ": peak amplitude of " + study.node) << "\n"
     << "set xlabel " << gnuplot_string(s0.path) << "\nset ylabel 'peak amplitude [m]'\n"
     << (lo > 0 && hi / lo > 100 ? "set logscale x\n" : "");
  const int peak_col =
      static_cast<int>(1 + study.sweeps.size() + 3) +
      2 * static_cast<int>(std::find(response.begin(), response.end(), study.node) -
                           response.begin()) +
      1;
  const std::size_t first_axis = study.axes().front().size();
  if (first_axis == study.sweeps.size()) {
    pk << "plot 'study.csv' using 2:" << peak_col << " with linespoints pt 7 lw 2 title "
       << gnuplot_string(study.node) << "\n";
  } else {
    pk << peak_plot_per_combination(r, first_axis, peak_col);
  }
  write_text(out.path("peak.gp"), pk.str());
  run_gnuplot(out.path("peak.gp"), out.stop());
}

}  // namespace

std::vector<std::string> study_outputs() {
  return {"study.csv", "study.json", "overlay.gp", "overlay.png", "peak.gp", "peak.png", "runs"};
}

void write_study(const StudyResult& result, StagedOutput& out) {
  const StudyIndex index = study_index(result);
  write_text(out.path("study.csv"), index.csv);
  write_json(out.path("study.json"), study_json(result, index));
  if (result.plots && !result.study.node.empty()) {
    const std::string title =
        result.scene_name.empty() ? result.scene_file.stem().string() : result.scene_name;
    write_overlay_plot(result, title, out);
    write_peak_plot(result, title, out);
  }
  spdlog::info("{} runs, {} did not reach the end of their sweep{} ({:.2f} s)", result.runs.size(),
               result.failed_runs,
               result.optimum < result.runs.size()
                   ? "; lowest peak of " + result.study.node + " among them: run " +
                         result.runs[result.optimum].id + " (" +
                         format_number(result.optimum_amplitude_m) + " m)"
                   : std::string(),
               result.wall_seconds);
}

}  // namespace frichb::core
