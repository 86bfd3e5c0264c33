#include "frichb/core/report/import_report.hpp"

namespace frichb::core {

std::vector<std::string> import_outputs() {
  return {kImportedFiles.begin(), kImportedFiles.end()};
}

void write_import(const ImportResult& result, StagedOutput& out) {
  write_sector(result.sector, [&out](const std::string& name) { return out.path(name); });
}

}  // namespace frichb::core
