// The model map of a finite-element structure (`structure.mesh`): which matrix rows belong to
// which FE node, the nodes' positions and nodal frames, named node sets and contact faces.
//
// Files (docs/fe-models.md): `mesh.yaml` names the units and the two tables, relative to its
// own folder:
//
//   format: 1
//   units: SI              # or mm-t-s: coordinates in mm and areas in mm^2, converted on reading
//   nodes: nodes.csv       # node,x,y,z,frame,dof_1,dof_2,dof_3
//   faces: faces.csv       # optional: face,node,area,nx,ny,nz
//   node_sets: {name: [node, ...]}   # optional
//
// nodes.csv: one row per FE node with DOFs in the matrices; `frame` is `global` (components
// along x, y, z) or `cylindrical` (r, theta, z about the global z axis at the node's angle
// atan2(y, x)); dof_k the 0-based matrix row of component k, -1 when the component is not in
// the matrices. faces.csv: the contact nodes of named faces, each with its tributary area and
// the face's outward unit normal (global Cartesian).
//
// Contract: every quantity held is SI (m, m^2). load_fe_mesh throws SceneError naming the file,
// the line and what is wrong (a missing file, a bad header, a malformed or duplicate row, an
// unknown node in a face or a node set, a non-unit normal, a non-positive area). A loaded FeMesh
// is immutable and may be read from several threads.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include "frichb/core/fe_import/nodal_frame.hpp"

namespace frichb::core {

struct MeshNode {
  std::int64_t number = 0;           // FE node number
  std::array<double, 3> position{};  // m, global Cartesian
  NodalFrame frame = NodalFrame::kGlobal;
  std::array<std::int64_t, 3> rows{};  // 0-based matrix rows, -1: not in the matrices
  int line = 0;                        // line of nodes.csv
};

struct FaceNode {
  std::int64_t node = 0;
  double area = 0;                 // m^2, tributary
  std::array<double, 3> normal{};  // outward unit normal, global Cartesian
  int line = 0;                    // line of faces.csv
};

struct FeMesh {
  std::filesystem::path file;  // mesh.yaml
  std::filesystem::path nodes_file, faces_file;
  std::string units;            // as declared: "SI" or "mm-t-s"
  std::vector<MeshNode> nodes;  // in file order
  std::map<std::string, std::vector<FaceNode>> faces;
  std::map<std::string, std::vector<std::int64_t>> node_sets;

  // The node with FE number `number`, or nullptr.
  const MeshNode* find(std::int64_t number) const;
  // The components of the global vector `v` in the node's frame (its DOFs' directions).
  static std::array<double, 3> to_nodal(const MeshNode& node, const std::array<double, 3>& v);

  std::unordered_map<std::int64_t, std::size_t> index;  // FE number -> position in `nodes`
};

// Reads mesh.yaml and the tables it names. Throws SceneError (file:line: what is wrong).
FeMesh load_fe_mesh(const std::filesystem::path& file);

// Reads the CSV table `file`: '#' lines and blank lines skipped, then the header line, which
// must be `header`, then calls `row(fields, line)` (fields trimmed) for every data line, which
// must have `columns` fields. Throws SceneError (file:line, `key_path`) for a missing file, a
// wrong header, a wrong field count; `row` throws its own.
using CsvRow = std::function<void(const std::vector<std::string>& fields, int line)>;
void read_csv_table(const std::filesystem::path& file, const std::string& header,
                    std::size_t columns, const std::string& key_path, const CsvRow& row);

// An FE node number written as a scene name ("1234"), or -1 when `text` is not one.
std::int64_t fe_node_number(const std::string& text);

}  // namespace frichb::core
