#include "frichb/core/commands/import.hpp"

#include <spdlog/spdlog.h>

#include <string>
#include <vector>

#include "frichb/core/report/failure.hpp"
#include "frichb/core/report/output.hpp"
#include "frichb/core/support/exit_codes.hpp"

namespace frichb::core {

namespace fs = std::filesystem;

namespace {

void log_summary(const ImportedSector& sector, const ImportRequest& request,
                 const fs::path& output_directory) {
  const bool mm = request.units == UnitSystem::kMmTonneSecond;
  spdlog::info("imported {} nodes, {} DOFs; stiffness {} and mass {} nonzeros (lower triangle)",
               sector.nodes.size(), sector.stiffness.size, sector.stiffness.entries.size(),
               sector.mass.entries.size());
  spdlog::info("cyclic boundary: {} node pairs, {} DOF pairs (tolerance {:.3g} m, {} sectors)",
               sector.boundary_node_pairs, sector.cyclic_pairs.size(), sector.tolerance,
               request.sectors);
  spdlog::info("units: {}; nodal frames: {}", mm ? "mm-t-s converted to SI" : "SI, as read",
               request.nodal_frame == NodalFrame::kGlobal
                   ? "global, turned into the nodes' cylindrical frames"
                   : "cylindrical, as read");
  spdlog::info("wrote {}", output_directory.string());
}

}  // namespace

int run_import(const ImportRequest& request, const fs::path& output_directory) {
  try {
    const ImportedSector sector = assemble_sector(request);
    StagedOutput out(output_directory, {kImportedFiles.begin(), kImportedFiles.end()});
    write_sector(sector, [&out](const std::string& name) { return out.path(name); });
    out.commit();
    log_summary(sector, request, output_directory);
    return kExitOk;
  } catch (const ImportError& e) {
    spdlog::error("{}", e.what());
    return kExitInvalidInput;
  } catch (const ImportWriteError& e) {
    spdlog::error("{}: writing the outputs: {}", output_directory.string(), e.what());
    return kExitOutput;
  } catch (...) {
    return report_failure(output_directory.string());
  }
}

}  // namespace frichb::core
