// The report of a response-curve run (run_report.hpp).
#include "frichb/core/report/run_report.hpp"

#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <sstream>

#include "frichb/core/numerics/dense_lu.hpp"
#include "frichb/core/numerics/harmonics.hpp"
#include "frichb/core/report/plot_style.hpp"
#include "frichb/core/support/version.hpp"

#include "frichb/core/support/format.hpp"

namespace frichb::core {

namespace fs = std::filesystem;

namespace {

// Where the response curve's wall time went, for users sizing a study: the continuation's
// evaluations and LU factorisations (ContinuationSummary::profile), the parts of all the
// model's evaluations (EvaluationStats, including the start point and the output pass), and
// the process's peak resident memory (getrusage; for the whole process, so a study's threads
// share it).
nlohmann::json profile_json(const ContinuationSummary& summary, const EvaluationStats& stats) {
  const SolveProfile& p = summary.profile;
  const double other = summary.wall_seconds - p.evaluation_seconds - p.factorisation_seconds -
                       p.krylov_seconds - p.preconditioner_seconds;
  rusage usage{};
  nlohmann::json peak_memory = nullptr;
  if (getrusage(RUSAGE_SELF, &usage) == 0)
    peak_memory = static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: kilobytes
  return {{"continuation",
           {{"wall_s", summary.wall_seconds},
            {"evaluations", p.evaluations},
            {"evaluation_s", p.evaluation_seconds},
            {"residual_only_evaluations", p.residual_only_evaluations},
            {"factorisations", p.factorisations},
            {"factorisation_s", p.factorisation_seconds},
            {"chord_points", summary.chord_points},
            {"chord_iterations", summary.chord_iterations},
            {"chord_fallbacks", summary.chord_fallbacks},
            {"other_s", std::max(0.0, other)}}},
          {"linear_solver",
           {{"kind", p.linear_solver},
            {"reason", p.linear_solver_reason},
            {"krylov_solves", p.krylov_solves},
            {"krylov_iterations", p.krylov_iterations},
            {"krylov_s", p.krylov_seconds},
            {"krylov_fallbacks", p.krylov_fallbacks},
            {"preconditioner_builds", p.preconditioner_builds},
            {"preconditioner_s", p.preconditioner_seconds},
            {"formed_matrices", p.formed_matrices}}},
          {"model_evaluations",
           {{"contact_traces_s", stats.contact_seconds},
            {"contact_traces", stats.traces},
            {"contact_trace_passes", stats.trace_passes},
            {"contact_trace_newton_steps", stats.trace_newton_steps},
            {"receptance_s", stats.receptance_seconds},
            {"jacobian_assembly_s", stats.assembly_seconds}}},
          {"dense_solver", dense_solver_description()},
          {"peak_memory_mib", peak_memory}};
}

nlohmann::json plugin_json(const LoadedPlugin& p) {
  const auto& d = p.descriptor();
  return {{"name", d.name},
          {"kind", to_string(p.kind())},
          {"version", d.version},
          {"abi", std::to_string(d.abi_major) + "." + std::to_string(d.abi_minor)},
          {"build", d.build_tag},
          {"file", p.file().string()}};
}

// The scene's plugins, each once: the structure's, then the contact laws' in scene order.
nlohmann::json plugins_json(const Scene& scene) {
  nlohmann::json plugins = nlohmann::json::array();
  plugins.push_back(plugin_json(*scene.structure.plugin));
  std::vector<std::string> listed = {scene.structure.plugin->name()};
  for (const auto& c : scene.contacts)
    if (std::find(listed.begin(), listed.end(), c.plugin->name()) == listed.end()) {
      listed.push_back(c.plugin->name());
      plugins.push_back(plugin_json(*c.plugin));
    }
  return plugins;
}

nlohmann::json resonances_json(const std::vector<LinearResonance>& resonances, double unit) {
  nlohmann::json out = nlohmann::json::array();
  for (const LinearResonance& r : resonances) {
    out.push_back({{"system", system_name(r.system)},
                   {"harmonic", r.harmonic},
                   {"harmonic_index", r.harmonic_index},
                   {"centre", r.centre / unit},
                   {"half_width", r.half_width / unit},
                   {"damping_ratio", r.damping_ratio},
                   {"step", kCentreStepInHalfWidths * r.half_width / unit}});
  }
  return out;
}

nlohmann::json peaks_json(const ResponseTable& table) {
  nlohmann::json peaks = nlohmann::json::object();
  for (std::size_t k = 0; k < table.nodes.size(); ++k) {
    const auto& peak = table.peaks[k];
    if (!peak) {  // no point on the curve: no peak
      peaks[table.nodes[k].name] = nullptr;
      continue;
    }
    peaks[table.nodes[k].name] = {{"amplitude_m", peak->amplitude_m},
                                  {"frequency_hz", peak->omega_rad_s / (2 * std::numbers::pi)},
                                  {"omega_rad_s", peak->omega_rad_s},
                                  {"refined", peak->refined}};
  }
  return peaks;
}

// With output.stability: the points off the unit circle, each node's highest stable point and
// where stability changes along the curve.
nlohmann::json stability_json(const ResponseTable& table) {
  nlohmann::json highest = nlohmann::json::object();
  for (std::size_t k = 0; k < table.nodes.size(); ++k) {
    const auto& p = table.stable_peaks[k];
    highest[table.nodes[k].name] =
        p ? nlohmann::json{{"point", p->point},
                           {"amplitude_m", p->amplitude_m},
                           {"frequency_hz", p->omega_rad_s / (2 * std::numbers::pi)},
                           {"omega_rad_s", p->omega_rad_s}}
          : nlohmann::json(nullptr);
  }
  nlohmann::json changes = nlohmann::json::array();
  for (const auto& c : table.stability_changes) {
    // A located change is given where it was located; a fold (or a change not located) at the
    // point after it.
    nlohmann::json amplitudes = nlohmann::json::object();
    for (std::size_t k = 0; k < table.nodes.size(); ++k) {
      const auto& node = table.nodes[k];
      const auto column =
          std::find(table.header.begin(), table.header.end(), node.name + "_amplitude_m") -
          table.header.begin();
      amplitudes[node.name] = c.located ? c.located->amplitude_m[k]
                                        : table.rows[c.point][static_cast<std::size_t>(column)];
    }
    const std::complex<double> mu = c.located ? c.located->multiplier : c.multiplier;
    nlohmann::json change = {
        {"kind", c.kind},
        {"point", c.point},
        {"located", c.located.has_value()},
        {"frequency_hz",
         c.located ? c.located->omega_rad_s / (2 * std::numbers::pi) : table.rows[c.point][1]},
        {"amplitude_m", amplitudes},
        {"stable_after", c.stable},
        {"unstable_multipliers_after", c.unstable_count},
        {"multiplier", {mu.real(), mu.imag()}},
        {"multiplier_modulus", std::abs(mu)}};
    if (const int nd = c.located ? c.located->nodal_diameter : c.nodal_diameter; nd >= 0)
      change["nodal_diameter"] = nd;
    changes.push_back(std::move(change));
  }
  return {{"unstable_points", table.unstable_points},
          {"highest_stable_point", highest},
          {"changes", changes}};
}

// Per kept harmonic: how the receptance at the contacts is represented (modes retained, and
// whether the static residual flexibility of the others is added).
nlohmann::json receptance_json(const HarmonicBalanceModel& model) {
  nlohmann::json out = nlohmann::json::array();
  for (const HarmonicBalanceModel::ReceptanceForm& f : model.receptance_forms())
    out.push_back({{"harmonic", f.harmonic},
                   {"harmonic_index", f.harmonic_index},
                   {"form", f.modal ? "modal" : "formed"},
                   {"modes", f.modes},
                   {"residual_flexibility", f.residual_flexibility}});
  return out;
}

nlohmann::json truncation_json(const std::optional<HarmonicTruncation>& truncation) {
  if (!truncation) return nullptr;
  return {{"frequency", truncation->frequency},
          {"highest_harmonic", truncation->highest_harmonic},
          {"largest_energy_share", truncation->largest_energy_share},
          {"contact", truncation->contact},
          {"warning_above", kHighestHarmonicShare}};
}

// The largest condition estimate of the Newton matrix along the curve, where, and the digits
// it costs; null when none was estimated.
nlohmann::json condition_json(const ContinuationSummary& summary, Eigen::Index n, double unit) {
  if (summary.points.empty() || !(summary.max_condition > 0.0)) return nullptr;
  const double worst = summary.max_condition;
  const double at = summary.points[summary.max_condition_point].y(n) / unit;
  return {{"max", std::isfinite(worst) ? nlohmann::json(worst) : nlohmann::json()},
          {"frequency", at},
          {"digits_lost", std::isfinite(worst) ? std::log10(worst) : 16.0}};
}

nlohmann::json last_point_json(const ContinuationSummary& summary, Eigen::Index n, double unit) {
  if (summary.points.empty()) return nullptr;
  const auto& p = summary.points.back();
  return {{"frequency", p.y(n) / unit},
          {"omega_rad_s", p.y(n)},
          {"scaled_residual", p.residual_norm},
          {"newton_iterations", p.newton_iterations}};
}

// The span of the amplitude columns (<node>_amplitude_m) of the response table.
ValueSpan amplitude_span(const ResponseTable& table) {
  ValueSpan span;
  for (std::size_t c = 0; c < table.header.size(); ++c)
    if (table.header[c].ends_with("_amplitude_m"))
      for (const auto& row : table.rows)
        if (c < row.size()) span.add(row[c]);
  return span;
}

// response.gp: every response node's amplitude against frequency (length_scale: µm, mm or m), on a
// log axis when the amplitudes span more than a decade (or as output.amplitude_axis says).
std::string response_plot_script(const Scene& scene, const ResponseTable& table) {
  const auto& nodes = table.nodes;
  const ValueSpan span = amplitude_span(table);
  const LengthScale scale = length_scale(span.largest);
  std::ostringstream gp;
  gp << "# gnuplot script written by frichb; run `gnuplot response.gp` to remake response.png\n"
     << plot_header("response.png", 1000, 640) << line_types(nodes.size()) << "set title "
     << gnuplot_string((scene.name.empty() ? scene.file.stem().string() : scene.name) +
                       ": forced response")
     << "\n"
     << "set xlabel 'frequency [" << unit_name(scene.continuation.unit) << "]'\n"
     << "set ylabel " << gnuplot_string(axis_label("amplitude", scale.unit)) << "\n"
     << log_axes(false, log_amplitude_axis(scene.output.amplitude_axis, span))
     << "set key outside right top\n";
  const int xcol = scene.continuation.unit == FrequencyUnit::kHz ? 2 : 3;
  // With the stability columns: the stable points solid, the whole curve under them dashed,
  // so that the unstable branches show dashed.
  const bool stability =
      std::find(table.header.begin(), table.header.end(), "stable") != table.header.end();
  gp << "plot ";
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const std::string amplitude = "column(" + gnuplot_string(nodes[i].name + "_amplitude_m") +
                                  ")*" + scale_factor_text(scale);
    gp << (i ? ", \\\n     " : "") << "'response.csv' using " << xcol << ":";
    if (stability)
      gp << "(" << amplitude << ") with lines lt " << i + 1 << " dt 2 lw 1.5 notitle, \\\n     "
         << "'response.csv' using " << xcol << ":(column('stable') > 0.5 ? " << amplitude
         << " : NaN)";
    else
      gp << "(" << amplitude << ")";
    gp << " with linespoints lt " << i + 1 << " pt 7 ps 0.4 title "
       << gnuplot_string(nodes[i].name);
  }
  if (stability) gp << ", \\\n     NaN with lines lc rgb 'black' dt 2 title 'unstable (dashed)'";
  gp << "\n";
  return gp.str();
}

// A friction loop's plot: the tangential force T1 against the relative displacement u_t1,
// the displacement in µm, mm or m (`largest_m`: its largest absolute value).
std::string loop_plot_script(const std::string& csv, const std::string& title, int dims,
                             double largest_m) {
  const LengthScale scale = length_scale(largest_m);
  std::ostringstream gp;
  gp << plot_header(fs::path(csv).replace_extension(".png").filename().string(), 800, 600)
     << line_types(1) << "unset key\n"
     << "set title " << gnuplot_string(title) << "\n"
     << "set xlabel " << gnuplot_string(axis_label("relative displacement u_t1", scale.unit))
     << "\n"
     << "set ylabel 'friction force T1 [N]'\n"
     << "plot " << gnuplot_string(fs::path(csv).filename().string()) << " using ($2*"
     << scale_factor_text(scale) << "):" << (2 + dims) << " with lines lt 1 title 'loop'\n";
  return gp.str();
}

// Harmonics of a loop's contact force (thesis Fig. 5.6): at least up to 10, and up to the
// highest kept harmonic, as far as the samples resolve them.
ForceHarmonics loop_force_harmonics(const Scene& scene, const FrictionLoop& loop,
                                    const std::vector<int>& components) {
  const int samples = static_cast<int>(loop.trace.force.rows());
  const int shown =
      std::min((samples - 1) / 2, std::max(10, scene.harmonic_balance.harmonics.back()));
  return force_harmonics(loop.trace.force, components, shown);
}

// One friction loop's files: the closed loop (phase, u per axis, f per axis), its force
// harmonics and, when `plots`, its plot. Returns its summary.json entry.
nlohmann::json write_loop(StagedOutput& out, const RunRecord& run, const FrictionLoop& loop,
                          bool plots) {
  const auto& scene = run.scene;
  const auto& contact = run.model.contacts()[loop.contact];
  const auto& comps = contact.tracer->components();
  const ContactTrace& trace = loop.trace;
  const std::string unit = unit_name(scene.continuation.unit);
  std::vector<std::string> header = {"phase"};
  for (int a : comps) header.push_back(std::string("u_") + kContactAxisNames[a] + "_m");
  for (int a : comps) header.push_back(std::string("f_") + kContactAxisNames[a] + "_N");
  std::vector<std::vector<double>> rows;
  const int samples = static_cast<int>(trace.displacement.rows());
  for (int j = 0; j <= samples; ++j) {  // closed loop: repeat the first sample
    const int jj = j % samples;
    std::vector<double> r = {static_cast<double>(j) / samples};
    for (Eigen::Index a = 0; a < trace.displacement.cols(); ++a)
      r.push_back(trace.displacement(jj, a));
    for (Eigen::Index a = 0; a < trace.force.cols(); ++a) r.push_back(trace.force(jj, a));
    rows.push_back(std::move(r));
  }
  const std::string base = "loops/" + contact.name + "_" + format_number(loop.frequency, 10) +
                           unit.substr(0, 2) + "_" + std::to_string(loop.crossing);
  const fs::path csv = out.path(base + ".csv");
  write_csv(csv, header, rows);
  const ForceHarmonics force_table = loop_force_harmonics(scene, loop, comps);
  write_csv(out.path(base + "_harmonics.csv"), force_table.header, force_table.rows);
  if (plots) {
    const fs::path gp = out.path(base + ".gp");
    write_text(
        gp,
        loop_plot_script(
            csv.string(), contact.name + " at " + format_number(loop.frequency) + " " + unit,
            static_cast<int>(comps.size()),
            trace.displacement.size() > 0 ? trace.displacement.col(0).cwiseAbs().maxCoeff() : 0.0));
    run_gnuplot(gp, out.stop());
  }
  nlohmann::json entry = friction_loop_entry(run, loop);
  entry["file"] = base + ".csv";
  entry["harmonics_file"] = base + "_harmonics.csv";
  return entry;
}

// A patch entry among a crossing's contacts and the extent of its pairs on face A: their
// coordinates along the face's tangents from its centroid (m).
struct PatchExtent {
  std::string entry;
  std::size_t pairs = 0;
  double s1_min = std::numeric_limits<double>::infinity(), s1_max = -s1_min;
  double s2_min = s1_min, s2_max = -s1_min;
  void add(const std::array<double, 2>& s) {
    ++pairs;
    s1_min = std::min(s1_min, s[0]);
    s1_max = std::max(s1_max, s[0]);
    s2_min = std::min(s2_min, s[1]);
    s2_max = std::max(s2_max, s[1]);
  }
};

// The plot of a patch's face at one frequency: each pair at its place on face A, coloured by
// its share of the period stuck (a colour-blind-safe sequential map), with equal scales on both
// axes. Each axis spans at least a quarter of the larger extent on either side of the pairs'
// centre, so that a single row of pairs (or a single pair) keeps a readable frame.
std::string face_plot_script(const std::string& csv, const std::string& png,
                             const PatchExtent& patch, const std::string& title) {
  const double largest = std::max({std::abs(patch.s1_min), std::abs(patch.s1_max),
                                   std::abs(patch.s2_min), std::abs(patch.s2_max)});
  const LengthScale scale = length_scale(largest);
  const double span1 = patch.s1_max - patch.s1_min, span2 = patch.s2_max - patch.s2_min;
  double extent = std::max(span1, span2);
  if (!(extent > 0)) extent = largest > 0 ? largest : 1e-3;  // one pair
  const auto range = [&](double lo, double hi) {
    const double half = std::max(0.5 * (hi - lo), 0.25 * extent) + 0.15 * extent;
    const double centre = 0.5 * (lo + hi);
    return "[" + format_number((centre - half) * scale.factor, 8) + ":" +
           format_number((centre + half) * scale.factor, 8) + "]";
  };
  const char* size = patch.pairs <= 16 ? "3" : patch.pairs <= 100 ? "2" : "1";
  const std::string factor = scale_factor_text(scale);
  const std::string using_ = " every ::1 using (strcol(1) eq " + gnuplot_string(patch.entry) +
                             " ? $5*" + factor + " : NaN):($6*" + factor + ")";
  std::ostringstream gp;
  gp << plot_header(png, 900, 600) << "set size ratio -1\nunset key\n"
     << "set xrange " << range(patch.s1_min, patch.s1_max) << "\n"
     << "set yrange " << range(patch.s2_min, patch.s2_max) << "\n"
     << "set title " << gnuplot_string(title) << "\n"
     << "set xlabel "
     << gnuplot_string(axis_label("along tangent1 from the face centroid", scale.unit)) << "\n"
     << "set ylabel " << gnuplot_string(axis_label("along tangent2", scale.unit)) << "\n"
     << "set cblabel 'share of the period stuck'\nset cbrange [0:1]\n"
     << sequential_palette() << "plot " << gnuplot_string(csv) << using_
     << ":8 with points pt 7 ps " << size << " palette notitle, \\\n     " << gnuplot_string(csv)
     << using_ << " with points pt 6 ps " << size << " lc rgb '#404040' notitle\n";
  return gp.str();
}

}  // namespace

