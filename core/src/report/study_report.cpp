#include "frichb/core/report/study_report.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "frichb/core/report/plot_style.hpp"
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
  for (const auto& node : r.mistuned_nodes)
    csv << "," << node << "_amplification," << node << "_worst_blade";
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
    nlohmann::json amplification = nlohmann::json::object();
    for (const auto& node : r.mistuned_nodes) {
      double factor = std::numeric_limits<double>::quiet_NaN();
      int worst = -1;
      for (const auto& a : o.amplification)
        if (a.node == node && a.factor > 0) {
          factor = a.factor;
          worst = a.worst_blade;
        }
      csv << "," << cell(factor) << "," << (worst >= 0 ? std::to_string(worst) : std::string());
      if (worst >= 0) amplification[node] = {{"factor", factor}, {"worst_blade", worst}};
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
                          {"amplification", amplification},
                          {"wall_s", o.wall_seconds}});
  }
  index.csv = csv.str();
  return index;
}

// study.json's `amplification`: a mistuned disk's statistics per sector node (null otherwise).
nlohmann::json amplification_json(const StudyResult& r) {
  if (r.mistuned_nodes.empty()) return nullptr;
  nlohmann::json out = nlohmann::json::object();
  for (const auto& s : amplification_statistics(r))
    out[s.node] = {
        {"runs", s.count},
        {"mean", s.mean},
        {"p95", s.p95},
        {"p99", s.p99},
        {"largest", s.largest},
        {"worst_run", s.worst_run < r.runs.size() ? nlohmann::json(r.runs[s.worst_run].id)
                                                  : nlohmann::json(nullptr)},
        {"among", "runs that reached the end of their sweep with a tuned and a blade's peak"}};
  return out;
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
          {"amplification", amplification_json(r)},
          {"wall_s", r.wall_seconds}};
}

// How a sweep is shown in plots: its short name (the path when two sweeps share one), its unit,
// and the factor its values are multiplied by (a length in metres is shown in µm or mm).
struct SweepDisplay {
  std::string name;
  std::string unit;
  double factor = 1.0;
  std::string factor_text = "1";
  int digits = 3;  // of the values in legends
};

std::vector<SweepDisplay> sweep_displays(const StudySpec& study) {
  std::vector<SweepDisplay> out;
  for (const SweepSpec& s : study.sweeps) {
    SweepDisplay d;
    d.name = s.name.empty() ? s.path : s.name;
    for (const SweepSpec& other : study.sweeps)
      if (&other != &s && other.name == s.name) d.name = s.path;
    d.unit = s.unit;
    if (s.unit == "m") {
      double largest = 0.0;
      for (double x : s.values) largest = std::max(largest, std::abs(x));
      const LengthScale scale = length_scale(largest);
      d.unit = scale.unit;
      d.factor = scale.factor;
      d.factor_text = scale_factor_text(scale);
    }
    std::vector<double> shown;
    for (double x : s.values) shown.push_back(x * d.factor);
    d.digits = distinguishing_digits(shown);
    out.push_back(d);
  }
  return out;
}

// A legend entry: "normal_load = 120 N".
std::string value_label(const SweepDisplay& d, double value) {
  return d.name + " = " + format_number(value * d.factor, d.digits) +
         (d.unit.empty() ? "" : " " + d.unit);
}

// The peak amplitude of study.node in a run's outcome (NaN when it has none).
double node_peak(const StudyRunRow& run, const std::string& node) {
  for (const auto& p : run.outcome.peaks)
    if (p.node == node) return p.amplitude_m;
  return std::numeric_limits<double>::quiet_NaN();
}

// The span of the peaks of study.node over the runs that wrote their output (`written`) or
// over every run.
ValueSpan peak_span(const StudyResult& r, bool written) {
  ValueSpan span;
  for (const auto& run : r.runs)
    if (!written || run.outcome.wrote_output) span.add(node_peak(run, r.study.node));
  return span;
}

