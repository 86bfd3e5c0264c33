// The files of `frichb peaks` (commands/peaks.hpp), staged (support/output.hpp):
//   peaks.csv     one row per point of the peak curve: point, the parameter (its scene path as
//                 the column name), peak_frequency_hz, peak_amplitude_m, newton_iterations,
//                 branch; normalised (PeaksOptions::normalise), also mu_n0_over_f and
//                 peak_amplitude_over_f_m_per_n; with the scene's output.stability, stable (1
//                 or 0) and largest_multiplier
//   summary.json  the scene, the parameter and its range (axis linear or log), the node, the
//                 start peak, the optimum (solved between the traced points, or the lowest
//                 traced point with why not; whether it lies at an end of the traced range),
//                 the jumps between branches, how the tracking ended,
//                 and every point with the sensitivities of its peak frequency (Hz per unit of
//                 the parameter) and amplitude (m per unit) along the peak curve (null where the
//                 curve turns in the parameter)
//   peaks.gp, peaks.png  peak amplitude and peak frequency against the parameter (normalised:
//                 the amplitude over f against mu N0 / f), the optimum marked, each located
//                 exchange with another peak marked (on the frequency panel with the other
//                 peak's frequency), and with the peaks' stability the unstable stretches
//                 dashed (log parameter axis on a logarithmic range; result.plots)
// Throws OutputError.
#pragma once

#include <string>
#include <vector>

#include "frichb/core/commands/peaks.hpp"
#include "frichb/core/support/output.hpp"

namespace frichb::core {

// The top-level names write_peaks writes: the output folder's managed names.
std::vector<std::string> peaks_outputs();
// Writes into the staged folder `out` (the caller commits).
void write_peaks(const PeaksResult& result, StagedOutput& out);
// peaks.gp's gnuplot script (it reads peaks.csv in its folder and writes peaks.png).
std::string peaks_plot_script(const PeaksResult& result);

}  // namespace frichb::core
