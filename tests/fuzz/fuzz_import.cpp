// libFuzzer target: one `frichb import` reader on arbitrary bytes, chosen at build time by
// FRICHB_FUZZ_IMPORT_FORMAT (0 abaqus-matrix-input, 1 abaqus-coordinate, 2 ansys-hbmat,
// 3 ansys-mmf, 4 the node-coordinate readers, 5 the equation map).
//
// For the matrix formats the input is the stiffness file of a whole import (assemble_sector)
// whose other files are fixed and valid: the two-node model of tests/test_fe_import.cpp (its
// mass matrix in the same format, its equation map and node coordinates). For the node
// readers the input is read as a CSV, an Abaqus input file and an NWRITE file in turn.
//
// Expected outcomes are success and ImportError. Anything else escaping (another exception,
// a crash, a sanitizer report, a hang, a blow-up of memory) is a finding, and so is an
// imported matrix with a non-finite entry or an entry outside its size.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <typeinfo>

#include "frichb/core/fe_import/sector_import.hpp"
#include "frichb/core/fe_import/vendor_files.hpp"

#ifndef FRICHB_FUZZ_IMPORT_FORMAT
#error "FRICHB_FUZZ_IMPORT_FORMAT selects the reader"
#endif

namespace {

namespace fs = std::filesystem;
using namespace frichb::core;

fs::path g_dir;
ImportRequest g_request;

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_import: FINDING: %s: %s\n", what, detail.c_str());
  std::fflush(stderr);
  std::abort();
}

fs::path write(const std::string& name, const std::string& bytes) {
  const fs::path file = g_dir / name;
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) finding("setup", "cannot write " + file.string());
  return file;
}

// The two-node model's mass matrix in each matrix format (equations 1..5 = 3x 3y 3z 7x 7y).
std::string mass_text(VendorFormat format) {
  switch (format) {
    case VendorFormat::kAbaqusMatrixInput:
      return "3,1, 3,1, 2.\n3,2, 3,2, 2.\n3,3, 3,3, 2.\n7,1, 7,1, 1.\n7,2, 7,2, 1.\n";
    case VendorFormat::kAbaqusCoordinate:
      return "1,1,2.\n2,2,2.\n3,3,2.\n4,4,1.\n5,5,1.\n";
    case VendorFormat::kAnsysHbmat:
      return "mass                                                                    KEY\n"
             "             4             1             1             2             0\n"
             "RSA                        5             5             5             0\n"
             "(6I8)           (8I8)           (4D20.12)           \n"
             "       1       2       3       4       5       6\n"
             "       1       2       3       4       5\n"
             "  0.200000000000D+01  0.200000000000D+01  0.200000000000D+01  0.100000000000D+01\n"
             "  0.100000000000D+01\n";
    case VendorFormat::kAnsysMmf:
      return "%%MatrixMarket matrix coordinate real symmetric\n5 5 5\n1 1 2\n2 2 2\n3 3 2\n"
             "4 4 1\n5 5 1\n";
  }
  return {};
}

void check_triangle(const LowerTriangle& m) {
  for (const auto& e : m.entries)
    if (!std::isfinite(e.value) || e.row < e.column || e.column < 0 || e.row >= m.size)
      finding("matrix", "entry (" + std::to_string(e.row) + ", " + std::to_string(e.column) +
                            ") = " + std::to_string(e.value) + " of size " +
                            std::to_string(m.size));
}

void check_input(const std::string& bytes) {
  constexpr int kFormat = FRICHB_FUZZ_IMPORT_FORMAT;
  if constexpr (kFormat <= 3) {
    g_request.stiffness_file = write("stiffness.txt", bytes);
    const ImportedSector sector = assemble_sector(g_request);
    check_triangle(sector.stiffness);
    check_triangle(sector.mass);
  } else if constexpr (kFormat == 4) {
    for (const char* name : {"nodes.csv", "nodes.inp", "nodes.node"}) {
      try {
        for (const auto& [node, x] : read_node_coordinates(write(name, bytes)))
          for (const double c : x)
            if (!std::isfinite(c)) finding("coordinates", "node " + std::to_string(node));
      } catch (const ImportError&) {
      }
    }
    try {
      read_node_list(write("list.txt", bytes));
    } catch (const ImportError&) {
    }
  } else {
    read_equation_map(write("map.txt", bytes));
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  g_dir = fs::temp_directory_path() /
          ("frichb-fuzz-import-" + std::to_string(static_cast<long long>(getpid())));
  fs::create_directories(g_dir);
  std::atexit([] {
    std::error_code ec;
    fs::remove_all(g_dir, ec);
  });
  constexpr int kFormat = FRICHB_FUZZ_IMPORT_FORMAT;
  if constexpr (kFormat <= 3) {
    const auto format = static_cast<VendorFormat>(kFormat);
    g_request.format = format;
    g_request.mass_file = write("mass.txt", mass_text(format));
    g_request.equation_map_file =
        write("map.txt", "Matrix Eqn   Node   DOF\n1 3 UX\n2 3 UY\n3 3 UZ\n4 7 UX\n5 7 UY\n");
    g_request.coordinates_file = write("nodes.csv", "node,x,y,z\n3,1,0,0\n7,2,0,0\n");
    g_request.nodal_frame = NodalFrame::kGlobal;
    g_request.sectors = 1;
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    check_input(bytes);
  } catch (const ImportError&) {
  } catch (const std::exception& e) {
    finding(typeid(e).name(), e.what());
  } catch (...) {
    finding("exception", "not derived from std::exception");
  }
  return 0;
}
