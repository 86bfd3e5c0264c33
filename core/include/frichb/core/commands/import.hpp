// `frichb import`: an ANSYS or Abaqus sector export turned into fe_sector's inputs and the
// model map (fe_import/sector_import.hpp says what is read, converted and refused).
#pragma once

#include <filesystem>

#include "frichb/core/fe_import/sector_import.hpp"

namespace frichb::core {

// Reads and converts `request`, logs a summary (nodes, DOFs, nonzeros, cyclic pairs, units,
// frame) and writes sector_stiffness.mtx, sector_mass.mtx, cyclic_pairs.txt, mesh.yaml and
// nodes.csv into `output_directory` as one staged set (report/output.hpp: the folder holds
// the earlier set or the whole new one). Returns an ExitCode: kExitInvalidInput for a vendor
// file that cannot be imported (the message names file and line), kExitOutput when the files
// cannot be written. Never throws.
int run_import(const ImportRequest& request, const std::filesystem::path& output_directory);

}  // namespace frichb::core
