#include "frichb/core/support/version.hpp"

namespace frichb::core {
const char* version() {
  return FRICHB_VERSION;
}
}  // namespace frichb::core
