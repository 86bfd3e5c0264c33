// The one mapping from a failure to an exit code (failure.hpp).
#include "frichb/core/commands/failure.hpp"

#include <spdlog/spdlog.h>

#include <exception>

#include "frichb/core/fe_import/sector_import.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/plugin_host/schema.hpp"
#include "frichb/core/support/exit_codes.hpp"
#include "frichb/core/support/interrupt.hpp"
#include "frichb/core/support/output.hpp"

namespace frichb::core {

namespace {

void log_error(const std::string& file, const std::string& middle, const char* what) {
  if (file.empty())
    spdlog::error("{}", what);
  else
    spdlog::error("{}: {}{}", file, middle, what);
}

}  // namespace

int report_failure(const std::string& file) noexcept {
  try {
    try {
      throw;
    } catch (const SceneError& e) {
      spdlog::error("{}", e.what());
      return kExitInvalidInput;
    } catch (const PluginError& e) {
      log_error(file, "", e.what());
      return kExitInvalidInput;
    } catch (const ImportError& e) {
      spdlog::error("{}", e.what());
      return kExitInvalidInput;
    } catch (const ImportWriteError& e) {
      log_error(file, "writing the outputs: ", e.what());
      return kExitOutput;
    } catch (const Interrupted& e) {
      log_error(file, "", e.what());
      return 128 + e.signal();
    } catch (const OutputError& e) {
      log_error(file, "writing the outputs: ", e.what());
      return e.user_error() ? kExitInvalidInput : kExitOutput;
    } catch (const std::exception& e) {
      log_error(file, "", e.what());
      return kExitInternal;
    } catch (...) {
      log_error(file, "", "unknown failure");
      return kExitInternal;
    }
  } catch (...) {  // logging itself failed
    return kExitInternal;
  }
}

}  // namespace frichb::core
