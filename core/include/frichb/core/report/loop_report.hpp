// The files of `frichb loop` (commands/loop.hpp), staged (support/output.hpp):
//   loop.csv       phase, u_<axis>_m, f_<axis>_N and status (0 stuck, 1 slipping, 2 open) per
//                  sample, the first sample repeated at the end to close the loop
//   harmonics.csv  the force harmonics per axis
//   summary.json   the law (name, version, file, params), energy per cycle, passes, periodic,
//                  shares slipping and open, significant force harmonics
//   loop.gp, loop.png  T1 against u_t1 and, beside it, the (T1, T2) loop of a 2D law or the
//                  forces over the period of a law with a normal (result.plots)
// Throws OutputError.
#pragma once

#include <string>
#include <vector>

#include "frichb/core/commands/loop.hpp"
#include "frichb/core/support/output.hpp"

namespace frichb::core {

// The top-level names write_loop writes: the output folder's managed names.
std::vector<std::string> loop_outputs();
// Writes into the staged folder `out` (the caller commits).
void write_loop(const LoopResult& result, StagedOutput& out);

}  // namespace frichb::core
