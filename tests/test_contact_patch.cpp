// Contact patches and the model map (structure.mesh). Oracles: a patch over a rigid pad is
// the same mechanical system as one contact with the totals (same peak to round-off); pairing
// across the cyclic boundary against the geometry it is built from (positions rotated by the
// sector angle, frames in the nodes' cylindrical components); the files' errors located at
// their lines.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "frichb/core/commands/run.hpp"
#include "frichb/core/numerics/harmonics.hpp"
#include "frichb/core/plugin_host/periodic_trace.hpp"
#include "frichb/core/plugin_host/registry.hpp"
#include "frichb/core/scene/contact_patch.hpp"
#include "frichb/core/scene/fe_mesh.hpp"
#include "frichb/core/scene/scene.hpp"
#include "test_support.hpp"

namespace {

namespace fs = std::filesystem;
using namespace frichb::core;

const Registry& registry() {
  static const Registry r(Registry::default_search_path({FRICHB_PLUGIN_DIR}));
  return r;
}

// Expects `f` to throw a SceneError whose text holds every string of `parts`.
template <class F>
void expect_scene_error(F f, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "expected a SceneError";
  } catch (const SceneError& e) {
    const std::string what = e.what();
    for (const auto& p : parts) EXPECT_NE(what.find(p), std::string::npos) << what;
  }
}

// ---- A patch over a rigid pad against one contact with the totals ----

// A rigid block with x, y, z DOFs (rows 0, 1, 2) on springs to ground.
constexpr const char* kBlock = R"(
  provider: lumped
  params:
    masses: [0.1, 0.1, 0.1]
    springs:
      - {between: [ground, 0], k: 4.0e5}
      - {between: [ground, 1], k: 5.0e5}
      - {between: [ground, 2], k: 6.0e5}
    modal_damping: [0.005]
)";

constexpr const char* kSweep = R"(
harmonic_balance: {max_harmonic: 5, samples_per_period: 64}
continuation:
  frequency: {from: 250, to: 450, unit: Hz}
  step: {initial: 1.0, min: 1.0e-5, max: 2.0}
)";

// The pad: four FE nodes on the block's rows, tributary areas 1 to 4 mm^2 (mm-t-s map).
void write_pad_mesh(const frichb::test::TempDir& dir) {
  dir.write("mesh.yaml", "format: 1\nunits: mm-t-s\nnodes: nodes.csv\nfaces: faces.csv\n");
  dir.write("nodes.csv",
            "node,x,y,z,frame,dof_1,dof_2,dof_3\n"
            "11,0,0,0,global,0,1,2\n12,1,0,0,global,0,1,2\n"
            "13,0,1,0,global,0,1,2\n14,1,1,0,global,0,1,2\n");
  dir.write("faces.csv",
            "face,node,area,nx,ny,nz\n"
            "pad,11,1,0,0,1\npad,12,2,0,0,1\npad,13,3,0,0,1\npad,14,4,0,0,1\n");
}

Scene bound(const fs::path& file) {
  Scene scene = load_scene(file);
  bind_plugins(scene, registry());
  return scene;
}

NodePeak peak_of(const Scene& scene) {
  const PreparedRun run = prepare_run(scene, 1);
  const auto& options = run.setup.options;
  const Eigen::VectorXd start = find_start_point(*run.model, options);
  const ContinuationSummary summary = trace_response(scene, *run.model, options, start);
  EXPECT_TRUE(summary.reached_end()) << summary.message;
  const ResponseTable table = tabulate_response(scene, *run.model, options, summary);
  EXPECT_EQ(table.peaks.size(), 1u);
  EXPECT_TRUE(!table.peaks.empty() && table.peaks[0].has_value());
  return *table.peaks[0];
}

