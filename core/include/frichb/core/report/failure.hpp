// The one mapping from a failure to an exit code and a log line, for every verb: call it from
// a `catch (...)` block.
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
