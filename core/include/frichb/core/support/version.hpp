// The version of the FricHB engine (the project's version, as CMake sets it), as written into
// every summary.json and printed by `frichb --version`.
#pragma once

namespace frichb::core {

// A static string, e.g. "0.9.0". Thread-safe.
const char* version();

}  // namespace frichb::core
