// The peak of a response node solved along the traced curve (resonance_peak.hpp).
#include "frichb/core/model/resonance_peak.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <utility>

#include <spdlog/spdlog.h>

#include "frichb/core/support/format.hpp"

namespace frichb::core {

namespace {

// The share of the bracket's side within which a secant root next to c is overshot (below).
constexpr double kSecantOvershootShare = 0.1;

// One evaluation of the stationarity condition: the curve's point at theta, the amplitude
// there and its slope along the curve.
struct Probe {
  double theta = 0.0;
  Eigen::VectorXd y;
  double amplitude = 0.0;
  double slope = 0.0;
};

class PeakSearch {
 public:
  PeakSearch(const HarmonicBalanceModel& model, ChordSolver& solver, Eigen::VectorXd a,
             Eigen::VectorXd b, const std::vector<Eigen::Index>& kept, AmplitudeSampler& sampler)
      : model_(model),
        solver_(solver),
        a_(std::move(a)),
        b_(std::move(b)),
        kept_(kept),
        sampler_(sampler) {}

  double theta_of(const Eigen::VectorXd& y) const { return solver_.theta(a_, b_, y); }
  int evaluations() const { return evaluations_; }
  const std::string& failure() const { return failure_; }

  std::optional<Probe> probe(double theta, const Eigen::VectorXd& guess) {
    ++evaluations_;
    const ChordPoint point = solver_.solve(a_, b_, theta, guess);
    if (!point.converged) {
      failure_ = "the curve's point at theta = " + format_number(theta) +
                 " between the neighbours of the highest point was not solved: " + point.message;
      return std::nullopt;
    }
    Probe p;
    p.theta = theta;
    p.y = point.y;
    try {
      p.amplitude = sampler_.peak_amplitude(model_.kept_response(point.y, point.record), kept_);
      const Eigen::VectorXd step = kSlopeStep * point.velocity;
      p.slope = (amplitude(point.y + step) - amplitude(point.y - step)) / (2 * kSlopeStep);
    } catch (const std::runtime_error& e) {
      failure_ = e.what();
      return std::nullopt;
    }
    spdlog::trace(
        "peak probe {}: theta {:.17g}, amplitude {:.17g} m, slope {:.6g} m, {} Newton iterations",
        evaluations_, theta, p.amplitude, p.slope, point.iterations);
    return p;
  }

 private:
  double amplitude(const Eigen::VectorXd& y) {
    return sampler_.peak_amplitude(model_.kept_response(y), kept_);
  }

