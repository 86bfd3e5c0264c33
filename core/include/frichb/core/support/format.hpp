// Numbers as messages and file names write them.
#pragma once

#include <string>

namespace frichb::core {

// `x` with `precision` significant digits in the shortest of fixed and scientific notation
// (std::ostream's default floating-point format): 330, 0.001, 1e-06, 2.5e+07.
std::string format_number(double x, int precision = 6);

}  // namespace frichb::core
