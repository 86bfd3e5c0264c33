// frichb import's readers and conversions (fe_import/): small files written by hand after the
// vendors' format descriptions (docs/fe-models.md), against matrices known by construction and
// a rotation computed by hand.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>
#include <string>

#include "frichb/core/fe_import/sector_import.hpp"
#include "frichb/core/fe_import/vendor_files.hpp"

namespace {

namespace fs = std::filesystem;
using frichb::core::assemble_sector;
using frichb::core::ImportedSector;
using frichb::core::ImportError;
using frichb::core::ImportRequest;
using frichb::core::LowerTriangle;
using frichb::core::NodalFrame;
using frichb::core::UnitSystem;
using frichb::core::VendorFormat;

class FeImport : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("frichb_fe_import_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& text) const {
    fs::path file = dir_ / name;
    std::ofstream(file) << text;
    return file;
  }

  // The message of the ImportError `request` raises ("" when it does not raise).
  static std::string refusal(const ImportRequest& request) {
    try {
      assemble_sector(request);
    } catch (const ImportError& e) {
      return e.what();
    }
    return "";
  }

  fs::path dir_;
};

Eigen::MatrixXd dense(const LowerTriangle& m) {
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(m.size, m.size);
  for (const auto& e : m.entries) {
    EXPECT_GE(e.row, e.column);
    d(e.row, e.column) = e.value;
    d(e.column, e.row) = e.value;
  }
  return d;
}

// The two-node model of the hand-written files: node 3 at (1, 0, 0) with x, y, z; node 7 at
// (2, 0, 0) with x, y (z removed). Rows: 3x 3y 3z 7x 7y.
Eigen::MatrixXd model_stiffness() {
  Eigen::MatrixXd k = Eigen::MatrixXd::Zero(5, 5);
  k.diagonal() << 10, 20, 30, 8, 9;
  k(1, 0) = k(0, 1) = 1.5;
  k(3, 0) = k(0, 3) = -4;
  k(4, 1) = k(1, 4) = -5;
  return k;
}

Eigen::MatrixXd model_mass() {
  Eigen::VectorXd d(5);
  d << 2, 2, 2, 1, 1;
  return d.asDiagonal();
}

const char* kAbaqusStiffness =
    "3,1, 3,1, 10.\n"
    "3,2, 3,1, 1.5\n"
    "3,2, 3,2, 20.\n"
    "3,3, 3,3, 30.\n"
    "7,1, 3,1, -4.\n"
    "7,1, 7,1, 8.\n"
    "7,2, 3,2, -5.\n"
    "7,2, 7,2, 9.\n";
const char* kAbaqusMass =
    "** mass\n3,1, 3,1, 2.\n3,2, 3,2, 2.\n3,3, 3,3, 2.\n7,1, 7,1, 1.\n7,2, 7,2, 1.\n";
const char* kAbaqusNodes =
    "*HEADING\ntwo nodes\n*NODE, NSET=ALL\n3, 1.0, 0.0, 0.0\n** a comment\n7, 2., 0.\n"
    "*ELEMENT, TYPE=T3D2, ELSET=BAR\n1, 3, 7\n";
// Equations 1..5 = 3x 3y 3z 7x 7y, as the ANSYS .mapping file lists them.
const char* kAnsysMapping =
    "Matrix Eqn   Node   DOF\n"
    "       1       3    UX\n       2       3    UY\n       3       3    UZ\n"
    "       4       7    UX\n       5       7    UY\n";

void expect_two_node_model(const ImportedSector& s, double matrix_scale, double length_scale) {
  ASSERT_EQ(s.nodes.size(), 2U);
  EXPECT_EQ(s.nodes[0].number, 3);
  EXPECT_EQ(s.nodes[1].number, 7);
  EXPECT_EQ(s.nodes[0].rows, (std::array<long, 3>{0, 1, 2}));
  EXPECT_EQ(s.nodes[1].rows, (std::array<long, 3>{3, 4, -1}));
  EXPECT_DOUBLE_EQ(s.nodes[1].position[0], 2.0 * length_scale);
  EXPECT_EQ(dense(s.stiffness), model_stiffness() * matrix_scale);
  EXPECT_EQ(dense(s.mass), model_mass() * matrix_scale);
  EXPECT_TRUE(s.cyclic_pairs.empty());
}

ImportRequest two_node_request(VendorFormat format, const fs::path& k, const fs::path& m,
                               const fs::path& nodes) {
  ImportRequest r;
  r.format = format;
  r.stiffness_file = k;
  r.mass_file = m;
  r.coordinates_file = nodes;
  r.nodal_frame = NodalFrame::kCylindrical;  // taken as given: the matrices are compared as is
  r.sectors = 1;
  return r;
}

TEST_F(FeImport, AbaqusMatrixInputAssemblesTheLowerTriangleNodeByNode) {
  const auto r =
      two_node_request(VendorFormat::kAbaqusMatrixInput, write("job_STIF1.mtx", kAbaqusStiffness),
                       write("job_MASS1.mtx", kAbaqusMass), write("job.inp", kAbaqusNodes));
  expect_two_node_model(assemble_sector(r), 1.0, 1.0);
}

TEST_F(FeImport, MillimetreTonneSecondIsConvertedToSIOnReading) {
  auto r =
      two_node_request(VendorFormat::kAbaqusMatrixInput, write("job_STIF1.mtx", kAbaqusStiffness),
                       write("job_MASS1.mtx", kAbaqusMass), write("job.inp", kAbaqusNodes));
  r.units = UnitSystem::kMmTonneSecond;
  expect_two_node_model(assemble_sector(r), 1e3, 1e-3);
}

