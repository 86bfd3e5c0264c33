// The imported sector written for fe_sector and the model map (sector_import.hpp).
#include <spdlog/fmt/fmt.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <system_error>

#include "frichb/core/fe_import/sector_import.hpp"

namespace frichb::core {

namespace fs = std::filesystem;

namespace {

std::string matrix_market(const LowerTriangle& m, const char* what) {
  std::string text = "%%MatrixMarket matrix coordinate real symmetric\n";
  text += fmt::format(
      "% sector {} (SI), written by frichb import: lower triangle, row = FricHB DOF + 1,\n"
      "% DOFs node by node (ascending node number), components (r, theta, z)\n",
      what);
  text += fmt::format("{} {} {}\n", m.size, m.size, m.entries.size());
  for (const auto& e : m.entries)
    text += fmt::format("{} {} {:.17g}\n", e.row + 1, e.column + 1, e.value);
  return text;
}

std::string cyclic_pairs(const ImportedSector& sector) {
  std::string text = fmt::format(
      "# cyclic boundary written by frichb import: 'left right' 0-based DOF rows, {} pairs of\n"
      "# {} node pairs (right = left turned by +2 pi / sectors about z, within {:.3g} m)\n",
      sector.cyclic_pairs.size(), sector.boundary_node_pairs, sector.tolerance);
  for (const auto& [left, right] : sector.cyclic_pairs) text += fmt::format("{} {}\n", left, right);
  return text;
}

std::string mesh_yaml() {
  return "# FricHB model map (written by frichb import)\n"
         "format: 1\n"
         "units: SI\n"
         "nodes: nodes.csv\n";
}

std::string nodes_csv(const ImportedSector& sector) {
  std::string text = "node,x,y,z,frame,dof_1,dof_2,dof_3\n";
  for (const auto& n : sector.nodes)
    text +=
        fmt::format("{},{:.17g},{:.17g},{:.17g},cylindrical,{},{},{}\n", n.number, n.position[0],
                    n.position[1], n.position[2], n.rows[0], n.rows[1], n.rows[2]);
  return text;
}

void write_checked(const fs::path& file, const std::string& text) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw ImportWriteError(file.string() + ": cannot be created");
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  out.flush();
  const bool written = static_cast<bool>(out);
  out.close();
  if (!written || !out) throw ImportWriteError(file.string() + ": write failed (disk full?)");
}

}  // namespace

void write_sector(const ImportedSector& sector,
                  const std::function<fs::path(const std::string&)>& path_of) {
  const std::pair<const char*, std::string> files[] = {
      {kImportedFiles[0], matrix_market(sector.stiffness, "stiffness, N/m")},
      {kImportedFiles[1], matrix_market(sector.mass, "mass, kg")},
      {kImportedFiles[2], cyclic_pairs(sector)},
      {kImportedFiles[3], mesh_yaml()},
      {kImportedFiles[4], nodes_csv(sector)}};
  const std::string suffix = ".tmp-" + std::to_string(::getpid());
  std::vector<fs::path> temporaries;
  try {
    for (const auto& [name, text] : files) {
      temporaries.push_back(fs::path(path_of(name)).concat(suffix));
      write_checked(temporaries.back(), text);
    }
    for (std::size_t k = 0; k < temporaries.size(); ++k) {
      std::error_code error;
      fs::rename(temporaries[k], path_of(files[k].first), error);
      if (error) throw ImportWriteError(path_of(files[k].first).string() + ": " + error.message());
    }
  } catch (...) {
    std::error_code ignored;
    for (const auto& file : temporaries) fs::remove(file, ignored);
    throw;
  }
}

}  // namespace frichb::core
