#include "frichb/core/report/nma_report.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <sstream>

#include "frichb/core/report/plot_style.hpp"
#include "frichb/core/support/format.hpp"
#include "frichb/core/support/version.hpp"

namespace frichb::core {

std::optional<std::size_t> most_damped_point(const NmaResult& result) {
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < result.points.size(); ++i)
    if (!best || result.points[i].damping_ratio > result.points[*best].damping_ratio) best = i;
  return best;
}

std::string nma_plot_script(const NmaResult& result) {
  std::ostringstream gp;
  const std::string title = "nonlinear mode " + std::to_string(result.mode) + " of " +
                            result.scene_file.filename().string();
  gp << "# gnuplot script written by frichb nma\n"
     << plot_header("nma.png", 1400, 600) << line_types(2) << "unset key\n"
     << "set multiplot layout 1,2 title " << gnuplot_string(title) << "\n"
     << log_axes(true, false) << "set xlabel 'modal amplitude a [m·√kg]'\n"
     << "set format x '%.0e'\n";
  const auto best = most_damped_point(result);
  if (best) {
    const NmaPoint& p = result.points[*best];
    gp << "set label 1 'most damped' at " << p.amplitude << "," << p.frequency_hz
       << " point pt 7 ps 1.5 offset 1,1\n";
  }
  gp << "set ylabel 'frequency [Hz]'\nset title 'frequency'\n"
     << "plot 'nma.csv' using 2:3 with linespoints lt 1 pt 7 ps 0.5\n";
  if (best) {
    const NmaPoint& p = result.points[*best];
    gp << "set label 1 'most damped' at " << p.amplitude << "," << p.damping_ratio
       << " point pt 7 ps 1.5 offset 1,1\n";
  }
  gp << "set ylabel 'damping ratio'\nset title 'damping ratio (structure and contacts)'\n"
     << "plot 'nma.csv' using 2:4 with linespoints lt 2 pt 7 ps 0.5\nunset multiplot\n";
  return gp.str();
}

std::string synthesis_plot_script(const NmaResult& result) {
  std::ostringstream gp;
  ValueSpan span;
  double largest = 0.0;
  for (const SynthesisedResponse& s : result.syntheses)
    for (const SynthesisedPoint& p : s.curve) {
      span.add(p.node_amplitude_with_residual_m);
      largest = std::max(largest, p.node_amplitude_with_residual_m);
    }
  const LengthScale unit = length_scale(largest);
  const std::string factor = scale_factor_text(unit);
  const std::string title = "forced responses synthesised from nonlinear mode " +
                            std::to_string(result.mode) + " of " +
                            result.scene_file.filename().string();
  gp << "# gnuplot script written by frichb nma\n"
     << plot_header("synthesis.png", 1000, 700) << line_types(result.syntheses.size())
     << "set title " << gnuplot_string(title) << "\n"
     << log_axes(false, span.ratio() > 10) << "set xlabel 'frequency [Hz]'\n"
     << "set ylabel " << gnuplot_string(axis_label(result.node + " amplitude", unit.unit))
     << "\nset key top right\n";
  std::vector<std::string> curves;
  for (std::size_t i = 0; i < result.syntheses.size(); ++i) {
    const SynthesisedResponse& s = result.syntheses[i];
    if (s.curve.empty()) continue;
    const std::size_t type = i + 1;
    std::ostringstream curve;
    curve << "'synthesis.csv' using ($1 == " << i << " ? $3 : 1/0):($6 * " << factor
          << ") with lines lt " << type << " lw 2 title "
          << gnuplot_string("excitation × " + format_number(s.scale, 6));
    curves.push_back(curve.str());
    if (s.check.converged) {
      std::ostringstream check;
      check << "'synthesis_peaks.csv' using ($1 == " << i << " && $10 == 1 ? $4 : 1/0):($11 * "
            << factor << ") with points lt " << type << " pt 6 ps 2 notitle";
      curves.push_back(check.str());
    }
    if (s.full && s.full->found) {
      std::ostringstream full;
      full << "'synthesis_peaks.csv' using ($1 == " << i << " && $15 == 1 ? $16 : 1/0):($17 * "
           << factor << ") with points lt " << type << " pt 2 ps 2 notitle";
      curves.push_back(full.str());
    }
  }
  gp << "# circles: the harmonic-balance solve at each synthesised peak; crosses: the full run's "
        "peak\nplot ";
  for (std::size_t i = 0; i < curves.size(); ++i) gp << (i ? ", \\\n     " : "") << curves[i];
  gp << "\n";
  return gp.str();
}

