// The files of `frichb modes` (commands/modes.hpp), written into one output folder, staged
// (support/output.hpp):
//   modes.csv       harmonic_index, nodal_diameter, wave, family, frequency_hz: every mode
//   families.csv    nodal_diameter, family1_hz, ...: each family's frequency per nodal diameter
//   excitation.csv  rpm, n, harmonic_index, nodal_diameter, frequency_hz: the kept temporal
//                   harmonics at the lowest and highest speed (a cyclic scene given a speed)
//   modes.gp, modes.png  the nodal-diameter map with the excitation lines (result.plots)
// Throws OutputError.
#pragma once

#include <string>
#include <vector>

#include "frichb/core/commands/modes.hpp"
#include "frichb/core/support/output.hpp"

namespace frichb::core {

// The top-level names write_modes writes: the output folder's managed names.
std::vector<std::string> modes_outputs();
// Writes into the staged folder `out` (the caller commits).
void write_modes(const ModesResult& result, StagedOutput& out);

}  // namespace frichb::core
