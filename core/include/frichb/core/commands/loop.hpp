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
// The verb shape: commands/verb.hpp; the writer: report/loop_report.hpp.
#pragma once

#include <Eigen/Dense>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "frichb/core/commands/verb.hpp"
#include "frichb/core/numerics/harmonics.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/scene/scene.hpp"

namespace frichb::core {

struct LoopRequest {
  std::filesystem::path input_file;
  // Load the law from the folders the input's plugin_paths names (--allow-scene-plugins).
  bool allow_input_plugins = false;
};

// One contact law traced over the prescribed period.
struct LoopResult {
  Outcome outcome;
  std::filesystem::path input_file;
  std::string name;  // the input's name, or the file's stem
  std::shared_ptr<const LoadedPlugin> law;
  nlohmann::json law_params;    // the law's validated parameters, defaults filled in
  std::vector<int> components;  // the local axes the law uses: 0 t1, 1 t2, 2 n (kContactAxisNames)
  int samples = 0;              // per period
  int max_harmonic = 0;         // force harmonics reported: 0..max_harmonic
  Eigen::MatrixXd displacement_m;   // samples x components: the prescribed relative motion
  Eigen::MatrixXd force_N;          // samples x components: the law's force
  std::vector<int> status;          // per sample: 0 stuck, 1 slipping (state moved), 2 open
  double energy_per_cycle_J = 0.0;  // the closed integral of f . du
  int passes = 0;                   // passes over the period until the state repeated
  bool periodic = true;             // false: max_passes reached (a warning in outcome)
  double fraction_slipping = 0.0, fraction_open = 0.0;
  ForceHarmonics harmonics;  // force harmonics per axis (harmonics.csv)
  // Per axis name, the harmonics from 1 whose amplitude exceeds significance_threshold times
  // the axis's largest.
  std::map<std::string, std::vector<int>> significant_harmonics;
  double significance_threshold = 0.0;
  bool plots = true;  // the input's output.plots
};

// Reads and validates the input (its law loaded from the default search path and its
// plugin_paths), traces the law over the period and analyses the loop. Throws SceneError
// (file:line:column and key) for the input, PluginError when the law fails. Writes nothing.
LoopResult trace_loop(const LoopRequest& request);

// The loop input's section schemas, for the generated reference.
std::vector<CoreSection> loop_schemas();

}  // namespace frichb::core