TEST_F(FeImport, AbaqusCoordinateFormatGoesThroughTheEquationMap) {
  auto r = two_node_request(
      VendorFormat::kAbaqusCoordinate,
      write("k.mtx", "1,1,10.\n2,1,1.5\n2,2,20.\n3,3,30.\n4,1,-4.\n4,4,8.\n5,2,-5.\n5,5,9.\n"),
      write("m.mtx", "1,1,2.\n2,2,2.\n3,3,2.\n4,4,1.\n5,5,1.\n"),
      write("nodes.csv", "node,x,y,z\n7,2,0,0\n3,1,0,0\n"));
  r.equation_map_file = write("map.txt", "1, 3, 1\n2, 3, 2\n3, 3, 3\n4, 7, 1\n5, 7, 2\n");
  expect_two_node_model(assemble_sector(r), 1.0, 1.0);
}

// RSA: the lower triangle by columns; fixed-width fields (6I8), (8I8), (4E20.12); with a
// right-hand side (RHSCRD = 2: the fifth header line, and values after the matrix).
const char* kHbStiffness =
    "FricHB two-node test                                                    KEY\n"
    "             6             1             1             2             2\n"
    "RSA                        5             5             8             0\n"
    "(6I8)           (8I8)           (4E20.12)           (4E20.12)           \n"
    "F                          1             0\n"
    "       1       4       6       7       8       9\n"
    "       1       2       4       2       5       3       4       5\n"
    "  0.100000000000E+02  0.150000000000E+01 -0.400000000000E+01  0.200000000000E+02\n"
    " -0.500000000000E+01  0.300000000000E+02  0.800000000000E+01  0.900000000000E+01\n"
    "  0.000000000000E+00  0.000000000000E+00  0.000000000000E+00  0.000000000000E+00\n"
    "  0.000000000000E+00\n";
const char* kHbMass =
    "FricHB two-node test mass                                               KEY\n"
    "             4             1             1             2             0\n"
    "RSA                        5             5             5             0\n"
    "(6I8)           (8I8)           (4D20.12)           \n"
    "       1       2       3       4       5       6\n"
    "       1       2       3       4       5\n"
    "  0.200000000000D+01  0.200000000000D+01  0.200000000000D+01  0.100000000000D+01\n"
    "  0.100000000000D+01\n";
// NWRITE: fields may touch ("...E+01-0.0...")
const char* kNwriteNodes =
    "        3 0.100000000000E+01 0.000000000000E+00 0.0\n"
    "        7 0.200000000000E+01-0.000000000000E+00 0.0 0.0 0.0 0.0\n";

TEST_F(FeImport, AnsysHarwellBoeingWithItsMappingFile) {
  auto r = two_node_request(VendorFormat::kAnsysHbmat, write("k.matrix", kHbStiffness),
                            write("m.matrix", kHbMass), write("sector.node", kNwriteNodes));
  r.equation_map_file = write("k.mapping", kAnsysMapping);
  expect_two_node_model(assemble_sector(r), 1.0, 1.0);
}

TEST_F(FeImport, AnsysMatrixMarketWithTheMappingFile) {
  auto r = two_node_request(
      VendorFormat::kAnsysMmf,
      write("k.mmf",
            "%%MatrixMarket matrix coordinate real general\n% both triangles\n5 5 11\n"
            "1 1 10\n2 1 1.5\n1 2 1.5\n2 2 20\n3 3 30\n4 1 -4\n1 4 -4\n4 4 8\n5 2 -5\n2 5 -5\n"
            "5 5 9\n"),
      write("m.mmf",
            "%%MatrixMarket matrix coordinate real symmetric\n5 5 5\n1 1 2\n2 2 2\n"
            "3 3 2\n4 4 1\n5 5 1\n"),
      write("nodes.csv", "node,x,y,z\n3,1,0,0\n7,2,0,0\n"));
  r.equation_map_file = write("k.mapping", kAnsysMapping);
  expect_two_node_model(assemble_sector(r), 1.0, 1.0);
}

// One node at 90 degrees (x = 0, y = 2): e_r = e_y, e_theta = -e_x. By hand, T^T K T of
// K = [[2, 1, 0], [1, 5, 0], [0, 0, 7]] with T = [[0, -1, 0], [1, 0, 0], [0, 0, 1]] is
// [[5, -1, 0], [-1, 2, 0], [0, 0, 7]].
TEST_F(FeImport, GlobalFramesAreTurnedIntoCylindricalOnesByHand) {
  auto r = two_node_request(VendorFormat::kAbaqusMatrixInput,
                            write("k.mtx", "5,1,5,1,2.\n5,2,5,1,1.\n5,2,5,2,5.\n5,3,5,3,7.\n"),
                            write("m.mtx", "5,1,5,1,1.\n5,2,5,2,1.\n5,3,5,3,1.\n"),
                            write("nodes.csv", "node,x,y,z\n5,0,2,0\n"));
  r.nodal_frame = NodalFrame::kGlobal;
  Eigen::Matrix3d expected;
  expected << 5, -1, 0, -1, 2, 0, 0, 0, 7;
  const auto s = assemble_sector(r);
  EXPECT_LT((dense(s.stiffness) - expected).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_LT((dense(s.mass) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-15);
}

// Two nodes at 30 and 130 degrees, a full symmetric 6 x 6 K: T^T K T with T assembled densely.
TEST_F(FeImport, GlobalFramesMatchADenseTransformation) {
  Eigen::MatrixXd k(6, 6);
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) k(i, j) = 1.0 + i + j + 0.25 * i * j + (i == j ? 40.0 : 0.0);
  std::ostringstream text;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j <= i; ++j)
      text << (i < 3 ? 1 : 2) << "," << i % 3 + 1 << "," << (j < 3 ? 1 : 2) << "," << j % 3 + 1
           << "," << k(i, j) << "\n";
  const double a1 = std::numbers::pi / 6;
  const double a2 = 130.0 * std::numbers::pi / 180;
  std::ostringstream nodes;
  nodes.precision(17);
  nodes << "node,x,y,z\n1," << 3 * std::cos(a1) << "," << 3 * std::sin(a1) << ",0.5\n2,"
        << 2 * std::cos(a2) << "," << 2 * std::sin(a2) << ",-1\n";
  auto r = two_node_request(VendorFormat::kAbaqusMatrixInput, write("k.mtx", text.str()),
                            write("m.mtx", text.str()), write("nodes.csv", nodes.str()));
  r.nodal_frame = NodalFrame::kGlobal;
  Eigen::MatrixXd t = Eigen::MatrixXd::Zero(6, 6);
  for (const auto& [at, angle] : {std::pair{0, a1}, std::pair{3, a2}}) {
    t.block<3, 3>(at, at) << std::cos(angle), -std::sin(angle), 0, std::sin(angle), std::cos(angle),
        0, 0, 0, 1;
  }
  const Eigen::MatrixXd expected = t.transpose() * k * t;
  const auto s = assemble_sector(r);
  EXPECT_LT((dense(s.stiffness) - expected).cwiseAbs().maxCoeff(), 1e-12 * k.maxCoeff());
}

