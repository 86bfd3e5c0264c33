// The mapping from a failure to an exit code and a log line: what a verb or its writer throws
// (commands/verb.hpp), for the command line; call it from a `catch (...)` block. run and study
// also map failures of their own stages, with what they know more (the run's termination in
// RunOutcome, the study's stage).
//
//   SceneError    -> kExitInvalidInput  (its message names the file, line and key)
//   PluginError   -> kExitInvalidInput  ("<file>: <message>")
//   ImportError   -> kExitInvalidInput  (its message names the vendor file and line)
//   ImportWriteError -> kExitOutput     ("<file>: writing the outputs: <message>")
//   Interrupted   -> 128 + its signal   ("<file>: interrupted by signal N; no output written")
//   OutputError   -> kExitInvalidInput when the output path itself is wrong, else kExitOutput
//                    ("<file>: writing the outputs: <message>")
//   anything else -> kExitInternal      ("<file>: <message>")
//
// With an empty `file` the message is logged alone. Logs at error level through spdlog.
// Never throws; must be called while an exception is being handled.
#pragma once

#include <string>

namespace frichb::core {

int report_failure(const std::string& file) noexcept;

}  // namespace frichb::core
