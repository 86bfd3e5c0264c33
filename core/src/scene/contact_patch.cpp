// Contact patches: pairing two meshed faces node by node (contact_patch.hpp).
#include "frichb/core/scene/contact_patch.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <set>
#include <sstream>

#include "frichb/core/scene/scene.hpp"
#include "frichb/plugin/sdk.hpp"

namespace frichb::core {

namespace fs = std::filesystem;
using sdk::Param;
using Vec3 = std::array<double, 3>;

const std::vector<frichb_param_spec>& contact_patch_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::real("tolerance", "m",
                  "largest distance between paired nodes in face A's plane (and along its "
                  "normal, unless that distance is the pair's gap)")
          .greater_than(0)
          .defaults_to(1e-6),
      Param::path("pairs_file",
                  "CSV table node_a,node_b of the pairs instead of pairing by position "
                  "(relative to the scene's folder)")
          .defaults_to_text(""),
      Param::text("values",
                  "how the law's force-valued params are given: total (over the face, shared by "
                  "tributary area) or per_area (per m^2)")
          .choices("total|per_area")
          .defaults_to_text("total"),
      Param::path("normal_load_file",
                  "CSV table node,normal_load (N, compressive) of face A's nodes: each pair's "
                  "preload")
          .defaults_to_text(""),
      Param::path("gap_file", "CSV table node,gap (m) of face A's nodes: each pair's initial gap")
          .defaults_to_text(""),
      Param::boolean("gaps_from_coordinates",
                     "each pair's initial gap is the distance of its nodes along the normal")
          .defaults_to(0),
  };
  return s;
}

const std::vector<frichb_param_spec>& contact_patch_side_schema() {
  static const std::vector<frichb_param_spec> s = {
      Param::text("face", "face name (a face of the model map's faces.csv)"),
      Param::integer("sector", "sector offset from the reference sector (cyclic scenes)")
          .defaults_to(0)
          .at_least(-1)
          .at_most(1),
  };
  return s;
}