std::vector<std::string> nma_outputs() {
  return {"nma.csv",       "summary.json", "nma.gp",        "nma.png",
          "synthesis.csv", "synthesis.gp", "synthesis.png", "synthesis_peaks.csv"};
}

namespace {

void write_syntheses(const NmaResult& result, StagedOutput& out) {
  std::vector<std::vector<double>> curve, peaks;
  for (std::size_t i = 0; i < result.syntheses.size(); ++i) {
    const SynthesisedResponse& s = result.syntheses[i];
    const auto level = static_cast<double>(i);
    for (const SynthesisedPoint& p : s.curve)
      curve.push_back({level, s.scale, p.frequency_hz, p.amplitude, p.node_amplitude_m,
                       p.node_amplitude_with_residual_m});
    const SynthesisedPeak& p = s.peak;
    const bool checked = p.found && s.check.converged;
    const bool full = s.full && s.full->found;
    const auto flag = [](bool b) { return b ? 1.0 : 0.0; };
    const auto only = [](bool b, double x) { return b ? x : 0.0; };
    peaks.push_back({level,
                     s.scale,
                     flag(p.found),
                     only(p.found, p.frequency_hz),
                     only(p.found, p.amplitude),
                     only(p.found, p.damping_ratio),
                     only(p.found, p.node_amplitude_m),
                     only(p.found, p.node_amplitude_with_residual_m),
                     only(p.found, p.residual_share),
                     flag(checked),
                     only(checked, s.check.node_amplitude_m),
                     only(checked, s.check.error),
                     only(checked, s.check.error_with_residual),
                     only(p.found, s.check.seconds),
                     flag(full),
                     only(full, full ? s.full->frequency_hz : 0.0),
                     only(full, full ? s.full->node_amplitude_m : 0.0),
                     only(full, full ? s.full->amplitude_error : 0.0),
                     only(full, full ? s.full->amplitude_error_with_residual : 0.0),
                     only(full, full ? s.full->frequency_error : 0.0),
                     s.full ? s.full->seconds : 0.0});
  }
  write_csv(out.path("synthesis.csv"),
            {"level", "excitation_scale", "frequency_hz", "amplitude_m_sqrt_kg",
             "node_amplitude_mode_m", "node_amplitude_m"},
            curve);
  write_csv(out.path("synthesis_peaks.csv"),
            {"level",
             "excitation_scale",
             "peak_found",
             "frequency_hz",
             "amplitude_m_sqrt_kg",
             "damping_ratio",
             "node_amplitude_mode_m",
             "node_amplitude_m",
             "residual_share",
             "check_converged",
             "check_node_amplitude_m",
             "check_error_mode",
             "check_error",
             "check_seconds",
             "full_run_found",
             "full_run_frequency_hz",
             "full_run_node_amplitude_m",
             "full_run_amplitude_error_mode",
             "full_run_amplitude_error",
             "full_run_frequency_error",
             "full_run_seconds"},
            peaks);
  const bool curves = std::any_of(result.syntheses.begin(), result.syntheses.end(),
                                  [](const SynthesisedResponse& s) { return !s.curve.empty(); });
  if (result.plots && curves) {
    write_text(out.path("synthesis.gp"), synthesis_plot_script(result));
    run_gnuplot(out.path("synthesis.gp"), out.stop());
  }
}

nlohmann::json synthesis_json(const NmaResult& result) {
  nlohmann::json levels = nlohmann::json::array();
  for (const SynthesisedResponse& s : result.syntheses) {
    const SynthesisedPeak& p = s.peak;
    nlohmann::json level = {{"excitation_scale", s.scale}, {"found", p.found}};
    if (!p.found) {
      level["message"] = p.message;
      levels.push_back(level);
      continue;
    }
    level["peak"] = {{"frequency_hz", p.frequency_hz},
                     {"amplitude_m_sqrt_kg", p.amplitude},
                     {"damping_ratio", p.damping_ratio},
                     {"node_amplitude_mode_m", p.node_amplitude_m},
                     {"node_amplitude_m", p.node_amplitude_with_residual_m},
                     {"residual_share", p.residual_share}};
    level["check"] = {{"converged", s.check.converged},
                      {"node_amplitude_m", s.check.node_amplitude_m},
                      {"error_mode", s.check.error},
                      {"error", s.check.error_with_residual},
                      {"newton_iterations", s.check.newton_iterations},
                      {"seconds", s.check.seconds},
                      {"message", s.check.message}};
    if (s.full)
      level["full_run"] = {{"found", s.full->found},
                           {"frequency_hz", s.full->frequency_hz},
                           {"node_amplitude_m", s.full->node_amplitude_m},
                           {"amplitude_error_mode", s.full->amplitude_error},
                           {"amplitude_error", s.full->amplitude_error_with_residual},
                           {"frequency_error", s.full->frequency_error},
                           {"points", s.full->points},
                           {"seconds", s.full->seconds},
                           {"termination", s.full->termination},
                           {"message", s.full->message}};
    levels.push_back(level);
  }
  return {{"node", result.node},
          {"levels", levels},
          {"backbone_seconds", result.wall_seconds},
          {"synthesis_seconds", result.synthesis_seconds},
          {"check_seconds", result.check_seconds},
          {"full_run_seconds", result.full_run_seconds}};
}

}  // namespace

