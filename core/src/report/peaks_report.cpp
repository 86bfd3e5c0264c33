#include "frichb/core/report/peaks_report.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

#include "frichb/core/report/plot_style.hpp"
#include "frichb/core/support/version.hpp"

namespace frichb::core {

namespace {

nlohmann::json number_or_null(double x) {
  return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
}

}  // namespace

std::string peaks_plot_script(const PeaksResult& result) {
  // The normalised chart plots mu N0 / f and the amplitude over f (columns 7 and 8).
  const bool normalised = result.mu_over_force > 0;
  const double x_factor = normalised ? result.mu_over_force : 1.0;
  const double y_factor = normalised ? result.per_force : 1.0;
  ValueSpan amplitudes;
  double largest = 0.0;
  for (const auto& p : result.peaks) {
    amplitudes.add(p.amplitude_m * y_factor);
    largest = std::max(largest, p.amplitude_m * y_factor);
  }
  const LengthScale scale = length_scale(largest);
  const std::string x = normalised ? "7" : "2";
  const std::string a =
      "($" + std::string(normalised ? "8" : "4") + "*" + scale_factor_text(scale) + ")";
  const std::string x_label = normalised ? "μN0 / f" : result.parameter;
  const std::string y_label = normalised ? axis_label("peak amplitude / f", scale.unit + "/N")
                                         : axis_label("peak amplitude", scale.unit);
  std::ostringstream gp;
  gp << "# gnuplot script written by frichb peaks\n"
     << plot_header("peaks.png", 1400, 600) << line_types(2) << "unset key\n"
     << "set multiplot layout 1,2 title "
     << gnuplot_string("resonance peak of " + result.node + " against " + result.parameter) << "\n"
     << log_axes(result.logarithmic, log_amplitude_axis(AmplitudeAxis::automatic, amplitudes))
     << "set xlabel " << gnuplot_string(x_label) << "\n"
     << "set ylabel " << gnuplot_string(y_label) << "\n"
     << "set title 'peak amplitude'\n";
  if (result.optimum) {
    const auto& best = result.peaks[*result.optimum];
    const auto& solved = result.solved_optimum;
    gp << "set label 1 'optimum' at "
       << (solved.solved ? solved.parameter : best.parameter) * x_factor << ","
       << (solved.solved ? solved.amplitude_m : best.amplitude_m) * y_factor * scale.factor
       << " point pt 7 ps 1.5 offset 1,1\n";
  }
  // Each located exchange with another peak: where the two are equally high, with the other
  // peak's frequency (the frequency panel marks the traced peak's).
  int label = 2;
  for (const PeakExchange& e : result.exchanges) {
    if (!e.located) continue;
    std::ostringstream text;
    text << std::setprecision(4) << (e.overtaken ? "overtaken by the " : "highest again over the ")
         << e.other_frequency_hz << " Hz peak";
    gp << "set label " << label++ << " " << gnuplot_string(text.str()) << " at "
       << e.parameter * x_factor << "," << e.amplitude_m * y_factor * scale.factor
       << " point pt 6 ps 1.5 offset 1,-1\n";
  }
  // With the peaks' stability: the stable points solid over the whole curve dashed, so that
  // the unstable stretches show dashed.
  const bool stability = std::any_of(result.peaks.begin(), result.peaks.end(),
                                     [](const TrackedPeak& p) { return p.stable.has_value(); });
  const auto curve = [&](const std::string& y, int type) {
    std::ostringstream c;
    if (stability)
      c << "'peaks.csv' using " << x << ":" << y << " with lines lt " << type
        << " dt 2 lw 1.5, 'peaks.csv' using " << x << ":(column('stable') > 0.5 ? " << y
        << " : NaN)";
    else
      c << "'peaks.csv' using " << x << ":" << y;
    c << " with linespoints lt " << type << " pt 7 ps 0.5";
    return c.str();
  };
  gp << "plot " << curve(a, 1) << "\n";
  for (int l = 1; l < label; ++l) gp << "unset label " << l << "\n";
  gp << "unset logscale y\n"
     << log_axes(result.logarithmic, false)
     << "set ylabel 'peak frequency [Hz]'\nset title 'peak frequency'\n";
  for (const PeakExchange& e : result.exchanges) {
    if (!e.located) continue;
    gp << "set label " << label++ << " \"\" at " << e.parameter * x_factor << "," << e.frequency_hz
       << " point pt 6 ps 1.5\n";
  }
  gp << "plot " << curve("($3)", 2) << "\nunset multiplot\n";
  return gp.str();
}

std::vector<std::string> peaks_outputs() {
  return {"peaks.csv", "summary.json", "peaks.gp", "peaks.png"};
}

void write_peaks(const PeaksResult& result, StagedOutput& out) {
  std::vector<std::string> header = {
      "point", result.parameter, "peak_frequency_hz", "peak_amplitude_m", "newton_iterations",
      "branch"};
  const bool normalised = result.mu_over_force > 0;
  if (normalised) header.insert(header.end(), {"mu_n0_over_f", "peak_amplitude_over_f_m_per_n"});
  // With the scene's output.stability: 1 stable, 0 unstable (NaN where not computed).
  const bool stability = std::any_of(result.peaks.begin(), result.peaks.end(),
                                     [](const TrackedPeak& p) { return p.stable.has_value(); });
  if (stability) header.insert(header.end(), {"stable", "largest_multiplier"});
  std::vector<std::vector<double>> rows;
  nlohmann::json points = nlohmann::json::array();
  for (std::size_t i = 0; i < result.peaks.size(); ++i) {
    const TrackedPeak& p = result.peaks[i];
    rows.push_back({static_cast<double>(i), p.parameter, p.frequency_hz, p.amplitude_m,
                    static_cast<double>(p.newton_iterations), static_cast<double>(p.branch)});
    if (normalised)
      rows.back().insert(rows.back().end(),
                         {p.parameter * result.mu_over_force, p.amplitude_m * result.per_force});
    if (stability)
      rows.back().insert(rows.back().end(),
                         {p.stable ? (*p.stable ? 1.0 : 0.0) : std::nan(""), p.largest_multiplier});
    points.push_back({{"parameter", p.parameter},
                      {"frequency_hz", p.frequency_hz},
                      {"amplitude_m", p.amplitude_m},
                      {"newton_iterations", p.newton_iterations},
                      {"branch", p.branch},
                      {"d_frequency_hz_d_parameter", number_or_null(p.d_frequency_hz_d_parameter)},
                      {"d_amplitude_m_d_parameter", number_or_null(p.d_amplitude_m_d_parameter)}});
    if (p.stable) {
      points.back()["stable"] = *p.stable;
      points.back()["largest_multiplier"] = number_or_null(p.largest_multiplier);
    }
  }
  write_csv(out.path("peaks.csv"), header, rows);
  nlohmann::json optimum = nullptr;
  if (result.optimum) {
    const TrackedPeak& best = result.peaks[*result.optimum];
    const auto& solved = result.solved_optimum;
    optimum = {{"solved", solved.solved},
               {"parameter", solved.solved ? solved.parameter : best.parameter},
               {"frequency_hz", solved.solved ? solved.frequency_hz : best.frequency_hz},
               {"amplitude_m", solved.solved ? solved.amplitude_m : best.amplitude_m},
               {"lowest_point", *result.optimum},
               {"at_range_end", result.optimum_at_end}};
    if (solved.solved)
      optimum["probes"] = solved.probes;
    else if (!solved.message.empty())
      optimum["why_not_solved"] = solved.message;
  }
  nlohmann::json jumps = nlohmann::json::array();
  for (const PeakJump& j : result.jumps)
    jumps.push_back({{"from_parameter", j.from_parameter},
                     {"from_frequency_hz", j.from_frequency_hz},
                     {"from_amplitude_m", j.from_amplitude_m},
                     {"parameter", j.parameter},
                     {"to_frequency_hz", j.to_frequency_hz},
                     {"to_amplitude_m", j.to_amplitude_m},
                     {"reason", j.reason}});
  nlohmann::json exchanges = nlohmann::json::array();
  for (const PeakExchange& e : result.exchanges) {
    exchanges.push_back({{"other_peak", e.overtaken ? "overtakes" : "falls_below"},
                         {"bracket", {e.bracket_from, e.bracket_to}},
                         {"located", e.located},
                         {"other_frequency_hz", e.other_frequency_hz}});
    if (e.located) {
      exchanges.back()["parameter"] = e.parameter;
      exchanges.back()["amplitude_m"] = e.amplitude_m;
      exchanges.back()["frequency_hz"] = e.frequency_hz;
    } else {
      exchanges.back()["why_not_located"] = e.message;
    }
  }
  nlohmann::json end_run = nullptr;
  if (result.end_run.made && !result.peaks.empty())
    end_run = {{"frequency_hz", result.end_run.frequency_hz},
               {"amplitude_m", result.end_run.amplitude_m},
               {"traced_frequency_hz", result.peaks.back().frequency_hz},
               {"traced_amplitude_m", result.peaks.back().amplitude_m}};
  const nlohmann::json doc = {
      {"frichb_version", version()},
      {"scene", result.scene_file.string()},
      {"parameter",
       {{"path", result.parameter},
        {"from", result.from},
        {"to", result.to},
        {"axis", result.logarithmic ? "log" : "linear"}}},
      {"node", result.node},
      {"unknowns", result.unknowns},
      {"start",
       {{"frequency_hz", result.start_frequency_hz},
        {"amplitude_m", result.start_amplitude_m},
        {"refined", result.start_refined},
        {"near_hz", result.near_hz ? nlohmann::json(*result.near_hz) : nlohmann::json(nullptr)}}},
      {"end_run", end_run},
      {"exchanges", exchanges},
      {"optimum", optimum},
      {"status", result.outcome.status},
      {"termination", result.outcome.termination},
      {"message", result.outcome.message},
      {"warnings", result.outcome.warnings},
      {"tracking",
       {{"termination", result.termination},
        {"points", result.peaks.size()},
        {"turning_points", result.turning_points}}},
      {"wall_time_s",
       {{"start_run_s", result.start_seconds},
        {"tracking_s", result.tracking_seconds},
        {"total_s", result.wall_seconds}}},
      {"jumps", jumps},
      {"normalised", normalised ? nlohmann::json{{"mu_over_f_per_n", result.mu_over_force},
                                                 {"one_over_f_per_n", result.per_force}}
                                : nlohmann::json(nullptr)},
      {"peaks", points}};
  write_json(out.path("summary.json"), doc);
  if (result.plots && !result.peaks.empty()) {
    write_text(out.path("peaks.gp"), peaks_plot_script(result));
    run_gnuplot(out.path("peaks.gp"), out.stop());
  }
}

}  // namespace frichb::core
