#include "frichb/core/report/timesim_report.hpp"

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "frichb/core/support/version.hpp"

namespace frichb::core {

std::vector<std::string> timesim_outputs() {
  return {"timesim.csv", "summary.json"};
}

void write_timesim(const TimesimResult& result, StagedOutput& out) {
  std::vector<std::string> header = {"time_s"};
  nlohmann::json nodes = nlohmann::json::object();
  for (const auto& r : result.nodes) {
    const std::size_t n_dofs = r.samples_m.size();
    for (std::size_t d = 0; d < n_dofs; ++d)
      header.push_back(r.node + (n_dofs > 1 ? "_" + std::to_string(d) : "") + "_m");
    nlohmann::json h = nlohmann::json::object();
    for (std::size_t k = 0; k < result.harmonics.size(); ++k)
      h[std::to_string(result.harmonics[k])] = r.harmonic_amplitudes_m[k];
    nodes[r.node] = {{"amplitude_m", r.amplitude_m},
                     {"half_peak_to_peak_m", r.half_peak_to_peak_m},
                     {"harmonic_amplitudes_m", h}};
  }
  std::vector<std::vector<double>> rows;
  for (std::size_t s = 0; s < result.time_s.size(); ++s) {
    std::vector<double> row = {result.time_s[s]};
    for (const auto& r : result.nodes)
      for (const auto& x : r.samples_m) row.push_back(x[s]);
    rows.push_back(std::move(row));
  }
  write_csv(out.path("timesim.csv"), header, rows);
  write_json(out.path("summary.json"), {{"frichb_version", version()},
                                        {"scene", result.scene_file.string()},
                                        {"frequency_hz", result.options.frequency_hz},
                                        {"steps_per_period", result.options.steps_per_period},
                                        {"periods", result.periods},
                                        {"periodic", result.periodic},
                                        {"termination", result.outcome.termination},
                                        {"response", nodes}});
}

}  // namespace frichb::core
