// The vendors' matrix files and equation maps (vendor_files.hpp); the format descriptions are
// cited in docs/fe-models.md.
#include <cctype>
#include <map>
#include <string>

#include "fe_import/text_input.hpp"
#include "frichb/core/fe_import/sector_import.hpp"
#include "frichb/core/fe_import/vendor_files.hpp"
#include "frichb/core/support/format.hpp"
#include "frichb/plugin/matrix_market.hpp"

namespace frichb::core {

namespace fs = std::filesystem;
using fe_import_detail::LineReader;
using fe_import_detail::parse_integer;
using fe_import_detail::parse_real;
using fe_import_detail::split_fields;
using fe_import_detail::trim;
using fe_import_detail::upper;

namespace {

bool is_comment_or_blank(std::string_view line) {
  const auto t = trim(line);
  return t.empty() || t.front() == '*' || t.front() == '%' || t.front() == '#';
}

int dof_number(const std::string& text) {
  static const std::pair<const char*, int> kLabels[] = {{"UX", 1},   {"UY", 2},   {"UZ", 3},
                                                        {"ROTX", 4}, {"ROTY", 5}, {"ROTZ", 6}};
  long number = 0;
  if (parse_integer(text, number)) return number >= 1 && number <= 1000 ? int(number) : -1;
  for (const auto& [label, dof] : kLabels)
    if (upper(text) == label) return dof;
  return -1;
}

// The (node, DOF) of an equation number of `file`'s line.
NodeDof lookup(const LineReader& in, const fs::path& map_file, const EquationMap& map,
               long equation) {
  const auto it = map.find(equation);
  if (it == map.end())
    in.fail("equation " + std::to_string(equation) + " is not in the equation map " +
            map_file.string());
  return it->second;
}

NodalEntry entry_between(const NodeDof& a, const NodeDof& b, double value, long line) {
  return NodalEntry{a.node, a.dof, b.node, b.dof, value, line};
}

}  // namespace

VendorMatrix read_abaqus_matrix_input(const fs::path& file) {
  LineReader in(file);
  VendorMatrix matrix;
  auto& entries = matrix.entries;
  std::string line;
  while (in.next(line)) {
    if (is_comment_or_blank(line)) continue;
    const auto f = split_fields(line);
    NodalEntry e;
    long dof_a = 0;
    long dof_b = 0;
    if (f.size() != 5 || !parse_integer(f[0], e.node_a) || !parse_integer(f[1], dof_a) ||
        !parse_integer(f[2], e.node_b) || !parse_integer(f[3], dof_b) || !parse_real(f[4], e.value))
      in.fail("expected 'node, dof, node, dof, value', found '" + line + "'");
    e.dof_a = static_cast<int>(dof_a);
    e.dof_b = static_cast<int>(dof_b);
    e.line = in.number();
    entries.push_back(e);
  }
  return matrix;
}

VendorMatrix read_abaqus_coordinate(const fs::path& file, const fs::path& map_file,
                                    const EquationMap& map) {
  LineReader in(file);
  VendorMatrix matrix;
  auto& entries = matrix.entries;
  std::string line;
  while (in.next(line)) {
    if (is_comment_or_blank(line)) continue;
    const auto f = split_fields(line);
    long row = 0;
    long column = 0;
    double value = 0;
    if (f.size() != 3 || !parse_integer(f[0], row) || !parse_integer(f[1], column) ||
        !parse_real(f[2], value))
      in.fail("expected 'row, column, value', found '" + line + "'");
    entries.push_back(entry_between(lookup(in, map_file, map, row),
                                    lookup(in, map_file, map, column), value, in.number()));
  }
  return matrix;
}

VendorMatrix read_matrix_market(const fs::path& file, const fs::path& map_file,
                                const EquationMap& map) {
  if (const std::string problem = regular_file_problem(file); !problem.empty())
    fe_import_detail::fail(file, 0, problem);
  std::ifstream in(file, std::ios::binary);
  if (!in) fe_import_detail::fail(file, 0, "cannot be opened for reading");
  VendorMatrix matrix;
  const auto equation = [&](long long number, long line) {
    const auto it = map.find(static_cast<long>(number));
    if (it == map.end())
      fe_import_detail::fail(file, line,
                             "equation " + std::to_string(number) + " is not in the equation map " +
                                 map_file.string());
    return it->second;
  };
  try {
    sdk::read_matrix_market(
        in,
        [&](const sdk::MatrixMarketHeader& h) {
          if (!h.coordinate)
            throw sdk::MatrixMarketError(h.size_line,
                                         "an array (dense) file: export the coordinate format");
          if (h.rows != h.columns)
            throw sdk::MatrixMarketError(h.size_line, "the matrix is " + std::to_string(h.rows) +
                                                          " x " + std::to_string(h.columns) +
                                                          ", not square");
          if (static_cast<std::size_t>(h.rows) != map.size())
            throw sdk::MatrixMarketError(
                h.size_line, "the matrix has " + std::to_string(h.rows) +
                                 " rows, the equation map " + map_file.string() + " lists " +
                                 std::to_string(map.size()) +
                                 " equations: are they of the same export?");
          matrix.storage =
              h.symmetric ? MatrixStorage::kLowerTriangle : MatrixStorage::kBothTriangles;
          matrix.entries.reserve(static_cast<std::size_t>(h.entries));
        },
        [&](long long i, long long j, double value, long line) {
          matrix.entries.push_back(
              entry_between(equation(i, line), equation(j, line), value, line));
        });
  } catch (const sdk::MatrixMarketError& e) {
    // The reader's message quotes the file's bytes escaped already.
    const std::string where =
        e.line() > 0 ? file.string() + ":" + std::to_string(e.line()) : file.string();
    throw ImportError(printable_text(where + ": ") + e.what());
  }
  return matrix;
}

EquationMap read_equation_map(const fs::path& file) {
  LineReader in(file);
  EquationMap map;
  std::map<std::pair<long, int>, long> seen;  // (node, dof) -> line
  std::string line;
  while (in.next(line)) {
    const auto t = trim(line);
    if (t.empty() || !std::isdigit(static_cast<unsigned char>(t.front()))) continue;
    const auto f = split_fields(t);
    long equation = 0;
    long node = 0;
    if (f.size() < 3 || !parse_integer(f[0], equation) || !parse_integer(f[1], node))
      in.fail("expected 'equation node dof', found '" + line + "'");
    const int dof = dof_number(f[2]);
    if (dof < 0)
      in.fail("DOF '" + f[2] + "' of node " + std::to_string(node) +
              " is not a structural DOF (UX, UY, UZ, ROTX, ROTY, ROTZ or a number 1-1000)");
    if (!map.emplace(equation, NodeDof{node, dof}).second)
      in.fail("equation " + std::to_string(equation) + " is listed twice");
    const auto [it, fresh] = seen.emplace(std::pair{node, dof}, in.number());
    if (!fresh)
      in.fail("node " + std::to_string(node) + " DOF " + f[2] + " is listed twice (line " +
              std::to_string(it->second) + ")");
  }
  if (map.empty()) in.fail("no 'equation node dof' line");
  return map;
}

}  // namespace frichb::core
