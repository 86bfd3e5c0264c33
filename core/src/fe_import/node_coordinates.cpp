// Node coordinates from a CSV file, an Abaqus input file or ANSYS NWRITE output
// (vendor_files.hpp; the formats are cited in docs/fe-models.md).
#include <algorithm>
#include <string>

#include "fe_import/text_input.hpp"
#include "frichb/core/fe_import/vendor_files.hpp"

namespace frichb::core {

namespace fs = std::filesystem;
using fe_import_detail::LineReader;
using fe_import_detail::parse_integer;
using fe_import_detail::parse_real;
using fe_import_detail::split_fields;
using fe_import_detail::trim;
using fe_import_detail::upper;
using Coordinates = std::map<long, std::array<double, 3>>;

namespace {

void add_node(const LineReader& in, Coordinates& nodes, long node,
              const std::array<double, 3>& position) {
  if (node <= 0) in.fail("node number " + std::to_string(node) + " is not positive");
  if (!nodes.emplace(node, position).second)
    in.fail("node " + std::to_string(node) + " is defined twice");
}

// `node, x, y[, z]` from fields[0..3]; a missing z is 0 (Abaqus). False when malformed.
bool node_fields(const std::vector<std::string>& f, std::size_t max_fields, long& node,
                 std::array<double, 3>& position) {
  position = {0.0, 0.0, 0.0};
  if (f.size() < 3 || f.size() > max_fields || !parse_integer(f[0], node)) return false;
  for (std::size_t k = 1; k < f.size() && k <= 3; ++k)
    if (!parse_real(f[k], position[k - 1])) return false;
  return true;
}

Coordinates read_csv(const fs::path& file) {
  LineReader in(file);
  std::string line;
  if (!in.next(line) || upper(trim(line)).rfind("NODE,X,Y,Z", 0) != 0)
    in.fail("expected the header line 'node,x,y,z'");
  Coordinates nodes;
  while (in.next(line)) {
    if (trim(line).empty()) continue;
    const auto f = split_fields(line);
    long node = 0;
    std::array<double, 3> position{};
    if (f.size() < 4 || !node_fields({f.begin(), f.begin() + 4}, 4, node, position))
      in.fail("expected 'node,x,y,z', found '" + line + "'");
    add_node(in, nodes, node, position);
  }
  return nodes;
}

// The keyword of an Abaqus keyword line ("*NODE, NSET=ALL" -> "*NODE").
std::string keyword_of(std::string_view line) {
  const auto comma = line.find(',');
  return upper(trim(line.substr(0, comma)));
}

void check_node_options(const LineReader& in, const std::string& line) {
  const auto f = split_fields(upper(line));
  for (const auto& option : f)
    if (option.rfind("SYSTEM=", 0) == 0 && option != "SYSTEM=R")
      in.fail("*NODE with " + option +
              ": only rectangular coordinates (SYSTEM=R, the default) are read");
}

Coordinates read_abaqus_input(const fs::path& file) {
  LineReader in(file);
  Coordinates nodes;
  std::string line;
  bool in_node_block = false;
  while (in.next(line)) {
    const auto t = trim(line);
    if (t.empty() || t.rfind("**", 0) == 0) continue;
    if (t.front() == '*') {
      const std::string keyword = keyword_of(t);
      if (keyword == "*INCLUDE")
        in.fail("*INCLUDE is not followed: give the input file with its nodes inline, or a CSV");
      in_node_block = keyword == "*NODE";
      if (in_node_block) check_node_options(in, line);
      continue;
    }
    if (!in_node_block) continue;
    long node = 0;
    std::array<double, 3> position{};
    if (!node_fields(split_fields(t), 4, node, position))
      in.fail("expected 'node, x, y[, z]' in the *NODE block, found '" + line + "'");
    add_node(in, nodes, node, position);
  }
  return nodes;
}

// NWRITE: (I9, 6G21.13E3) NODE, X, Y, Z, THXY, THYZ, THZX per line, trailing zeros left
// blank (so "node x" is a node at (x, 0, 0)); fields may touch; lines that are not numbers
// before the first node (a title) are skipped.
Coordinates read_nwrite(const fs::path& file) {
  LineReader in(file);
  Coordinates nodes;
  std::string line;
  std::vector<std::string> numbers;
  while (in.next(line)) {
    if (trim(line).empty()) continue;
    if (!fe_import_detail::scan_numbers(line, numbers)) {
      if (nodes.empty()) continue;  // a heading before the first node
      in.fail("expected 'node x y z ...' numbers, found '" + line + "'");
    }
    long node = 0;
    std::array<double, 3> position{};
    bool valid = !numbers.empty() && numbers.size() <= 7 && parse_integer(numbers[0], node);
    for (std::size_t k = 1; valid && k < std::min<std::size_t>(numbers.size(), 4); ++k)
      valid = parse_real(numbers[k], position[k - 1]);
    if (!valid) in.fail("expected 'node x y z [thxy thyz thzx]', found '" + line + "'");
    add_node(in, nodes, node, position);
  }
  return nodes;
}

}  // namespace

std::vector<long> read_node_list(const fs::path& file) {
  LineReader in(file);
  std::vector<long> nodes;
  std::string line;
  while (in.next(line)) {
    auto text = std::string_view(line);
    text = text.substr(0, std::min(text.find('#'), text.find("**")));
    for (const auto& field : split_fields(text)) {
      long node = 0;
      if (!parse_integer(field, node) || node <= 0) in.fail("'" + field + "' is not a node number");
      nodes.push_back(node);
    }
  }
  return nodes;
}

Coordinates read_node_coordinates(const fs::path& file) {
  const std::string extension = upper(file.extension().string());
  Coordinates nodes;
  if (extension == ".CSV")
    nodes = read_csv(file);
  else if (extension == ".INP")
    nodes = read_abaqus_input(file);
  else
    nodes = read_nwrite(file);
  if (nodes.empty()) fe_import_detail::fail(file, 0, "no node coordinates found");
  return nodes;
}

}  // namespace frichb::core
