// `frichb modes`: natural frequencies of a scene's structure for every harmonic index, the
// nodal-diameter map (ZZENF diagram, thesis Fig. 5.3) with the engine-order excitation of the
// kept temporal harmonics at a rotation speed. The verb shape: commands/verb.hpp; the writer:
// report/modes_report.hpp.
#pragma once

#include <vector>

#include "frichb/core/commands/verb.hpp"
#include "frichb/core/scene/scene.hpp"

namespace frichb::core {

struct ModesOptions {
  SceneInput scene;
  // Speed range of the engine-order excitation lines, rpm (equal for one speed; 0: none).
  double rpm_low = 0.0;
  double rpm_high = 0.0;
};

// One natural frequency of the structure without contacts.
struct NaturalFrequency {
  int harmonic_index = 0;  // h = 0..sectors-1 (0 for a plain structure)
  int nodal_diameter = 0;  // min(h, sectors - h)
  int wave = 0;            // travelling direction of harmonic index h: +1 forward, -1 backward, 0
  int family = 0;          // 1-based rank of the frequency within its harmonic index
  double frequency_hz = 0.0;
};

// Temporal harmonic n of the engine-order excitation at one speed: it excites
// n * engine_order * rpm / 60 Hz on harmonic index h = mod(n * engine_order, sectors).
struct ExcitationLine {
  double rpm = 0.0;
  int harmonic = 0;  // n
  int harmonic_index = 0;
  int nodal_diameter = 0;
  double frequency_hz = 0.0;
};

struct ModesResult {
  Outcome outcome;
  std::filesystem::path scene_file;
  int sectors = 1;       // of the structure (1: not cyclic)
  int engine_order = 0;  // of the scene's cyclic section (0: none)
  bool plots = true;     // the scene's output.plots
  // Every harmonic index's natural frequencies, by harmonic index then family.
  std::vector<NaturalFrequency> modes;
  // frequencies_hz[nd][r]: family r + 1 on nodal diameter nd = 0..sectors/2 (h and sectors - h
  // have complex-conjugate sector matrices, hence the same frequencies).
  std::vector<std::vector<double>> frequencies_hz;
  // The families every nodal diameter has (the fewest modes over the nodal diameters).
  std::size_t families = 0;
  std::vector<double> speeds_rpm;          // the excitation speeds asked for (0, 1 or 2)
  std::vector<ExcitationLine> excitation;  // per speed, per kept harmonic n > 0; cyclic only
};

// Loads the scene (options.scene), builds its structure and solves the natural frequencies of
// harmonic indices 0..sectors/2. Logs each nodal diameter's progress. Throws SceneError or
// PluginError for a scene or a structure it cannot use. Threading: calls on different options
// share no state.
ModesResult compute_modes(const ModesOptions& options);

}  // namespace frichb::core
