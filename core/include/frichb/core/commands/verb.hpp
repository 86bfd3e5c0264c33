// The shape of a verb. Every verb of frichb is one function in commands/ that takes the verb's
// typed options and returns the verb's typed result:
//
//   ModesResult compute_modes(const ModesOptions& options);          // commands/modes.hpp
//   std::vector<std::string> modes_outputs();                        // report/modes_report.hpp
//   void write_modes(const ModesResult& result, StagedOutput& out);  // report/modes_report.hpp
//
// The function computes and returns: it writes no file; the scene, its overrides and the
// plugin permission come in the options as a SceneInput (the process-wide settings it reads
// are the plugin search path's FRICHB_PLUGIN_PATH and the stop flag of support/interrupt.hpp);
// it logs progress and warnings through spdlog. Its result holds the numbers, an Outcome
// (how the computation ended and what it warned about) and the settings the writer needs; a
// library caller reads it in memory. A writer in report/ turns a result into the verb's files
// and plots, staged (support/output.hpp: the folder holds the earlier set or the whole new
// one). The command line (core/app/verbs.cpp) only parses the options, calls the function,
// calls the writer and maps the outcome (or the exception) to the exit code, the same way for
// every verb.
//
// Failure: input the verb cannot use throws (SceneError naming file, line and key;
// PluginError; ImportError) before anything is computed; a computation that ends early is a
// result (Outcome::status kExitIncomplete, its termination and message) and is written;
// commands/failure.hpp maps what is thrown to an exit code.
#pragma once

#include <string>
#include <vector>

#include "frichb/core/support/exit_codes.hpp"

namespace frichb::core {

// How a verb's computation ended.
struct Outcome {
  // kExitOk, or kExitIncomplete when it ended before the end it aimed at (results written
  // all the same), or 128 + signal when interrupted (nothing is written).
  int status = kExitOk;                   // an ExitCode, or 128 + signal
  std::string termination = "completed";  // a word per reason: "completed", "not_periodic", ...
  std::string message;                    // why it ended, for a person ("" when it completed)
  std::vector<std::string> warnings;      // as logged while it ran, in order
};

}  // namespace frichb::core
