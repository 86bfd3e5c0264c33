// What `frichb validate` reports (commands/validate.hpp): no files, the verdict on the log.
#pragma once

#include "frichb/core/commands/validate.hpp"

namespace frichb::core {

// Logs at info level: the study's run count when there is one, the structure and contacts,
// and every plugin file the run loads.
void log_validation(const ValidationResult& result);

}  // namespace frichb::core
