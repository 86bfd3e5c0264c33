// `frichb import`: a sector's stiffness and mass matrices exported by ANSYS or Abaqus turned
// into the inputs of the fe_sector structure provider and the model map (mesh.yaml, nodes.csv:
// the shared model-map format of docs/fe-models.md).
//
// Contract:
// - Formats (docs/fe-models.md says which vendor commands write them):
//     abaqus-matrix-input  `node, dof, node, dof, value` lines (*MATRIX OUTPUT,
//                          FORMAT=MATRIX INPUT); no equation map needed;
//     abaqus-coordinate    `row, column, value` lines (FORMAT=COORDINATE) + an equation map;
//     ansys-hbmat          Harwell-Boeing ASCII (HBMAT) + the .mapping file;
//     ansys-mmf            Matrix Market (APDL Math *EXPORT, MMF) + the .mapping file.
//   Either triangle of a symmetric matrix may be given, or both (they must then agree to 1e-10
//   of the largest entry), as the file declares it (vendor_files.hpp, MatrixStorage): a file
//   that declares both triangles and lacks a mirror entry, or (undeclared) mixes one and both,
//   is refused. A position listed twice in the same triangle is refused. The stiffness and
//   mass matrices must have the same DOFs.
// - Node coordinates: a CSV `node,x,y,z`, an Abaqus input file (*NODE blocks, rectangular
//   coordinates) or ANSYS NWRITE output, chosen by the file's extension (.csv, .inp, other).
// - Units are converted once, on reading: with mm-t-s, stiffness x 1e3 (N/mm -> N/m), mass
//   x 1e3 (t -> kg), coordinates x 1e-3 (mm -> m). Everything returned and written is SI.
// - Frames: with NodalFrame::global every node's three translations are turned into its
//   cylindrical frame (r, theta, z) about the global z axis at atan2(y, x): K' = T^T K T,
//   M' = T^T M T with T block-diagonal. The matrices returned are always in the nodes'
//   cylindrical frames.
// - DOF numbering: nodes in ascending node number, components in the order (r, theta, z); a
//   component absent from both matrices (removed by the exporter) gets no row.
// - Refused with an ImportError naming file, line (where there is one) and what is wrong:
//   rotational or other non-translational DOFs, internal nodes (node labels <= 0: Lagrange
//   multipliers, internal nodes of hybrid or connector elements), a node without coordinates,
//   a node with only one of its x and y components in the global frame, a malformed line.
// - Cyclic boundary: node L pairs with node R when R's position equals L's turned by
//   +phi = 2 pi / sectors about z within `tolerance` (default 1e-6 of the largest coordinate
//   magnitude); nodes listed in `not_cyclic_file` are left out (each must be a node of the
//   matrices). Every present component of
//   the pair is paired. Refused: two nodes within the
//   tolerance of one rotated position, a node paired twice, a node on the axis, a node that is
//   both a left and a right boundary node, a component present on one side only.
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "frichb/core/fe_import/nodal_frame.hpp"

namespace frichb::core {

// A vendor file (or the request) that cannot be imported; the message names the file and the
// line where there is one.
class ImportError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The imported files could not be written (I/O error, disk full, folder not writable).
class ImportWriteError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class VendorFormat { kAbaqusMatrixInput, kAbaqusCoordinate, kAnsysHbmat, kAnsysMmf };
enum class UnitSystem { kSI, kMmTonneSecond };

// Parses "abaqus-matrix-input", ... / "SI", "mm-t-s" / "global", "cylindrical"; false when the
// name is not one of them.
bool parse_vendor_format(const std::string& name, VendorFormat& format);
bool parse_unit_system(const std::string& name, UnitSystem& units);
bool parse_nodal_frame(const std::string& name, NodalFrame& frame);

struct ImportRequest {
  VendorFormat format = VendorFormat::kAbaqusMatrixInput;
  std::filesystem::path stiffness_file;
  std::filesystem::path mass_file;
  std::filesystem::path equation_map_file;  // all formats but abaqus-matrix-input
  std::filesystem::path coordinates_file;
  UnitSystem units = UnitSystem::kSI;
  NodalFrame nodal_frame = NodalFrame::kGlobal;
  int sectors = 0;         // >= 1
  double tolerance = 0.0;  // in the coordinates' units; 0: 1e-6 of the largest coordinate
  // Optional: a list of nodes never paired across the cyclic boundary (contact faces that
  // coincide with the neighbour's at rest, e.g. shroud or platform interfaces).
  std::filesystem::path not_cyclic_file;
};

// One FE node of the imported sector: SI coordinates and the 0-based rows of its (r, theta, z)
// components (-1: not in the matrices).
struct ImportedNode {
  long number = 0;
  std::array<double, 3> position{};
  std::array<long, 3> rows{};
};

// A symmetric matrix by its lower triangle (row >= column, 0-based), sorted by row then column.
struct LowerTriangle {
  struct Entry {
    long row = 0;
    long column = 0;
    double value = 0.0;
  };
  long size = 0;
  std::vector<Entry> entries;
};

struct ImportedSector {
  std::vector<ImportedNode> nodes;                  // ascending node number
  LowerTriangle stiffness;                          // N/m, cylindrical nodal frames
  LowerTriangle mass;                               // kg
  std::vector<std::pair<long, long>> cyclic_pairs;  // (left row, right row), ascending left
  std::size_t boundary_node_pairs = 0;
  double tolerance = 0.0;  // the pairing tolerance used, m
};

// Reads, converts and pairs; throws ImportError.
ImportedSector assemble_sector(const ImportRequest& request);

// Writes sector_stiffness.mtx, sector_mass.mtx, cyclic_pairs.txt, mesh.yaml and nodes.csv,
// each to `path_of(name)` through a temporary file that is flushed, checked and renamed;
// throws ImportWriteError (the temporary files removed).
inline constexpr std::array<const char*, 5> kImportedFiles = {
    "sector_stiffness.mtx", "sector_mass.mtx", "cyclic_pairs.txt", "mesh.yaml", "nodes.csv"};
void write_sector(const ImportedSector& sector,
                  const std::function<std::filesystem::path(const std::string&)>& path_of);

}  // namespace frichb::core
