// A shared module that links the core's plugin host, as a Python extension does: it reports
// the first folder of its default plugin search path.
#include <string>

#include "frichb/core/plugin_host/registry.hpp"

extern "C" __attribute__((visibility("default"))) const char* frichb_test_first_plugin_folder() {
  static const std::string folder = frichb::core::Registry::default_search_path().front().string();
  return folder.c_str();
}
