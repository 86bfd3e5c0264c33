// Contact patches: one scene entry that pairs the nodes of two meshed faces (or of one face
// and the ground) and becomes one contact per node pair (docs/scene-reference.md, `patch`).
//
//   contacts:
//     - name: shroud
//       law: coupled_3d
//       patch:
//         faces: [{face: shroud_right, sector: 0}, {face: shroud_left, sector: 1}]
//         tolerance: 1.0e-6          # m
//       frame: {tangent1: [0, 0, 1]}  # optional, global; projected onto each pair's face plane
//       params: {kt: 2.0e5, kn: 1.0e5, mu: 0.5, normal_load: 5.0}   # totals over the face
//
// Pairing: each node of face A is paired with the node of face B nearest to it in A's face
// plane, B's positions rotated first by the sectors between the sides (sector s + 1 is
// sector s turned by +2 pi / sectors about z); the in-plane distance must be within
// `tolerance` and the pairing one-to-one over both faces, else the entry is refused naming
// the node and the distance it missed by. Or the pairs come from `pairs_file`. The normal
// distance of a pair must be within the tolerance too, unless it becomes the pair's gap
// (`gaps_from_coordinates`).
//
// Each pair's frame: normal = minus face A's outward normal at its node (u_n > 0 closes the
// contact), tangent1 the projection of frame.tangent1 (default: the first of z, x, y that is
// not within 25 degrees of the normal), tangent2 = normal x tangent1; all expressed in node A's
// nodal frame (mesh.hpp), which both sides share: nodes across sectors must be in cylindrical
// frames, nodes of one sector coincide within the tolerance.
//
// Each pair's share of the law's force-valued parameters (unit N, N/m, N/m^1.5, ...): its
// node A's tributary area over face A's total (`values: total`), or its area in m^2
// (`values: per_area`, the params then per unit area). A normal-load file (`node,normal_load`,
// N, compressive) and a gap file (`node,gap`, m) set those parameters pair by pair, keyed by
// face A's node numbers; every node of face A must be listed once.
//
// Failure: read_contact_patch throws SceneError at the entry's keys (or the file and line of
// a pair, load or gap file).
#pragma once

#include <yaml-cpp/yaml.h>

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "frichb/core/plugin_host/schema.hpp"
#include "frichb/core/scene/fe_mesh.hpp"

namespace frichb::core {

struct PatchPair {
  std::int64_t node_a = 0;
  std::int64_t node_b = 0;                            // 0: the ground
  double area = 0;                                    // m^2, node A's tributary area
  double share = 0;                                   // factor on the law's force-valued parameters
  double in_plane_distance = 0, normal_distance = 0;  // m, B (rotated) from A
  // Per-pair parameters set by a file or the coordinates (N, m).
  std::map<std::string, double> overrides;
  // The frame in node A's nodal components, and its tangents in global components.
  std::array<double, 3> tangent1{}, tangent2{}, normal{};
  std::array<double, 3> tangent1_global{}, tangent2_global{};
  // Node A's position on the face (m): from face A's area-weighted centroid along the
  // tangents, for plots of the face.
  std::array<double, 2> face_coordinates{};
};

struct ContactPatch {
  std::string face_a, face_b;  // face_b empty: the ground
  int sector_a = 0, sector_b = 0;
  double tolerance = 0;  // m
  bool per_area = false;
  double area_a = 0, area_b = 0;  // m^2, the faces' total tributary areas
  std::vector<PatchPair> pairs;
};

// Reads the `patch` and `frame` keys of contact entry `entry` (key path `path`) against the
// scene's model map. `sectors` is the scene's sector count (1: no cyclic symmetry).
ContactPatch read_contact_patch(const YAML::Node& entry, const std::string& path,
                                const YamlContext& ctx, const FeMesh& mesh, int sectors);

// The schemas of a contact entry's `patch` map and of one of its `faces`.
const std::vector<frichb_param_spec>& contact_patch_schema();
const std::vector<frichb_param_spec>& contact_patch_side_schema();

// True for a parameter unit that a patch distributes over its pairs: a force, or a force per
// displacement power or per velocity ("N", "N/m", "N/m^1.5", "N s/m").
bool is_force_valued_unit(const char* unit);

}  // namespace frichb::core