void write_nma(const NmaResult& result, StagedOutput& out) {
  std::vector<std::vector<double>> rows;
  for (std::size_t i = 0; i < result.points.size(); ++i) {
    const NmaPoint& p = result.points[i];
    rows.push_back({static_cast<double>(i), p.amplitude, p.frequency_hz, p.damping_ratio, p.xi,
                    p.contact_energy_j, p.stuck, p.slipping, p.open, p.contact_motion_m,
                    p.higher_harmonics, static_cast<double>(p.newton_iterations)});
  }
  write_csv(out.path("nma.csv"),
            {"point", "amplitude_m_sqrt_kg", "frequency_hz", "damping_ratio", "xi_rad_s",
             "contact_energy_j", "stuck_share", "slipping_share", "open_share", "contact_motion_m",
             "higher_harmonics_share", "newton_iterations"},
            rows);
  nlohmann::json most_damped = nullptr;
  if (const auto best = most_damped_point(result)) {
    const NmaPoint& p = result.points[*best];
    most_damped = {{"point", *best},
                   {"amplitude_m_sqrt_kg", p.amplitude},
                   {"frequency_hz", p.frequency_hz},
                   {"damping_ratio", p.damping_ratio},
                   {"contact_motion_m", p.contact_motion_m},
                   {"slipping_share", p.slipping}};
  }
  const nlohmann::json doc = {
      {"frichb_version", version()},
      {"scene", result.scene_file.string()},
      {"mode",
       {{"mode", result.mode},
        {"harmonic_index", result.harmonic_index},
        {"frequency_without_contacts_hz", result.free_frequency_hz},
        {"undamped_frequency_contacts_at_rest_hz", result.start_frequency_hz}}},
      {"amplitude",
       {{"from_m_sqrt_kg", result.from},
        {"to_m_sqrt_kg", result.to},
        {"chosen_from_contact_motion", result.default_range}}},
      {"harmonics", result.harmonics},
      {"unknowns", result.unknowns},
      {"points", result.points.size()},
      {"most_damped", most_damped},
      {"status", result.outcome.status},
      {"termination", result.outcome.termination},
      {"message", result.outcome.message},
      {"warnings", result.outcome.warnings},
      {"continuation", {{"termination", result.termination}}},
      {"wall_time_s", result.wall_seconds}};
  nlohmann::json summary = doc;
  if (!result.syntheses.empty()) summary["synthesis"] = synthesis_json(result);
  write_json(out.path("summary.json"), summary);
  if (!result.syntheses.empty()) write_syntheses(result, out);
  if (result.plots && !result.points.empty()) {
    write_text(out.path("nma.gp"), nma_plot_script(result));
    run_gnuplot(out.path("nma.gp"), out.stop());
  }
}

}  // namespace frichb::core
