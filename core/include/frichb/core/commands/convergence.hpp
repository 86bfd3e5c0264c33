// `frichb convergence`: how much accuracy each harmonic-balance setting buys for its cost.
//
// The scene is run at every combination of kept harmonics H, samples per period N (with
// N >= 2H + 1) and trace oversampling o. Each run's peak amplitude and peak frequency (of
// the first output.response node, refined as in `frichb run`) are compared with those of
// the finest setting (largest H, N and o) and, for a scene without cyclic symmetry, with
// the time-integration reference (simulate_in_time at the finest setting's peak
// frequency). Runs are serial by default so that their wall times are comparable.
//
// Outputs (staged, as every verb): DIR/convergence.csv (one row per setting: H, N, o,
// unknowns, peak, errors, wall time), convergence.json (the same with the reference and
// time-integration results), convergence.md (a Markdown table for reports) and
// convergence.png (log-log: error against wall time). Each run's own files stay under
// DIR/runs/H<H>_N<N>_o<o>/.
#pragma once

#include <filesystem>
#include <vector>

namespace frichb::core {

struct ConvergenceRequest {
  std::filesystem::path scene_file;
  std::filesystem::path output_directory;             // empty: out/<scene stem>-convergence
  std::vector<int> harmonics = {1, 3, 5, 7, 10, 15};  // largest kept harmonic H
  std::vector<int> samples = {64, 128, 256, 512, 1024, 2048};
  std::vector<int> oversampling = {1, 4};
  bool time_integration = true;  // compare with simulate_in_time (plain structures)
  int timesim_steps_per_period = 8000;
};

// Returns an ExitCode (run.hpp): kExitIncomplete when a setting's curve ended early (its
// row says why); kExitInvalidInput for a bad scene or an empty setting list. Never throws.
int run_convergence(const ConvergenceRequest& request);

}  // namespace frichb::core
