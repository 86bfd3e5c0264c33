// The mapping from a failure to an exit code and a log line, for the verbs whose failures carry
// no more than their type (loop, modes, timesim, convergence, and what escapes any verb to the
// command line): call it from a `catch (...)` block. run and study map their failures
// themselves, with what they know more (the run's termination in RunOutcome, the study's stage).
//
//   SceneError    -> kExitInvalidInput  (its message names the file, line and key)
//   PluginError   -> kExitInvalidInput  ("<file>: <message>")
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
