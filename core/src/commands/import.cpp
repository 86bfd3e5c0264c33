#include "frichb/core/commands/import.hpp"

#include <spdlog/spdlog.h>

namespace frichb::core {

ImportResult import_sector(const ImportRequest& request) {
  ImportResult result{{}, request, assemble_sector(request)};
  const ImportedSector& sector = result.sector;
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
  return result;
}

}  // namespace frichb::core
