// `frichb peaks`: the resonance peak of a scene's forced response traced against one design
// parameter (model/peak_tracking.hpp), from the peak of an ordinary run at the range's start.
// The verb shape: commands/verb.hpp; the writer: report/peaks_report.hpp.
#pragma once

#include <Eigen/Dense>
#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "frichb/core/commands/verb.hpp"
#include "frichb/core/model/peak_tracking.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/support/interrupt.hpp"

namespace frichb::core {

inline constexpr int kDefaultCheckRuns = 8;

struct PeaksOptions {
  SceneInput scene;
  // The design parameter: a scene-key path (scene.hpp's paths, as study sweeps take them)
  // under `contacts` (a contact law's parameter: normal load, friction coefficient, gap, a
  // stiffness) or `excitation` (an amplitude). Other sections are refused: the structure is
  // built once.
  std::string parameter;
  double from = 0.0;  // the range of the parameter, in the scene's units; from != to
  double to = 0.0;
  // The node whose peak is traced: one of output.response (empty: the first).
  std::string node;
  // Which of the start run's peaks is traced: the local maximum of the node's amplitude along
  // the run's curve nearest this frequency (Hz), solved at `from`; nullopt: the run's peak (the
  // highest in its frequency window).
  std::optional<double> near_hz;
  // A logarithmic parameter axis (lambda = ln p): nullopt decides (from and to > 0, spanning
  // at least a decade).
  std::optional<bool> logarithmic;
  int max_points = 500;
  // Runs of the whole response at this many traced points between the range's ends (besides
  // the start's, the jumps' and the end's), for where another peak overtakes the traced one
  // (PeakExchange); 0: none. Each costs one ordinary run.
  int check_runs = kDefaultCheckRuns;
  // The thesis's normalised design chart: the peak against mu N0 / f, the amplitude over f. For
  // a contact's normal_load whose law has a `mu`, with one excitation (f: its amplitude).
  bool normalise = false;
  // The call's stop token: a stop ends the start run or the tracking at its next step
  // (outcome 128 + signal, nothing to write).
  StopToken stop;
};

// The peak at one point of the traced peak curve.
struct TrackedPeak {
  double parameter = 0.0;     // p, in the scene's units
  double frequency_hz = 0.0;  // the peak's frequency
  double amplitude_m = 0.0;   // the measure at the peak (a run's peak measure)
  int newton_iterations = 0;  // of the point's correction (0: a jump's run gave it)
  int branch = 0;             // the branch it lies on: 0, then one more after each jump
  // Sensitivities along the peak curve, per unit of p; NaN where the curve turns in p (a fold
  // of the peak curve: dp/ds = 0).
  double d_frequency_hz_d_parameter = 0.0;
  double d_amplitude_m_d_parameter = 0.0;
  // With the scene's output.stability: whether the periodic response at the peak is stable and
  // its largest Floquet multiplier's modulus (model/stability.hpp; nullopt and NaN without it,
  // or where the multipliers could not be computed).
  std::optional<bool> stable;
  double largest_multiplier = 0.0;
  // The point on the peak curve: the harmonic-balance unknowns, w (rad/s), lambda (p, or ln p
  // on a logarithmic axis).
  Eigen::VectorXd y;
};

// Where the traced peak stopped being one and the tracking went on from the peak of a run a
// little further on (kPeakJumpStep): the traced maximum merged with a valley of the response
// curve (a fold of the peak curve, where the maximum turns into a minimum), or the
// continuation could not go on or stalled (a sample-by-sample law's corners).
struct PeakJump {
  double from_parameter = 0.0;  // the last point of the branch left
  double from_frequency_hz = 0.0, from_amplitude_m = 0.0;
  double parameter = 0.0;  // the run's, where the next branch starts
  double to_frequency_hz = 0.0, to_amplitude_m = 0.0;
  std::string reason;
};
// Where another resonance peak of the node's response and the traced one exchange being the
// highest (the traced peak is overtaken, or becomes the highest again). Seen at the runs the
// tracking makes (the start, each jump's, one at the range's end and PeaksOptions::check_runs
// between), each holding all the response's peaks at its parameter value: between two of them whose
// highest peak differs, the other peak is continued in the parameter over that interval and the
// parameter where the two amplitudes are equal is solved (secant steps, each the two peaks solved
// at that value). The tracking stays on its own peak. An exchange made and undone between two runs
// is not seen.
struct PeakExchange {
  bool overtaken = true;  // the other peak becomes the highest (false: falls below again)
  // The interval between the runs that bracket it.
  double bracket_from = 0.0, bracket_to = 0.0;
  bool located = false;      // the crossing solved (false: only bracketed; `message` says why)
  double parameter = 0.0;    // the crossing (the bracket's end when not located)
  double amplitude_m = 0.0;  // both peaks' amplitude there
  double frequency_hz = 0.0, other_frequency_hz = 0.0;  // the traced peak's and the other's
  std::string message;
};
// The largest relative difference of amplitude at which a secant step of an exchange's
// location stops (the peaks' own accuracy is about 1e-11 of the amplitude), and the most steps.
inline constexpr double kExchangeTolerance = 1e-9;
inline constexpr int kMaxExchangeSteps = 30;

// The step of a jump, in lambda (ln p, or p over the range's width), and the most jumps.
inline constexpr double kPeakJumpStep = 0.01;
inline constexpr int kMaxPeakJumps = 20;
// A branch whose continuation steps stay below kStalledStep (scaled arclength) for
// kStalledPoints points in a row has stalled: it ends there and the tracking jumps.
inline constexpr double kStalledStep = 1e-4;
inline constexpr int kStalledPoints = 10;

// The optimum's solve: converged when a probe lands within kOptimumTolerance (of lambda's
// scale) of the bracket end it replaces, or the bracket is that narrow; at most
// kMaxOptimumProbes probes.
inline constexpr double kOptimumTolerance = 1e-7;
inline constexpr int kMaxOptimumProbes = 30;

struct PeaksResult {
  Outcome outcome;
  std::filesystem::path scene_file;
  std::string parameter;  // the path varied
  std::string node;
  double from = 0.0, to = 0.0;
  bool logarithmic = false;
  bool plots = true;  // the scene's output.plots
  long unknowns = 0;  // harmonic-balance unknowns
  // With PeaksOptions::normalise, both in 1/N: mu / f (the chart's abscissa mu N0 / f is the
  // normal load times it) and 1 / f (the amplitude per newton of excitation); else 0.
  double mu_over_force = 0.0, per_force = 0.0;
  // The start: the peak of an ordinary run at p = from.
  double start_frequency_hz = 0.0, start_amplitude_m = 0.0;
  bool start_refined = false;           // solved along the curve (false: its highest traced point)
  std::vector<TrackedPeak> peaks;       // along the peak curve, from `from`
  std::vector<PeakJump> jumps;          // between its branches, in order
  std::vector<PeakExchange> exchanges;  // with other peaks of the response, in order
  std::optional<double> near_hz;        // PeaksOptions::near_hz
  // The run at the range's end (made when the peak curve reached it, for the exchanges): the
  // peak of that run nearest the traced one's frequency, against the last traced point.
  struct EndCheck {
    bool made = false;
    double frequency_hz = 0.0, amplitude_m = 0.0;
  } end_run;
  // The lowest peak amplitude over the traced points (none when nothing was traced), and
  // whether it lies at an end of the traced range (then the optimum may lie beyond it).
  std::optional<std::size_t> optimum;
  bool optimum_at_end = false;
  // The optimum solved between the traced points: where the peak amplitude's sensitivity to
  // the parameter changes sign beside the lowest point, on one branch (regula falsi in lambda,
  // each probe the peak solved at a fixed parameter). Not solved at an end of the range, across
  // a jump, or where a probe fails: then the lowest traced point is the optimum.
  struct SolvedOptimum {
    bool solved = false;
    double parameter = 0.0, frequency_hz = 0.0, amplitude_m = 0.0;
    int probes = 0;
    std::string message;  // why not, when not solved
  } solved_optimum;
  std::string termination;  // the last branch's continuation termination ("reached_end", ...)
  int turning_points = 0;   // folds of the peak curve in p, over its branches
  double start_seconds = 0.0, tracking_seconds = 0.0, wall_seconds = 0.0;
};

// The scene at values of its design parameter `path` (ParameterModels): the document read
// again with the parameter set, bound to the same plugins, each model on one structure built
// from `base` (the parameter must lie outside the structure: PeaksOptions::parameter); for a
// contact's parameter, the models share one reduction of the structure
// (HarmonicBalanceModel::with_contact_params) and only the laws are instantiated per value.
// Keeps the last four models (the tracking asks for p and p +- h in turn). `base` and
// `registry` outlive it. Not thread-safe.
class SceneParameterModels final : public ParameterModels {
 public:
  SceneParameterModels(const Scene& base, const Registry& registry, std::string path,
                       int contact_threads);
  ~SceneParameterModels() override;
  const HarmonicBalanceModel& at(double p) const override;

