// `frichb loop`: one contact law traced under a prescribed multiharmonic relative motion.
//
// Input (YAML, validated like a scene; see docs/scene-reference.md, "Loop inputs"):
//   law: coupled_3d            # plugin name
//   params: {...}              # the law's parameters
//   motion:                    # local relative displacement, m; each a list of terms
//     t1: [{harmonic: 1, amplitude: 1.0, phase_deg: 0, function: sin}, ...]
//     t2: [...]
//     n:  [...]                # harmonic 0: a constant `amplitude`
//   sampling: {max_harmonic: 15, samples_per_period: 1024}
// Output folder: loop.csv (phase, u, force, stick/slip/open status per sample),
// harmonics.csv (force harmonics), summary.json (dissipated energy per cycle, passes,
// significant harmonics), loop.png and its gnuplot script.
#pragma once

#include <Eigen/Dense>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "frichb/core/numerics/harmonics.hpp"
#include "frichb/core/scene/scene.hpp"

namespace frichb::core {

struct LoopRequest {
  std::filesystem::path input_file;
  std::filesystem::path output_directory;  // empty: out/<input stem>
};

// Returns an ExitCode (run.hpp). Never throws.
int run_loop(const LoopRequest& request);

// The loop input's section schemas, for the generated reference.
std::vector<CoreSection> loop_schemas();

}  // namespace frichb::core
