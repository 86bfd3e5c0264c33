#include "frichb/core/report/convergence_report.hpp"

#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>

#include "frichb/core/report/plot_style.hpp"
#include "frichb/core/support/format.hpp"
#include "frichb/core/support/version.hpp"

namespace frichb::core {

namespace {

std::string cell(double x) {
  return std::isfinite(x) ? format_number(x, 12) : std::string();
}

std::string csv_line(const ConvergenceRow& r) {
  std::ostringstream csv;
  csv << r.setting.id << "," << r.setting.max_harmonic << "," << r.setting.samples << ","
      << r.setting.oversampling << "," << r.outcome.unknowns << "," << r.outcome.termination << ","
      << cell(r.amplitude_m) << "," << cell(r.frequency_hz) << "," << cell(r.amplitude_error) << ","
      << cell(r.frequency_error) << "," << cell(r.amplitude_error_vs_timesim) << ","
      << cell(r.outcome.wall_seconds) << "\n";
  return csv.str();
}

std::string markdown_line(const ConvergenceRow& r, bool reference) {
  auto sci = [](double x) { return std::isfinite(x) ? format_number(x, 3) : std::string("-"); };
  std::ostringstream md;
  md << "| " << r.setting.max_harmonic << " | " << r.setting.samples << " | "
     << r.setting.oversampling << " | " << r.outcome.unknowns << " | "
     << format_number(r.amplitude_m, 6) << " | " << format_number(r.frequency_hz, 7) << " | "
     << (reference ? "reference" : sci(r.amplitude_error)) << " | "
     << (reference ? "reference" : sci(r.frequency_error)) << " | "
     << sci(r.amplitude_error_vs_timesim) << " | " << format_number(r.outcome.wall_seconds, 3)
     << " | " << r.outcome.termination << " |\n";
  return md.str();
}

nlohmann::json json_row(const ConvergenceRow& r) {
  nlohmann::json j = {{"setting", r.setting.id},
                      {"harmonics", r.setting.harmonics},
                      {"samples_per_period", r.setting.samples},
                      {"trace_oversampling", r.setting.oversampling},
                      {"unknowns", r.outcome.unknowns},
                      {"termination", r.outcome.termination},
                      {"message", r.outcome.message},
                      {"wall_s", r.outcome.wall_seconds}};
  if (std::isfinite(r.amplitude_m)) {
    j["peak_amplitude_m"] = r.amplitude_m;
    j["peak_frequency_hz"] = r.frequency_hz;
  }
  if (std::isfinite(r.amplitude_error)) j["amplitude_error"] = r.amplitude_error;
  if (std::isfinite(r.frequency_error)) j["frequency_error"] = r.frequency_error;
  if (std::isfinite(r.amplitude_error_vs_timesim))
    j["amplitude_error_vs_timesim"] = r.amplitude_error_vs_timesim;
  return j;
}

nlohmann::json timesim_json(const ConvergenceTimesim& t) {
  if (!t.run) return nullptr;
  return {{"frequency_hz", t.frequency_hz},
          {"amplitude_m", t.amplitude_m},
          {"periodic", t.periodic},
          {"periods", t.periods},
          {"steps_per_period", t.steps_per_period},
          {"wall_s", t.wall_seconds}};
}

// convergence.csv, convergence.md and convergence.json: one row per setting, errors against
// the last row (the reference).
void write_tables(const ConvergenceResult& result, StagedOutput& out) {
  const ConvergenceRow& reference = result.rows.back();
  std::ostringstream csv, md;
  csv << "setting,max_harmonic,samples_per_period,trace_oversampling,unknowns,termination,"
         "peak_amplitude_m,peak_frequency_hz,amplitude_error,frequency_error,"
         "amplitude_error_vs_timesim,wall_s\n";
  md << "| H | N | oversampling | unknowns | peak amplitude [m] | peak frequency [Hz] | "
        "amplitude error | frequency error | error vs time integration | wall time [s] | "
        "termination |\n"
     << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  nlohmann::json table = nlohmann::json::array();
  for (const ConvergenceRow& r : result.rows) {
    csv << csv_line(r);
    md << markdown_line(r, &r == &reference);
    table.push_back(json_row(r));
  }
  write_text(out.path("convergence.csv"), csv.str());
  write_text(out.path("convergence.md"), md.str());
  write_json(out.path("convergence.json"),
             {{"frichb_version", version()},
              {"scene", {{"file", result.scene_file.string()}, {"name", result.scene_name}}},
              {"node", result.node},
              {"reference", reference.setting.id},
              {"time_integration", timesim_json(result.timesim)},
              {"settings", table},
              {"incomplete_settings", result.incomplete_settings},
              {"note",
               "errors are relative to the reference setting (the finest), and to the "
               "time-integration amplitude at the reference's peak frequency; wall times "
               "are of serial runs on this machine"}});
}

// convergence.gp and, through gnuplot, convergence.png: error against wall time, log-log;
// one series per oversampling factor.
void write_plot(const ConvergenceResult& result, StagedOutput& out) {
  const std::string name =
      result.scene_name.empty() ? result.scene_file.stem().string() : result.scene_name;
  std::ostringstream gp;
  gp << "# gnuplot script written by frichb convergence; `gnuplot convergence.gp`\n"
     << plot_header("convergence.png", 1200, 560) << line_types(result.oversampling.size() + 1)
     << "set logscale xy\nset key below\n"
     << "set xlabel 'wall time of the run [s]'\nset multiplot layout 1,2 title "
     << gnuplot_string(name + ": error against run time (reference " +
                       result.rows.back().setting.id + ")")
     << "\n";
  const char* columns[] = {"amplitude_error", "frequency_error"};
  const char* titles[] = {"peak amplitude error (relative)", "peak frequency error (relative)"};
  for (int k = 0; k < 2; ++k) {
    gp << "set ylabel '" << titles[k] << "'\nplot ";
    std::size_t series = 0;
    for (int o : result.oversampling) {
      gp << (series ? ", \\\n     " : "") << "'convergence.csv' using (column(4) == " << o
         << " && column('" << columns[k] << "') > 0 ? column('wall_s') : 1/0):(column('"
         << columns[k] << "')) with points lt " << series + 1 << " pt 7 ps 1.2 title 'oversampling "
         << o << "'";
      ++series;
    }
    if (k == 0 && std::isfinite(result.timesim.compared()))
      gp << ", \\\n     'convergence.csv' using (column('wall_s')):(column("
            "'amplitude_error_vs_timesim') > 0 ? column('amplitude_error_vs_timesim') : "
            "1/0) with points lt "
         << series + 1 << " pt 6 ps 1.2 title 'vs time integration'";
    gp << "\n";
  }
  gp << "unset multiplot\n";
  write_text(out.path("convergence.gp"), gp.str());
  run_gnuplot(out.path("convergence.gp"), out.stop());
}

}  // namespace

std::vector<std::string> convergence_outputs() {
  return {"convergence.csv", "convergence.json", "convergence.md",
          "convergence.gp",  "convergence.png",  "runs"};
}

void write_convergence(const ConvergenceResult& result, StagedOutput& out) {
  write_tables(result, out);
  if (result.plots) write_plot(result, out);
}

}  // namespace frichb::core
