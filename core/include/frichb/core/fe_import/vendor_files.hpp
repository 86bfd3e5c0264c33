// Readers of the vendor files `frichb import` takes (sector_import.hpp): matrices as entries
// between (node, DOF) pairs, equation maps and node coordinates. Values are returned in the
// file's own units; DOF numbers are the vendors' (1, 2, 3: translations x, y, z or the nodal
// frame's; 4, 5, 6: rotations; others: pressure, temperature, ...). Every reader throws
// ImportError "FILE:LINE: what is wrong" on a malformed line and "FILE: ..." on a file that
// cannot be opened or is not a regular file (folders, devices and FIFOs are refused before
// reading); lines longer than 64 KiB are refused, and the bytes of a file quoted in a message
// are shown escaped where a terminal would interpret them.
#pragma once

#include <array>
#include <filesystem>
#include <map>
#include <vector>

namespace frichb::core {

// One matrix entry between two (node, DOF) pairs, with the line it came from.
struct NodalEntry {
  long node_a = 0;
  int dof_a = 0;
  long node_b = 0;
  int dof_b = 0;
  double value = 0.0;
  long line = 0;
};

struct NodeDof {
  long node = 0;
  int dof = 0;
};

// Equation number (1-based) -> (node, DOF).
using EquationMap = std::map<long, NodeDof>;

// What a file says it stores of a symmetric matrix.
enum class MatrixStorage {
  kUndeclared,     // the format does not say (Abaqus): one triangle or both, not a mix
  kLowerTriangle,  // one triangle, by the file's equation numbers (HB RSA, MM symmetric)
  kBothTriangles,  // every off-diagonal entry and its mirror (HB RUA, MM general)
};

struct VendorMatrix {
  std::vector<NodalEntry> entries;
  MatrixStorage storage = MatrixStorage::kUndeclared;
};

// Abaqus FORMAT=MATRIX INPUT: `node, dof, node, dof, value` per line; `**` comments.
VendorMatrix read_abaqus_matrix_input(const std::filesystem::path& file);

// Abaqus FORMAT=COORDINATE: `row, column, value` per line (1-based equations).
VendorMatrix read_abaqus_coordinate(const std::filesystem::path& file,
                                    const std::filesystem::path& map_file, const EquationMap& map);

// Harwell-Boeing ASCII (RSA, RUA: column pointers, row indices, values, fixed-width fields).
// Every field is read at the position its Fortran format gives and refused when the format
// does not describe the file's lines (line counts, widths, fields beyond the format, real
// fields without a decimal point); RSA entries above the diagonal are refused; the matrix
// must have as many rows as the equation map lists equations.
VendorMatrix read_harwell_boeing(const std::filesystem::path& file,
                                 const std::filesystem::path& map_file, const EquationMap& map);

// Matrix Market `coordinate real|integer general|symmetric` through the SDK's reader
// (frichb/plugin/matrix_market.hpp): an entry above the diagonal of a `symmetric` file is
// refused there; array (dense) files and matrices of another number of rows than the equation
// map lists equations are refused here.
VendorMatrix read_matrix_market(const std::filesystem::path& file,
                                const std::filesystem::path& map_file, const EquationMap& map);

// An equation map: lines `equation node dof` (whitespace or commas), the DOF a number or an
// ANSYS label (UX, UY, UZ, ROTX, ROTY, ROTZ, ...). Header and comment lines (not starting with
// a digit) are skipped. An equation listed twice, or a (node, DOF) listed twice, is refused.
EquationMap read_equation_map(const std::filesystem::path& file);

// Node coordinates by the file's extension: `.csv` (`node,x,y,z`, one header line), `.inp`
// (Abaqus *NODE blocks), anything else ANSYS NWRITE (node number then x, y, z per line,
// fixed-width fields that may touch).
std::map<long, std::array<double, 3>> read_node_coordinates(const std::filesystem::path& file);

// A list of node numbers: integers separated by blanks, commas or line ends; `#` or `**`
// starts a comment (so an Abaqus *NSET data block pasted into a file is read as is).
std::vector<long> read_node_list(const std::filesystem::path& file);

}  // namespace frichb::core
