// The forced-response curve in stages (response_curve.hpp).
#include "frichb/core/model/response_curve.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>

#include "frichb/core/model/resonance_peak.hpp"
#include "frichb/core/model/response.hpp"
#include "frichb/core/model/stability.hpp"
#include "frichb/core/numerics/harmonics.hpp"

#include "frichb/core/support/format.hpp"
#include "frichb/core/support/interrupt.hpp"

namespace frichb::core {

namespace {

TurningPoints find_turning_points(const ContinuationSummary& summary, Eigen::Index n, double unit,
                                  double span) {
  TurningPoints report;
  for (std::size_t i = 1; i < summary.points.size(); ++i)
    if (summary.points[i - 1].tangent(n) * summary.points[i].tangent(n) < 0.0)
      report.frequencies.push_back(summary.points[i].y(n) / unit);
  report.cluster_width = kMicroFoldWidth * span;
  const auto& f = report.frequencies;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const bool near_previous = i > 0 && std::abs(f[i] - f[i - 1]) < report.cluster_width;
    const bool near_next = i + 1 < f.size() && std::abs(f[i + 1] - f[i]) < report.cluster_width;
    if (!near_previous && !near_next) continue;
    if (report.micro_folds == 0) report.first_cluster = f[i];
    ++report.micro_folds;
  }
  return report;
}

// What the stability pass keeps of a point: whether it was computed, its stability, the number
// of multipliers outside the unit circle, the one of them nearest it, and the real positive
// multiplier nearest +1 (the one a fold moves through +1; 0 when there is none); for a cyclic
// structure the nodal diameters of those two (else -1).
struct PointStability {
  bool computed = false;
  bool stable = false;
  int unstable_count = 0;
  std::complex<double> nearest_unstable = 0.0;
  double nearest_one = 0.0;
  int nearest_unstable_nodal_diameter = -1;
  int nearest_one_nodal_diameter = -1;
};

PointStability point_stability(const FloquetMultipliers& f) {
  PointStability p{true,
                   f.stable(),
                   f.unstable_count,
                   f.nearest_unstable,
                   0.0,
                   f.nearest_unstable_nodal_diameter,
                   -1};
  for (std::size_t k = 0; k < f.multipliers.size(); ++k) {
    const auto& mu = f.multipliers[k];
    if (std::abs(mu.imag()) <= 1e-9 * std::abs(mu) && mu.real() > 0 &&
        std::abs(mu.real() - 1) < std::abs(p.nearest_one - 1)) {
      p.nearest_one = mu.real();
      p.nearest_one_nodal_diameter = f.nodal_diameters.empty() ? -1 : f.nodal_diameters[k];
    }
  }
  return p;
}

// The bifurcations along the curve and each node's highest stable point (ResponseTable::
// StabilityChange, StablePoint). Wherever the number of multipliers outside the unit circle
// differs between points i - 1 and i, the multiplier that crossed (the nearest the circle of
// the point with more) names the change. The folds are the curve's turning points (the points
// between which d omega / ds changes sign): the harmonic-balance fold, where its Jacobian is
// singular, and the crossing of +1 by a multiplier of the truncated orbit meet only as the
// harmonics grow, so the real crossings of +1 within kFoldWindow of a turning point's frequency
// are that fold's: its entry takes the nearest one's multiplier (else the real multiplier
// nearest +1 at the turning point) and the stability after the last of them (or after the
// turning point, where they came before it).
void summarise_stability(ResponseTable& table, const ContinuationSummary& summary, Eigen::Index n,
                         const std::vector<PointStability>& points) {
  using Change = ResponseTable::StabilityChange;
  const std::size_t count = std::min(points.size(), table.rows.size());
  std::vector<Change> crossings;
  std::vector<std::size_t> turning;
  table.stable_peaks.assign(table.nodes.size(), std::nullopt);
  for (std::size_t i = 0; i < count; ++i) {
    const PointStability& p = points[i];
    if (!p.computed) continue;
    table.unstable_points += p.stable ? 0 : 1;
    if (i > 0 && summary.points[i - 1].tangent(n) * summary.points[i].tangent(n) < 0.0)
      turning.push_back(i);
    const PointStability* before = i > 0 && points[i - 1].computed ? &points[i - 1] : nullptr;
    if (before && before->unstable_count != p.unstable_count) {
      const PointStability& more = p.unstable_count > before->unstable_count ? p : *before;
      const std::complex<double> mu = more.nearest_unstable;
      const bool real = std::abs(mu.imag()) <= 1e-9 * std::abs(mu);
      crossings.push_back({i, p.stable, p.unstable_count, mu,
                           !real             ? "neimark_sacker"
                           : mu.real() < 0.0 ? "period_doubling"
                                             : "branch_point",
                           std::nullopt, more.nearest_unstable_nodal_diameter});
    }
    for (std::size_t k = 0; k < table.nodes.size() && p.stable; ++k) {
      const double amp = table.rows[i][3 + k * (1 + table.harmonics[i][k].cols())];
      auto& best = table.stable_peaks[k];
      if (!best || amp > best->amplitude_m)
        best = ResponseTable::StablePoint{i, amp, table.rows[i][2]};
    }
  }
  for (std::size_t t : turning) {
    const double hz = table.rows[t][1];
    const PointStability& at = points[t];
    const PointStability* before = points[t - 1].computed ? &points[t - 1] : nullptr;
    const PointStability& nearer =
        before && std::abs(before->nearest_one - 1) < std::abs(at.nearest_one - 1) ? *before : at;
    Change fold{t,
                at.stable,
                at.unstable_count,
                nearer.nearest_one,
                "fold",
                std::nullopt,
                nearer.nearest_one_nodal_diameter};
    std::size_t nearest = count, last = t;
    for (auto& c : crossings)
      if (c.kind == "branch_point" && std::abs(table.rows[c.point][1] - hz) <= kFoldWindow * hz) {
        const auto distance = [&](std::size_t i) { return i > t ? i - t : t - i; };
        if (nearest == count || distance(c.point) < distance(nearest)) {
          nearest = c.point;
          fold.multiplier = c.multiplier;
          fold.nodal_diameter = c.nodal_diameter;
        }
        if (c.point >= last) {
          last = c.point;
          fold.stable = c.stable;
          fold.unstable_count = c.unstable_count;
        }
        c.kind.clear();  // the fold's
      }
    crossings.push_back(fold);
  }
  std::erase_if(crossings, [](const Change& c) { return c.kind.empty(); });
  std::sort(crossings.begin(), crossings.end(),
            [](const Change& a, const Change& b) { return a.point < b.point; });
  table.stability_changes = std::move(crossings);
}

// Bisection on the chord between points `point` - 1 and `point` of `summary` for where the
// number of multipliers outside the unit circle leaves `before` (ResponseTable::LocatedChange);
// nullopt where a solve or the multipliers fail.
std::optional<ResponseTable::LocatedChange> locate_change(const HarmonicBalanceModel& model,
                                                          ChordSolver& chord,
                                                          const ContinuationSummary& summary,
                                                          std::size_t point, int before,
                                                          const std::vector<ResponseNode>& nodes,
                                                          AmplitudeSampler& sampler) {
  const Eigen::VectorXd& a = summary.points[point - 1].y;
  const Eigen::VectorXd& b = summary.points[point].y;
  double lo = 0.0, hi = 1.0;
  Eigen::VectorXd y_lo = a, y_hi = b;
  FloquetMultipliers at_lo, at_hi;
  for (int i = 0; i < kLocateBisections; ++i) {
    const double theta = 0.5 * (lo + hi);
    const ChordPoint p = chord.solve(a, b, theta, y_lo + (y_hi - y_lo) * 0.5);
    if (!p.converged) return std::nullopt;
    FloquetMultipliers f = floquet_multipliers(model, p.y);
    if (!f.failure.empty()) return std::nullopt;
    if (f.unstable_count == before) {
      lo = theta;
      y_lo = p.y;
      at_lo = std::move(f);
    } else {
      hi = theta;
      y_hi = p.y;
      at_hi = std::move(f);
    }
  }
  // The side with more multipliers outside the circle names the crossing one.
  if (at_lo.steps == 0) at_lo = floquet_multipliers(model, y_lo);
  if (at_hi.steps == 0) at_hi = floquet_multipliers(model, y_hi);
  if (!at_lo.failure.empty() || !at_hi.failure.empty()) return std::nullopt;
  const bool after_more = at_hi.unstable_count > at_lo.unstable_count;
  const Eigen::VectorXd& y = after_more ? y_hi : y_lo;
  ResponseTable::LocatedChange out;
  out.omega_rad_s = y(model.equation_count());
  out.multiplier = (after_more ? at_hi : at_lo).nearest_unstable;
  out.nodal_diameter = (after_more ? at_hi : at_lo).nearest_unstable_nodal_diameter;
  out.theta = after_more ? hi : lo;
  const auto x = model.kept_response(y);
  for (const auto& node : nodes) out.amplitude_m.push_back(sampler.peak_amplitude(x, node.kept));
  return out;
}

// Every change of `table` other than a fold located by locate_change (warned where it is
// not), the chord solver made on first use.
void locate_changes(const Scene& scene, const HarmonicBalanceModel& model,
                    const ContinuationOptions& options, const ContinuationSummary& summary,
                    const std::vector<PointStability>& multipliers, AmplitudeSampler& sampler,
                    std::unique_ptr<ChordSolver>& chord, ResponseTable& table) {
  for (auto& change : table.stability_changes) {
    if (change.kind == "fold" || options.newton.stop.stop_requested()) continue;
    if (!chord) chord = std::make_unique<ChordSolver>(model, options);
    change.located =
        locate_change(model, *chord, summary, change.point,
                      multipliers[change.point - 1].unstable_count, table.nodes, sampler);
    if (!change.located)
      spdlog::warn(
          "{}: the {} between points {} and {} was not located; the point after it is "
          "reported",
          scene.file.string(), change.kind, change.point - 1, change.point);
  }
}

// A contact component's force energy below this fraction of its largest component's is
// rounding (the check_truncation below skips it).
constexpr double kNegligibleForceEnergy = 1e-12;

// The harmonic truncation at the curve's highest point (of the first response node, column 3
// of `rows`); warns above kHighestHarmonicShare.
std::optional<HarmonicTruncation> check_truncation(const Scene& scene,
                                                   const HarmonicBalanceModel& model,
                                                   const ContinuationSummary& summary,
                                                   const std::vector<std::vector<double>>& rows) {
  const auto& kept = model.layout().harmonics();
  const int highest = kept.back();
  if (rows.empty() || model.contacts().empty() || highest < 2) return std::nullopt;
  std::size_t top = 0;
  for (std::size_t i = 1; i < rows.size(); ++i)
    if (rows[i][3] > rows[top][3]) top = i;
  const Eigen::Index n = model.equation_count();
  double worst = 0.0;
  std::string where;
  for (std::size_t c = 0; c < model.contacts().size(); ++c) {
    ContactTrace trace;
    if (!model.trace_contact(c, summary.points[top].y, trace, nullptr)) continue;
    if (highest > (static_cast<int>(trace.force.rows()) - 1) / 2) continue;
    const auto& comps = model.contacts()[c].tracer->components();
    const ForceHarmonics table = force_harmonics(trace.force, comps, highest);
    std::vector<double> totals(comps.size(), 0.0);
    for (std::size_t a = 0; a < comps.size(); ++a)
      for (int h : kept)
        if (h > 0) totals[a] += std::pow(table.amplitude[a][static_cast<std::size_t>(h)], 2);
    const double largest = *std::max_element(totals.begin(), totals.end());
    for (std::size_t a = 0; a < comps.size(); ++a) {
      // A component that carries no force (rounding beside the others': a direction the
      // motion never takes) has no spectrum to cut.
      const double total = totals[a];
      if (total <= kNegligibleForceEnergy * largest) continue;
      const double top_share =
          total > 0 ? std::pow(table.amplitude[a][static_cast<std::size_t>(highest)], 2) / total
                    : 0.0;
      if (top_share > worst) {
        worst = top_share;
        where = model.contacts()[c].name + " (" + kContactAxisNames[comps[a]] + ")";
      }
    }
  }
  const double unit = scene.continuation.to_rad_per_s();
  const double at = summary.points[top].y(n) / unit;
  if (worst > kHighestHarmonicShare)
    spdlog::warn(
        "{}: at the curve's highest point ({} {}) harmonic {} carries {:.1f} % of the force "
        "energy of contact {}: the kept harmonics cut the force's spectrum where it still "
        "matters; keep more harmonics (harmonic_balance.max_harmonic) and compare the peak",
        scene.file.string(), format_number(at), unit_name(scene.continuation.unit), highest,
        100 * worst, where);
  HarmonicTruncation truncation;
  truncation.frequency = at;
  truncation.highest_harmonic = highest;
  truncation.largest_energy_share = worst;
  truncation.contact = where;
  return truncation;
}

}  // namespace

