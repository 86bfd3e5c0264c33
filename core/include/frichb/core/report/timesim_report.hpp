// The files of `frichb timesim` (commands/timesim.hpp), staged (support/output.hpp):
//   timesim.csv   the last period: time_s and each response node's DOFs (<node>[_<dof>]_m)
//   summary.json  per response node the maximum displacement norm, half peak-to-peak and
//                 harmonic amplitudes; frequency, steps per period, periods run, periodic,
//                 termination
// Throws OutputError.
#pragma once

#include <string>
#include <vector>

#include "frichb/core/commands/timesim.hpp"
#include "frichb/core/support/output.hpp"

namespace frichb::core {

// The top-level names write_timesim writes: the output folder's managed names.
std::vector<std::string> timesim_outputs();
// Writes into the staged folder `out` (the caller commits).
void write_timesim(const TimesimResult& result, StagedOutput& out);

}  // namespace frichb::core