// Eight sectors: node 2 is node 1 turned by +45 degrees; node 3 is inside the sector.
class CyclicPairing : public FeImport {
 protected:
  ImportRequest request(const std::string& extra_nodes, const std::string& extra_entries = "") {
    const double c = std::cos(std::numbers::pi / 4);
    std::ostringstream nodes;
    nodes.precision(17);
    nodes << "node,x,y,z\n1,1,0,0\n2," << c << "," << c << ",0\n3,1.4,0.5,0.1\n" << extra_nodes;
    std::string diagonal;
    for (const int node : {1, 2, 3})
      for (const int dof : {1, 2, 3})
        diagonal += std::to_string(node) + "," + std::to_string(dof) + "," + std::to_string(node) +
                    "," + std::to_string(dof) + ",1.0\n";
    auto r =
        two_node_request(VendorFormat::kAbaqusMatrixInput, write("k.mtx", diagonal + extra_entries),
                         write("m.mtx", diagonal + extra_entries), write("nodes.csv", nodes.str()));
    r.sectors = 8;
    r.nodal_frame = NodalFrame::kGlobal;
    return r;
  }
};

TEST_F(CyclicPairing, PairsEveryComponentOfTheNodeAtThePlusPhiImage) {
  const auto s = assemble_sector(request(""));
  EXPECT_EQ(s.boundary_node_pairs, 1U);
  const std::vector<std::pair<long, long>> expected = {{0, 3}, {1, 4}, {2, 5}};
  EXPECT_EQ(s.cyclic_pairs, expected);
  EXPECT_DOUBLE_EQ(s.tolerance, 1.4e-6);
}

TEST_F(CyclicPairing, RefusesTwoNodesAtOneImage) {
  const double c = std::cos(std::numbers::pi / 4);
  const auto message = refusal(request("4," + std::to_string(c) + "," + std::to_string(c) + ",0\n",
                                       "4,1,4,1,1.0\n4,2,4,2,1.0\n4,3,4,3,1.0\n"));
  EXPECT_NE(message.find("node 2 and node 4 both lie within"), std::string::npos) << message;
}

TEST_F(CyclicPairing, RefusesAComponentOnOneSideOnly) {
  auto r = request("");
  const double c = std::cos(std::numbers::pi / 4);
  std::ostringstream nodes;
  nodes.precision(17);
  nodes << "node,x,y,z\n1,1,0,0\n2," << c << "," << c << ",0\n";
  r.coordinates_file = write("nodes.csv", nodes.str());
  r.stiffness_file = write("k.mtx", "1,1,1,1,1.\n1,2,1,2,1.\n1,3,1,3,1.\n2,1,2,1,1.\n2,2,2,2,1.\n");
  r.mass_file = r.stiffness_file;
  const auto message = refusal(r);
  EXPECT_NE(message.find("component 3 of node 2 is not in the matrices but that of its cyclic "
                         "partner node 1 is"),
            std::string::npos)
      << message;
}

TEST_F(CyclicPairing, LeavesTheNotCyclicNodesOutAndRefusesTwoSectors) {
  auto r = request("");
  r.not_cyclic_file = write("shroud.txt", "# contact nodes\n2 ** the image of node 1\n");
  const auto s = assemble_sector(r);
  EXPECT_TRUE(s.cyclic_pairs.empty());
  EXPECT_EQ(s.boundary_node_pairs, 0U);
  // A node the model does not have (another mesh's list, an off-by-one) is refused.
  r.not_cyclic_file = write("other.txt", "2, 7\n");
  EXPECT_EQ(refusal(r), r.not_cyclic_file.string() +
                            ": node 7 is not a node of the matrices: the list of nodes never "
                            "paired names nodes of this model (a list of another mesh or an "
                            "off-by-one would leave the real contact nodes paired)");
  r.not_cyclic_file = write("bad.txt", "2 x\n");
  EXPECT_EQ(refusal(r), r.not_cyclic_file.string() + ":1: 'x' is not a node number");
  r.not_cyclic_file.clear();
  r.sectors = 2;
  EXPECT_NE(refusal(r).find("--sectors 2"), std::string::npos);
}