Eigen::VectorXd find_start_point(const HarmonicBalanceModel& model,
                                 const ContinuationOptions& options,
                                 spdlog::level::level_enum log_level) {
  const Eigen::Index n = model.equation_count();
  Eigen::VectorXd y0(n + 1);
  y0.head(n) = model.linear_response(options.lambda_start);
  y0(n) = options.lambda_start;
  if (n == 0) return y0;
  FixedParameterSolver solver(model, options);
  const NewtonResult first = solver.solve(y0);
  if (first.converged) return first.y;  // trace_curve then starts from the solution itself
  for (const double shrink : {0.0, 1e-3, 1e-6}) {
    if (options.newton.stop.stop_requested()) break;
    Eigen::VectorXd guess = y0;
    guess.head(n) *= shrink;
    const NewtonResult start = solver.solve(guess);
    if (start.converged) {
      spdlog::log(log_level, "start point found from {} the contact-free response",
                  shrink == 0 ? std::string("zero instead of") : format_number(shrink) + " x");
      return start.y;
    }
  }
  return y0;
}

ContinuationSummary trace_response(const Scene& scene, const HarmonicBalanceModel& model,
                                   const ContinuationOptions& options, const Eigen::VectorXd& start,
                                   const PointCallback& on_point) {
  if (model.equation_count() > 0) return trace_curve(model, start, options, on_point);
  const auto& C = scene.continuation;
  const double unit = C.to_rad_per_s();
  const double w_from = options.lambda_start, w_to = options.lambda_end;
  // The largest step, shortened near each resonance as the continuation's bands do.
  std::vector<double> ws = {w_from};
  const double largest = C.max_step * unit, direction = w_to > w_from ? 1.0 : -1.0;
  while (direction * (w_to - ws.back()) > 1e-12 * std::abs(w_to)) {
    const double advance = std::min(largest, options.band_advance(ws.back(), direction));
    ws.push_back(direction * (w_to - ws.back()) <= advance ? w_to
                                                           : ws.back() + direction * advance);
  }
  ContinuationSummary summary;
  for (std::size_t i = 0; i < ws.size(); ++i) {
    ContinuationPoint p;
    p.y = Eigen::VectorXd::Constant(1, ws[i]);
    p.tangent = Eigen::VectorXd::Constant(1, w_to > w_from ? 1.0 : -1.0);
    p.step = i ? std::abs(ws[i] - ws[i - 1]) / unit : 0.0;
    summary.points.push_back(p);
  }
  summary.termination = TerminationType::kReachedEnd;
  summary.message = "linear scene (no contacts): sampled every " + format_number(C.max_step) + " " +
                    unit_name(C.unit) + ", finer near " +
                    std::to_string(options.step_bands.size()) + " resonance(s)";
  return summary;
}