 private:
  static constexpr std::size_t kKept = 4;
  struct Entry {
    double p = 0.0;
    long used = 0;
    std::unique_ptr<Scene> scene;
    std::unique_ptr<HarmonicBalanceModel> model;
  };
  const Scene& base_;
  const Registry& registry_;
  std::string path_;
  int threads_ = 0;
  std::unique_ptr<StructureModel> structure_;
  mutable std::vector<Entry> cache_;
  mutable long clock_ = 0;
};

// Runs the scene at p = from and takes its peak at `node` (or the one nearest near_hz), then
// continues that peak to p = to. Where the traced maximum turns into a minimum or the
// continuation cannot go on, it runs the scene kPeakJumpStep further on and continues from that
// run's peak nearest the branch's last frequency (a PeakJump). Once the range's end is reached it
// runs the scene there too, and reports where another peak of the response and the traced one
// exchange being the highest (PeakExchange). With the scene's output.stability, each point's
// Floquet multipliers. Logs progress. Throws SceneError for a scene, path or node it cannot use
// (the run's errors, a path outside contacts and excitation, a node not in output.response),
// std::invalid_argument for a range that is empty or not positive on a logarithmic axis or a
// near_hz that is not a positive frequency. A start run that finds no peak (near near_hz), or a
// tracking that ends early, is an outcome (kExitIncomplete, with what was traced).
PeaksResult track_peaks(const PeaksOptions& options);

}  // namespace frichb::core
