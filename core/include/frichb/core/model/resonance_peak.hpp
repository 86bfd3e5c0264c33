// The peak of a response node's amplitude along a traced forced-response curve, solved for.
//
// The measure is AmplitudeSampler::peak_amplitude (model/response.hpp): the maximum over the
// period of the node's displacement norm, in continuous time, smooth in the unknowns where that
// maximum is a single one. Along the curve near its highest traced point `top`, the curve is
// parametrised by theta on the chord from point top - 1 (theta = 0) to point top + 1 (theta =
// 1) (ChordSolver: the curve's points on the planes across the chord). The peak is where
//   g(theta) = dA(y(theta))/dtheta = 0,
// the stationarity of the amplitude along the curve. theta is a parameter of the curve across
// a fold as well, so a peak beside a fold (where d omega/ds -> 0 and the frequency is no
// parameter) is found the same way. g is the amplitude's directional derivative along the
// curve's velocity (central differences of A with a step of kSlopeStep in theta). The search
// keeps three points l < c < r of the chord with c the highest (at first the traced points
// top - 1, top, top + 1), so that a maximum of A lies in the bracket, and steps from c to the
// secant root of g through c and the previous probe where that root falls on the side g(c)
// points to and shortens the steps (a root within a tenth of the side's width from c is
// overshot to twice its distance, so that the probe closes that side), else to the middle of
// that side. Where the curve is
// smooth (laws traced along the motion) the secant steps converge superlinearly; where it has
// corners (a sample-only law's stick-slip switches move between samples) the peak may be a
// corner, which the halvings close in on. It stops when that side is kThetaTolerance wide,
// when the last step was shorter than that (the secant has converged), or when the side's
// width times the larger slope at its ends, a bound on what the amplitude can still rise
// there, is below kAmplitudeTolerance of the amplitude. Each probe is one Keller
// corrector solve (from the bracket's chord), one tangent and three response recoveries
// (HarmonicBalanceModel::kept_response). The result's accuracy is that of the solves
// (continuation.tolerance) on top of these tolerances.
// Failure is a result: the reason the peak was not solved (the top point is an end of the
// curve, a solve fails, kMaxPeakEvaluations probes did not close the bracket, a stop was
// requested).
// Threading: reads the model (not thread-safe); one model per thread.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/model/response.hpp"
#include "frichb/core/solver/continuation.hpp"
#include "frichb/core/support/interrupt.hpp"

namespace frichb::core {

inline constexpr double kSlopeStep = 1e-5;
inline constexpr double kThetaTolerance = 1e-10;
inline constexpr double kAmplitudeTolerance = 1e-12;
inline constexpr int kMaxPeakEvaluations = 40;

struct ResonancePeak {
  bool solved = false;
  double amplitude_m = 0.0;  // the measure at the peak
  Eigen::VectorXd y;         // the solution there (unknowns, omega in rad/s last)
  double slope = 0.0;        // g at the returned point, m per unit theta (0 at an exact peak)
  double bracket = 0.0;      // width in theta of the last bracket l..r
  int evaluations = 0;       // points solved on the chord
  std::string message;       // why not, when not solved
};

// The peak of the amplitude of the node whose kept DOF indices are `kept`, near traced point
// `top` of `points` (a curve of `model` traced with the options `solver` was made with).
ResonancePeak solve_resonance_peak(const HarmonicBalanceModel& model, ChordSolver& solver,
                                   const std::vector<ContinuationPoint>& points, std::size_t top,
                                   const std::vector<Eigen::Index>& kept, AmplitudeSampler& sampler,
                                   const StopToken& stop);

}  // namespace frichb::core
