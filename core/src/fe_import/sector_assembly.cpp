// From the vendor files to the sector's SI matrices in the nodes' cylindrical frames
// (sector_import.hpp).
#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <tuple>

#include "fe_import/cyclic_pairing.hpp"
#include "fe_import/text_input.hpp"
#include "frichb/core/fe_import/sector_import.hpp"
#include "frichb/core/fe_import/vendor_files.hpp"

namespace frichb::core {

namespace fs = std::filesystem;
using fe_import_detail::fail;

bool parse_vendor_format(const std::string& name, VendorFormat& format) {
  static const std::pair<const char*, VendorFormat> kNames[] = {
      {"abaqus-matrix-input", VendorFormat::kAbaqusMatrixInput},
      {"abaqus-coordinate", VendorFormat::kAbaqusCoordinate},
      {"ansys-hbmat", VendorFormat::kAnsysHbmat},
      {"ansys-mmf", VendorFormat::kAnsysMmf}};
  for (const auto& [text, value] : kNames)
    if (name == text) {
      format = value;
      return true;
    }
  return false;
}

bool parse_unit_system(const std::string& name, UnitSystem& units) {
  if (name != "SI" && name != "mm-t-s") return false;
  units = name == "SI" ? UnitSystem::kSI : UnitSystem::kMmTonneSecond;
  return true;
}

bool parse_nodal_frame(const std::string& name, NodalFrame& frame) {
  if (name != "global" && name != "cylindrical") return false;
  frame = name == "global" ? NodalFrame::kGlobal : NodalFrame::kCylindrical;
  return true;
}

namespace {

// One matrix entry of the upper triangle, (node_a, dof_a) <= (node_b, dof_b).
struct UpperEntry {
  long node_a = 0;
  int dof_a = 0;
  long node_b = 0;
  int dof_b = 0;
  double value = 0.0;
};

std::string node_dof(long node, int dof) {
  return "node " + std::to_string(node) + " DOF " + std::to_string(dof);
}

// Internal nodes and non-translational DOFs are refused at the line that names them.
void check_translational(const fs::path& file, const std::vector<NodalEntry>& entries) {
  for (const auto& e : entries)
    for (const auto& [node, dof] : {std::pair{e.node_a, e.dof_a}, std::pair{e.node_b, e.dof_b}}) {
      if (node <= 0)
        fail(file, e.line,
             "node " + std::to_string(node) +
                 " is an internal node (a Lagrange multiplier or an internal node of a hybrid, "
                 "connector or MPC element): FricHB's sector is a plain displacement model; "
                 "remove the constraint or element that introduces it");
      if (dof >= 4 && dof <= 6)
        fail(file, e.line,
             node_dof(node, dof) +
                 " is a rotation: FricHB's nodes carry the three translations only; export a "
                 "solid-element model (or constrain the rotations out)");
      if (dof < 1 || dof > 6)
        fail(file, e.line,
             node_dof(node, dof) + " is not a displacement (translations are DOFs 1, 2, 3)");
    }
}

// The entries as one upper triangle: a position given in both triangles must agree to 1e-10
// of the largest entry; one given twice in the same triangle is refused. How the triangles
// are stored must be what the file declares: both (every off-diagonal entry has its mirror),
// one, or (undeclared) one of the two throughout; a file that mixes them is refused rather
// than symmetrised.
std::vector<UpperEntry> upper_triangle(const fs::path& file, const VendorMatrix& matrix) {
  struct Keyed {
    std::tuple<long, int, long, int> key;
    bool mirrored;
    double value;
    long line;
  };
  std::vector<Keyed> keyed;
  keyed.reserve(matrix.entries.size());
  double largest = 0.0;
  for (const auto& e : matrix.entries) {
    const bool mirrored = std::pair{e.node_a, e.dof_a} > std::pair{e.node_b, e.dof_b};
    keyed.push_back({mirrored ? std::tuple{e.node_b, e.dof_b, e.node_a, e.dof_a}
                              : std::tuple{e.node_a, e.dof_a, e.node_b, e.dof_b},
                     mirrored, e.value, e.line});
    largest = std::max(largest, std::abs(e.value));
  }
  std::sort(keyed.begin(), keyed.end(), [](const Keyed& a, const Keyed& b) {
    return std::tie(a.key, a.mirrored, a.line) < std::tie(b.key, b.mirrored, b.line);
  });
  const auto where_of = [](const Keyed& k) {
    const auto& [na, da, nb, db] = k.key;
    return "entry " + node_dof(na, da) + " / " + node_dof(nb, db);
  };
  std::vector<UpperEntry> upper;
  upper.reserve(keyed.size());
  const Keyed* single = nullptr;  // an off-diagonal entry without its mirror
  const Keyed* paired = nullptr;  // an off-diagonal entry with its mirror
  for (std::size_t k = 0; k < keyed.size(); ++k) {
    const auto& [na, da, nb, db] = keyed[k].key;
    const bool diagonal = na == nb && da == db;
    if (k > 0 && keyed[k - 1].key == keyed[k].key) {
      const auto& before = keyed[k - 1];
      if (before.mirrored == keyed[k].mirrored || diagonal)
        fail(file, keyed[k].line,
             where_of(keyed[k]) + " is listed twice (also line " + std::to_string(before.line) +
                 ")");
      if (std::abs(before.value - keyed[k].value) > 1e-10 * largest)
        fail(file, std::max(before.line, keyed[k].line),
             where_of(keyed[k]) + " differs from its symmetric partner on line " +
                 std::to_string(std::min(before.line, keyed[k].line)) +
                 ": the matrix is not symmetric");
      paired = &keyed[k];
      continue;
    }
    const bool has_mirror = k + 1 < keyed.size() && keyed[k + 1].key == keyed[k].key;
    if (!diagonal && !has_mirror && single == nullptr) single = &keyed[k];
    upper.push_back({na, da, nb, db, keyed[k].value});
  }
  if (matrix.storage == MatrixStorage::kBothTriangles && single != nullptr)
    fail(file, single->line,
         where_of(*single) +
             " has no mirror entry, but the file declares an unsymmetric matrix stored in full "
             "(Harwell-Boeing RUA, Matrix Market general): a stiffness or mass matrix is "
             "symmetric, so export it as symmetric (RSA, symmetric) or with both triangles");
  if (matrix.storage == MatrixStorage::kUndeclared && single != nullptr && paired != nullptr)
    fail(file, single->line,
         where_of(*single) + " has no mirror entry, but " + where_of(*paired) + " (line " +
             std::to_string(paired->line) +
             ") has one: the file stores one triangle for some entries and both for others");
  return upper;
}

VendorMatrix read_matrix(const ImportRequest& request, const fs::path& file,
                         const EquationMap& map) {
  switch (request.format) {
    case VendorFormat::kAbaqusMatrixInput:
      return read_abaqus_matrix_input(file);
    case VendorFormat::kAbaqusCoordinate:
      return read_abaqus_coordinate(file, request.equation_map_file, map);
    case VendorFormat::kAnsysHbmat:
      return read_harwell_boeing(file, request.equation_map_file, map);
    case VendorFormat::kAnsysMmf:
      return read_matrix_market(file, request.equation_map_file, map);
  }
  return {};
}

std::vector<UpperEntry> read_upper(const ImportRequest& request, const fs::path& file,
                                   const EquationMap& map, double scale) {
  const auto matrix = read_matrix(request, file, map);
  if (matrix.entries.empty()) fail(file, 0, "no matrix entry");
  check_translational(file, matrix.entries);
  auto upper = upper_triangle(file, matrix);
  for (auto& e : upper) e.value *= scale;
  return upper;
}

// Every DOF of one matrix must be in the other: a DOF with stiffness and no mass (or the
// reverse) is a mass matrix of another model or of part of it.
void check_same_dofs(const ImportRequest& request, const std::vector<UpperEntry>& k,
                     const std::vector<UpperEntry>& m) {
  const auto dofs_of = [](const std::vector<UpperEntry>& upper) {
    std::map<std::pair<long, int>, bool> dofs;
    for (const auto& e : upper) {
      dofs[{e.node_a, e.dof_a}] = true;
      dofs[{e.node_b, e.dof_b}] = true;
    }
    return dofs;
  };
  const auto in_k = dofs_of(k);
  const auto in_m = dofs_of(m);
  const auto missing = [](const auto& from, const auto& in) -> const std::pair<long, int>* {
    for (const auto& [dof, _] : from)
      if (!in.count(dof)) return &dof;
    return nullptr;
  };
  if (const auto* d = missing(in_k, in_m))
    fail(request.mass_file, 0,
         node_dof(d->first, d->second) + " is in the stiffness matrix (" +
             std::to_string(in_k.size()) + " DOFs) but not in this mass matrix (" +
             std::to_string(in_m.size()) +
             " DOFs): both must be of the same model, and every DOF must carry mass");
  if (const auto* d = missing(in_m, in_k))
    fail(request.stiffness_file, 0,
         node_dof(d->first, d->second) + " is in the mass matrix (" + std::to_string(in_m.size()) +
             " DOFs) but not in this stiffness matrix (" + std::to_string(in_k.size()) +
             " DOFs): both must be of the same model");
}

using Block = std::array<double, 9>;  // row-major 3 x 3
using Frame = std::array<double, 9>;  // T: global components = T * nodal components

Frame frame_of(const ImportedNode& node, NodalFrame given) {
  if (given == NodalFrame::kCylindrical) return {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const double theta = std::atan2(node.position[1], node.position[0]);
  const double c = std::cos(theta);
  const double s = std::sin(theta);
  return {c, -s, 0, s, c, 0, 0, 0, 1};
}

// Node blocks of T^T K T (node_a <= node_b), each entry spread by the two nodes' frames.
std::map<std::pair<long, long>, Block> rotated_blocks(const std::vector<UpperEntry>& upper,
                                                      const std::map<long, Frame>& frames) {
  std::map<std::pair<long, long>, Block> blocks;
  for (const auto& e : upper) {
    const Frame& ta = frames.at(e.node_a);
    const Frame& tb = frames.at(e.node_b);
    Block& b = blocks[{e.node_a, e.node_b}];
    const auto i = static_cast<std::size_t>(e.dof_a - 1);
    const auto j = static_cast<std::size_t>(e.dof_b - 1);
    const bool off_diagonal_within_node = e.node_a == e.node_b && i != j;
    for (std::size_t p = 0; p < 3; ++p)
      for (std::size_t q = 0; q < 3; ++q) {
        double v = ta[3 * i + p] * tb[3 * j + q];
        if (off_diagonal_within_node) v += ta[3 * j + p] * tb[3 * i + q];
        b[3 * p + q] += e.value * v;
      }
  }
  return blocks;
}

LowerTriangle lower_triangle(const std::map<std::pair<long, long>, Block>& blocks,
                             const std::map<long, const ImportedNode*>& by_number, long size) {
  LowerTriangle m;
  m.size = size;
  for (const auto& [pair, b] : blocks) {
    const auto& ra = by_number.at(pair.first)->rows;
    const auto& rb = by_number.at(pair.second)->rows;
    for (std::size_t p = 0; p < 3; ++p)
      for (std::size_t q = 0; q < 3; ++q) {
        const long row = rb[q];
        const long column = ra[p];
        if (row < 0 || column < 0 || row < column) continue;
        const double v = b[3 * p + q];
        if (v != 0.0 || row == column) m.entries.push_back({row, column, v});
      }
  }
  std::sort(m.entries.begin(), m.entries.end(), [](const auto& x, const auto& y) {
    return std::tie(x.row, x.column) < std::tie(y.row, y.column);
  });
  return m;
}

// The nodes of the matrices with their coordinates (SI) and rows, ascending node number.
std::vector<ImportedNode> number_nodes(const std::vector<UpperEntry>& k,
                                       const std::vector<UpperEntry>& m,
                                       const ImportRequest& request, double length_scale) {
  std::map<long, unsigned> components;
  for (const auto* upper : {&k, &m})
    for (const auto& e : *upper) {
      components[e.node_a] |= 1U << (e.dof_a - 1);
      components[e.node_b] |= 1U << (e.dof_b - 1);
    }
  const auto coordinates = read_node_coordinates(request.coordinates_file);
  std::vector<ImportedNode> nodes;
  long next_row = 0;
  for (const auto& [number, mask] : components) {
    const auto it = coordinates.find(number);
    if (it == coordinates.end())
      fail(request.coordinates_file, 0,
           "node " + std::to_string(number) + " of the matrices has no coordinates here");
    if (request.nodal_frame == NodalFrame::kGlobal && ((mask & 1U) != 0) != ((mask & 2U) != 0))
      fail(request.stiffness_file, 0,
           "node " + std::to_string(number) +
               " has only one of its x and y DOFs in the matrices: it cannot be turned into "
               "its cylindrical frame (constrain both or neither)");
    ImportedNode node;
    node.number = number;
    for (std::size_t c = 0; c < 3; ++c) {
      node.position[c] = it->second[c] * length_scale;
      node.rows[c] = (mask >> c & 1U) != 0 ? next_row++ : -1;
    }
    nodes.push_back(node);
  }
  return nodes;
}

}  // namespace

ImportedSector assemble_sector(const ImportRequest& request) {
  if (request.sectors < 1) throw ImportError("the sector count must be at least 1");
  const bool mm = request.units == UnitSystem::kMmTonneSecond;
  EquationMap map;
  if (request.format != VendorFormat::kAbaqusMatrixInput)
    map = read_equation_map(request.equation_map_file);
  const auto k = read_upper(request, request.stiffness_file, map, mm ? 1e3 : 1.0);
  const auto m = read_upper(request, request.mass_file, map, mm ? 1e3 : 1.0);
  check_same_dofs(request, k, m);
  ImportedSector sector;
  sector.nodes = number_nodes(k, m, request, mm ? 1e-3 : 1.0);
  std::map<long, Frame> frames;
  std::map<long, const ImportedNode*> by_number;
  for (const auto& node : sector.nodes) {
    frames[node.number] = frame_of(node, request.nodal_frame);
    by_number[node.number] = &node;
  }
  long size = 0;
  for (const auto& node : sector.nodes)
    for (const long row : node.rows) size = std::max(size, row + 1);
  sector.stiffness = lower_triangle(rotated_blocks(k, frames), by_number, size);
  sector.mass = lower_triangle(rotated_blocks(m, frames), by_number, size);
  const double tolerance = request.tolerance * (mm ? 1e-3 : 1.0);
  std::vector<long> not_cyclic;
  if (!request.not_cyclic_file.empty()) {
    not_cyclic = read_node_list(request.not_cyclic_file);
    for (const long node : not_cyclic)
      if (!by_number.count(node))
        fail(request.not_cyclic_file, 0,
             "node " + std::to_string(node) +
                 " is not a node of the matrices: the list of nodes never paired names nodes of "
                 "this model (a list of another mesh or an off-by-one would leave the real "
                 "contact nodes paired)");
  }
  pair_cyclic_boundary(sector, request.sectors, tolerance, not_cyclic, request.coordinates_file);
  return sector;
}

}  // namespace frichb::core
