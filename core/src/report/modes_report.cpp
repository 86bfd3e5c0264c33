#include "frichb/core/report/modes_report.hpp"

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

#include "frichb/core/report/plot_style.hpp"

namespace frichb::core {

namespace {

// Spacing of the labelled nodal diameters on the map's axis: every one up to 20, then
// every 2, 5 or 10 so that the labels (up to two or three digits) do not overlap.
int nodal_diameter_tic_step(std::size_t nodal_diameters) {
  if (nodal_diameters <= 20) return 1;
  if (nodal_diameters <= 40) return 2;
  if (nodal_diameters <= 100) return 5;
  return 10;
}

std::string map_script(const ModesResult& result) {
  std::ostringstream gp;
  gp << "# gnuplot script written by frichb modes\n"
     << plot_header("modes.png", 1000, 700)
     << line_types(result.families + std::min<std::size_t>(result.speeds_rpm.size(), 2))
     << "set key outside right top\n"
     << "set title 'nodal-diameter map (" << result.sectors << " sectors, engine order "
     << result.engine_order << ")'\n"
     << "set xlabel 'nodal diameter'\nset ylabel 'natural frequency [Hz]'\n"
     << "set xtics " << nodal_diameter_tic_step(result.frequencies_hz.size()) << "\nplot ";
  gp << "for [i=2:" << result.families + 1
     << "] 'families.csv' using 1:i with linespoints lt (i - 1) lw 1.5 pt 7 title "
        "sprintf('family %d', i - 1)";
  for (std::size_t k = 0; k < result.speeds_rpm.size() && !result.excitation.empty(); ++k) {
    const double rpm = result.speeds_rpm[k];
    gp << ", \\\n     'excitation.csv' using 4:($1 == " << rpm
       << " ? $5 : 1/0) with linespoints lt " << result.families + std::min<std::size_t>(k, 1) + 1
       << " dt 2 lw 2 title 'EO " << result.engine_order << " at " << rpm
       << " rpm', \\\n     'excitation.csv' using 4:($1 == " << rpm
       << " ? $5 : 1/0):(sprintf('%d', $2)) with labels offset 1,0.5 notitle";
  }
  gp << "\n";
  return gp.str();
}

}  // namespace

std::vector<std::string> modes_outputs() {
  return {"modes.csv", "families.csv", "excitation.csv", "modes.gp", "modes.png"};
}

void write_modes(const ModesResult& result, StagedOutput& out) {
  std::vector<std::vector<double>> rows;
  for (const auto& m : result.modes)
    rows.push_back({static_cast<double>(m.harmonic_index), static_cast<double>(m.nodal_diameter),
                    static_cast<double>(m.wave), static_cast<double>(m.family), m.frequency_hz});
  write_csv(out.path("modes.csv"),
            {"harmonic_index", "nodal_diameter", "wave", "family", "frequency_hz"}, rows);
  if (!result.excitation.empty()) {
    std::vector<std::vector<double>> excitation;
    for (const auto& e : result.excitation)
      excitation.push_back({e.rpm, static_cast<double>(e.harmonic),
                            static_cast<double>(e.harmonic_index),
                            static_cast<double>(e.nodal_diameter), e.frequency_hz});
    write_csv(out.path("excitation.csv"),
              {"rpm", "n", "harmonic_index", "nodal_diameter", "frequency_hz"}, excitation);
  }
  std::vector<std::string> header = {"nodal_diameter"};
  for (std::size_t r = 0; r < result.families; ++r)
    header.push_back("family" + std::to_string(r + 1) + "_hz");
  std::vector<std::vector<double>> families;
  for (std::size_t nd = 0; nd < result.frequencies_hz.size(); ++nd) {
    std::vector<double> row = {static_cast<double>(nd)};
    const auto& f = result.frequencies_hz[nd];
    row.insert(row.end(), f.begin(), f.begin() + static_cast<long>(result.families));
    families.push_back(std::move(row));
  }
  write_csv(out.path("families.csv"), header, families);
  if (result.plots) {
    write_text(out.path("modes.gp"), map_script(result));
    run_gnuplot(out.path("modes.gp"), out.stop());
  }
}

}  // namespace frichb::core
