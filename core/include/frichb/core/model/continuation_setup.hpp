// The continuation options of a frequency sweep of a harmonic-balance model: the scaling that
// gives the arclength its meaning, the bounds the curve must stay within, and the step bands
// that keep it from stepping over a linear resonance. The heuristics live here, next to the
// model they read, so that every caller that traces a response curve (frichb run, studies,
// convergence reports, a program of its own) gets the same options from the same scene.
#pragma once

#include <vector>

#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/model/linear_resonances.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/solver/continuation.hpp"

namespace frichb::core {

// The advance in lambda at a resonance, in half-power half-widths, and its growth with the
// distance d from the centre (ContinuationOptions::StepBand). Approaching from d, a step ends
// no nearer than 0.2 d - 0.1 on the same side, or past the centre by at most 0.1 - 0.2 d (only
// from d < 0.5): the last point before the centre and the first one past it are never both
// farther than 0.1 / 1.2 = 0.083 half-widths from it, where a single mode's amplitude is within
// 0.35 % of its peak (1 / sqrt(1 + 0.083^2)). Moving away, the advance grows faster (0.1 + 2 d):
// the peak is behind, its flank drawn by a point at 0.3, 1, 3, 9 ... half-widths.
inline constexpr double kCentreStepInHalfWidths = 0.1;
inline constexpr double kApproachGrowth = 0.8;
inline constexpr double kLeavingGrowth = 2.0;

// Scaling: displacements are scaled so that the contact-free peak over the sweep is kTallness
// times as tall as the sweep is wide (in the scene's frequency unit). Friction peaks are lower
// than the contact-free one, so a tall box keeps the arclength resolving them; a taller one
// costs points on curves that do climb (gaps closing, light friction).
inline constexpr double kTallness = 5.0;
// A window much wider than its resonances (50 Hz to 20 kHz about a 300 Hz mode) would make the
// peak kTallness x 20 kHz tall: the arclength would go to climbing its flanks, a few mHz a
// point. The width the height is measured against is therefore at most kWideWindowFactor times
// the lowest primary (harmonic 1) linear resonance inside the window, free or stuck; windows
// narrower than that, or without such a resonance, keep their own width.
inline constexpr double kWideWindowFactor = 4.0;
// The curve stays within this share of the window's span around it (and at positive
// frequency): one that comes back that far past its start has walked its branch backwards (or
// the branch overhangs the window by that much) and ends with a reason.
inline constexpr double kBoundsMargin = 0.25;
// Frequencies at which the contact-free response is sampled over the sweep (plus one).
inline constexpr int kContactFreeSamples = 256;

struct ContinuationSetup {
  ContinuationOptions options;
  double peak = 0.0;    // largest contact-free displacement over the sweep, m (the residual scale)
  double u_unit = 0.0;  // displacement scale of the arclength, m
  double span = 0.0;    // the sweep's width in the scene's frequency unit
  std::vector<LinearResonance> resonances;  // of the free and the stuck structure, in the window
};

// The step bands of linear resonances: the continuation bounds its advance in frequency near
// each, so that no resonance is stepped over.
std::vector<ContinuationOptions::StepBand> resonance_bands(
    const std::vector<LinearResonance>& resonances);

// The continuation options for sweeping `model` as `scene`'s continuation section says: lambda
// is the circular frequency (rad/s, scaled by the scene's unit), the unknowns are scaled by
// u_unit (continuation.displacement_scale when set), the residual by the contact-free peak.
// Throws SceneError, located at the structure, when the contact-free response is not finite
// somewhere on the sweep (a rigid-body mode with harmonic 0, an undamped resonance). Reads the
// model only.
ContinuationSetup derive_continuation(const Scene& scene, const HarmonicBalanceModel& model);

}  // namespace frichb::core
