// The checks of the forced responses synthesised from a nonlinear mode (commands/nma.hpp):
// the harmonic-balance solve at a synthesised peak's frequency and the full run of a level.
#pragma once

#include "frichb/core/commands/nma.hpp"
#include "frichb/core/model/nonlinear_modes.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/scene/scene.hpp"

namespace frichb::core {

// The scene `input` reads (whose bound form is `scene`) with its harmonic-1 excitation times
// `scale` (the static and higher harmonics' excitation as they are), read again. Throws as
// load_bound_scene.
BoundScene with_excitation_scaled(const SceneInput& input, const Scene& scene, double scale);

// One harmonic-balance solve of the scene's forced equations at the peak's frequency: of
// `model` (the scene's, unscaled) with its harmonic-1 excitation scaled by response.scale,
// started from the backbone of `problem` at the peak (result.points) turned into the
// excitation's phase. A solve that fails is a check with converged false and why.
SynthesisCheck check_synthesised_peak(const Scene& scene, const HarmonicBalanceModel& model,
                                      const NonlinearModeProblem& problem, const NmaResult& result,
                                      const SynthesisedResponse& response, const StopToken& stop);

// The full forced response of `scaled` (frichb run's trace, quiet, without plots) and its peak
// at the response node against the synthesised peak.
FullRunComparison compare_with_full_run(const Scene& scaled, const SynthesisedResponse& response,
                                        const StopToken& stop);

}  // namespace frichb::core