// NWRITE leaves trailing zero fields blank: "node x" is (x, 0, 0); an Abaqus *NODE in another
// coordinate system is refused.
TEST_F(FeImport, NodeFilesReadBlankFieldsAsZeroAndRefuseOtherSystems) {
  const auto nwrite = write("sector.node", "        3 0.1E+01\n        7 0.2E+01 0.5E+00\n");
  const auto nodes = frichb::core::read_node_coordinates(nwrite);
  ASSERT_EQ(nodes.size(), 2U);
  EXPECT_EQ(nodes.at(3), (std::array<double, 3>{1.0, 0.0, 0.0}));
  EXPECT_EQ(nodes.at(7), (std::array<double, 3>{2.0, 0.5, 0.0}));
  const auto inp = write("c.inp", "*HEADING\nx\n*NODE, NSET=N, SYSTEM=C\n1, 1., 30., 0.\n");
  try {
    frichb::core::read_node_coordinates(inp);
    ADD_FAILURE() << "SYSTEM=C accepted";
  } catch (const ImportError& e) {
    EXPECT_EQ(std::string(e.what()),
              inp.string() +
                  ":3: *NODE with SYSTEM=C: only rectangular coordinates (SYSTEM=R, "
                  "the default) are read");
  }
}

// A write failure throws ImportWriteError and leaves no temporary file behind.
TEST_F(FeImport, AFailedWriteLeavesNoFiles) {
  auto r = two_node_request(VendorFormat::kAbaqusMatrixInput, write("k.mtx", kAbaqusStiffness),
                            write("m.mtx", kAbaqusMass), write("job.inp", kAbaqusNodes));
  const auto sector = assemble_sector(r);
  const fs::path out = dir_ / "out";
  fs::create_directories(out);
  // nodes.csv, the last file, goes to a folder that does not exist
  const auto path_of = [&](const std::string& name) {
    return name == "nodes.csv" ? dir_ / "missing" / name : out / name;
  };
  EXPECT_THROW(frichb::core::write_sector(sector, path_of), frichb::core::ImportWriteError);
  EXPECT_TRUE(fs::is_empty(out));
}

TEST_F(FeImport, ErrorsNameTheFileAndTheLine) {
  const auto nodes = write("nodes.csv", "node,x,y,z\n3,1,0,0\n7,2,0,0\n");
  const auto mass = write("m.mtx", kAbaqusMass);
  const auto with_stiffness = [&](const std::string& text) {
    return refusal(
        two_node_request(VendorFormat::kAbaqusMatrixInput, write("k.mtx", text), mass, nodes));
  };
  const std::string file = (dir_ / "k.mtx").string();
  EXPECT_EQ(with_stiffness("3,1,3,1,10.\n3,2,3,1\n"),
            file + ":2: expected 'node, dof, node, dof, value', found '3,2,3,1'");
  EXPECT_EQ(with_stiffness("3,1,3,1,10.\n3,5,3,5,1.\n"),
            file +
                ":2: node 3 DOF 5 is a rotation: FricHB's nodes carry the three "
                "translations only; export a solid-element model (or constrain the rotations "
                "out)");
  EXPECT_NE(
      with_stiffness("3,1,3,1,1.\n-2,1,3,1,1.\n").find(file + ":2: node -2 is an internal node"),
      std::string::npos);
  EXPECT_EQ(with_stiffness("3,1,3,1,1.\n3,1,3,1,1.\n"),
            file + ":2: entry node 3 DOF 1 / node 3 DOF 1 is listed twice (also line 1)");
  EXPECT_EQ(with_stiffness("3,1,3,1,1.\n3,2,3,1,1.\n3,1,3,2,2.\n"),
            file +
                ":3: entry node 3 DOF 1 / node 3 DOF 2 differs from its symmetric partner on "
                "line 2: the matrix is not symmetric");
  const auto both = write("both.mtx", "3,1,3,1,1.\n9,1,9,1,1.\n");
  EXPECT_EQ(refusal(two_node_request(VendorFormat::kAbaqusMatrixInput, both, both, nodes)),
            (dir_ / "nodes.csv").string() + ": node 9 of the matrices has no coordinates here");
}

TEST_F(FeImport, EquationMapAndHarwellBoeingErrorsNameTheirLines) {
  auto r = two_node_request(VendorFormat::kAnsysMmf,
                            write("k.mmf",
                                  "%%MatrixMarket matrix coordinate real symmetric\n"
                                  "6 6 1\n6 6 1.0\n"),
                            write("m.mmf",
                                  "%%MatrixMarket matrix coordinate real symmetric\n"
                                  "5 5 1\n1 1 1.0\n"),
                            write("nodes.csv", "node,x,y,z\n3,1,0,0\n7,2,0,0\n"));
  r.equation_map_file = write("k.mapping", kAnsysMapping);
  EXPECT_EQ(refusal(r), (dir_ / "k.mmf").string() + ":2: the matrix has 6 rows, the equation map " +
                            r.equation_map_file.string() +
                            " lists 5 equations: are they of the same export?");
  r.equation_map_file = write("bad.mapping", "Matrix Eqn Node DOF\n1 3 UX\n2 3 TEMP\n");
  EXPECT_EQ(refusal(r), r.equation_map_file.string() +
                            ":3: DOF 'TEMP' of node 3 is not a structural DOF (UX, UY, UZ, "
                            "ROTX, ROTY, ROTZ or a number 1-1000)");
  r.format = VendorFormat::kAnsysHbmat;
  r.equation_map_file = write("k.mapping", kAnsysMapping);
  r.stiffness_file = write("k.matrix",
                           "title\n 3 1 1 1 0\nRSA 5 5 1 0\n(6I8) (8I8) (4E20.12)\n"
                           "       1       2       2       2       2       x\n       1\n"
                           "  0.100000000000E+02\n");
  EXPECT_EQ(refusal(r), r.stiffness_file.string() +
                            ":5: '       x' in columns 41-48 is not one of the column pointers of "
                            "format (6I8)");
}

