// frichb import's readers and conversions (fe_import/): small files written by hand after the
// vendors' format descriptions (docs/fe-models.md), against matrices known by construction and
// a rotation computed by hand.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Dense>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
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

TEST_F(FeImport, AnsysHarwellBoeingWithItsMappingFile) {
  // RSA: the lower triangle by columns; fixed-width fields (6I8), (8I8), (4E20.12); with a
  // right-hand side (RHSCRD = 2: the fifth header line, and values after the matrix).
  const char* stiffness =
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
  const char* mass =
      "FricHB two-node test mass                                               KEY\n"
      "             4             1             1             2             0\n"
      "RSA                        5             5             5             0\n"
      "(6I8)           (8I8)           (4D20.12)           \n"
      "       1       2       3       4       5       6\n"
      "       1       2       3       4       5\n"
      "  0.200000000000D+01  0.200000000000D+01  0.200000000000D+01  0.100000000000D+01\n"
      "  0.100000000000D+01\n";
  auto r = two_node_request(
      VendorFormat::kAnsysHbmat, write("k.matrix", stiffness), write("m.matrix", mass),
      // NWRITE: fields may touch ("...E+01-0.0...")
      write("sector.node",
            "        3 0.100000000000E+01 0.000000000000E+00 0.0\n"
            "        7 0.200000000000E+01-0.000000000000E+00 0.0 0.0 0.0 0.0\n"));
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
  r.not_cyclic_file = write("shroud.txt", "# contact nodes\n2, 7 ** and one not in the model\n");
  const auto s = assemble_sector(r);
  EXPECT_TRUE(s.cyclic_pairs.empty());
  EXPECT_EQ(s.boundary_node_pairs, 0U);
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
  EXPECT_EQ(with_stiffness("3,1,3,1,1.\n9,1,9,1,1.\n"),
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
  EXPECT_EQ(refusal(r), (dir_ / "k.mmf").string() + ":3: equation 6 is not in the equation map " +
                            r.equation_map_file.string());
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
  EXPECT_EQ(refusal(r), r.stiffness_file.string() + ":5: column pointer '       x' is not in 2..2");
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

}  // namespace
