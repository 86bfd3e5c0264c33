// The model map of an FE structure: mesh.yaml, nodes.csv and faces.csv (fe_mesh.hpp).
#include "frichb/core/scene/fe_mesh.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>

#include "frichb/core/scene/scene.hpp"
#include "frichb/plugin/sdk.hpp"

namespace frichb::core {

namespace fs = std::filesystem;
using sdk::Param;

namespace {

const std::vector<frichb_param_spec>& manifest_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::integer("format", "version of the model-map format").at_least(1).at_most(1),
      Param::text("units",
                  "units of the coordinates and areas: SI (m) or mm-t-s (mm, converted on "
                  "reading)")
          .choices("SI|mm-t-s"),
      Param::path("nodes", "CSV table node,x,y,z,frame,dof_1,dof_2,dof_3 (relative to this file)"),
      Param::path("faces", "CSV table face,node,area,nx,ny,nz of the contact faces (optional)")
          .defaults_to_text(""),
  };
  return s;
}

[[noreturn]] void fail_at(const fs::path& file, int line, const std::string& message) {
  throw SceneError(file.string(), line, 0, "", message);
}

// The fields of one CSV line, trimmed.
std::vector<std::string> split_fields(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream ss(line);
  std::string field;
  while (std::getline(ss, field, ',')) {
    const auto first = field.find_first_not_of(" \t\r");
    const auto last = field.find_last_not_of(" \t\r");
    fields.push_back(first == std::string::npos ? "" : field.substr(first, last - first + 1));
  }
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

double parse_real(const std::string& text, const fs::path& file, int line, const char* what) {
  errno = 0;
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(x))
    fail_at(file, line, std::string(what) + " '" + text + "' is not a finite number");
  return x;
}

std::int64_t parse_integer(const std::string& text, const fs::path& file, int line,
                           const char* what) {
  errno = 0;
  char* end = nullptr;
  const long long x = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
    fail_at(file, line, std::string(what) + " '" + text + "' is not an integer");
  return x;
}

void read_nodes(FeMesh& mesh, double length_scale) {
  read_csv_table(
      mesh.nodes_file, "node,x,y,z,frame,dof_1,dof_2,dof_3", 8, "",
      [&](const std::vector<std::string>& f, int line) {
        MeshNode n;
        n.line = line;
        n.number = parse_integer(f[0], mesh.nodes_file, line, "node");
        if (n.number <= 0) fail_at(mesh.nodes_file, line, "node numbers are positive");
        for (int k = 0; k < 3; ++k)
          n.position[k] = length_scale * parse_real(f[1 + k], mesh.nodes_file, line, "coordinate");
        if (f[4] == "global") {
          n.frame = NodalFrame::kGlobal;
        } else if (f[4] == "cylindrical") {
          n.frame = NodalFrame::kCylindrical;
        } else {
          fail_at(mesh.nodes_file, line,
                  "frame '" + f[4] + "': expected 'global' or 'cylindrical'");
        }
        for (int k = 0; k < 3; ++k) {
          n.rows[k] = parse_integer(f[5 + k], mesh.nodes_file, line, "DOF row");
          if (n.rows[k] < -1)
            fail_at(mesh.nodes_file, line, "a DOF row is >= 0, or -1 (not in the matrices)");
        }
        if (!mesh.index.emplace(n.number, mesh.nodes.size()).second)
          fail_at(mesh.nodes_file, line,
                  "node " + std::to_string(n.number) + " is listed twice (first on line " +
                      std::to_string(mesh.nodes[mesh.index.at(n.number)].line) + ")");
        mesh.nodes.push_back(n);
      });
}

void read_faces(FeMesh& mesh, double length_scale) {
  read_csv_table(
      mesh.faces_file, "face,node,area,nx,ny,nz", 6, "",
      [&](const std::vector<std::string>& f, int line) {
        FaceNode n;
        n.line = line;
        if (f[0].empty()) fail_at(mesh.faces_file, line, "empty face name");
        n.node = parse_integer(f[1], mesh.faces_file, line, "node");
        if (!mesh.find(n.node))
          fail_at(mesh.faces_file, line,
                  "node " + f[1] + " is not in " + mesh.nodes_file.filename().string());
        n.area = length_scale * length_scale * parse_real(f[2], mesh.faces_file, line, "area");
        if (!(n.area > 0)) fail_at(mesh.faces_file, line, "the area must be > 0");
        double norm2 = 0;
        for (int k = 0; k < 3; ++k) {
          n.normal[k] = parse_real(f[3 + k], mesh.faces_file, line, "normal component");
          norm2 += n.normal[k] * n.normal[k];
        }
        if (std::abs(std::sqrt(norm2) - 1.0) > 1e-6)
          fail_at(
              mesh.faces_file, line,
              "the normal is not a unit vector (length " + std::to_string(std::sqrt(norm2)) + ")");
        auto& face = mesh.faces[f[0]];
        for (const auto& other : face)
          if (other.node == n.node)
            fail_at(mesh.faces_file, line,
                    "node " + f[1] + " is listed twice in face '" + f[0] + "' (line " +
                        std::to_string(other.line) + ")");
        face.push_back(n);
      });
}

