// `frichb modes`: natural frequencies of a scene's structure for every harmonic index, the
// nodal-diameter map (ZZENF diagram, thesis Fig. 5.3) with the engine-order excitation of the
// kept temporal harmonics at a rotation speed.
#pragma once

#include <filesystem>

namespace frichb::core {

struct ModesRequest {
  std::filesystem::path scene_file;
  std::filesystem::path output_directory;  // empty: out/<scene stem>-modes
  // Speed range of the engine-order excitation lines, rpm (equal for one speed; 0: none).
  double rpm_low = 0.0;
  double rpm_high = 0.0;
};

// Writes modes.csv (harmonic_index, nodal_diameter, wave, family, frequency_hz),
// families.csv (frequency of each mode family per nodal diameter), with a speed range
// excitation.csv (rpm, n, harmonic_index, nodal_diameter, frequency_hz: the kept temporal
// harmonics at the lowest and highest speed), and modes.png.
// Returns an ExitCode (run.hpp). Never throws.
int run_modes(const ModesRequest& request);

}  // namespace frichb::core
