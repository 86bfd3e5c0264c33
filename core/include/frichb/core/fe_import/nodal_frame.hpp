// The frame a node's three matrix rows are in: global (components along x, y, z) or
// cylindrical about the global z axis (r, theta, z at the node's angle atan2(y, x)). Shared by
// the importers, which write it into nodes.csv, and the model map, which reads it.
#pragma once

namespace frichb::core {

enum class NodalFrame { kGlobal, kCylindrical };

}  // namespace frichb::core