TEST_F(FeImport, WritesTheSharedModelMapAndTheMatrixMarketFiles) {
  auto r = two_node_request(VendorFormat::kAbaqusMatrixInput, write("k.mtx", kAbaqusStiffness),
                            write("m.mtx", kAbaqusMass), write("job.inp", kAbaqusNodes));
  const auto sector = assemble_sector(r);
  const fs::path out = dir_ / "out";
  fs::create_directories(out);
  frichb::core::write_sector(sector, [&](const std::string& name) { return out / name; });
  const auto read = [&](const char* name) {
    std::ifstream in(out / name);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_EQ(read("nodes.csv"),
            "node,x,y,z,frame,dof_1,dof_2,dof_3\n3,1,0,0,cylindrical,0,1,2\n"
            "7,2,0,0,cylindrical,3,4,-1\n");
  EXPECT_EQ(read("mesh.yaml"),
            "# FricHB model map (written by frichb import)\nformat: 1\nunits: SI\nnodes: "
            "nodes.csv\n");
  const std::string k = read("sector_stiffness.mtx");
  EXPECT_EQ(k.rfind("%%MatrixMarket matrix coordinate real symmetric\n", 0), 0U);
  EXPECT_NE(k.find("\n5 5 8\n1 1 10\n2 1 1.5\n2 2 20\n3 3 30\n4 1 -4\n4 4 8\n5 2 -5\n5 5 9\n"),
            std::string::npos)
      << k;
  EXPECT_EQ(std::distance(fs::directory_iterator(out), fs::directory_iterator()), 5);
}

// --- Files that cannot be read exactly are refused at their line -------------------------

// `text` with the first `from` replaced by `to` (which must be there).
std::string edited(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

class HbRefusals : public FeImport {
 protected:
  // The refusal of the two-node HB import with `stiffness` (and the shipped mass).
  std::string with_stiffness(const std::string& stiffness) {
    auto r = two_node_request(VendorFormat::kAnsysHbmat, write("k.matrix", stiffness),
                              write("m.matrix", kHbMass), write("sector.node", kNwriteNodes));
    r.equation_map_file = write("k.mapping", kAnsysMapping);
    return refusal(r);
  }
  std::string file() const { return (dir_ / "k.matrix").string(); }
};

// A width of 0 looped forever; a width beyond 2^64 threw std::out_of_range.
TEST_F(HbRefusals, FormatWidthsOfZeroOrAbsurdSizeAreRefusedAtTheFormatLine) {
  EXPECT_EQ(with_stiffness(edited(kHbStiffness, "(6I8)   ", "(6I0)   ")),
            file() +
                ":4: the pointer format '(6I0)' gives 6 fields of width 0 per line: both must "
                "be at least 1");
  EXPECT_EQ(with_stiffness(edited(kHbStiffness, "(6I8)", "(6I99999999999999999999)")),
            file() +
                ":4: the pointer format '(6I99999999999999999999)' has a count or width of "
                "more than six digits");
  EXPECT_EQ(with_stiffness(edited(kHbStiffness, "(8I8)", "(800I8)")),
            file() +
                ":4: the row index format '(800I8)' describes lines of 6400 characters, more "
                "than the 1000 this reader accepts");
  EXPECT_EQ(with_stiffness(edited(kHbStiffness, "(4E20.12)   ", "(4I20)      ")),
            file() +
                ":4: the value format '(4I20)' must be a real format (nEw.d, nDw.d, nFw.d or "
                "nGw.d)");
}

// (4E10.12) over 20-wide fields was read as K11 = 0.1, K22 = K33 = 0 and exited 0.
TEST_F(HbRefusals, AFormatThatDoesNotDescribeTheDataLinesIsRefused) {
  EXPECT_EQ(with_stiffness(edited(kHbStiffness, "(4E20.12)   ", "(4E10.12)   ")),
            file() + ":4: the value format '(4E10.12)': 12 digits do not fit a field of width 10");
  // Narrower fields, as many per line: the line holds more than the format describes.
  EXPECT_EQ(with_stiffness(edited(kHbStiffness, "(4E20.12)   ", "(4E10.3)    ")),
            file() +
                ":8: the line holds more than the 4 values of (4E10.3) (40 columns): the format "
                "does not describe this file's lines");
  // Twice as many narrower fields cover the line, but cut the numbers: refused because a field
  // without its decimal point would be read by the format's digit count.
  EXPECT_EQ(
      with_stiffness(edited(edited(kHbStiffness, "(4E20.12)   ", "(8E10.3)    "),
                            "             6             1             1             2",
                            "             5             1             1             1")),
      file() + ":8: '000000E+02' in columns 11-20 is not one of the values of format (8E10.3)");
  // A line count of the header that the counts and formats do not need.
  EXPECT_EQ(with_stiffness(edited(kHbStiffness, "(8I8)", "(4I8)")),
            file() + ":2: INDCRD = 1, but 8 row indices at 4 per line ((4I8)) take 2 lines");
  // A blank field where the format puts a number.
  EXPECT_EQ(with_stiffness(edited(kHbStiffness, "       2       5       3       4       5\n",
                                  "       2       5       3       4\n")),
            file() +
                ":7: field 8 of the row indices (columns 57-64) is blank, but (8I8) puts 8 of "
                "them on this line");
}

// (1P,4E20.12): fields with their exponent read as written; one without reads x 10^-1 in
// Fortran, so it is refused rather than read as 10.
TEST_F(HbRefusals, AScaleFactorNeedsTheExponentOfEveryField) {
  const std::string scaled = edited(kHbStiffness, "(4E20.12)   ", "(1P,4E20.12)");
  EXPECT_EQ(with_stiffness(scaled), "");
  EXPECT_EQ(with_stiffness(edited(scaled, "  0.100000000000E+02", "     10.000000000000")),
            file() +
                ":8: '     10.000000000000' in columns 1-20 is not one of the values of format "
                "(1P,4E20.12)");
}

// An HB or MMF file whose declared storage is not what it stores was symmetrised silently.
TEST_F(HbRefusals, StorageMustBeWhatTheFileDeclares) {
  // RUA (unsymmetric, both triangles) storing the lower triangle only.
  EXPECT_EQ(with_stiffness(edited(kHbStiffness, "RSA ", "RUA ")),
            file() +
                ":8: entry node 3 DOF 1 / node 3 DOF 2 has no mirror entry, but the file "
                "declares an unsymmetric matrix stored in full (Harwell-Boeing RUA, Matrix "
                "Market general): a stiffness or mass matrix is symmetric, so export it as "
                "symmetric (RSA, symmetric) or with both triangles");
  // RSA with an entry above the diagonal: column 1's row indices 1, 2, 4 -> column 2 gets
  // row 1.
  EXPECT_EQ(with_stiffness(edited(kHbStiffness, "       1       2       4       2       5",
                                  "       1       2       4       1       5")),
            file() +
                ":7: row index 1 of column 2 lies above the diagonal: an RSA file stores the "
                "lower triangle only");
  auto r = two_node_request(
      VendorFormat::kAnsysMmf,
      write("k.mmf",
            "%%MatrixMarket matrix coordinate real general\n5 5 8\n1 1 10\n2 1 1.5\n2 2 20\n"
            "3 3 30\n4 1 -4\n4 4 8\n5 2 -5\n5 5 9\n"),
      write("m.mmf",
            "%%MatrixMarket matrix coordinate real symmetric\n5 5 5\n1 1 2\n2 2 2\n3 3 2\n"
            "4 4 1\n5 5 1\n"),
      write("nodes.csv", "node,x,y,z\n3,1,0,0\n7,2,0,0\n"));
  r.equation_map_file = write("k.mapping", kAnsysMapping);
  EXPECT_NE(refusal(r).find(r.stiffness_file.string() +
                            ":4: entry node 3 DOF 1 / node 3 DOF 2 has no mirror entry, but the "
                            "file declares an unsymmetric matrix"),
            std::string::npos)
      << refusal(r);
  r.stiffness_file =
      write("k.mmf", "%%MatrixMarket matrix coordinate real symmetric\n5 5 1\n1 2 1.5\n");
  EXPECT_EQ(refusal(r), r.stiffness_file.string() +
                            ":3: entry (1, 2) lies above the diagonal: a symmetric Matrix Market "
                            "file stores the lower triangle only");
  // Abaqus declares nothing: one triangle or both, not a mix.
  r = two_node_request(VendorFormat::kAbaqusMatrixInput,
                       write("k.mtx", std::string(kAbaqusStiffness) + "3,1, 3,2, 1.5\n"),
                       write("m.mtx", kAbaqusMass), write("job.inp", kAbaqusNodes));
  EXPECT_EQ(refusal(r), r.stiffness_file.string() +
                            ":5: entry node 3 DOF 1 / node 7 DOF 1 has no mirror entry, but "
                            "entry node 3 DOF 1 / node 3 DOF 2 (line 2) has one: the file stores "
                            "one triangle for some entries and both for others");
}

// A mass matrix of fewer DOFs than the stiffness was written with zero rows; a size line of
// 10^12 rows or entries was ignored.
TEST_F(FeImport, SizesMustMatchTheOtherMatrixTheMapAndTheData) {
  auto r = two_node_request(VendorFormat::kAbaqusMatrixInput, write("k.mtx", kAbaqusStiffness),
                            write("m.mtx",
                                  "3,1, 3,1, 2.\n3,2, 3,2, 2.\n3,3, 3,3, 2.\n"
                                  "7,1, 7,1, 1.\n"),
                            write("job.inp", kAbaqusNodes));
  EXPECT_EQ(refusal(r), r.mass_file.string() +
                            ": node 7 DOF 2 is in the stiffness matrix (5 DOFs) but not in this "
                            "mass matrix (4 DOFs): both must be of the same model, and every DOF "
                            "must carry mass");
  r = two_node_request(VendorFormat::kAnsysMmf,
                       write("k.mmf",
                             "%%MatrixMarket matrix coordinate real symmetric\n"
                             "1000000000000 1000000000000 1\n1 1 1.0\n"),
                       write("m.mmf",
                             "%%MatrixMarket matrix coordinate real symmetric\n"
                             "5 5 100000000000\n1 1 1.0\n"),
                       write("nodes.csv", "node,x,y,z\n3,1,0,0\n7,2,0,0\n"));
  r.equation_map_file = write("k.mapping", kAnsysMapping);
  EXPECT_EQ(refusal(r), r.stiffness_file.string() +
                            ":2: the size line '1000000000000 1000000000000 1' gives sizes "
                            "outside 1..2147483647");
  r.stiffness_file = write("k2.mmf",
                           "%%MatrixMarket matrix coordinate real symmetric\n"
                           "5 5 15\n1 1 1.0\n");
  r.mass_file = write("m.mmf",
                      "%%MatrixMarket matrix coordinate real symmetric\n"
                      "5 5 100000000000\n1 1 1.0\n");
  EXPECT_EQ(refusal(r), r.stiffness_file.string() +
                            ":2: the size line announces 15 entries, which the 8 bytes after it "
                            "cannot hold");
  r.stiffness_file = write("k3.mmf",
                           "%%MatrixMarket matrix coordinate real symmetric\n"
                           "5 5 1\n1 1 1.0\n");
  EXPECT_EQ(refusal(r), r.mass_file.string() +
                            ":2: the size line announces 100000000000 entries, but a 5 x 5 "
                            "symmetric matrix has 15 positions");
  // HB: NROW against the equation map.
  auto hb = two_node_request(
      VendorFormat::kAnsysHbmat,
      write("k.matrix", edited(kHbStiffness, "RSA                        5             5",
                               "RSA                        4             4")),
      write("m.matrix", kHbMass), write("sector.node", kNwriteNodes));
  hb.equation_map_file = write("k.mapping", kAnsysMapping);
  EXPECT_EQ(refusal(hb),
            hb.stiffness_file.string() + ":3: the matrix has 4 rows, the equation map " +
                hb.equation_map_file.string() + " lists 5 equations: are they of the same export?");
}

// /dev/zero as a matrix read forever with memory growing; a FIFO would block.
TEST_F(FeImport, OnlyRegularFilesAreRead) {
  const auto nodes = write("nodes.csv", "node,x,y,z\n3,1,0,0\n7,2,0,0\n");
  auto r = two_node_request(VendorFormat::kAbaqusMatrixInput, "/dev/zero",
                            write("m.mtx", kAbaqusMass), nodes);
  EXPECT_EQ(refusal(r), "/dev/zero: is a device, a FIFO or a socket, not a regular file");
  r.stiffness_file = dir_;
  EXPECT_EQ(refusal(r), dir_.string() + ": is a folder");
  r.format = VendorFormat::kAnsysMmf;
  r.stiffness_file = "/dev/zero";
  r.equation_map_file = write("k.mapping", kAnsysMapping);
  EXPECT_EQ(refusal(r), "/dev/zero: is a device, a FIFO or a socket, not a regular file");
  // A regular file of one endless line.
  r.format = VendorFormat::kAbaqusMatrixInput;
  r.stiffness_file = write("long.mtx", std::string(100000, '1'));
  EXPECT_EQ(refusal(r), r.stiffness_file.string() +
                            ":1: line longer than 65536 bytes: not a text file of this format");
}

// File bytes were echoed raw: a terminal escape sequence reached the user's terminal.
TEST_F(FeImport, FileBytesInMessagesAreEscaped) {
  auto r = two_node_request(VendorFormat::kAbaqusMatrixInput,
                            write("k.mtx", "3,1,3,1,\x1b]0;owned\x07\x1b[2J\xff 10.\n"),
                            write("m.mtx", kAbaqusMass), write("job.inp", kAbaqusNodes));
  EXPECT_EQ(refusal(r), r.stiffness_file.string() +
                            ":1: expected 'node, dof, node, dof, value', found "
                            "'3,1,3,1,\\x1B]0;owned\\x07\\x1B[2J\\xFF 10.'");
  // The Matrix Market reader quotes escaped too, once.
  r = two_node_request(VendorFormat::kAnsysMmf,
                       write("k.mmf",
                             "%%MatrixMarket matrix coordinate real symmetric\n5 5 1\n"
                             "1 1 \x1b[2J\n"),
                       write("m.mtx", kAbaqusMass), write("job.inp", kAbaqusNodes));
  r.equation_map_file = write("k.mapping", kAnsysMapping);
  EXPECT_EQ(refusal(r),
            r.stiffness_file.string() + ":3: expected a finite number, found '\\x1B[2J'");
}

// --- Round trip: the test's own writers of each vendor format, read back to the bit ------

struct RandomSymmetric {
  Eigen::MatrixXd k;  // symmetric, full diagonal, sparse off-diagonal
  Eigen::MatrixXd m;
};

RandomSymmetric random_symmetric(std::mt19937_64& rng, int n) {
  std::uniform_real_distribution<double> mantissa(1.0, 10.0);
  std::uniform_int_distribution<int> exponent(-200, 200);
  std::bernoulli_distribution present(0.3), negative(0.5);
  const auto value = [&] {
    const double v = mantissa(rng) * std::pow(10.0, exponent(rng));
    return negative(rng) ? -v : v;
  };
  RandomSymmetric r{Eigen::MatrixXd::Zero(n, n), Eigen::MatrixXd::Zero(n, n)};
  for (int i = 0; i < n; ++i)
    for (int j = 0; j <= i; ++j)
      for (Eigen::MatrixXd* a : {&r.k, &r.m})
        if (i == j || present(rng)) (*a)(i, j) = (*a)(j, i) = value();
  return r;
}

std::string printed(double v) {
  char text[40];
  std::snprintf(text, sizeof text, "%.17g", v);
  return text;
}

// Equation e (0-based) is node e / 3 + 1, DOF e % 3 + 1.
std::string abaqus_matrix_input(const Eigen::MatrixXd& a) {
  std::string out = "** written by the test\n";
  for (int i = 0; i < a.rows(); ++i)
    for (int j = 0; j <= i; ++j)
      if (a(i, j) != 0.0)
        out += std::to_string(i / 3 + 1) + "," + std::to_string(i % 3 + 1) + "," +
               std::to_string(j / 3 + 1) + "," + std::to_string(j % 3 + 1) + "," +
               printed(a(i, j)) + "\n";
  return out;
}

// Both triangles, as Abaqus COORDINATE output of an unsymmetric-storage step.
std::string abaqus_coordinate(const Eigen::MatrixXd& a) {
  std::string out;
  for (int i = 0; i < a.rows(); ++i)
    for (int j = 0; j < a.cols(); ++j)
      if (a(i, j) != 0.0)
        out += std::to_string(i + 1) + "," + std::to_string(j + 1) + "," + printed(a(i, j)) + "\n";
  return out;
}

std::string matrix_market(const Eigen::MatrixXd& a, bool symmetric) {
  std::string entries;
  long count = 0;
  for (int j = 0; j < a.cols(); ++j)
    for (int i = symmetric ? j : 0; i < a.rows(); ++i)
      if (a(i, j) != 0.0) {
        entries +=
            std::to_string(i + 1) + " " + std::to_string(j + 1) + " " + printed(a(i, j)) + "\n";
        ++count;
      }
  return std::string("%%MatrixMarket matrix coordinate real ") +
         (symmetric ? "symmetric" : "general") + "\n% written by the test\n" +
         std::to_string(a.rows()) + " " + std::to_string(a.cols()) + " " + std::to_string(count) +
         "\n" + entries;
}

// Fixed-width fields, `per_line` to a line; the line count returned in `lines`.
std::string fixed_fields(const std::vector<std::string>& fields, int per_line, long& lines) {
  std::string out;
  lines = 0;
  for (std::size_t k = 0; k < fields.size(); ++k) {
    out += fields[k];
    if ((k + 1) % static_cast<std::size_t>(per_line) == 0 || k + 1 == fields.size()) {
      out += "\n";
      ++lines;
    }
  }
  return out;
}

// RSA (lower triangle) or RUA (both), pointers and indices (10I8), values (1P,3E26.16E3).
std::string harwell_boeing(const Eigen::MatrixXd& a, bool symmetric) {
  std::vector<std::string> pointers, indices, values;
  const auto integer = [](long v) {
    char text[24];
    std::snprintf(text, sizeof text, "%8ld", v);
    return std::string(text);
  };
  long nonzeros = 0;
  pointers.push_back(integer(1));
  for (int j = 0; j < a.cols(); ++j) {
    for (int i = symmetric ? j : 0; i < a.rows(); ++i)
      if (a(i, j) != 0.0) {
        indices.push_back(integer(i + 1));
        char text[40];
        std::snprintf(text, sizeof text, "%26.16E", a(i, j));
        values.push_back(text);
        ++nonzeros;
      }
    pointers.push_back(integer(nonzeros + 1));
  }
  long pl = 0, il = 0, vl = 0;
  const std::string p = fixed_fields(pointers, 10, pl);
  const std::string i = fixed_fields(indices, 10, il);
  const std::string v = fixed_fields(values, 3, vl);
  char header[400];
  std::snprintf(header, sizeof header,
                "%-72s%-8s\n%14ld%14ld%14ld%14ld%14d\n%-3s%11s%14ld%14ld%14ld%14d\n"
                "%-16s%-16s%-20s\n",
                "written by the test", "KEY", pl + il + vl, pl, il, vl, 0,
                symmetric ? "RSA" : "RUA", "", static_cast<long>(a.rows()),
                static_cast<long>(a.cols()), nonzeros, 0, "(10I8)", "(10I8)", "(1P,3E26.16E3)");
  return header + p + i + v;
}

std::string ansys_mapping(long n) {
  std::string out = "Matrix Eqn   Node   DOF\n";
  for (long e = 0; e < n; ++e)
    out += std::to_string(e + 1) + " " + std::to_string(e / 3 + 1) + " " +
           (e % 3 == 0   ? "UX"
            : e % 3 == 1 ? "UY"
                         : "UZ") +
           "\n";
  return out;
}

// Every vendor format, random sparse symmetric matrices of random sizes (1 to 40 DOFs, values
// over 400 decades): the imported matrices equal the written ones to the last bit.
TEST_F(FeImport, EveryFormatReadsBackWhatItsWriterWroteToTheLastBit) {
  std::mt19937_64 rng(20261205);
  std::uniform_int_distribution<int> size(1, 40);
  for (int trial = 0; trial < 12; ++trial) {
    const int n = size(rng);
    const auto a = random_symmetric(rng, n);
    std::string coordinates = "node,x,y,z\n";
    for (int node = 1; node <= (n + 2) / 3; ++node)
      coordinates += std::to_string(node) + "," + std::to_string(node) + ",0.5,0\n";
    const auto nodes = write("nodes.csv", coordinates);
    const auto map = write("k.mapping", ansys_mapping(n));
    struct Case {
      VendorFormat format;
      std::string k, m;
    };
    const bool symmetric = trial % 2 == 0;
    const Case cases[] = {
        {VendorFormat::kAbaqusMatrixInput, abaqus_matrix_input(a.k), abaqus_matrix_input(a.m)},
        {VendorFormat::kAbaqusCoordinate, abaqus_coordinate(a.k), abaqus_coordinate(a.m)},
        {VendorFormat::kAnsysHbmat, harwell_boeing(a.k, symmetric), harwell_boeing(a.m, symmetric)},
        {VendorFormat::kAnsysMmf, matrix_market(a.k, symmetric), matrix_market(a.m, symmetric)},
    };
    for (const auto& c : cases) {
      auto r = two_node_request(c.format, write("k.txt", c.k), write("m.txt", c.m), nodes);
      r.equation_map_file = map;
      const auto s = assemble_sector(r);
      ASSERT_EQ(s.stiffness.size, n);
      EXPECT_EQ(dense(s.stiffness), a.k) << "trial " << trial << ", format " << int(c.format);
      EXPECT_EQ(dense(s.mass), a.m) << "trial " << trial << ", format " << int(c.format);
    }
  }
}

}  // namespace