Eigen::MatrixXcd node_harmonics(const std::vector<Eigen::VectorXcd>& x, const ResponseNode& node) {
  Eigen::MatrixXcd out(static_cast<Eigen::Index>(node.kept.size()),
                       static_cast<Eigen::Index>(x.size()));
  for (std::size_t d = 0; d < node.kept.size(); ++d)
    for (std::size_t k = 0; k < x.size(); ++k)
      out(static_cast<Eigen::Index>(d), static_cast<Eigen::Index>(k)) = x[k](node.kept[d]);
  return out;
}

std::vector<ContactHarmonics> contact_harmonics(const HarmonicBalanceModel& model,
                                                const Eigen::VectorXd& y) {
  const HarmonicLayout& layout = model.layout();
  const Eigen::Index kept = static_cast<Eigen::Index>(layout.harmonics().size());
  const int c = layout.coefficient_count();
  // The complex amplitude of kept harmonic k from a signal's coefficients: cos - i sin.
  const auto amplitude = [&](const Eigen::VectorXd& coefficients, Eigen::Index first,
                             std::size_t k) {
    const int s = layout.sin_index(k);
    return std::complex<double>(coefficients(first + layout.cos_index(k)),
                                s < 0 ? 0.0 : -coefficients(first + s));
  };
  std::vector<ContactHarmonics> out(model.contacts().size());
  ContactTrace trace;
  for (std::size_t i = 0; i < model.contacts().size(); ++i) {
    const ContactModel& contact = model.contacts()[i];
    std::string error;
    if (!model.trace_contact(i, y, trace, &error))
      throw std::runtime_error("contact '" + contact.name +
                               "' failed on a point of the curve: " + error);
    const auto& components = contact.tracer->components();
    const Eigen::Index d = static_cast<Eigen::Index>(components.size());
    const Eigen::VectorXd u = y.segment(static_cast<Eigen::Index>(contact.offset) * c, d * c);
    ContactHarmonics& h = out[i];
    h.displacement.resize(d, kept);
    h.force.resize(d, kept);
    h.periodic = trace.periodic;
    for (Eigen::Index a = 0; a < d; ++a)
      for (Eigen::Index k = 0; k < kept; ++k) {
        const auto kk = static_cast<std::size_t>(k);
        h.displacement(a, k) = amplitude(u, a * c, kk);
        h.force(a, k) = amplitude(trace.force_coefficients, a * c, kk);
        // The trace's coefficients are of the force less the law's force at u = 0 (the
        // preload the static equilibrium balances): added back to the static term.
        if (layout.harmonics()[kk] == 0)
          h.force(a, k) +=
              contact.tracer->reference_force()(components[static_cast<std::size_t>(a)]);
      }
  }
  return out;
}

