// The files of `frichb convergence` (commands/convergence.hpp), staged (support/output.hpp):
//   convergence.csv   one row per setting: H, N, o, unknowns, termination, peak, errors, wall
//                     time
//   convergence.json  the same with the reference and the time-integration results
//   convergence.md    a Markdown table for reports
//   convergence.gp, convergence.png  error against wall time, log-log, one series per
//                     oversampling factor (result.plots)
// The settings' own runs are written by the RunWriter the request carries (runs/).
// Throws OutputError.
#pragma once

#include <string>
#include <vector>

#include "frichb/core/commands/convergence.hpp"
#include "frichb/core/support/output.hpp"

namespace frichb::core {

// The top-level names of the output folder: the files above and runs/.
std::vector<std::string> convergence_outputs();
// Writes into the staged folder `out` (the caller commits).
void write_convergence(const ConvergenceResult& result, StagedOutput& out);

}  // namespace frichb::core