// Every pair of a rigid pad moves alike: pair i carries share_i of kt and of the normal load,
// so its slider follows the single contact's and its force is share_i times the single force.
// The sum is the single contact's force: the same response, to round-off.
TEST(ContactPatch, RigidPadGivesTheSingleContactsResponse) {
  frichb::test::TempDir dir;
  write_pad_mesh(dir);
  const fs::path patch_file = dir.write("patch.yaml", std::string("structure:") + kBlock +
                                                          R"(  mesh: mesh.yaml
excitation:
  - {dof: "11", amplitude: 2.0, direction: [1.0, 0.0, 0.0]}
contacts:
  - name: pad
    law: jenkins_1d
    patch: {faces: [pad, ground]}
    params: {kt: 2.0e5, mu: 0.5, normal_load: 5.0}
output: {response: ["11"], plots: false}
)" + kSweep);
  const fs::path single_file = dir.write("single.yaml", std::string("structure:") + kBlock +
                                                            R"(  dofs: {block: [0, 1, 2]}
excitation:
  - {dof: block, amplitude: 2.0, direction: [1.0, 0.0, 0.0]}
contacts:
  - name: pad
    law: jenkins_1d
    between: [block, ground]
    frame: {tangent1: [1.0, 0.0, 0.0]}
    params: {kt: 2.0e5, mu: 0.5, normal_load: 5.0}
output: {response: [block], plots: false}
)" + kSweep);
  const Scene patch = bound(patch_file);
  ASSERT_EQ(patch.contacts.size(), 4u);
  // Shares 0.1 .. 0.4 of the totals; the default tangent is x (z is the normal).
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_NEAR(patch.contacts[i].param_scale, 0.1 * static_cast<double>(i + 1), 1e-15);
    EXPECT_EQ(patch.contacts[i].name, "pad." + std::to_string(11 + i));
    EXPECT_NEAR(patch.contacts[i].tangent1[0], 1.0, 1e-15);
    EXPECT_NEAR(patch.contacts[i].normal[2], -1.0, 1e-15);
  }
  // mm^2 on reading: 10 mm^2 in all.
  EXPECT_NEAR(patch.contacts[0].patch->area_a, 1e-5, 1e-20);
  // The same peak. The sample-only law's curve has a corner wherever a sample switches between
  // stick and slip, and its peak is one of them: the two traces' different points lead the
  // peak solve to neighbouring corners (measured 8.0e-9 apart in amplitude and 1.2e-8 in
  // frequency; docs/theory.md "The peak").
  const NodePeak a = peak_of(patch);
  const NodePeak b = peak_of(bound(single_file));
  EXPECT_NEAR(a.amplitude_m / b.amplitude_m, 1.0, 2e-8);
  EXPECT_NEAR(a.omega_rad_s / b.omega_rad_s, 1.0, 3e-8);
  // The summary records the patch once, with its params as written and its pairs.
  const auto j = scene_to_json(patch);
  ASSERT_EQ(j["contacts"].size(), 1u);
  EXPECT_EQ(j["contacts"][0]["params"]["kt"], 2.0e5);
  EXPECT_EQ(j["contacts"][0]["patch"]["pair_count"], 4);
}

// ---- Forces along global directions on nodes of the model map ----

// Node 21 at theta = 60 deg in its cylindrical frame (r, theta, z), node 22 in the global frame,
// both on the block's rows.
fs::path axis_scene(const frichb::test::TempDir& dir, const std::string& excitation,
                    const std::string& dofs = "") {
  dir.write("mesh.yaml", "format: 1\nunits: SI\nnodes: nodes.csv\n");
  dir.write("nodes.csv",
            "node,x,y,z,frame,dof_1,dof_2,dof_3\n"
            "21,0.5,0.8660254037844386,0,cylindrical,0,1,2\n22,0,0,0,global,0,1,2\n");
  return dir.write("axis.yaml", std::string("structure:") + kBlock + dofs + "  mesh: mesh.yaml\n" +
                                    "excitation:\n" + excitation +
                                    "output: {response: [\"21\"], plots: false}\n" + kSweep);
}