namespace {

double dot(const Vec3& a, const Vec3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
Vec3 minus(const Vec3& a, const Vec3& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
Vec3 scaled(const Vec3& a, double s) {
  return {a[0] * s, a[1] * s, a[2] * s};
}
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double norm(const Vec3& a) {
  return std::sqrt(dot(a, a));
}
Vec3 rotated_about_z(const Vec3& a, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return {c * a[0] - s * a[1], s * a[0] + c * a[1], a[2]};
}
std::string metres(double x) {
  std::ostringstream os;
  os.precision(3);
  os << x << " m";
  return os.str();
}

struct Side {
  std::string face;  // empty: ground
  int sector = 0;
};

// faces: [side A, side B]: each a face name or {face, sector}; side B may be 'ground'.
std::array<Side, 2> read_sides(const YAML::Node& faces, const std::string& path,
                               const YamlContext& ctx, const FeMesh& mesh, int sectors) {
  if (!faces || !faces.IsSequence() || faces.size() != 2)
    ctx.fail(faces, path,
             "expected [face A, face B]: face names, {face: name, sector: 1}, or 'ground' as B");
  std::array<Side, 2> sides;
  for (std::size_t k = 0; k < 2; ++k) {
    const std::string side_path = path + "[" + std::to_string(k) + "]";
    const YAML::Node n = faces[k];
    if (n.IsScalar()) {
      sides[k].face = n.Scalar() == "ground" && k == 1 ? "" : n.Scalar();
    } else {
      const auto values = validate_params(n, contact_patch_side_schema(), side_path, ctx);
      const sdk::Params v(contact_patch_side_schema().data(), contact_patch_side_schema().size(),
                          values.data());
      sides[k].face = v.text("face");
      sides[k].sector = static_cast<int>(v.integer("sector"));
      if (sides[k].sector != 0 && sectors < 2)
        ctx.fail(n["sector"], side_path + ".sector",
                 "a neighbouring sector needs a `cyclic: {sectors, engine_order}` section");
    }
    if (k == 1 && sides[k].face.empty()) continue;
    if (!mesh.faces.count(sides[k].face)) {
      std::vector<std::string> names;
      for (const auto& f : mesh.faces) names.push_back(f.first);
      const std::string close = closest_match(sides[k].face, names);
      ctx.fail(n, side_path,
               "'" + sides[k].face + "' is not a face of the model map " + mesh.file.string() +
                   (close.empty() ? std::string() : " (did you mean '" + close + "'?)"));
    }
  }
  if (sides[0].face == sides[1].face && sides[0].sector == sides[1].sector)
    ctx.fail(faces, path, "both sides are the same face of the same sector");
  return sides;
}

double total_area(const std::vector<FaceNode>& face) {
  double a = 0;
  for (const auto& n : face) a += n.area;
  return a;
}

// The pair's frame: normal against face A's outward normal, tangent1 from `hint` (or the first
// global axis not near the normal) projected onto the face plane, tangent2 = normal x tangent1.
void set_frame(PatchPair& pair, const Vec3& outward_a, const std::optional<Vec3>& hint,
               const MeshNode& node_a, const YAML::Node& frame, const std::string& path,
               const YamlContext& ctx) {
  const Vec3 normal = scaled(outward_a, -1.0);
  Vec3 t1{};
  if (hint) {
    t1 = minus(*hint, scaled(normal, dot(*hint, normal)));
    if (norm(t1) < 1e-6)
      ctx.fail(frame["tangent1"], path + ".frame.tangent1",
               "is along the face normal at node " + std::to_string(pair.node_a));
  } else {
    for (const Vec3& axis : {Vec3{0, 0, 1}, Vec3{1, 0, 0}, Vec3{0, 1, 0}}) {
      if (std::abs(dot(axis, normal)) > std::cos(25.0 * std::numbers::pi / 180.0)) continue;
      t1 = minus(axis, scaled(normal, dot(axis, normal)));
      break;
    }
  }
  t1 = scaled(t1, 1.0 / norm(t1));
  const Vec3 t2 = cross(normal, t1);
  pair.normal = FeMesh::to_nodal(node_a, normal);
  pair.tangent1 = FeMesh::to_nodal(node_a, t1);
  pair.tangent2 = FeMesh::to_nodal(node_a, t2);
  pair.tangent1_global = t1;
  pair.tangent2_global = t2;
}

// Each pair's position on face A: node A from the face's area-weighted centroid, along the
// pair's tangent1 and tangent2 (global), in m.
void set_face_coordinates(ContactPatch& patch, const FeMesh& mesh) {
  Vec3 centroid{};
  for (const auto& pair : patch.pairs)
    for (int k = 0; k < 3; ++k)
      centroid[k] += pair.area * mesh.find(pair.node_a)->position[k] / patch.area_a;
  for (auto& pair : patch.pairs) {
    const Vec3 d = minus(mesh.find(pair.node_a)->position, centroid);
    pair.face_coordinates = {dot(d, pair.tangent1_global), dot(d, pair.tangent2_global)};
  }
}

// A CSV table `header` (two columns: node and a value) read into node -> value.
std::map<std::int64_t, double> read_node_values(const fs::path& file, const std::string& header,
                                                const std::string& key_path) {
  std::map<std::int64_t, double> values;
  read_csv_table(file, header, 2, key_path, [&](const std::vector<std::string>& f, int line) {
    const std::int64_t node = fe_node_number(f[0]);
    char* end = nullptr;
    const double value = std::strtod(f[1].c_str(), &end);
    if (node < 0 || f[1].empty() || *end != '\0' || !std::isfinite(value))
      throw SceneError(
          file.string(), line, 0, key_path,
          "expected an FE node number and a finite number: '" + f[0] + "," + f[1] + "'");
    if (!values.emplace(node, value).second)
      throw SceneError(file.string(), line, 0, key_path, "node " + f[0] + " is listed twice");
  });
  return values;
}

struct Pairing {
  std::int64_t node_b = 0;
  double in_plane = 0, normal = 0;
};

// Node B (rotated) relative to node A: its distance in A's face plane and along A's normal.
Pairing measure(const FaceNode& a, const MeshNode& node_a, const MeshNode& node_b, double angle) {
  const Vec3 d = minus(rotated_about_z(node_b.position, angle), node_a.position);
  const double along = dot(d, a.normal);
  return {node_b.number, norm(minus(d, scaled(a.normal, along))), along};
}

// Pairs face A's nodes with face B's by position (one-to-one within the tolerance).
std::vector<Pairing> pair_by_position(const std::vector<FaceNode>& face_a,
                                      const std::vector<FaceNode>& face_b, const FeMesh& mesh,
                                      double angle, const ContactPatch& patch,
                                      const YAML::Node& faces, const std::string& path,
                                      const YamlContext& ctx) {
  std::vector<Pairing> out;
  std::map<std::int64_t, std::int64_t> taken;  // node B -> node A
  for (const auto& a : face_a) {
    const MeshNode& node_a = *mesh.find(a.node);
    Pairing best{0, std::numeric_limits<double>::infinity(), 0};
    for (const auto& b : face_b) {
      const Pairing p = measure(a, node_a, *mesh.find(b.node), angle);
      if (p.in_plane < best.in_plane) best = p;
    }
    if (best.in_plane > patch.tolerance)
      ctx.fail(faces, path,
               "node " + std::to_string(a.node) + " of face '" + patch.face_a +
                   "' has no partner on face '" + patch.face_b + "' within the tolerance " +
                   metres(patch.tolerance) + ": the nearest, node " + std::to_string(best.node_b) +
                   ", is " + metres(best.in_plane) +
                   " away in the face plane (non-conforming faces are refused: give a "
                   "pairs_file, or conforming meshes)");
    const auto [it, fresh] = taken.emplace(best.node_b, a.node);
    if (!fresh)
      ctx.fail(faces, path,
               "nodes " + std::to_string(it->second) + " and " + std::to_string(a.node) +
                   " of face '" + patch.face_a + "' both pair with node " +
                   std::to_string(best.node_b) + " of face '" + patch.face_b +
                   "': reduce the tolerance or give a pairs_file");
    out.push_back(best);
  }
  for (const auto& b : face_b)
    if (!taken.count(b.node))
      ctx.fail(faces, path,
               "node " + std::to_string(b.node) + " of face '" + patch.face_b +
                   "' pairs with no node of face '" + patch.face_a +
                   "' (face B has more nodes than face A: non-conforming faces are refused)");
  return out;
}

// frame: only tangent1, a global direction (the normal comes from the faces).
std::optional<Vec3> read_tangent_hint(const YAML::Node& frame, const std::string& path,
                                      const YamlContext& ctx) {
  if (!frame) return std::nullopt;
  if (!frame.IsMap()) ctx.fail(frame, path + ".frame", "expected {tangent1: [x, y, z]}");
  for (const auto& kv : frame)
    if (kv.first.Scalar() != "tangent1")
      ctx.fail(kv.first, path + ".frame." + kv.first.Scalar(),
               "a patch takes its normal from the faces and tangent2 = normal x tangent1: give "
               "only tangent1 (global x, y, z)");
  const YAML::Node t = frame["tangent1"];
  Vec3 hint{};
  for (std::size_t k = 0; t.IsSequence() && t.size() == 3 && k < 3; ++k)
    if (!t[k].IsScalar() || !YAML::convert<double>::decode(t[k], hint[k]) ||
        !std::isfinite(hint[k]))
      ctx.fail(t[k], path + ".frame.tangent1", "expected a finite number");
  if (!t.IsSequence() || t.size() != 3 || norm(hint) == 0)
    ctx.fail(t, path + ".frame.tangent1", "expected a non-zero global direction [x, y, z]");
  return hint;
}

// Both sides of a pair use node A's frame: nodes across sectors must be in cylindrical frames
// (the sector rotation leaves those components unchanged), nodes of one sector in one kind.
void check_shared_frame(const MeshNode& a, const MeshNode& b, double angle, const YAML::Node& node,
                        const std::string& path, const YamlContext& ctx) {
  if (b.frame == a.frame && (angle == 0 || a.frame == NodalFrame::kCylindrical)) return;
  ctx.fail(node, path,
           "nodes " + std::to_string(a.number) + " and " + std::to_string(b.number) +
               ": the two sides of a pair share node A's frame, so both must be in cylindrical "
               "frames (across sectors) or both in the same frame");
}

// The largest distance from a node of `face` to its nearest other node of the face (0 for a
// face of one node): how far apart two nodes that touch can lie on non-conforming meshes.
double mesh_spacing(const std::vector<FaceNode>& face, const FeMesh& mesh) {
  double spacing = 0.0;
  for (const auto& a : face) {
    double nearest = std::numeric_limits<double>::infinity();
    for (const auto& b : face)
      if (b.node != a.node)
        nearest = std::min(nearest,
                           norm(minus(mesh.find(b.node)->position, mesh.find(a.node)->position)));
    if (std::isfinite(nearest)) spacing = std::max(spacing, nearest);
  }
  return spacing;
}

// pairs_file: `node_a,node_b` rows; each node of face A once, each of face B at most once; the
// two nodes of a pair no farther apart in the face plane than the faces' mesh spacing (or the
// tolerance, where that is larger).
std::vector<Pairing> pair_from_file(const fs::path& file, const std::vector<FaceNode>& face_a,
                                    const std::vector<FaceNode>& face_b, const FeMesh& mesh,
                                    double angle, double tolerance, const std::string& key_path) {
  std::map<std::int64_t, std::int64_t> partner;  // node A -> node B
  std::set<std::int64_t> on_b;
  for (const auto& b : face_b) on_b.insert(b.node);
  std::set<std::int64_t> used_b;
  for (const auto& [a, b_value] : read_node_values(file, "node_a,node_b", key_path)) {
    const auto b = static_cast<std::int64_t>(b_value);
    if (b_value != static_cast<double>(b) || !on_b.count(b))
      throw SceneError(file.string(), 0, 0, key_path,
                       "node " + std::to_string(a) + " pairs with " + std::to_string(b_value) +
                           ", which is not a node of face B");
    if (!used_b.insert(b).second)
      throw SceneError(file.string(), 0, 0, key_path,
                       "node " + std::to_string(b) + " of face B is paired twice");
    partner[a] = b;
  }
  const double reach =
      std::max({mesh_spacing(face_a, mesh), mesh_spacing(face_b, mesh), tolerance});
  std::vector<Pairing> out;
  for (const auto& a : face_a) {
    const auto it = partner.find(a.node);
    if (it == partner.end())
      throw SceneError(file.string(), 0, 0, key_path,
                       "node " + std::to_string(a.node) + " of face A has no pair");
    out.push_back(measure(a, *mesh.find(a.node), *mesh.find(it->second), angle));
    if (out.back().in_plane > reach)
      throw SceneError(file.string(), 0, 0, key_path,
                       "node " + std::to_string(a.node) + " pairs with node " +
                           std::to_string(it->second) + ", " + metres(out.back().in_plane) +
                           " away in the face plane: farther than the faces' mesh spacing (" +
                           metres(reach) + "), so the two nodes cannot touch");
    partner.erase(it);
  }
  if (!partner.empty())
    throw SceneError(file.string(), 0, 0, key_path,
                     "node " + std::to_string(partner.begin()->first) + " is not a node of face A");
  return out;
}

// Sets `name` of every pair from a `node,<name>` table keyed by face A's nodes.
void set_from_node_file(ContactPatch& patch, const fs::path& file, const std::string& name,
                        const std::string& key_path) {
  auto values = read_node_values(file, "node," + name, key_path);
  for (auto& pair : patch.pairs) {
    const auto it = values.find(pair.node_a);
    if (it == values.end())
      throw SceneError(
          file.string(), 0, 0, key_path,
          "node " + std::to_string(pair.node_a) + " of face '" + patch.face_a + "' is not listed");
    if (it->second < 0)
      throw SceneError(file.string(), 0, 0, key_path,
                       "node " + std::to_string(pair.node_a) + ": " + name + " must be >= 0");
    pair.overrides[name] = it->second;
    values.erase(it);
  }
  if (!values.empty())
    throw SceneError(file.string(), 0, 0, key_path,
                     "node " + std::to_string(values.begin()->first) + " is not a node of face '" +
                         patch.face_a + "'");
}

// Normal distances: the pair's gap (gaps_from_coordinates), else within the tolerance.
void check_normal_distances(ContactPatch& patch, bool gaps_from_coordinates, const YAML::Node& node,
                            const std::string& path, const YamlContext& ctx) {
  for (auto& pair : patch.pairs) {
    if (pair.node_b == 0) continue;
    const double d = pair.normal_distance;
    if (gaps_from_coordinates && d >= -patch.tolerance) {
      pair.overrides["gap"] = std::max(0.0, d);
    } else if (std::abs(d) > patch.tolerance) {
      ctx.fail(node, path,
               "nodes " + std::to_string(pair.node_a) + " and " + std::to_string(pair.node_b) +
                   " are " + metres(d) + " apart along the normal (" +
                   (d < 0 ? std::string("they overlap")
                          : std::string("give gaps_from_coordinates: true or a gap_file")) +
                   ")");
    }
  }
}

// B's outward normal must face A's: the faces touch, they do not cross.
void check_facing(const ContactPatch& patch, const FeMesh& mesh, double angle,
                  const YAML::Node& node, const std::string& path, const YamlContext& ctx) {
  if (patch.face_b.empty()) return;
  std::map<std::int64_t, Vec3> normal_b;
  for (const auto& b : mesh.faces.at(patch.face_b)) normal_b[b.node] = b.normal;
  for (const auto& a : mesh.faces.at(patch.face_a)) {
    const auto& pair = *std::find_if(patch.pairs.begin(), patch.pairs.end(),
                                     [&](const PatchPair& p) { return p.node_a == a.node; });
    const Vec3 nb = rotated_about_z(normal_b.at(pair.node_b), angle);
    if (dot(nb, a.normal) > -std::cos(25.0 * std::numbers::pi / 180.0))
      ctx.fail(node, path,
               "the faces' outward normals at nodes " + std::to_string(pair.node_a) + " and " +
                   std::to_string(pair.node_b) +
                   " are not opposite (more than 25 degrees off): "
                   "check the faces and their sectors");
  }
}

}  // namespace

bool is_force_valued_unit(const char* unit) {
  if (!unit || unit[0] != 'N') return false;
  const char next = unit[1];
  return next == '\0' || next == '/' || next == ' ' || next == '*' || next == '.';
}

ContactPatch read_contact_patch(const YAML::Node& entry, const std::string& path,
                                const YamlContext& ctx, const FeMesh& mesh, int sectors) {
  const YAML::Node pn = entry["patch"];
  const std::string patch_path = path + ".patch";
  if (!pn.IsMap()) ctx.fail(pn, patch_path, "expected a map {faces: [A, B], tolerance, ...}");
  const auto values = validate_params(pn, contact_patch_schema(), patch_path, ctx,
                                      std::vector<std::string>{"faces"});
  const sdk::Params v(contact_patch_schema().data(), contact_patch_schema().size(), values.data());
  const auto sides = read_sides(pn["faces"], patch_path + ".faces", ctx, mesh, sectors);
  ContactPatch patch;
  patch.face_a = sides[0].face;
  patch.face_b = sides[1].face;
  patch.sector_a = sides[0].sector;
  patch.sector_b = sides[1].sector;
  patch.tolerance = v.real("tolerance");
  patch.per_area = v.text("values") == "per_area";
  const auto& face_a = mesh.faces.at(patch.face_a);
  patch.area_a = total_area(face_a);
  const bool ground = patch.face_b.empty();
  const double angle =
      sectors > 1 ? (patch.sector_b - patch.sector_a) * 2.0 * std::numbers::pi / sectors : 0.0;
  // Path params come resolved against the scene's folder.
  auto file_of = [&](const char* key) { return fs::path(v.text(key)); };
  std::vector<Pairing> pairing;
  if (!ground) {
    const auto& face_b = mesh.faces.at(patch.face_b);
    patch.area_b = total_area(face_b);
    pairing = v.text("pairs_file").empty()
                  ? pair_by_position(face_a, face_b, mesh, angle, patch, pn["faces"],
                                     patch_path + ".faces", ctx)
                  : pair_from_file(file_of("pairs_file"), face_a, face_b, mesh, angle,
                                   patch.tolerance, patch_path + ".pairs_file");
  }
  const YAML::Node frame = entry["frame"];
  const std::optional<Vec3> hint = read_tangent_hint(frame, path, ctx);
  for (std::size_t i = 0; i < face_a.size(); ++i) {
    PatchPair pair;
    pair.node_a = face_a[i].node;
    pair.area = face_a[i].area;
    pair.share = patch.per_area ? pair.area : pair.area / patch.area_a;
    const MeshNode& node_a = *mesh.find(pair.node_a);
    if (!ground) {
      pair.node_b = pairing[i].node_b;
      pair.in_plane_distance = pairing[i].in_plane;
      pair.normal_distance = pairing[i].normal;
      check_shared_frame(node_a, *mesh.find(pair.node_b), angle, pn["faces"], patch_path + ".faces",
                         ctx);
    }
    set_frame(pair, face_a[i].normal, hint, node_a, frame, path, ctx);
    patch.pairs.push_back(std::move(pair));
  }
  set_face_coordinates(patch, mesh);
  check_facing(patch, mesh, angle, pn["faces"], patch_path + ".faces", ctx);
  check_normal_distances(patch, v.boolean("gaps_from_coordinates"), pn["faces"],
                         patch_path + ".faces", ctx);
  if (!v.text("gap_file").empty())
    set_from_node_file(patch, file_of("gap_file"), "gap", patch_path + ".gap_file");
  if (!v.text("normal_load_file").empty())
    set_from_node_file(patch, file_of("normal_load_file"), "normal_load",
                       patch_path + ".normal_load_file");
  return patch;
}

}  // namespace frichb::core