namespace {

// `value` in the fewest digits that read back as the same double. Throws for NaN and Inf (an
// output file never holds them).
std::string round_trip(double value) {
  if (!std::isfinite(value)) throw std::runtime_error("a result is not finite (NaN or Inf)");
  std::array<char, 32> text{};
  const auto end = std::to_chars(text.data(), text.data() + text.size(), value).ptr;
  return {text.data(), end};
}

// A CSV field: quoted (quotes doubled) when it holds a comma, a quote or a line break.
std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (const char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

// response_harmonics.csv: every response node's complex harmonic amplitudes at every point.
void write_response_harmonics(const fs::path& file, const RunRecord& run) {
  const Eigen::Index n = run.model.equation_count();
  const auto& harmonics = run.model.layout().harmonics();
  std::string csv = "point,frequency_hz,node,component,dof,harmonic,cos_m,sin_m\n";
  for (std::size_t i = 0; i < run.summary.points.size(); ++i) {
    const auto& y = run.summary.points[i].y;
    const std::string point = std::to_string(i) + "," + round_trip(y(n) / (2 * std::numbers::pi));
    for (std::size_t j = 0; j < run.table.nodes.size(); ++j) {
      const ResponseNode& node = run.table.nodes[j];
      const Eigen::MatrixXcd& x = run.table.harmonics.at(i).at(j);
      const auto& dofs = run.scene.structure.find(node.name)->dofs;
      for (Eigen::Index d = 0; d < x.rows(); ++d)
        for (Eigen::Index k = 0; k < x.cols(); ++k) {
          const std::complex<double> c = x(d, k);
          csv += point + "," + csv_field(node.name) + "," + std::to_string(d) + "," +
                 std::to_string(dofs[static_cast<std::size_t>(d)]) + "," +
                 std::to_string(harmonics[static_cast<std::size_t>(k)]) + "," +
                 round_trip(c.real() + 0.0) + "," +  // + 0.0, 0.0 - x: no negative zeros
                 round_trip(harmonics[static_cast<std::size_t>(k)] == 0 ? 0.0 : 0.0 - c.imag()) +
                 "\n";
        }
    }
  }
  write_text(file, csv);
}

// contact_harmonics.csv (output.contact_forces): every contact's relative displacement and
// force harmonics at every point, in the convention of response_harmonics.csv.
void write_contact_harmonics(const fs::path& file, const RunRecord& run) {
  static constexpr std::array<const char*, 3> kComponentNames = {"t1", "t2", "n"};
  const Eigen::Index n = run.model.equation_count();
  const auto& harmonics = run.model.layout().harmonics();
  std::string csv =
      "point,frequency_hz,contact,component,harmonic,displacement_cos_m,displacement_sin_m,"
      "force_cos_n,force_sin_n,periodic\n";
  const auto sine = [&](std::complex<double> x, std::size_t k) {
    return round_trip(harmonics[k] == 0 ? 0.0 : 0.0 - x.imag());  // 0.0 - x: no negative zeros
  };
  for (std::size_t i = 0; i < run.table.contacts.size(); ++i) {
    const std::string point =
        std::to_string(i) + "," + round_trip(run.summary.points[i].y(n) / (2 * std::numbers::pi));
    for (std::size_t j = 0; j < run.table.contacts[i].size(); ++j) {
      const ContactHarmonics& h = run.table.contacts[i][j];
      const auto& components = run.table.contact_components.at(j);
      for (Eigen::Index a = 0; a < h.displacement.rows(); ++a)
        for (Eigen::Index k = 0; k < h.displacement.cols(); ++k) {
          const auto kk = static_cast<std::size_t>(k);
          csv += point + "," + csv_field(run.model.contacts()[j].name) + "," +
                 kComponentNames.at(
                     static_cast<std::size_t>(components[static_cast<std::size_t>(a)])) +
                 "," + std::to_string(harmonics[kk]) + "," +
                 round_trip(h.displacement(a, k).real() + 0.0) + "," +
                 sine(h.displacement(a, k), kk) + "," + round_trip(h.force(a, k).real() + 0.0) +
                 "," + sine(h.force(a, k), kk) + "," + (h.periodic ? "1" : "0") + "\n";
        }
    }
  }
  write_text(file, csv);
}

}  // namespace

nlohmann::json friction_loop_entry(const RunRecord& run, const FrictionLoop& loop) {
  const auto& contact = run.model.contacts()[loop.contact];
  const auto& comps = contact.tracer->components();
  const ForceHarmonics force_table = loop_force_harmonics(run.scene, loop, comps);
  nlohmann::json force_amplitudes = nlohmann::json::object();
  for (std::size_t a = 0; a < comps.size(); ++a)
    force_amplitudes[kContactAxisNames[comps[a]]] = force_table.amplitude[a];
  return {{"contact", contact.name},
          {"frequency", loop.frequency},
          {"crossing", loop.crossing},
          {"force_harmonic_amplitudes_N", force_amplitudes},
          {"dissipated_energy_per_cycle_J", loop.trace.energy_per_cycle},
          {"trace_passes", loop.trace.passes}};
}

nlohmann::json write_curve_files(StagedOutput& out, const RunRecord& run, bool plots) {
  write_csv(out.path("response.csv"), run.table.header, run.table.rows);
  write_response_harmonics(out.path("response_harmonics.csv"), run);
  if (run.scene.output.contact_forces)
    write_contact_harmonics(out.path("contact_harmonics.csv"), run);
  nlohmann::json loops = nlohmann::json::array();
  for (const FrictionLoop& loop : run.loops) loops.push_back(write_loop(out, run, loop, plots));
  if (plots && !run.table.rows.empty()) {  // no points: no empty plot
    const fs::path gp = out.path("response.gp");
    write_text(gp, response_plot_script(run.scene, run.table));
    run_gnuplot(gp, out.stop());
  }
  return loops;
}

namespace {

// The table of one crossing's contact states (states[first, last)); returns the patch entries
// among them with their extents.
std::vector<PatchExtent> write_states_table(const fs::path& csv_file, const RunRecord& run,
                                            const std::vector<FrictionLoop>& states,
                                            std::size_t first, std::size_t last) {
  std::ostringstream csv;
  csv.precision(12);
  csv << "entry,contact,node_a,node_b,face_s1_m,face_s2_m,area_m2,stuck,slipping,open\n";
  std::vector<PatchExtent> patches;
  for (std::size_t i = first; i < last; ++i) {
    const ContactSpec& spec = run.scene.contacts[states[i].contact];
    const auto& comps = run.model.contacts()[states[i].contact].tracer->components();
    const SlipShares shares = slip_shares(states[i].trace, comps);
    const PatchPair* pair = nullptr;
    if (spec.patch)
      for (const auto& p : spec.patch->pairs)
        if (spec.side_a == std::to_string(p.node_a)) pair = &p;
    const std::string entry = pair ? spec.name.substr(0, spec.name.rfind('.')) : spec.name;
    if (pair) {
      auto found = std::find_if(patches.begin(), patches.end(),
                                [&](const PatchExtent& p) { return p.entry == entry; });
      if (found == patches.end()) {
        patches.emplace_back().entry = entry;
        found = patches.end() - 1;
      }
      found->add(pair->face_coordinates);
    }
    csv << entry << ',' << spec.name << ',' << spec.side_a << ',' << spec.side_b << ',';
    if (pair)
      csv << pair->face_coordinates[0] << ',' << pair->face_coordinates[1] << ',' << pair->area;
    else
      csv << ",,";
    csv << ',' << shares.stuck << ',' << shares.slipping << ',' << shares.open << '\n';
  }
  write_text(csv_file, csv.str());
  return patches;
}

}  // namespace

nlohmann::json write_contact_states(StagedOutput& out, const RunRecord& run,
                                    const std::vector<FrictionLoop>& states, bool plots) {
  const std::string unit = unit_name(run.scene.continuation.unit);
  nlohmann::json entries = nlohmann::json::array();
  for (std::size_t first = 0; first < states.size();) {
    // The traces of one crossing of one frequency: consecutive in `states`.
    std::size_t last = first;
    while (last < states.size() && states[last].frequency == states[first].frequency &&
           states[last].crossing == states[first].crossing)
      ++last;
    const double frequency = states[first].frequency;
    std::string stem = format_number(frequency, 10);
    stem.append(unit.substr(0, 2)).append("_").append(std::to_string(states[first].crossing));
    const std::string base = "contact_states/" + stem;
    const auto patches = write_states_table(out.path(base + ".csv"), run, states, first, last);
    nlohmann::json plot_files = nlohmann::json::array();
    for (std::size_t k = 0; plots && k < patches.size(); ++k) {
      std::string face = stem;
      face.append("_").append(patches[k].entry).append("_face");
      std::string title = patches[k].entry;
      title.append(" at ").append(format_number(frequency)).append(" ").append(unit);
      title.append(": share of the period stuck");
      const fs::path gp = out.path("contact_states/" + face + ".gp");
      write_text(gp, face_plot_script(stem + ".csv", face + ".png", patches[k], title));
      run_gnuplot(gp, out.stop());
      plot_files.push_back("contact_states/" + face + ".png");
    }
    entries.push_back({{"frequency", frequency},
                       {"crossing", states[first].crossing},
                       {"file", base + ".csv"},
                       {"face_plots", plot_files}});
    first = last;
  }
  return entries;
}

nlohmann::json run_summary(const RunRecord& run, const nlohmann::json& friction_loops,
                           const nlohmann::json& timing, const nlohmann::json& study_context) {
  const auto& scene = run.scene;
  const auto& model = run.model;
  const auto& summary = run.summary;
  const auto& stats = model.stats();
  const Eigen::Index n = model.equation_count();
  const double unit = scene.continuation.to_rad_per_s();
  nlohmann::json doc = {
      {"frichb_version", version()},
      {"scene", {{"file", scene.file.string()}, {"name", scene.name}}},
      {"termination",
       {{"reason", to_string(summary.termination)},
        {"reached_end", summary.reached_end()},
        {"message", summary.message},
        {"suggestion", suggestion(summary, scene)},
        {"last_point", last_point_json(summary, n, unit)}}},
      {"points", summary.points.size()},
      {"rejected_steps", summary.rejected_steps},
      {"turning_points", summary.turning_points},
      {"turning_point_frequencies", run.table.turning_points.frequencies},
      {"micro_folds", run.table.turning_points.micro_folds},
      {"newton_condition", condition_json(summary, n, unit)},
      {"fine_control_restarts", summary.fine_control_restarts},
      {"steep_branch_caps", summary.steep_branch_caps},
      {"residual_floor_points", summary.residual_floor_points},
      {"corners", summary.corners},
      {"kink_steps", summary.kink_steps},
      {"reversed_tangents", summary.reversed_tangents},
      {"newton_iterations", summary.total_newton_iterations},
      {"residual_evaluations", stats.residual_evaluations},
      {"jacobian_evaluations", stats.jacobian_evaluations},
      {"jacobian",
       {{"mode",
         model.jacobian_mode() == JacobianMode::kAnalytic ? "analytic" : "finite_difference"},
        {"contact_traces_with_finite_differences", stats.contacts_with_fd_jacobian}}},
      {"non_periodic_traces", stats.non_periodic_traces},
      {"resonance_bands", resonances_json(run.setup.resonances, unit)},
      {"harmonic_truncation", truncation_json(run.table.truncation)},
      {"unknowns", n},
      {"receptance", receptance_json(model)},
      {"scaling", {{"displacement_m", run.setup.u_unit}, {"residual_m", run.setup.peak}}},
      {"peak", peaks_json(run.table)},
      {"friction_loops", friction_loops},
      {"wall_time_s", timing},
      {"profile", profile_json(summary, stats)},
      {"plugins", plugins_json(scene)},
      {"validated_scene", scene_to_json(scene)}};
  if (!run.table.stable_peaks.empty()) doc["stability"] = stability_json(run.table);
  if (!stats.last_trace_diagnostic.empty())
    doc["last_trace_diagnostic"] = stats.last_trace_diagnostic;
  if (!study_context.is_null()) doc["study"] = study_context;
  if (!scene.overrides.empty()) {
    nlohmann::json set = nlohmann::json::object();
    for (const auto& o : scene.overrides) set[o.path] = scene_override_json(o);
    doc["command_line_overrides"] = set;
  }
  return doc;
}

std::vector<std::string> run_outputs() {
  return {"response.csv",   "response_harmonics.csv", "contact_harmonics.csv",
          "response.gp",    "response.png",           "summary.json",
          "loops",          "blade_peaks.csv",        "blade_peaks.gp",
          "blade_peaks.png"};
}

nlohmann::json mistuning_json(const MistuningComparison& m) {
  nlohmann::json nodes = nlohmann::json::array();
  for (const auto& b : m.nodes)
    nodes.push_back({{"node", b.node},
                     {"amplification", b.amplification},
                     {"worst_blade", b.worst_blade},
                     {"tuned_peak_m", b.tuned_amplitude_m},
                     {"tuned_peak_hz", b.tuned_frequency_hz},
                     {"blade_peak_m", b.amplitude_m},
                     {"blade_peak_hz", b.frequency_hz},
                     {"blade_peak_solved", b.solved}});
  return {{"deviations", m.deviations},
          {"nodes", nodes},
          {"tuned_run",
           {{"termination", m.tuned_termination},
            {"points", m.tuned_points},
            {"wall_s", m.tuned_seconds}}},
          {"file", "blade_peaks.csv"}};
}

namespace {

// blade_peaks.csv: per blade its stiffness deviation and, per response node, its peak, the
// peak's frequency, the peak over the tuned disk's (0 where a peak is missing) and whether the
// peak was solved (1) or is the highest traced point (0).
void write_blade_peaks(const fs::path& file, const MistuningComparison& m) {
  std::vector<std::string> header = {"blade", "deviation"};
  for (const auto& b : m.nodes)
    for (const char* column : {"_peak_m", "_peak_hz", "_over_tuned", "_solved"})
      header.push_back(b.node + column);
  std::vector<std::vector<double>> rows;
  for (std::size_t j = 0; j < m.deviations.size(); ++j) {
    std::vector<double> row = {static_cast<double>(j), m.deviations[j]};
    for (const auto& b : m.nodes) {
      row.push_back(b.amplitude_m[j]);
      row.push_back(b.frequency_hz[j]);
      row.push_back(b.tuned_amplitude_m > 0 ? b.amplitude_m[j] / b.tuned_amplitude_m : 0.0);
      row.push_back(b.solved[j] ? 1.0 : 0.0);
    }
    rows.push_back(std::move(row));
  }
  write_csv(file, header, rows);
}

// blade_peaks.png: each blade's peak over the tuned peak, a bar per blade and node, around
// the disk; the line at 1 is the tuned disk.
std::string blade_peaks_plot_script(const Scene& scene, const MistuningComparison& m) {
  std::ostringstream gp;
  const std::size_t n = m.nodes.size();
  gp << "# gnuplot script written by frichb; run `gnuplot blade_peaks.gp` to remake "
        "blade_peaks.png\n"
     << plot_header("blade_peaks.png", 1000, 560) << line_types(n) << "set title "
     << gnuplot_string((scene.name.empty() ? scene.file.stem().string() : scene.name) +
                       ": every blade's peak against the tuned disk's")
     << "\n"
     << "set xlabel 'blade'\nset ylabel 'peak / tuned peak'\n"
     << "set style data histogram\nset style histogram clustered gap 1\n"
     << "set style fill solid 0.8 border -1\nset boxwidth 0.9\nset yrange [0:*]\n"
     << "set key outside right top\n";
  gp << "plot ";
  for (std::size_t i = 0; i < n; ++i)
    gp << (i ? ", \\\n     " : "") << "'blade_peaks.csv' using (column("
       << gnuplot_string(m.nodes[i].node + "_over_tuned") << ")):xtic(1) lt " << i + 1 << " title "
       << gnuplot_string(m.nodes[i].node);
  gp << ", \\\n     1 with lines lc rgb 'black' dt 2 title 'tuned'\n";
  return gp.str();
}

}  // namespace

void write_run(const RunResult& result, StagedOutput& out) {
  const auto started = std::chrono::steady_clock::now();
  const Scene& scene = *result.scene;
  const RunRecord record{scene,          *result.prepared.model, result.prepared.setup,
                         result.summary, result.table,           result.loops};
  const int plots_option = result.options.plots;
  const bool plots = plots_option < 0 ? scene.output.plots : plots_option != 0;
  const nlohmann::json loop_entries = write_curve_files(out, record, plots);
  const nlohmann::json state_entries = write_contact_states(out, record, result.states, plots);
  const double writing =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  nlohmann::json timing = {{"setup_s", result.setup_seconds},
                           {"continuation_s", result.continuation_seconds},
                           {"post_and_output_s", result.post_seconds + writing},
                           {"total_s", result.wall_seconds + writing}};
  // Part of post_and_output_s: the Floquet multipliers of every point.
  if (!result.table.stable_peaks.empty()) timing["stability_s"] = result.table.stability_seconds;
  nlohmann::json doc = run_summary(record, loop_entries, timing, result.options.study_context);
  doc["contact_states"] = state_entries;
  if (result.mistuning) {
    doc["mistuning"] = mistuning_json(*result.mistuning);
    write_blade_peaks(out.path("blade_peaks.csv"), *result.mistuning);
    if (plots) {
      const fs::path gp = out.path("blade_peaks.gp");
      write_text(gp, blade_peaks_plot_script(scene, *result.mistuning));
      run_gnuplot(gp, out.stop());
    }
  }
  write_json(out.path("summary.json"), doc);
  spdlog::log(result.options.quiet ? spdlog::level::debug : spdlog::level::info,
              "{} points; total {:.3f} s", result.table.rows.size(), result.wall_seconds + writing);
}

void write_run_folder(const RunResult& result, const fs::path& folder) {
  StagedOutput out(folder, run_outputs(), StagingControl(result.options.stop));
  write_run(result, out);
  out.commit();
}

RunOutcome run_bound_scene(const Scene& scene, const fs::path& folder, const RunOptions& options) {
  return run_member(scene, folder, options, write_run_folder);
}

}  // namespace frichb::core
