// The files of `frichb nma` (commands/nma.hpp), staged (support/output.hpp):
//   nma.csv       one row per point of the backbone: point, amplitude_m_sqrt_kg (the mode's
//                 fundamental modal coordinate), frequency_hz, damping_ratio, xi_rad_s,
//                 contact_energy_j (dissipated by the contacts per cycle), stuck_share,
//                 slipping_share, open_share (of the contacts' samples), contact_motion_m
//                 (largest contact component's harmonic-1 amplitude), higher_harmonics_share
//                 (of the contacts' motion), newton_iterations
//   summary.json  the scene, the mode (its harmonic index, its frequency without contacts and
//                 with the contacts at rest), the amplitude range (and whether it was chosen
//                 from the contact motion), the harmonics, the most damped point, how the
//                 continuation ended, and the timings
//   nma.gp, nma.png  frequency and damping ratio against the amplitude (log axis), the most
//                 damped point marked (result.plots)
// With syntheses (NmaOptions::synthesise), also:
//   synthesis.csv  the synthesised curves, one row per point: level (0-based), excitation_scale,
//                 frequency_hz, amplitude_m_sqrt_kg (the mode's a), node_amplitude_mode_m (the
//                 response node's harmonic-1 amplitude, the mode alone), node_amplitude_m (with
//                 the off-resonant modes' residual terms)
//   synthesis_peaks.csv  one row per level: the synthesised peak (peak_found; frequency, a,
//                 damping ratio, node amplitudes, the residual terms' share), the
//                 harmonic-balance check at its frequency (check_converged; node amplitude,
//                 errors, seconds) and the full run's peak (full_run_found; frequency, node
//                 amplitude, errors, seconds); a flag 0 and its fields 0 where there is none
//   synthesis.gp, synthesis.png  the curves (node amplitude against frequency, log axis where
//                 they span a decade), the checks as circles, the full runs' peaks as crosses
//   summary.json's "synthesis": the same per level, and the backbone's, the syntheses', the
//                 checks' and the full runs' seconds
// Throws OutputError.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "frichb/core/commands/nma.hpp"
#include "frichb/core/support/output.hpp"

namespace frichb::core {

// The top-level names write_nma writes: the output folder's managed names.
std::vector<std::string> nma_outputs();
// Writes into the staged folder `out` (the caller commits).
void write_nma(const NmaResult& result, StagedOutput& out);
// nma.gp's gnuplot script (it reads nma.csv in its folder and writes nma.png).
std::string nma_plot_script(const NmaResult& result);
// synthesis.gp's gnuplot script (it reads synthesis.csv and synthesis_peaks.csv).
std::string synthesis_plot_script(const NmaResult& result);
// The index of the point with the largest damping ratio (none without points).
std::optional<std::size_t> most_damped_point(const NmaResult& result);

}  // namespace frichb::core
