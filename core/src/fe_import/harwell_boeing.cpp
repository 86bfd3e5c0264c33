// Harwell-Boeing ASCII files (vendor_files.hpp): the header of four or five lines (title; card
// counts; matrix type and sizes; the Fortran formats of pointers, indices and values; the
// right-hand side line when there is one), then the column pointers, the row indices and the
// values, each in fixed-width fields of its format. Described in I. S. Duff, R. G. Grimes,
// J. G. Lewis, "Users' Guide for the Harwell-Boeing Sparse Matrix Collection", 1992.
//
// Read exactly or refused: every field is read at the position its format gives, the line
// counts of the header must be those the counts and formats need, a line holds nothing beyond
// its fields, and a real field must carry its decimal point (without one, Fortran would place
// it by the format's digit count, which a mismatched format silently gets wrong) and, under a
// kP scale factor, its exponent (without one, Fortran scales the value by 10^-k).
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
using fe_import_detail::trim;
using fe_import_detail::upper;

namespace {

// The longest record a format may describe (fields per line x width), in characters.
constexpr long kMaxRecord = 1000;
// The longest format a reader takes ("(1P,4E20.12)" has 12 characters).
constexpr std::size_t kMaxFormatText = 40;
// The largest line count of a section (2^40 lines): larger counts describe no file this reader
// can take, and their sum would overflow.
constexpr long kMaxLines = 1L << 40;

struct FieldFormat {
  std::string text;  // as written, for messages
  long per_line = 0;
  long width = 0;
  char kind = 'I';  // I, E, D, F or G
  long scale = 0;   // the kP scale factor: a real field without an exponent is read x 10^-k
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

// A small decimal number of a format ("" counts as `absent`); false when it has more digits
// than any sensible format.
bool format_count(const std::string& digits, long absent, long& value) {
  if (digits.empty()) {
    value = absent;
    return true;
  }
  if (digits.size() > 6) return false;
  value = std::stol(digits);
  return true;
}

// "(8I10)", "(1P,4E20.12)", "(5D16.8)", "(3E26.18E3)": fields per line, type and width.
FieldFormat parse_format(const LineReader& in, const std::string& text, const char* what,
                         bool integers) {
  static const std::regex kFormat(
      R"(\(\s*(?:([+-]?\d+)\s*P\s*,?\s*)?(\d*)\s*([IEDFG])\s*(\d+)\s*(?:\.\s*(\d+))?\s*(?:E\s*\d+)?\s*\))",
      std::regex::icase);
  std::smatch m;
  const std::string shown = "the " + std::string(what) + " format '" + text + "'";
  if (!std::regex_match(text, m, kFormat))
    in.fail(shown + " is not a Fortran format of the form (nIw), (nEw.d) or (kP,nEw.d)");
  FieldFormat f;
  f.text = text;
  f.kind = upper(m[3].str())[0];
  long digits = -1;
  std::string scale = m[1].str();
  const bool negative = !scale.empty() && scale[0] == '-';
  if (!scale.empty() && (scale[0] == '-' || scale[0] == '+')) scale.erase(0, 1);
  if (!format_count(m[2].str(), 1, f.per_line) || !format_count(m[4].str(), 0, f.width) ||
      !format_count(m[5].str(), -1, digits) || !format_count(scale, 0, f.scale))
    in.fail(shown + " has a count or width of more than six digits");
  if (negative) f.scale = -f.scale;
  if (integers != (f.kind == 'I'))
    in.fail(shown + (integers ? " must be an integer format (nIw)"
                              : " must be a real format (nEw.d, nDw.d, nFw.d or nGw.d)"));
  if (f.per_line < 1 || f.width < 1)
    in.fail(shown + " gives " + std::to_string(f.per_line) + " fields of width " +
            std::to_string(f.width) + " per line: both must be at least 1");
  if (f.per_line * f.width > kMaxRecord)
    in.fail(shown + " describes lines of " + std::to_string(f.per_line * f.width) +
            " characters, more than the " + std::to_string(kMaxRecord) + " this reader accepts");
  if (digits >= (integers ? f.width + 1 : f.width))
    in.fail(shown + ": " + std::to_string(digits) + " digits do not fit a field of width " +
            std::to_string(f.width));
  return f;
}

// The parenthesised groups of the format line, in order; anything else but blanks is refused.
std::vector<std::string> format_groups(const LineReader& in, const std::string& line) {
  std::vector<std::string> groups;
  std::size_t at = 0;
  while (at < line.size()) {
    if (line[at] == ' ' || line[at] == '\t') {
      ++at;
      continue;
    }
    const std::size_t close = line.find(')', at);
    if (line[at] != '(' || close == std::string::npos)
      in.fail("expected the Fortran formats '(PTRFMT) (INDFMT) (VALFMT) [(RHSFMT)]', found '" +
              line + "'");
    if (close + 1 - at > kMaxFormatText)
      in.fail("the Fortran format '" + line.substr(at, kMaxFormatText) + "...' is longer than " +
              std::to_string(kMaxFormatText) + " characters");
    groups.push_back(line.substr(at, close + 1 - at));
    at = close + 1;
  }
  return groups;
}

long lines_needed(long count, long per_line) {
  return count == 0 ? 0 : (count - 1) / per_line + 1;
}

HbHeader read_header(LineReader& in, const fs::path& map_file, const EquationMap& map) {
  std::string line;
  HbHeader h;
  if (!in.next(line)) in.fail("empty file, expected a Harwell-Boeing title line");
  if (!in.next(line)) in.fail("missing the card-count line");
  const long counts_line = in.number();
  auto f = split_fields(line);
  long total = 0;
  if (f.size() < 4 || f.size() > 5 || !parse_integer(f[0], total) ||
      !parse_integer(f[1], h.pointer_lines) || !parse_integer(f[2], h.index_lines) ||
      !parse_integer(f[3], h.value_lines) || (f.size() > 4 && !parse_integer(f[4], h.rhs_lines)))
    in.fail("expected 'TOTCRD PTRCRD INDCRD VALCRD [RHSCRD]', found '" + line + "'");
  for (const long count : {h.pointer_lines, h.index_lines, h.value_lines, h.rhs_lines})
    if (count < 0 || count > kMaxLines)
      in.fail("the card counts in '" + line + "' are not all in 0.." + std::to_string(kMaxLines));
  if (total != h.pointer_lines + h.index_lines + h.value_lines + h.rhs_lines)
    in.fail("the card counts in '" + line + "' are not TOTCRD = PTRCRD + INDCRD + VALCRD + RHSCRD");
  if (!in.next(line)) in.fail("missing the matrix-type line");
  f = split_fields(line);
  long rows = 0;
  long elements = 0;
  if (f.size() < 4 || f.size() > 5 || !parse_integer(f[1], rows) ||
      !parse_integer(f[2], h.columns) || !parse_integer(f[3], h.nonzeros) ||
      (f.size() == 5 && !parse_integer(f[4], elements)) || rows != h.columns || rows < 1 ||
      h.nonzeros < 0 || h.nonzeros > kMaxLines || elements != 0)
    in.fail("expected 'MXTYPE NROW NCOL NNZERO [0]' of an assembled square matrix, found '" + line +
            "'");
  h.type = upper(f[0]);
  if (h.type != "RSA" && h.type != "RUA")
    in.fail("matrix type '" + f[0] +
            "': only real assembled matrices are read (RSA: symmetric, its lower triangle; "
            "RUA: unsymmetric, both triangles)");
  if (static_cast<std::size_t>(rows) != map.size())
    in.fail("the matrix has " + std::to_string(rows) + " rows, the equation map " +
            map_file.string() + " lists " + std::to_string(map.size()) +
            " equations: are they of the same export?");
  if (!in.next(line)) in.fail("missing the format line");
  const auto groups = format_groups(in, line);
  if (groups.size() < 3 || groups.size() > 4)
    in.fail("expected the Fortran formats '(PTRFMT) (INDFMT) (VALFMT) [(RHSFMT)]', found '" + line +
            "'");
  h.pointer_format = parse_format(in, groups[0], "pointer", true);
  h.index_format = parse_format(in, groups[1], "row index", true);
  h.value_format = parse_format(in, groups[2], "value", false);
  const auto check_lines = [&](const char* card, long given, long count, const char* what,
                               const FieldFormat& format) {
    const long needed = lines_needed(count, format.per_line);
    if (given != needed)
      fe_import_detail::fail(in.file(), counts_line,
                             std::string(card) + " = " + std::to_string(given) + ", but " +
                                 std::to_string(count) + " " + what + " at " +
                                 std::to_string(format.per_line) + " per line (" + format.text +
                                 ") take " + std::to_string(needed) + " lines");
  };
  check_lines("PTRCRD", h.pointer_lines, h.columns + 1, "column pointers", h.pointer_format);
  check_lines("INDCRD", h.index_lines, h.nonzeros, "row indices", h.index_format);
  check_lines("VALCRD", h.value_lines, h.nonzeros, "values", h.value_format);
  if (h.rhs_lines > 0 && !in.next(line)) in.fail("missing the right-hand side line");
  return h;
}

template <typename T>
struct Field {
  T value;
  long line;
};

// `count` fields of `format` over `lines` lines, each read at its position and converted by
// `convert` (false: not a number of that kind).
template <typename T, typename Convert>
std::vector<Field<T>> read_fields(LineReader& in, long lines, long count, const FieldFormat& format,
                                  const char* what, Convert convert) {
  std::vector<Field<T>> fields;
  std::string line;
  const auto width = static_cast<std::size_t>(format.width);
  for (long k = 0; k < lines; ++k) {
    if (!in.next(line))
      in.fail(std::string("the file ends inside the ") + what + " (" + std::to_string(lines) +
              " lines announced)");
    const long on_line = std::min(format.per_line, count - k * format.per_line);
    const std::size_t end = static_cast<std::size_t>(on_line) * width;
    if (end < line.size() && !trim(std::string_view(line).substr(end)).empty())
      in.fail("the line holds more than the " + std::to_string(on_line) + " " + what + " of " +
              format.text + " (" + std::to_string(end) +
              " columns): the format does not describe this file's lines");
    for (long j = 0; j < on_line; ++j) {
      const std::size_t at = static_cast<std::size_t>(j) * width;
      const std::string field = at < line.size() ? line.substr(at, width) : std::string();
      T value{};
      if (trim(field).empty())
        in.fail("field " + std::to_string(j + 1) + " of the " + what + " (columns " +
                std::to_string(at + 1) + "-" + std::to_string(at + width) + ") is blank, but " +
                format.text + " puts " + std::to_string(on_line) + " of them on this line");
      if (!convert(field, value))
        in.fail("'" + field + "' in columns " + std::to_string(at + 1) + "-" +
                std::to_string(at + width) + " is not one of the " + what + " of format " +
                format.text);
      fields.push_back({value, in.number()});
    }
  }
  return fields;
}

bool integer_field(const std::string& field, long& value) {
  return parse_integer(field, value);
}

// A Fortran real field as written: a decimal point is required (see the file's head), and
// under a kP scale factor (k != 0) an exponent too: Fortran reads a field without one as its
// value x 10^-k, a factor a reader that ignores the scale gets wrong.
bool real_field(const std::string& field, long scale, double& value) {
  if (field.find('.') == std::string::npos) return false;
  if (scale != 0 && field.find_first_of("EeDd") == std::string::npos) return false;
  return parse_real(field, value);
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

VendorMatrix read_harwell_boeing(const fs::path& file, const fs::path& map_file,
                                 const EquationMap& map) {
  LineReader in(file);
  const HbHeader h = read_header(in, map_file, map);
  const auto pointers = read_fields<long>(in, h.pointer_lines, h.columns + 1, h.pointer_format,
                                          "column pointers", integer_field);
  const auto indices = read_fields<long>(in, h.index_lines, h.nonzeros, h.index_format,
                                         "row indices", integer_field);
  const auto values = read_fields<double>(in, h.value_lines, h.nonzeros, h.value_format, "values",
                                          [&](const std::string& field, double& value) {
                                            return real_field(field, h.value_format.scale, value);
                                          });
  const bool lower = h.type == "RSA";
  VendorMatrix matrix;
  matrix.storage = lower ? MatrixStorage::kLowerTriangle : MatrixStorage::kBothTriangles;
  matrix.entries.reserve(static_cast<std::size_t>(h.nonzeros));
  long begin = pointers[0].value;
  if (begin != 1)
    fe_import_detail::fail(file, pointers[0].line, "the first column pointer must be 1");
  for (long column = 1; column <= h.columns; ++column) {
    const auto& end = pointers[static_cast<std::size_t>(column)];
    if (end.value < begin || end.value > h.nonzeros + 1)
      fe_import_detail::fail(file, end.line,
                             "column pointer " + std::to_string(end.value) + " is not in " +
                                 std::to_string(begin) + ".." + std::to_string(h.nonzeros + 1));
    for (long k = begin - 1; k < end.value - 1; ++k) {
      const auto& row = indices[static_cast<std::size_t>(k)];
      const auto& value = values[static_cast<std::size_t>(k)];
      if (row.value < 1 || row.value > h.columns)
        fe_import_detail::fail(file, row.line,
                               "row index " + std::to_string(row.value) + " is not in 1.." +
                                   std::to_string(h.columns));
      if (lower && row.value < column)
        fe_import_detail::fail(file, row.line,
                               "row index " + std::to_string(row.value) + " of column " +
                                   std::to_string(column) +
                                   " lies above the diagonal: an RSA file stores the lower "
                                   "triangle only");
      const NodeDof a = lookup(file, value.line, map_file, map, row.value);
      const NodeDof b = lookup(file, value.line, map_file, map, column);
      matrix.entries.push_back(NodalEntry{a.node, a.dof, b.node, b.dof, value.value, value.line});
    }
    begin = end.value;
  }
  if (begin != h.nonzeros + 1)
    fe_import_detail::fail(file, pointers.back().line,
                           "the last column pointer is " + std::to_string(begin) +
                               ", not NNZERO + 1 = " + std::to_string(h.nonzeros + 1));
  return matrix;
}

}  // namespace frichb::core