ResponseTable tabulate_response(const Scene& scene, const HarmonicBalanceModel& model,
                                const ContinuationOptions& options,
                                const ContinuationSummary& summary) {
  ResponseTable table;
  if (scene.output.contact_forces)
    for (const ContactModel& contact : model.contacts())
      table.contact_components.push_back(contact.tracer->components());
  const Eigen::Index n = model.equation_count();
  for (const auto& name : scene.output.response) {
    ResponseNode node{name, {}};
    for (std::size_t d : scene.structure.find(name)->dofs) node.kept.push_back(model.kept_index(d));
    table.nodes.push_back(node);
  }
  const auto& nodes = table.nodes;
  const auto& harmonics = model.layout().harmonics();
  AmplitudeSampler sampler(harmonics, std::max(256, 8 * model.layout().samples()));
  table.header = {"point", "frequency_hz", "omega_rad_s"};
  for (const auto& node : nodes) {
    table.header.push_back(node.name + "_amplitude_m");
    for (int h : harmonics) table.header.push_back(node.name + "_h" + std::to_string(h) + "_m");
  }
  table.header.insert(table.header.end(), {"newton_iterations", "step", "condition"});
  if (scene.output.stability)
    table.header.insert(table.header.end(),
                        {"stable", "largest_multiplier", "unstable_multipliers"});
  const bool nodal_diameters = scene.output.stability && scene.cyclic.enabled();
  if (nodal_diameters) table.header.emplace_back("largest_multiplier_nodal_diameter");
  double stability_seconds = 0.0;
  std::vector<PointStability> multipliers(scene.output.stability ? summary.points.size() : 0);
  int stability_failures = 0;
  auto& rows = table.rows;
  const auto tabulating = std::chrono::steady_clock::now();
  std::vector<double> peak_amp(nodes.size(), -1.0), peak_w(nodes.size(), 0.0);
  for (std::size_t i = 0; i < summary.points.size(); ++i) {
    if (options.newton.stop.stop_requested()) break;  // the caller reports it
    const auto& p = summary.points[i];
    const double w = p.y(n);
    const auto x = model.kept_response(p.y, p.record);
    std::vector<double> row = {static_cast<double>(i), w / (2 * std::numbers::pi), w};
    auto& at_point = table.harmonics.emplace_back();
    if (scene.output.contact_forces) table.contacts.push_back(contact_harmonics(model, p.y));
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      at_point.push_back(node_harmonics(x, nodes[k]));
      const double amp = sampler.peak_amplitude(x, nodes[k].kept);
      row.push_back(amp);
      if (amp > peak_amp[k]) {
        peak_amp[k] = amp;
        peak_w[k] = w;
      }
      for (double a : AmplitudeSampler::harmonic_amplitudes(x, nodes[k].kept)) row.push_back(a);
    }
    row.push_back(p.newton_iterations);
    row.push_back(p.step);
    row.push_back(std::isfinite(p.condition) ? p.condition : 0.0);  // 0: not estimated
    if (scene.output.stability) {
      const auto started = std::chrono::steady_clock::now();
      const FloquetMultipliers f = floquet_multipliers(model, p.y);
      stability_seconds +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      if (f.failure.empty()) {
        row.push_back(f.stable() ? 1.0 : 0.0);
        row.push_back(f.largest_modulus);
        row.push_back(f.unstable_count);
        if (nodal_diameters)
          row.push_back(f.nodal_diameters.empty() ? std::numeric_limits<double>::quiet_NaN()
                                                  : f.nodal_diameters.front());
        multipliers[i] = point_stability(f);
      } else {  // reported in the table as NaN, and logged
        if (stability_failures++ == 0)
          spdlog::warn("no Floquet multipliers at point {}: {}", i, f.failure);
        row.insert(row.end(), nodal_diameters ? 4 : 3, std::numeric_limits<double>::quiet_NaN());
      }
    }
    rows.push_back(std::move(row));
  }

  spdlog::debug(
      "response at {} points ({} with the continuation's contact forces) in {} s", rows.size(),
      std::count_if(summary.points.begin(), summary.points.end(),
                    [](const ContinuationPoint& p) { return p.record.size() > 0; }),
      format_number(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - tabulating).count()));
  std::unique_ptr<ChordSolver> chord;
  if (scene.output.stability) {
    summarise_stability(table, summary, n, multipliers);
    const auto started = std::chrono::steady_clock::now();
    locate_changes(scene, model, options, summary, multipliers, sampler, chord, table);
    stability_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  }
  table.stability_seconds = stability_seconds;
  if (scene.output.stability)
    spdlog::debug("Floquet multipliers of {} points in {} s ({} failed)", rows.size(),
                  format_number(stability_seconds), stability_failures);
  // The peak of each node's curve, solved along the curve beside its highest point.
  std::vector<bool> refined(nodes.size(), false);
  std::vector<Eigen::VectorXd> peak_y(nodes.size());
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    if (rows.empty() || options.newton.stop.stop_requested()) break;
    const std::size_t column = 3 + k * (1 + harmonics.size());
    std::size_t top = 0;
    for (std::size_t i = 1; i < rows.size(); ++i)
      if (rows[i][column] > rows[top][column]) top = i;
    peak_y[k] = summary.points[top].y;
    if (top == 0 || top + 1 >= rows.size()) continue;  // the curve's end is its highest point
    if (!chord) chord = std::make_unique<ChordSolver>(model, options);
    ResonancePeak solved = solve_resonance_peak(model, *chord, summary.points, top, nodes[k].kept,
                                                sampler, options.newton.stop);
    if (!solved.solved) {
      if (!options.newton.stop.stop_requested())
        spdlog::warn(
            "{}: the peak of {} was not solved ({}); the highest traced point is "
            "reported",
            scene.file.string(), nodes[k].name, solved.message);
      continue;
    }
    spdlog::debug("peak of {}: {} m at {} rad/s, {} evaluations, slope {} m", nodes[k].name,
                  format_number(solved.amplitude_m), format_number(solved.y(n)), solved.evaluations,
                  format_number(solved.slope));
    if (solved.amplitude_m >= peak_amp[k]) {
      peak_amp[k] = solved.amplitude_m;
      peak_w[k] = solved.y(n);
      peak_y[k] = std::move(solved.y);
      refined[k] = true;
    } else {
      spdlog::warn(
          "{}: the solved peak of {} ({} m) lies below its highest traced point ({} m); "
          "the highest traced point is reported",
          scene.file.string(), nodes[k].name, format_number(solved.amplitude_m),
          format_number(peak_amp[k]));
    }
  }
  table.truncation = check_truncation(scene, model, summary, rows);
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    if (peak_amp[k] < 0) {  // no point on the curve: no peak
      table.peaks.emplace_back(std::nullopt);
      continue;
    }
    table.peaks.emplace_back(
        NodePeak{nodes[k].name, peak_amp[k], peak_w[k], refined[k], std::move(peak_y[k])});
  }
  const double unit = scene.continuation.to_rad_per_s();
  table.turning_points = find_turning_points(
      summary, n, unit, std::abs(scene.continuation.to - scene.continuation.from));
  return table;
}

