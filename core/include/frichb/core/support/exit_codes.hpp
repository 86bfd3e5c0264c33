// The exit codes of the frichb program (a verb's Outcome::status, commands/verb.hpp, and
// report_failure's mapping of what a verb throws), documented in docs/getting-started.md.
#pragma once

namespace frichb::core {

enum ExitCode : int {
  kExitOk = 0,
  kExitUsage = 1,         // bad command line
  kExitInvalidInput = 2,  // bad scene, unknown plugin, plugin of another ABI, missing file
  kExitIncomplete = 3,    // the curve ended before the sweep's end (outputs written)
  kExitInternal = 4,      // unexpected failure
  kExitOutput = 5,        // the outputs could not be written (disk full, I/O error); the
                          // output folder keeps its earlier results
  // 128 + signal (130 SIGINT, 143 SIGTERM): interrupted, no output written (interrupt.hpp)
};

}  // namespace frichb::core
