// The cyclic boundary of an imported sector found from the node coordinates.
#pragma once

#include <filesystem>
#include <vector>

#include "frichb/core/fe_import/sector_import.hpp"

namespace frichb::core {

// Fills sector.cyclic_pairs, boundary_node_pairs and tolerance: node L (left face) pairs with
// node R when R's position equals L's turned by +2 pi / sectors about z within `tolerance`
// (m; 0: 1e-6 of the largest coordinate magnitude). No pairs for one sector. Throws
// ImportError ("COORDINATES_FILE: ...") on duplicate candidates, a node paired twice, a node on
// the axis, a node on both faces, a component present on one side only, or sectors == 2.
// Nodes in `excluded` (node numbers) are never paired.
void pair_cyclic_boundary(ImportedSector& sector, int sectors, double tolerance,
                          const std::vector<long>& excluded,
                          const std::filesystem::path& coordinates_file);

}  // namespace frichb::core
