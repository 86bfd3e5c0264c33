#include "frichb/core/version.hpp"

namespace frichb::core {
const char* version() {
  return FRICHB_VERSION;
}
}  // namespace frichb::core