// overlay.gp/png: the response curves of study.node, one line per run that wrote its output
// (nothing when none did). The amplitude axis is logarithmic when the runs' peaks span more
// than a decade (or as output.amplitude_axis says). With output.stability each curve's
// stable points are drawn solid over the whole curve dashed, so that its unstable branches
// show dashed, as in response.png.
void write_overlay_plot(const StudyResult& r, const std::string& title, StagedOutput& out) {
  const StudySpec& study = r.study;
  const auto& runs = r.runs;
  const std::vector<SweepDisplay> displays = sweep_displays(study);
  const ValueSpan span = peak_span(r, true);
  const LengthScale scale = length_scale(span.largest);
  std::size_t curves = 0;
  for (const auto& run : runs) curves += run.outcome.wrote_output ? 1 : 0;
  std::ostringstream gp;
  gp << "# gnuplot script written by frichb study; `gnuplot overlay.gp` remakes it\n"
     << plot_header("overlay.png", 1100, 700) << line_types(curves) << "set key outside right top\n"
     << "set title " << gnuplot_string(title + ": " + study.node + " over the study") << "\n"
     << "set xlabel 'frequency [" << unit_name(r.unit) << "]'\n"
     << "set ylabel " << gnuplot_string(axis_label("amplitude", scale.unit)) << "\n"
     << log_axes(false, log_amplitude_axis(r.amplitude_axis, span)) << "plot ";
  const int xcol = r.unit == FrequencyUnit::kHz ? 2 : 3;
  std::size_t curve = 0;
  for (const auto& run : runs) {
    if (!run.outcome.wrote_output) continue;
    std::string label;
    for (std::size_t s = 0; s < study.sweeps.size(); ++s)
      label += (s ? ", " : "") + value_label(displays[s], run.values[s]);
    const std::string file = gnuplot_string("runs/" + run.id + "/response.csv");
    const std::string amplitude =
        "column(" + gnuplot_string(study.node + "_amplitude_m") + ")*" + scale_factor_text(scale);
    gp << (curve ? ", \\\n     " : "") << file << " using " << xcol << ":";
    if (r.stability)
      gp << "(" << amplitude << ") with lines lt " << curve + 1 << " dt 2 lw 1 notitle, \\\n     "
         << file << " using " << xcol << ":(column('stable') > 0.5 ? " << amplitude << " : NaN)";
    else
      gp << "(" << amplitude << ")";
    gp << " with lines lt " << curve + 1 << " title " << gnuplot_string(label);
    ++curve;
  }
  if (r.stability && curve > 0)
    gp << ", \\\n     NaN with lines lc rgb 'black' dt 2 title 'unstable (dashed)'";
  gp << "\n";
  if (curve > 0) {
    write_text(out.path("overlay.gp"), gp.str());
    run_gnuplot(out.path("overlay.gp"), out.stop());
  }
}

// The plot command of peak.gp when the grid has more than one axis: the first axis on x, one
// line per combination of the sweeps of the other axes.
std::string peak_plot_per_combination(const StudyResult& r, std::size_t first_axis,
                                      const std::string& x, const std::string& y) {
  const StudySpec& study = r.study;
  const std::vector<SweepDisplay> displays = sweep_displays(study);
  std::vector<std::vector<double>> others;
  for (const auto& run : r.runs) {
    std::vector<double> rest(run.values.begin() + static_cast<std::ptrdiff_t>(first_axis),
                             run.values.end());
    if (std::find(others.begin(), others.end(), rest) == others.end()) others.push_back(rest);
  }
  std::ostringstream pk;
  pk << line_types(others.size()) << "plot ";
  for (std::size_t g = 0; g < others.size(); ++g) {
    std::string cond = "1", label;
    for (std::size_t s = first_axis; s < study.sweeps.size(); ++s) {
      const double value = others[g][s - first_axis];
      cond += " && abs(column(" + std::to_string(s + 2) + ") - (" + format_scene_value(value) +
              ")) <= 1e-9 * (1 + abs(" + format_scene_value(value) + "))";
      label += (s > first_axis ? ", " : "") + value_label(displays[s], value);
    }
    pk << (g ? ", \\\n     " : "") << "'study.csv' using " << x << ":((" << cond << ") ? " << y
       << " : 1/0) with linespoints lt " << g + 1 << " pt 7 title " << gnuplot_string(label);
  }
  pk << "\n";
  return pk.str();
}

// peak.gp/png: the peak amplitude of study.node (from study.csv) against the first swept value.
// The swept axis is logarithmic when its values are log-spaced (log_spaced, or spacing: log);
// the amplitude axis when the peaks span more than a decade (or as output.amplitude_axis says).
void write_peak_plot(const StudyResult& r, const std::string& title, StagedOutput& out) {
  const StudySpec& study = r.study;
  const auto& response = r.response;
  const auto& s0 = study.sweeps.front();
  const SweepDisplay d0 = sweep_displays(study).front();
  const ValueSpan span = peak_span(r, false);
  const LengthScale scale = length_scale(span.largest);
  const bool log_x = s0.log_spacing || log_spaced(s0.values);
  std::ostringstream pk;
  pk << "# gnuplot script written by frichb study; `gnuplot peak.gp` remakes it\n"
     << plot_header("peak.png", 900, 600) << "set key outside right top\n"
     << "set title " << gnuplot_string(title + ": peak amplitude of " + study.node) << "\n"
     << "set xlabel " << gnuplot_string(axis_label(d0.name, d0.unit)) << "\n"
     << "set ylabel " << gnuplot_string(axis_label("peak amplitude", scale.unit)) << "\n"
     << log_axes(log_x, log_amplitude_axis(r.amplitude_axis, span));
  const int peak_col =
      static_cast<int>(1 + study.sweeps.size() + 3) +
      2 * static_cast<int>(std::find(response.begin(), response.end(), study.node) -
                           response.begin()) +
      1;
  const std::string x = d0.factor == 1.0 ? "2" : "(column(2)*" + d0.factor_text + ")";
  const std::string y =
      "(column(" + std::to_string(peak_col) + ")*" + scale_factor_text(scale) + ")";
  const std::size_t first_axis = study.axes().front().size();
  if (first_axis == study.sweeps.size()) {
    pk << line_types(1) << "plot 'study.csv' using " << x << ":" << y
       << " with linespoints lt 1 pt 7 title " << gnuplot_string(study.node) << "\n";
  } else {
    pk << peak_plot_per_combination(r, first_axis, x, y);
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