std::vector<FrictionLoop> solve_friction_loops(const Scene& scene,
                                               const HarmonicBalanceModel& model,
                                               const ContinuationOptions& options,
                                               const ContinuationSummary& summary) {
  return solve_contact_traces(scene, model, options, summary, scene.output.friction_loops_at);
}

std::vector<FrictionLoop> solve_contact_traces(const Scene& scene,
                                               const HarmonicBalanceModel& model,
                                               const ContinuationOptions& options,
                                               const ContinuationSummary& summary,
                                               const std::vector<double>& frequencies) {
  std::vector<FrictionLoop> loops;
  const auto& C = scene.continuation;
  const double unit = C.to_rad_per_s();
  const Eigen::Index n = model.equation_count();
  std::unique_ptr<FixedParameterSolver> solver;
  for (double f_req : frequencies) {
    if (options.newton.stop.stop_requested()) break;  // the caller reports it
    const double w_req = f_req * unit;
    int crossing = 0;
    for (std::size_t i = 1; i < summary.points.size(); ++i) {
      const double wa = summary.points[i - 1].y(n), wb = summary.points[i].y(n);
      if (options.newton.stop.stop_requested()) break;
      if ((wa - w_req) * (wb - w_req) > 0 || wa == wb) continue;
      if (wb == w_req && i + 1 < summary.points.size()) continue;  // counted at the next pair
      const double s = (w_req - wa) / (wb - wa);
      Eigen::VectorXd guess = (1 - s) * summary.points[i - 1].y + s * summary.points[i].y;
      guess(n) = w_req;
      if (!solver) solver = std::make_unique<FixedParameterSolver>(model, options);
      const NewtonResult solved = solver->solve(guess);
      if (!solved.converged) {
        spdlog::warn("friction loop at {} {}: Newton did not converge ({})", f_req,
                     unit_name(C.unit), solved.message);
        continue;
      }
      ++crossing;
      for (std::size_t c = 0; c < model.contacts().size(); ++c) {
        FrictionLoop loop;
        std::string error;
        if (!model.trace_contact(c, solved.y, loop.trace, &error)) {
          spdlog::warn("friction loop: {}", error);
          continue;
        }
        loop.contact = c;
        loop.frequency = f_req;
        loop.crossing = crossing;
        loops.push_back(std::move(loop));
      }
    }
    if (crossing == 0 && !options.newton.stop.stop_requested())
      spdlog::warn("friction loop at {} {}: the response curve does not reach it", f_req,
                   unit_name(C.unit));
  }
  return loops;
}

}  // namespace frichb::core
