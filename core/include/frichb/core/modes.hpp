// `frichb modes`: natural frequencies of a scene's structure for every harmonic index, the
// nodal-diameter map (ZZENF diagram, seed Fig. 5.3) with the engine-order excitation of the
// kept temporal harmonics at a rotation speed.
#pragma once

#include <filesystem>

namespace frichb::core {

struct ModesRequest {
  std::filesystem::path scene_file;
  std::filesystem::path output_directory;  // empty: out/<scene stem>-modes
  double rpm = 0.0;  // rotation speed for the engine-order excitation points; 0: none
};

// Writes modes.csv (harmonic_index, nodal_diameter, wave, family, frequency_hz), and with a
// speed excitation.csv (n, harmonic_index, nodal_diameter, frequency_hz) and modes.png.
// Returns an ExitCode (run.hpp). Never throws.
int run_modes(const ModesRequest& request);

}  // namespace frichb::core
