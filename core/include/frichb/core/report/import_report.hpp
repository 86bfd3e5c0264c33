// The files of `frichb import` (commands/import.hpp), staged (support/output.hpp):
// sector_stiffness.mtx, sector_mass.mtx (Matrix Market, SI, lower triangle), cyclic_pairs.txt,
// mesh.yaml and nodes.csv, the inputs of the fe_sector provider and the model map. Throws
// ImportWriteError or OutputError.
#pragma once

#include <string>
#include <vector>

#include "frichb/core/commands/import.hpp"
#include "frichb/core/support/output.hpp"

namespace frichb::core {

// The top-level names write_import writes: the output folder's managed names.
std::vector<std::string> import_outputs();
// Writes into the staged folder `out` (the caller commits).
void write_import(const ImportResult& result, StagedOutput& out);

}  // namespace frichb::core