TEST(Excitation, GlobalAxesTurnIntoTheNodalFrame) {
  frichb::test::TempDir dir;
  const Scene scene =
      bound(axis_scene(dir,
                       "  - {dof: \"21\", amplitude: 1, axis: uy}\n"
                       "  - {dof: \"21\", amplitude: 1, axis: ur}\n"
                       "  - {dof: \"21\", amplitude: 1, axis: ut}\n"
                       "  - {dof: \"21\", amplitude: 1, global_direction: [1, 0, 1]}\n"
                       "  - {dof: \"22\", amplitude: 1, axis: uy}\n"));
  ASSERT_EQ(scene.excitation.size(), 5u);
  // At theta = 60 deg: e_r = (cos, sin, 0), e_theta = (-sin, cos, 0). Global y has the
  // components (sin 60, cos 60, 0); x + z has (cos 60, -sin 60, 1) / sqrt 2.
  const double c = 0.5, s = std::sqrt(3.0) / 2, h = 1 / std::sqrt(2.0);
  const std::vector<std::vector<double>> expected = {
      {s, c, 0}, {1, 0, 0}, {0, 1, 0}, {c * h, -s * h, h}, {0, 1, 0}};
  for (std::size_t i = 0; i < expected.size(); ++i)
    for (std::size_t k = 0; k < 3; ++k)
      EXPECT_NEAR(scene.excitation[i].direction[k], expected[i][k], 1e-15) << i << "," << k;
}

TEST(Excitation, GlobalAxesNeedANodeOfTheModelMap) {
  frichb::test::TempDir dir;
  expect_scene_error(
      [&] {
        bound(axis_scene(dir,
                         "  - {dof: \"21\", amplitude: 1, axis: uy, "
                         "direction: [0, 1, 0]}\n"));
      },
      {"excitation[0].axis", "give one of direction"});
  expect_scene_error(
      [&] {
        bound(axis_scene(dir,
                         "  - {dof: \"21\", amplitude: 1, axis: uy, "
                         "global_direction: [0, 1, 0]}\n"));
      },
      {"excitation[0].axis", "give one of direction"});
  // A node named by structure.dofs has no coordinates: no global direction.
  expect_scene_error(
      [&] {
        bound(axis_scene(dir, "  - {dof: block, amplitude: 1, axis: ux}\n",
                         "  dofs: {block: [0, 1, 2]}\n"));
      },
      {"excitation[0].axis", "'block' is not a node of the model map"});
  expect_scene_error([&] { bound(axis_scene(dir, "  - {dof: \"22\", amplitude: 1, axis: ur}\n")); },
                     {"excitation[0].axis", "FE node 22 lies on the z axis"});
  expect_scene_error([&] { bound(axis_scene(dir, "  - {dof: \"21\", amplitude: 1, axis: uq}\n")); },
                     {"excitation[0].axis", "'uq' is not one of"});
  expect_scene_error(
      [&] {
        bound(axis_scene(dir, "  - {dof: \"21\", amplitude: 1, global_direction: [0, 0]}\n"));
      },
      {"excitation[0].global_direction", "three components"});
}

// ---- Pairing across the cyclic boundary ----

constexpr int kSectors = 8;
const double kPhi = 2 * std::numbers::pi / kSectors;

struct FaceGeometry {
  // Nodes of the shroud's side faces: right at theta = +phi/2 (nodes 1..4), left at -phi/2
  // (nodes 101..104, each the -phi rotation of its right partner), radii 1.0/1.1, z = +-0.1.
  std::vector<std::string> node_rows, face_rows;
  double left_z_shift = 0, left_theta_shift = 0;  // moves node 101
  bool extra_left_node = false;
};

