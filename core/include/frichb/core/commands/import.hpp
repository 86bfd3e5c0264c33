// `frichb import`: an ANSYS or Abaqus sector export turned into fe_sector's inputs and the
// model map (fe_import/sector_import.hpp says what is read, converted and refused). The verb
// shape: commands/verb.hpp; the writer: report/import_report.hpp.
#pragma once

#include "frichb/core/commands/verb.hpp"
#include "frichb/core/fe_import/sector_import.hpp"

namespace frichb::core {

struct ImportResult {
  Outcome outcome;
  ImportRequest request;  // as imported (units and frames of the source files)
  ImportedSector sector;  // SI, cylindrical nodal frames
};

// Reads, converts and pairs (assemble_sector), and logs a summary: nodes, DOFs, nonzeros,
// cyclic pairs, units, frames. Throws ImportError naming the file and line. Writes nothing.
ImportResult import_sector(const ImportRequest& request);

}  // namespace frichb::core
