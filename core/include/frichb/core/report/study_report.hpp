// The index of `frichb study` (commands/study.hpp), staged (support/output.hpp):
//   study.csv, study.json  parameters, termination, points, peaks and wall time per run; the
//                          sweeps, the processes and threads, the optimum (study.json)
//   overlay.gp/png         the response curves of study.node, one line per run written
//   peak.gp/png            the peak amplitude of study.node against the first swept value
// (plots when the scene's output.plots; report/plot_style.hpp: amplitudes in µm or mm, log axes
// where the peaks span more than a decade or the swept values are log-spaced, the swept keys by
// SweepSpec::name and unit). Each run's own files are written into runs/NNNN/ by
// the request's RunWriter as the run ends. Throws OutputError.
#pragma once

#include <string>
#include <vector>

#include "frichb/core/commands/study.hpp"
#include "frichb/core/support/output.hpp"

namespace frichb::core {

// The top-level names of the output folder: the files above and runs/.
std::vector<std::string> study_outputs();
// Writes the index of rank 0's result into the staged folder `out` (the caller commits) and
// logs a line: runs, runs that ended early, the optimum.
void write_study(const StudyResult& result, StagedOutput& out);

}  // namespace frichb::core