std::string mesh_text(const FaceGeometry& g, frichb::test::TempDir& dir) {
  std::ostringstream nodes, faces;
  nodes.precision(17);
  faces.precision(17);
  nodes << "node,x,y,z,frame,dof_1,dof_2,dof_3\n";
  faces << "face,node,area,nx,ny,nz\n";
  int row = 0;
  const double areas[] = {1e-4, 2e-4, 3e-4, 4e-4};
  auto add = [&](int number, double r, double theta, double z, const char* face, double area,
                 double outward) {
    nodes << number << ',' << r * std::cos(theta) << ',' << r * std::sin(theta) << ',' << z
          << ",cylindrical," << row << ',' << row + 1 << ',' << row + 2 << '\n';
    row += 3;
    faces << face << ',' << number << ',' << area << ',' << -outward * std::sin(theta) << ','
          << outward * std::cos(theta) << ",0\n";
  };
  int k = 0;
  for (double r : {1.0, 1.1})
    for (double z : {-0.1, 0.1}) {
      add(1 + k, r, kPhi / 2, z, "right", areas[k], +1.0);
      const bool moved = k == 0;
      add(101 + k, r, -kPhi / 2 + (moved ? g.left_theta_shift : 0.0),
          z + (moved ? g.left_z_shift : 0.0), "left", areas[k], -1.0);
      ++k;
    }
  if (g.extra_left_node) add(199, 1.05, -kPhi / 2, 0.0, "left", 1e-4, -1.0);
  dir.write("nodes.csv", nodes.str());
  dir.write("faces.csv", faces.str());
  return dir.write("mesh.yaml", "format: 1\nunits: SI\nnodes: nodes.csv\nfaces: faces.csv\n")
      .string();
}

ContactPatch pair_faces(const FaceGeometry& g, const std::string& patch_yaml) {
  frichb::test::TempDir dir;
  const FeMesh mesh = load_fe_mesh(mesh_text(g, dir));
  const YAML::Node entry = YAML::Load(patch_yaml);
  return read_contact_patch(entry, "contacts[0]", YamlContext{"scene.yaml"}, mesh, kSectors);
}

constexpr const char* kAcross =
    "{patch: {faces: [{face: right, sector: 0}, {face: left, sector: 1}]}}";

TEST(ContactPatch, PairsAcrossTheCyclicBoundaryInCylindricalFrames) {
  const ContactPatch patch = pair_faces(FaceGeometry{}, kAcross);
  ASSERT_EQ(patch.pairs.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) {
    const PatchPair& p = patch.pairs[k];
    EXPECT_EQ(p.node_a, static_cast<std::int64_t>(1 + k));
    EXPECT_EQ(p.node_b, static_cast<std::int64_t>(101 + k));
    EXPECT_LT(p.in_plane_distance, 1e-14);
    EXPECT_LT(std::abs(p.normal_distance), 1e-14);
    EXPECT_NEAR(p.share, (1.0 + static_cast<double>(k)) / 10.0, 1e-15);
    // The contact normal is -theta (u_n > 0 closes), tangent1 the axis z, tangent2 = n x t1 =
    // -r: in the node's cylindrical components (r, theta, z).
    const std::array<double, 3> n{0, -1, 0}, t1{0, 0, 1}, t2{-1, 0, 0};
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(p.normal[c], n[c], 1e-15);
      EXPECT_NEAR(p.tangent1[c], t1[c], 1e-15);
      EXPECT_NEAR(p.tangent2[c], t2[c], 1e-15);
    }
  }
  EXPECT_NEAR(patch.area_a, 1e-3, 1e-18);
  EXPECT_NEAR(patch.area_b, 1e-3, 1e-18);
}

TEST(ContactPatch, RefusesANodeWithoutPartnerNamingTheDistance) {
  FaceGeometry g;
  g.left_z_shift = 1e-3;
  expect_scene_error([&] { pair_faces(g, kAcross); },
                     {"contacts[0].patch.faces", "node 1 of face 'right'",
                      "the nearest, node 101, is 0.001 m away"});
  FaceGeometry extra;
  extra.extra_left_node = true;
  expect_scene_error([&] { pair_faces(extra, kAcross); },
                     {"node 199 of face 'left' pairs with no node"});
  // Without the rotation (both sides in sector 0) nothing pairs.
  expect_scene_error([&] { pair_faces(FaceGeometry{}, "{patch: {faces: [right, left]}}"); },
                     {"has no partner"});
}

