#include "fe_import/cyclic_pairing.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <string>
#include <unordered_map>

#include "fe_import/text_input.hpp"
#include "frichb/core/support/format.hpp"

namespace frichb::core {

namespace fs = std::filesystem;

namespace {

using Cell = std::array<long long, 3>;

struct CellHash {
  std::size_t operator()(const Cell& c) const {
    std::size_t h = 1469598103934665603ULL;
    for (const long long v : c) h = (h ^ static_cast<std::size_t>(v)) * 1099511628211ULL;
    return h;
  }
};

// Nodes binned in cubes of side `cell` (>= the tolerance): the nodes within the tolerance of a
// point lie in its cube and the 26 around it.
class NodeGrid {
 public:
  NodeGrid(const std::vector<ImportedNode>& nodes, const std::vector<bool>& excluded, double cell)
      : nodes_(nodes), cell_(cell) {
    for (std::size_t k = 0; k < nodes.size(); ++k)
      if (!excluded[k]) bins_[cell_of(nodes[k].position)].push_back(k);
  }

  std::vector<std::size_t> within(const std::array<double, 3>& point, double tolerance) const {
    std::vector<std::size_t> found;
    const Cell centre = cell_of(point);
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          const auto it = bins_.find({centre[0] + dx, centre[1] + dy, centre[2] + dz});
          if (it == bins_.end()) continue;
          for (const std::size_t k : it->second)
            if (distance(nodes_[k].position, point) <= tolerance) found.push_back(k);
        }
    std::sort(found.begin(), found.end());
    return found;
  }

 private:
  static double distance(const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
  }
  Cell cell_of(const std::array<double, 3>& p) const {
    return {std::llround(std::floor(p[0] / cell_)), std::llround(std::floor(p[1] / cell_)),
            std::llround(std::floor(p[2] / cell_))};
  }
  const std::vector<ImportedNode>& nodes_;
  double cell_;
  std::unordered_map<Cell, std::vector<std::size_t>, CellHash> bins_;
};

double default_tolerance(const std::vector<ImportedNode>& nodes) {
  double largest = 0.0;
  for (const auto& node : nodes)
    for (const double x : node.position) largest = std::max(largest, std::abs(x));
  return 1e-6 * largest;
}

std::string node_name(const ImportedNode& node) {
  return "node " + std::to_string(node.number);
}

// Left node index -> right node index.
std::map<std::size_t, std::size_t> pair_nodes(const std::vector<ImportedNode>& nodes,
                                              const std::vector<bool>& excluded, double phi,
                                              double tolerance, const fs::path& file) {
  const NodeGrid grid(nodes, excluded, 2.0 * tolerance);
  const double c = std::cos(phi);
  const double s = std::sin(phi);
  std::map<std::size_t, std::size_t> right_of;
  std::map<std::size_t, std::size_t> left_of;
  const std::string within = " within " + format_number(tolerance, 3) + " m";
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    if (excluded[k]) continue;
    const auto& x = nodes[k].position;
    const auto found = grid.within({c * x[0] - s * x[1], s * x[0] + c * x[1], x[2]}, tolerance);
    if (found.empty()) continue;
    if (found.size() > 1)
      fe_import_detail::fail(file, 0,
                             node_name(nodes[found[0]]) + " and " + node_name(nodes[found[1]]) +
                                 " both lie" + within + " of " + node_name(nodes[k]) +
                                 " turned by +2 pi / sectors (duplicate nodes?)");
    if (found[0] == k)
      fe_import_detail::fail(file, 0,
                             node_name(nodes[k]) +
                                 " lies on the symmetry axis (it belongs to every sector): "
                                 "fe_sector needs a sector without nodes on the axis");
    const auto [it, fresh] = left_of.emplace(found[0], k);
    if (!fresh)
      fe_import_detail::fail(file, 0,
                             node_name(nodes[found[0]]) + " is the +phi image of both " +
                                 node_name(nodes[it->second]) + " and " + node_name(nodes[k]));
    right_of[k] = found[0];
  }
  for (const auto& [left, right] : right_of)
    if (right_of.count(right))
      fe_import_detail::fail(file, 0,
                             node_name(nodes[right]) + " is on the right face (image of " +
                                 node_name(nodes[left]) + ") and on the left face (its image is " +
                                 node_name(nodes[right_of.at(right)]) +
                                 "): is the sector wider than 2 pi / sectors?");
  return right_of;
}

}  // namespace

void pair_cyclic_boundary(ImportedSector& sector, int sectors, double tolerance,
                          const std::vector<long>& excluded, const fs::path& file) {
  sector.tolerance = tolerance > 0 ? tolerance : default_tolerance(sector.nodes);
  sector.cyclic_pairs.clear();
  sector.boundary_node_pairs = 0;
  if (sectors == 1) return;
  if (sectors == 2)
    throw ImportError(
        "--sectors 2: the two faces of a half disk are each other's +pi image, so the left and "
        "right boundaries cannot be told apart by position");
  std::vector<long> sorted_out = excluded;
  std::sort(sorted_out.begin(), sorted_out.end());
  std::vector<bool> left_out(sector.nodes.size(), false);
  for (std::size_t k = 0; k < sector.nodes.size(); ++k)
    left_out[k] = std::binary_search(sorted_out.begin(), sorted_out.end(), sector.nodes[k].number);
  const auto right_of =
      pair_nodes(sector.nodes, left_out, 2 * std::numbers::pi / sectors, sector.tolerance, file);
  for (const auto& [l, r] : right_of) {
    const auto& left = sector.nodes[l];
    const auto& right = sector.nodes[r];
    for (std::size_t c = 0; c < 3; ++c) {
      if ((left.rows[c] < 0) != (right.rows[c] < 0))
        fe_import_detail::fail(file, 0,
                               "component " + std::to_string(c + 1) + " of " +
                                   node_name(left.rows[c] < 0 ? left : right) +
                                   " is not in the matrices but that of its cyclic partner " +
                                   node_name(left.rows[c] < 0 ? right : left) +
                                   " is: constrain both sides alike");
      if (left.rows[c] >= 0) sector.cyclic_pairs.emplace_back(left.rows[c], right.rows[c]);
    }
  }
  std::sort(sector.cyclic_pairs.begin(), sector.cyclic_pairs.end());
  sector.boundary_node_pairs = right_of.size();
}

}  // namespace frichb::core
