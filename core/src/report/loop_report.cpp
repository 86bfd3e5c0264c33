#include "frichb/core/report/loop_report.hpp"

#include <sstream>
#include <string>
#include <vector>

#include "frichb/core/report/plot_style.hpp"
#include "frichb/core/support/version.hpp"

namespace frichb::core {

namespace {

std::string loop_plot_script(const LoopResult& result) {
  const auto& comps = result.components;
  const auto d = static_cast<int>(comps.size());
  const LengthScale scale = length_scale(
      result.displacement_m.size() > 0 ? result.displacement_m.col(0).cwiseAbs().maxCoeff() : 0.0);
  const std::string u = "($2*" + scale_factor_text(scale) + ")";
  std::ostringstream gp;
  gp << "# gnuplot script written by frichb loop\n"
     << plot_header("loop.png", d > 1 ? 1400 : 800, 600) << line_types(2) << "unset key\n";
  const bool two_d = comps.size() >= 2 && comps[1] == 1;
  const std::string title = gnuplot_string(result.name + " (" + result.law->name() + ")");
  gp << (d > 1 ? "set multiplot layout 1,2 title " : "set title ") << title << "\n";
  if (d > 1) gp << "set title 'T1 against u_t1'\n";
  gp << "set xlabel " << gnuplot_string(axis_label("u_t1", scale.unit)) << "\nset ylabel 'T1 [N]'\n"
     << "plot 'loop.csv' using " << u << ":" << 2 + d << " with lines lt 1 title 'T1 vs u_t1'\n";
  if (two_d) {
    gp << "set title 'friction force path (T1, T2)'\n"
       << "set xlabel 'T1 [N]'\nset ylabel 'T2 [N]'\nset size ratio -1\n"
       << "plot 'loop.csv' using " << 2 + d << ":" << 3 + d
       << " with lines lt 1 title 'friction loop (T1, T2)'\n";
  } else if (d > 1) {
    gp << "set title 'forces over the period'\nset key outside right top\n"
       << "set xlabel 'phase [period]'\nset ylabel 'force [N]'\n"
       << "plot 'loop.csv' using 1:" << 2 + d << " with lines lt 1 title 'T1', "
       << "'loop.csv' using 1:" << 1 + 2 * d << " with lines lt 2 title 'N'\n";
  }
  if (d > 1) gp << "unset multiplot\n";
  return gp.str();
}

}  // namespace

std::vector<std::string> loop_outputs() {
  return {"loop.csv", "harmonics.csv", "summary.json", "loop.gp", "loop.png"};
}

void write_loop(const LoopResult& result, StagedOutput& out) {
  const auto& comps = result.components;
  const auto d = static_cast<int>(comps.size());
  const int samples = result.samples;
  std::vector<std::string> header = {"phase"};
  for (int k : comps) header.push_back(std::string("u_") + kContactAxisNames[k] + "_m");
  for (int k : comps) header.push_back(std::string("f_") + kContactAxisNames[k] + "_N");
  header.push_back("status");
  std::vector<std::vector<double>> rows;
  for (int j = 0; j <= samples; ++j) {  // closed loop: the first sample repeated
    const int jj = j % samples;
    std::vector<double> row = {static_cast<double>(j) / samples};
    for (int a = 0; a < d; ++a) row.push_back(result.displacement_m(jj, a));
    for (int a = 0; a < d; ++a) row.push_back(result.force_N(jj, a));
    row.push_back(result.status[static_cast<std::size_t>(jj)]);
    rows.push_back(std::move(row));
  }
  write_csv(out.path("loop.csv"), header, rows);
  write_csv(out.path("harmonics.csv"), result.harmonics.header, result.harmonics.rows);
  const nlohmann::json doc = {{"frichb_version", version()},
                              {"input", result.input_file.string()},
                              {"law",
                               {{"name", result.law->name()},
                                {"version", result.law->descriptor().version},
                                {"file", result.law->file().string()},
                                {"params", result.law_params}}},
                              {"dissipated_energy_per_cycle_J", result.energy_per_cycle_J},
                              {"passes", result.passes},
                              {"periodic", result.periodic},
                              {"fraction_slipping", result.fraction_slipping},
                              {"fraction_open", result.fraction_open},
                              {"significant_force_harmonics", result.significant_harmonics},
                              {"significance_threshold", result.significance_threshold}};
  write_json(out.path("summary.json"), doc);
  if (result.plots) {
    write_text(out.path("loop.gp"), loop_plot_script(result));
    run_gnuplot(out.path("loop.gp"), out.stop());
  }
}

}  // namespace frichb::core