// A pairs file pairing nodes that cannot touch (farther apart in the face plane than the
// faces' mesh spacing, here 0.1 m) was accepted and gave contacts between distant nodes.
TEST(ContactPatch, PairsFileRefusesNodesThatCannotTouch) {
  frichb::test::TempDir dir;
  const auto patch_with = [&](const std::string& rows) {
    const auto pairs = dir.write("pairs.csv", "node_a,node_b\n" + rows);
    return "{patch: {faces: [{face: right, sector: 0}, {face: left, sector: 1}], pairs_file: '" +
           pairs.string() + "'}}";
  };
  const ContactPatch patch = pair_faces(FaceGeometry{}, patch_with("1,101\n2,102\n3,103\n4,104\n"));
  ASSERT_EQ(patch.pairs.size(), 4u);
  EXPECT_EQ(patch.pairs[3].node_b, 104);
  // Node 1 (r = 1.0, z = -0.1) with node 104 (r = 1.1, z = 0.1): 0.224 m in the face plane.
  expect_scene_error(
      [&] { pair_faces(FaceGeometry{}, patch_with("1,104\n2,102\n3,103\n4,101\n")); },
      {"contacts[0].patch.pairs_file", "node 1 pairs with node 104, 0.224 m away in the face plane",
       "mesh spacing (0.1 m)"});
}

TEST(ContactPatch, NormalDistanceIsRefusedOrBecomesTheGap) {
  // Node 101 moved by 2e-4 m into sector 1 (away from the right face): a gap of 2e-4 m.
  FaceGeometry g;
  g.left_theta_shift = 2e-4 / 1.0;  // radius 1.0: arc 2e-4 m, in-plane drift 2e-8 m
  expect_scene_error(
      [&] { pair_faces(g, kAcross); },
      {"nodes 1 and 101 are 0.0002 m apart along the normal", "gaps_from_coordinates"});
  const ContactPatch patch =
      pair_faces(g,
                 "{patch: {faces: [{face: right, sector: 0}, {face: left, sector: 1}], "
                 "gaps_from_coordinates: true}}");
  EXPECT_NEAR(patch.pairs[0].overrides.at("gap"), 2e-4, 1e-11);
  EXPECT_NEAR(patch.pairs[1].overrides.at("gap"), 0.0, 1e-15);
}

// ---- Where a contact sticks ----

// Jenkins element (kt = 2e5 N/m, mu N = 2.5 N) under u = d cos(theta): after each reversal it
// sticks until u has come back 2 mu N / kt, i.e. for theta_s = arccos(1 - 2 mu N / (kt d)) of
// each half period: stuck theta_s / pi of the period. Sampled, each of the two stick-slip
// transitions is located to one sample.
TEST(SlipShares, JenkinsStickShareMeetsTheClosedForm) {
  constexpr double kKt = 2e5, kSlipForce = 2.5;
  constexpr int kSamples = 512;
  auto h = frichb::test::make_law("jenkins_1d", "{kt: 2.0e5, mu: 0.5, normal_load: 5.0}");
  const HarmonicLayout layout({0, 1}, kSamples);
  PeriodicTracer tracer(*h.law, layout);
  for (double ratio : {0.5, 1.5, 3.0, 10.0}) {
    const double d = ratio * kSlipForce / kKt;
    Eigen::VectorXd u = Eigen::VectorXd::Zero(layout.coefficient_count());
    u(layout.cos_index(1)) = d;
    ContactTrace trace;
    std::string error;
    ASSERT_TRUE(tracer.trace(u, JacobianMode::kNone, trace, &error)) << error;
    const SlipShares shares = slip_shares(trace, tracer.components());
    const double stuck =
        ratio <= 1 ? 1.0 : std::acos(1 - 2 * kSlipForce / (kKt * d)) / std::numbers::pi;
    EXPECT_NEAR(shares.stuck, stuck, 2.0 / kSamples) << "d = " << ratio << " mu N / kt";
    EXPECT_NEAR(shares.slipping, 1 - stuck, 2.0 / kSamples);
    EXPECT_EQ(shares.open, 0.0);
  }
}

