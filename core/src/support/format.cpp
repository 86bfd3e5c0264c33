// Numbers as messages and file names write them (format.hpp).
#include "frichb/core/support/format.hpp"

#include <sstream>

namespace frichb::core {

std::string format_number(double x, int precision) {
  std::ostringstream os;
  os.precision(precision);
  os << x;
  return os.str();
}

}  // namespace frichb::core
