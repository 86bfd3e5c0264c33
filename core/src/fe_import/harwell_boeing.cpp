// Harwell-Boeing ASCII files (vendor_files.hpp): the header of four or five lines (title; card
// counts; matrix type and sizes; the Fortran formats of pointers, indices and values; the
// right-hand side line when there is one), then the column pointers, the row indices and the
// values, each in fixed-width fields of its format. Described in I. S. Duff, R. G. Grimes,
// J. G. Lewis, "Users' Guide for the Harwell-Boeing Sparse Matrix Collection", 1992.
#include <regex>
#include <string>

#include "fe_import/text_input.hpp"
#include "frichb/core/fe_import/vendor_files.hpp"

namespace frichb::core {

namespace fs = std::filesystem;
using fe_import_detail::LineReader;
using fe_import_detail::parse_integer;
using fe_import_detail::parse_real;
using fe_import_detail::split_fields;
using fe_import_detail::upper;

namespace {

struct FieldFormat {
  std::size_t per_line = 0;
  std::size_t width = 0;
};

struct HbHeader {
  long pointer_lines = 0;
  long index_lines = 0;
  long value_lines = 0;
  long rhs_lines = 0;
  std::string type;
  long columns = 0;
  long nonzeros = 0;
  FieldFormat pointer_format;
  FieldFormat index_format;
  FieldFormat value_format;
};

// "(8I10)", "(1P,4E20.12)", "(5D16.8)": fields per line and width.
FieldFormat parse_format(const LineReader& in, const std::string& text) {
  static const std::regex kFormat(R"(\((?:\s*\d*P\s*,?)?\s*(\d+)\s*[IEDFG]\s*(\d+))",
                                  std::regex::icase);
  std::smatch m;
  if (!std::regex_search(text, m, kFormat))
    in.fail("Fortran format '" + text + "' is not of the form (nIw) or (nEw.d)");
  return FieldFormat{std::stoul(m[1].str()), std::stoul(m[2].str())};
}

HbHeader read_header(LineReader& in) {
  std::string line;
  HbHeader h;
  if (!in.next(line)) in.fail("empty file, expected a Harwell-Boeing title line");
  if (!in.next(line)) in.fail("missing the card-count line");
  auto f = split_fields(line);
  long total = 0;
  if (f.size() < 4 || !parse_integer(f[0], total) || !parse_integer(f[1], h.pointer_lines) ||
      !parse_integer(f[2], h.index_lines) || !parse_integer(f[3], h.value_lines) ||
      (f.size() > 4 && !parse_integer(f[4], h.rhs_lines)))
    in.fail("expected 'TOTCRD PTRCRD INDCRD VALCRD [RHSCRD]', found '" + line + "'");
  if (!in.next(line)) in.fail("missing the matrix-type line");
  f = split_fields(line);
  long rows = 0;
  if (f.size() < 4 || !parse_integer(f[1], rows) || !parse_integer(f[2], h.columns) ||
      !parse_integer(f[3], h.nonzeros) || rows != h.columns || h.nonzeros < 0)
    in.fail("expected 'MXTYPE NROW NCOL NNZERO' of a square matrix, found '" + line + "'");
  h.type = upper(f[0]);
  if (h.type != "RSA" && h.type != "RUA")
    in.fail("matrix type '" + f[0] + "': only real assembled matrices (RSA, RUA) are read");
  if (!in.next(line)) in.fail("missing the format line");
  f = split_fields(line);
  if (f.size() < 3) in.fail("expected 'PTRFMT INDFMT VALFMT [RHSFMT]', found '" + line + "'");
  h.pointer_format = parse_format(in, f[0]);
  h.index_format = parse_format(in, f[1]);
  h.value_format = parse_format(in, f[2]);
  if (h.rhs_lines > 0 && !in.next(line)) in.fail("missing the right-hand side line");
  return h;
}

// `count` fixed-width fields over `lines` lines; the line of each field in `field_lines`.
std::vector<std::string> read_fields(LineReader& in, long lines, long count,
                                     const FieldFormat& format, const char* what,
                                     std::vector<long>& field_lines) {
  std::vector<std::string> fields;
  field_lines.clear();
  std::string line;
  for (long k = 0; k < lines; ++k) {
    if (!in.next(line))
      in.fail(std::string("the file ends inside the ") + what + " (" + std::to_string(lines) +
              " lines announced)");
    for (std::size_t at = 0; at < line.size() && fields.size() < std::size_t(count);
         at += format.width) {
      const std::string field = line.substr(at, format.width);
      if (split_fields(field).empty()) continue;
      fields.push_back(field);
      field_lines.push_back(in.number());
    }
  }
  if (static_cast<long>(fields.size()) != count)
    in.fail(std::string("expected ") + std::to_string(count) + " " + what + ", found " +
            std::to_string(fields.size()));
  return fields;
}

NodeDof lookup(const fs::path& file, long line, const fs::path& map_file, const EquationMap& map,
               long equation) {
  const auto it = map.find(equation);
  if (it == map.end())
    fe_import_detail::fail(file, line,
                           "equation " + std::to_string(equation) + " is not in the equation map " +
                               map_file.string());
  return it->second;
}

}  // namespace

std::vector<NodalEntry> read_harwell_boeing(const fs::path& file, const fs::path& map_file,
                                            const EquationMap& map) {
  LineReader in(file);
  const HbHeader h = read_header(in);
  std::vector<long> pointer_lines;
  std::vector<long> index_lines;
  std::vector<long> value_lines;
  const auto pointers = read_fields(in, h.pointer_lines, h.columns + 1, h.pointer_format,
                                    "column pointers", pointer_lines);
  const auto indices =
      read_fields(in, h.index_lines, h.nonzeros, h.index_format, "row indices", index_lines);
  const auto values =
      read_fields(in, h.value_lines, h.nonzeros, h.value_format, "values", value_lines);
  std::vector<NodalEntry> entries;
  entries.reserve(static_cast<std::size_t>(h.nonzeros));
  long begin = 0;
  if (!parse_integer(pointers[0], begin) || begin != 1)
    fe_import_detail::fail(file, pointer_lines[0], "the first column pointer must be 1");
  for (long column = 1; column <= h.columns; ++column) {
    long end = 0;
    const auto p = static_cast<std::size_t>(column);
    if (!parse_integer(pointers[p], end) || end < begin || end > h.nonzeros + 1)
      fe_import_detail::fail(file, pointer_lines[p],
                             "column pointer '" + pointers[p] + "' is not in " +
                                 std::to_string(begin) + ".." + std::to_string(h.nonzeros + 1));
    for (long k = begin - 1; k < end - 1; ++k) {
      const auto q = static_cast<std::size_t>(k);
      long row = 0;
      double value = 0;
      if (!parse_integer(indices[q], row) || row < 1 || row > h.columns)
        fe_import_detail::fail(
            file, index_lines[q],
            "row index '" + indices[q] + "' is not in 1.." + std::to_string(h.columns));
      if (!parse_real(values[q], value))
        fe_import_detail::fail(file, value_lines[q], "value '" + values[q] + "' is not a number");
      const NodeDof a = lookup(file, value_lines[q], map_file, map, row);
      const NodeDof b = lookup(file, value_lines[q], map_file, map, column);
      entries.push_back(NodalEntry{a.node, a.dof, b.node, b.dof, value, value_lines[q]});
    }
    begin = end;
  }
  return entries;
}

}  // namespace frichb::core