// With a normal load N = max(0, N0 + kn u_n) and u_n = e cos(theta), e > N0 / kn, the contact is
// open where cos(theta) < -N0 / (kn e): a share 1 - arccos(-N0 / (kn e)) / pi of the period.
TEST(SlipShares, OpenShareMeetsTheClosedForm) {
  constexpr double kN0 = 5.0, kKn = 1e5, kE = 2e-4;
  constexpr int kSamples = 512;
  auto h =
      frichb::test::make_law("jenkins_1d", "{kt: 2.0e5, kn: 1.0e5, mu: 0.5, normal_load: 5.0}");
  const HarmonicLayout layout({0, 1}, kSamples);
  PeriodicTracer tracer(*h.law, layout);
  ASSERT_EQ(tracer.components().size(), 2u);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(2 * layout.coefficient_count());
  u(layout.coefficient_count() + layout.cos_index(1)) = kE;
  ContactTrace trace;
  std::string error;
  ASSERT_TRUE(tracer.trace(u, JacobianMode::kNone, trace, &error)) << error;
  const SlipShares shares = slip_shares(trace, tracer.components());
  const double open = 1 - std::acos(-kN0 / (kKn * kE)) / std::numbers::pi;
  EXPECT_NEAR(shares.open, open, 2.0 / kSamples);
  // No tangential motion: closed, the slider stays put.
  EXPECT_NEAR(shares.stuck, 1 - open, 2.0 / kSamples);
  EXPECT_EQ(shares.slipping, 0.0);
}

// ---- The model map's files ----

TEST(FeMesh, ConvertsUnitsAndRotatesGlobalVectorsIntoCylindricalFrames) {
  frichb::test::TempDir dir;
  write_pad_mesh(dir);
  const FeMesh mesh = load_fe_mesh(dir.path() / "mesh.yaml");
  ASSERT_EQ(mesh.nodes.size(), 4u);
  EXPECT_NEAR(mesh.find(12)->position[0], 1e-3, 1e-18);
  EXPECT_NEAR(mesh.faces.at("pad")[3].area, 4e-6, 1e-21);
  MeshNode at_60_degrees;
  at_60_degrees.frame = NodalFrame::kCylindrical;
  at_60_degrees.position = {0.5, std::sqrt(3.0) / 2, 0};
  // Global y at theta = 60 deg: r component sin 60, theta component cos 60.
  const auto v = FeMesh::to_nodal(at_60_degrees, {0, 1, 0});
  EXPECT_NEAR(v[0], std::sqrt(3.0) / 2, 1e-15);
  EXPECT_NEAR(v[1], 0.5, 1e-15);
}

TEST(FeMesh, LocatesBadRowsAtTheirLine) {
  frichb::test::TempDir dir;
  dir.write("mesh.yaml", "format: 1\nunits: SI\nnodes: nodes.csv\nfaces: faces.csv\n");
  dir.write("nodes.csv",
            "node,x,y,z,frame,dof_1,dof_2,dof_3\n1,0,0,0,global,0,1,2\n"
            "1,0,0,0,global,3,4,5\n");
  dir.write("faces.csv", "face,node,area,nx,ny,nz\n");
  expect_scene_error([&] { load_fe_mesh(dir.path() / "mesh.yaml"); },
                     {"nodes.csv:3", "node 1 is listed twice (first on line 2)"});
  dir.write("nodes.csv", "node,x,y,z,frame,dof_1,dof_2,dof_3\n1,0,0,0,polar,0,1,2\n");
  expect_scene_error([&] { load_fe_mesh(dir.path() / "mesh.yaml"); },
                     {"nodes.csv:2", "frame 'polar'"});
  dir.write("nodes.csv", "node,x,y,z,frame,dof_1,dof_2,dof_3\n1,0,0,0,global,0,1,2\n");
  dir.write("faces.csv", "face,node,area,nx,ny,nz\n# a comment\npad,7,1,0,0,1\n");
  expect_scene_error([&] { load_fe_mesh(dir.path() / "mesh.yaml"); },
                     {"faces.csv:3", "node 7 is not in nodes.csv"});
  dir.write("faces.csv", "face,node,area,nx,ny,nz\npad,1,1,0,0,2\n");
  expect_scene_error([&] { load_fe_mesh(dir.path() / "mesh.yaml"); },
                     {"faces.csv:2", "not a unit vector"});
  dir.write("faces.csv", "face,node,area\n");
  expect_scene_error([&] { load_fe_mesh(dir.path() / "mesh.yaml"); },
                     {"faces.csv:1", "expected the header"});
}

}  // namespace