  const HarmonicBalanceModel& model_;
  ChordSolver& solver_;
  Eigen::VectorXd a_, b_;
  const std::vector<Eigen::Index>& kept_;
  AmplitudeSampler& sampler_;
  int evaluations_ = 0;
  std::string failure_;
};

ResonancePeak failed(std::string why, int evaluations) {
  ResonancePeak peak;
  peak.message = std::move(why);
  peak.evaluations = evaluations;
  return peak;
}

}  // namespace

ResonancePeak solve_resonance_peak(const HarmonicBalanceModel& model, ChordSolver& solver,
                                   const std::vector<ContinuationPoint>& points, std::size_t top,
                                   const std::vector<Eigen::Index>& kept, AmplitudeSampler& sampler,
                                   const StopToken& stop) {
  if (kept.empty()) return failed("the node has no kept DOF", 0);
  if (top == 0 || top + 1 >= points.size())
    return failed("the highest traced point is an end of the curve", 0);
  PeakSearch search(model, solver, points[top - 1].y, points[top + 1].y, kept, sampler);
  const auto stopped = [&] { return failed(stop.reason(), search.evaluations()); };

  // A bracket l < c < r of the highest point c known so far, with the slope of each.
  auto l = search.probe(0.0, points[top - 1].y);
  if (!l) return failed(search.failure(), search.evaluations());
  auto c = search.probe(search.theta_of(points[top].y), points[top].y);
  if (!c) return failed(search.failure(), search.evaluations());
  auto r = search.probe(1.0, points[top + 1].y);
  if (!r) return failed(search.failure(), search.evaluations());
  if (c->amplitude < l->amplitude || c->amplitude < r->amplitude || !(c->theta > 0.0) ||
      !(c->theta < 1.0))
    return failed("the highest traced point is not the highest of its neighbours on the chord",
                  search.evaluations());
  Probe previous = c->slope > 0 ? *r : *l;  // the other end of the secant
  double move = 1.0, move_before = 1.0;     // the last two steps of c
  while (c->slope != 0) {
    if (stop.stop_requested()) return stopped();
    // The maximum lies on the side of c the slope points to.
    const bool right = c->slope > 0;
    const Probe& far = right ? *r : *l;
    const double width = std::abs(far.theta - c->theta);
    const double rise = width * std::max(std::abs(c->slope), std::abs(far.slope));
    if (width <= kThetaTolerance || rise <= kAmplitudeTolerance * c->amplitude ||
        move <= kThetaTolerance)
      break;
    if (search.evaluations() >= kMaxPeakEvaluations)
      return failed("the peak was not solved in " + std::to_string(kMaxPeakEvaluations) +
                        " evaluations (bracket " + format_number(width) + " in theta)",
                    search.evaluations());
    // The secant root of the slope through c and the previous probe where it falls inside the
    // side's interval and shortens the steps (superlinear where the curve is smooth), else the
    // interval's middle (where the amplitude has a corner, the law's sample-made kinks). A
    // secant root within kSecantOvershootShare of the side's width from c is overshot to twice
    // its distance: where the secant is good the probe lands past the root, lower than c, and
    // closes the side to that distance, where a probe at the root itself would leave the far
    // end (and the bound on the rise there) where it was.
    double theta = 0.5 * (c->theta + far.theta);
    if (previous.slope != c->slope) {
      const double secant =
          c->theta - c->slope * (c->theta - previous.theta) / (c->slope - previous.slope);
      const double step = secant - c->theta;
      const bool toward_far = right ? step > 0 : step < 0;
      const double target =
          std::abs(step) < kSecantOvershootShare * width ? c->theta + 2 * step : secant;
      const double margin = 1e-3 * width;
      const bool inside = right ? target < far.theta - margin : target > far.theta + margin;
      if (toward_far && inside && std::abs(step) < 0.5 * move_before) theta = target;
    }
    const double s = (theta - c->theta) / (far.theta - c->theta);
    auto m = search.probe(theta, (1 - s) * c->y + s * far.y);
    if (!m) return failed(search.failure(), search.evaluations());
    move_before = move;
    move = std::abs(theta - c->theta);
    if (m->amplitude >= c->amplitude) {
      // m is the new top: the old one bounds the bracket on its side.
      previous = *c;
      (right ? l : r) = std::move(c);
      c = std::move(m);
    } else {
      previous = *m;
      (right ? r : l) = std::move(m);
    }
  }
  // At a smooth top the amplitudes of the last probes agree to rounding and cannot rank them;
  // their slopes can: of the probes within kAmplitudeTolerance of the highest, the one whose
  // slope is smallest (at a corner, the highest itself).
  const double bracket = r->theta - l->theta;
  Probe best = std::move(*c);
  for (const Probe* other : {&*l, &*r, &previous})
    if (other->amplitude >= best.amplitude * (1 - kAmplitudeTolerance) &&
        std::abs(other->slope) < std::abs(best.slope))
      best = *other;
  ResonancePeak peak;
  peak.solved = true;
  peak.amplitude_m = best.amplitude;
  peak.y = std::move(best.y);
  peak.slope = best.slope;
  peak.bracket = bracket;
  peak.evaluations = search.evaluations();
  return peak;
}

}  // namespace frichb::core