void read_node_sets(FeMesh& mesh, const YAML::Node& sets, const YamlContext& ctx) {
  if (!sets) return;
  if (!sets.IsMap()) ctx.fail(sets, "node_sets", "expected a map {name: [node, ...]}");
  for (const auto& kv : sets) {
    const std::string name = kv.first.Scalar();
    const std::string path = "node_sets." + name;
    if (!kv.second.IsSequence() || kv.second.size() == 0)
      ctx.fail(kv.second, path, "expected a list of FE node numbers");
    std::vector<std::int64_t> nodes;
    for (const auto& n : kv.second) {
      const std::int64_t number = n.IsScalar() ? fe_node_number(n.Scalar()) : -1;
      if (number < 0) ctx.fail(n, path, "expected an FE node number");
      if (!mesh.find(number)) ctx.fail(n, path, "node " + n.Scalar() + " is not in the mesh");
      nodes.push_back(number);
    }
    mesh.node_sets[name] = std::move(nodes);
  }
}

}  // namespace

const MeshNode* FeMesh::find(std::int64_t number) const {
  const auto it = index.find(number);
  return it == index.end() ? nullptr : &nodes[it->second];
}

std::array<double, 3> FeMesh::to_nodal(const MeshNode& node, const std::array<double, 3>& v) {
  if (node.frame == NodalFrame::kGlobal) return v;
  const double theta = std::atan2(node.position[1], node.position[0]);
  const double c = std::cos(theta), s = std::sin(theta);
  return {c * v[0] + s * v[1], -s * v[0] + c * v[1], v[2]};
}

std::int64_t fe_node_number(const std::string& text) {
  if (text.empty() || text.size() > 18) return -1;
  for (char ch : text)
    if (ch < '0' || ch > '9') return -1;
  const std::int64_t n = std::stoll(text);
  return n > 0 ? n : -1;
}

void read_csv_table(const fs::path& file, const std::string& header, std::size_t columns,
                    const std::string& key_path, const CsvRow& row) {
  auto fail_at = [&](int line, const std::string& message) {
    throw SceneError(file.string(), line, 0, key_path, message);
  };
  std::ifstream in(file);
  if (!in) fail_at(0, "cannot open the file (a relative path is taken from mesh.yaml's folder)");
  std::string text;
  int line = 0;
  bool header_seen = false;
  while (std::getline(in, text)) {
    ++line;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (text.find_first_not_of(" \t") == std::string::npos || text[0] == '#') continue;
    if (!header_seen) {
      if (text != header) fail_at(line, "expected the header '" + header + "'");
      header_seen = true;
      continue;
    }
    const auto fields = split_fields(text);
    if (fields.size() != columns)
      fail_at(line, "expected " + std::to_string(columns) + " fields (" + header + "), found " +
                        std::to_string(fields.size()));
    row(fields, line);
  }
  if (in.bad()) fail_at(line, "read error");
  if (!header_seen) fail_at(line, "empty table: expected the header '" + header + "'");
}

FeMesh load_fe_mesh(const fs::path& file) {
  FeMesh mesh;
  mesh.file = file;
  const YAML::Node doc = load_scene_yaml(file);
  const YamlContext ctx{file.string()};
  if (!doc.IsMap()) ctx.fail(doc, "", "a model map is a YAML map {format, units, nodes, ...}");
  const auto values =
      validate_params(doc, manifest_schema(), "", ctx, std::vector<std::string>{"node_sets"});
  const sdk::Params v(manifest_schema().data(), manifest_schema().size(), values.data());
  mesh.units = v.text("units");
  const double length_scale = mesh.units == "mm-t-s" ? 1e-3 : 1.0;
  // Path values come resolved against mesh.yaml's folder.
  mesh.nodes_file = v.text("nodes");
  std::error_code ec;
  if (!fs::is_regular_file(mesh.nodes_file, ec))
    ctx.fail(doc["nodes"], "nodes", "'" + mesh.nodes_file.string() + "' not found");
  read_nodes(mesh, length_scale);
  if (!v.text("faces").empty()) {
    mesh.faces_file = v.text("faces");
    if (!fs::is_regular_file(mesh.faces_file, ec))
      ctx.fail(doc["faces"], "faces", "'" + mesh.faces_file.string() + "' not found");
    read_faces(mesh, length_scale);
  }
  read_node_sets(mesh, doc["node_sets"], ctx);
  return mesh;
}

}  // namespace frichb::core
