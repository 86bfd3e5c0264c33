#include "frichb/core/report/validate_report.hpp"

#include <spdlog/spdlog.h>

namespace frichb::core {

void log_validation(const ValidationResult& result) {
  const std::string file = result.scene_file.string();
  if (result.study_runs > 0)
    spdlog::info("{}: study of {} runs, each valid up to its first Newton iteration", file,
                 result.study_runs);
  std::string contacts;
  for (const auto& c : result.contacts) contacts += (contacts.empty() ? "" : ", ") + c;
  spdlog::info("{}: valid; structure '{}' {}; contacts: {}", file, result.structure,
               result.structure_version, contacts.empty() ? "none" : contacts);
  for (const auto& f : result.plugin_files) spdlog::info("  loads {}", f.string());
}

}  // namespace frichb::core
