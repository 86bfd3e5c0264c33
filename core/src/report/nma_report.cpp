#include "frichb/core/report/nma_report.hpp"

#include <nlohmann/json.hpp>
#include <sstream>

#include "frichb/core/report/plot_style.hpp"
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

std::vector<std::string> nma_outputs() {
  return {"nma.csv", "summary.json", "nma.gp", "nma.png"};
}

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
  write_json(out.path("summary.json"), doc);
  if (result.plots && !result.points.empty()) {
    write_text(out.path("nma.gp"), nma_plot_script(result));
    run_gnuplot(out.path("nma.gp"), out.stop());
  }
}

}  // namespace frichb::core
