// FricHB plugin SDK: the one Matrix Market reader, shared by the fe_sector provider and
// `frichb import` (header-only; the standard library alone).
//
//   std::ifstream in(file, std::ios::binary);
//   frichb::sdk::read_matrix_market(in,
//       [&](const frichb::sdk::MatrixMarketHeader& h) { /* sizes, storage */ },
//       [&](long long row, long long column, double value, long line) { /* one entry */ });
//
// Contract:
//  - Accepted: the banner `%%MatrixMarket matrix coordinate|array real|integer|double
//    general|symmetric` (words in any case), comment lines (`%`) and blank lines anywhere after
//    it, the size line (`rows columns entries` for coordinate, `rows columns` for array), then
//    exactly the announced entries: `row column value` per line (coordinate), one value per
//    line in column-major order (array; symmetric arrays give the lower triangle, diagonal
//    included).
//  - Refused with MatrixMarketError (its line() is 1-based; 0 for the file as a whole), before
//    any entry is passed on where the header or size line is at fault: another banner, object,
//    format, field or symmetry; a size line that is not exactly those integers; sizes below 1
//    or above 2^31 - 1; a symmetric matrix that is not square; more entries than the matrix
//    has positions, or than the rest of a seekable stream could hold (each entry needs at
//    least 6 bytes with its line end, each array value 2: a size line of 10^12 entries is
//    refused without allocating); an entry line with other than its fields, an index outside
//    the sizes, a non-finite or malformed value (an `integer` file's values must be integers); in a
//    symmetric coordinate file an entry above the diagonal (row < column: the format stores the
//    lower triangle); fewer or more entries than announced; a line longer than kMaxMatrixMarketLine
//    bytes. Quoted file text has its control and non-ASCII bytes written as \xNN.
//  - Callbacks: on_header once, after the size line; on_entry per stored entry with 1-based
//    indices and the entry's line. An exception thrown by a callback propagates unchanged.
//  - Threading: none; the reader holds no state between calls.
#pragma once

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <istream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace frichb::sdk {

inline constexpr std::size_t kMaxMatrixMarketLine = 64 * 1024;

class MatrixMarketError : public std::runtime_error {
 public:
  MatrixMarketError(long line, const std::string& what) : std::runtime_error(what), line_(line) {}
  long line() const { return line_; }

 private:
  long line_;
};

struct MatrixMarketHeader {
  bool coordinate = true;  // false: array (dense, column-major)
  bool symmetric = false;  // one triangle stored: the lower (row >= column)
  long long rows = 0;
  long long columns = 0;
  long long entries = 0;  // stored entries (array: rows x columns, or n (n + 1) / 2)
  long size_line = 0;     // the size line's number, for a caller's own refusal of the sizes
};

// One line of `in` into `line`, without its '\n' and a trailing '\r', reading at most `max`
// bytes of it: kEnd at the end of the stream, kTooLong (the line's first `max` bytes in `line`)
// when it is longer. For text readers that must not grow without bound on a file of no line
// ends.
enum class LineRead { kLine, kEnd, kTooLong };
inline LineRead read_bounded_line(std::istream& in, std::string& line, std::size_t max) {
  line.clear();
  std::streambuf* buffer = in.rdbuf();
  bool any = false;
  for (int c = buffer->sbumpc(); c != std::char_traits<char>::eof(); c = buffer->sbumpc()) {
    any = true;
    if (c == '\n') break;
    if (line.size() == max) return LineRead::kTooLong;
    line.push_back(static_cast<char>(c));
  }
  if (!any) return LineRead::kEnd;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return LineRead::kLine;
}

namespace detail {

// `text` with control and non-ASCII bytes as \xNN, for quoting file contents in messages.
inline std::string market_shown(std::string_view text) {
  std::string out;
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c >= 0x20 && c < 0x7F && c != '\\') {
      out.push_back(ch);
    } else {
      char escaped[5];
      std::snprintf(escaped, sizeof escaped, "\\x%02X", static_cast<unsigned>(c));
      out += escaped;
    }
  }
  return out;
}

inline std::string market_lower(std::string text) {
  for (char& c : text)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return text;
}

inline std::vector<std::string> market_words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

inline bool market_integer(const std::string& text, long long& value) {
  if (text.empty()) return false;
  char* end = nullptr;
  errno = 0;
  value = std::strtoll(text.c_str(), &end, 10);
  return errno == 0 && end == text.c_str() + text.size();
}

inline bool market_real(const std::string& text, double& value) {
  if (text.empty()) return false;
  char* end = nullptr;
  value = std::strtod(text.c_str(), &end);
  return end == text.c_str() + text.size() && std::isfinite(value);
}

// Reads lines with a length bound, counting them and skipping comments and blank lines.
class MarketLines {
 public:
  explicit MarketLines(std::istream& in) : in_(in) {}
  // The next line, comments and blanks included; false at the end.
  bool raw(std::string& line) {
    const LineRead read = read_bounded_line(in_, line, kMaxMatrixMarketLine);
    if (read == LineRead::kTooLong)
      throw MatrixMarketError(number_ + 1, "line longer than " +
                                               std::to_string(kMaxMatrixMarketLine) +
                                               " bytes: not a Matrix Market file");
    if (read == LineRead::kEnd) return false;
    ++number_;
    return true;
  }
  // The next line that is neither a comment nor blank; false at the end.
  bool data(std::string& line) {
    while (raw(line)) {
      const std::size_t first = line.find_first_not_of(" \t");
      if (first != std::string::npos && line[first] != '%') return true;
    }
    return false;
  }
  long number() const { return number_; }
  // Bytes left in a seekable stream; -1 when it cannot tell.
  long long remaining() {
    const auto here = in_.tellg();
    if (here < 0) return -1;
    in_.seekg(0, std::ios::end);
    const auto end = in_.tellg();
    in_.seekg(here);
    if (end < 0 || !in_) {
      in_.clear();
      return -1;
    }
    return static_cast<long long>(end - here);
  }

 private:
  std::istream& in_;
  long number_ = 0;
};

}  // namespace detail

template <typename OnHeader, typename OnEntry>
void read_matrix_market(std::istream& in, OnHeader&& on_header, OnEntry&& on_entry) {
  detail::MarketLines lines(in);
  std::string line;
  const auto fail = [&](const std::string& what) -> void {
    throw MatrixMarketError(lines.number(), what);
  };
  if (!lines.raw(line)) fail("empty file: not a Matrix Market file");
  const auto banner = detail::market_words(line);
  if (banner.empty() || banner[0] != "%%MatrixMarket")
    fail("not a Matrix Market file (the first line must start with %%MatrixMarket)");
  if (banner.size() != 5)
    fail("expected '%%MatrixMarket matrix coordinate|array real general|symmetric', found '" +
         detail::market_shown(line) + "'");
  const std::string object = detail::market_lower(banner[1]);
  const std::string format = detail::market_lower(banner[2]);
  const std::string field = detail::market_lower(banner[3]);
  const std::string symmetry = detail::market_lower(banner[4]);
  if (object != "matrix") fail("object '" + detail::market_shown(object) + "' is not 'matrix'");
  if (format != "coordinate" && format != "array")
    fail("format '" + detail::market_shown(format) + "' is neither 'coordinate' nor 'array'");
  if (field != "real" && field != "integer" && field != "double")
    fail("field '" + detail::market_shown(field) + "' is not supported (real or integer only)");
  if (symmetry != "general" && symmetry != "symmetric")
    fail("symmetry '" + detail::market_shown(symmetry) +
         "' is not supported (general or symmetric only)");
  MatrixMarketHeader h;
  h.coordinate = format == "coordinate";
  h.symmetric = symmetry == "symmetric";

  if (!lines.data(line)) fail("the size line is missing");
  h.size_line = lines.number();
  const auto size = detail::market_words(line);
  const std::size_t size_fields = h.coordinate ? 3 : 2;
  constexpr long long kLargest = 2147483647LL;
  if (size.size() != size_fields || !detail::market_integer(size[0], h.rows) ||
      !detail::market_integer(size[1], h.columns) ||
      (h.coordinate && !detail::market_integer(size[2], h.entries)))
    fail("bad size line '" + detail::market_shown(line) + "' (expected rows, columns" +
         (h.coordinate ? std::string(" and entry count") : std::string()) + ")");
  if (h.rows < 1 || h.columns < 1 || h.rows > kLargest || h.columns > kLargest)
    fail("the size line '" + detail::market_shown(line) + "' gives sizes outside 1.." +
         std::to_string(kLargest));
  if (h.symmetric && h.rows != h.columns)
    fail("a symmetric matrix must be square, not " + std::to_string(h.rows) + " x " +
         std::to_string(h.columns));
  const long long positions = h.symmetric ? h.rows * (h.rows + 1) / 2 : h.rows * h.columns;
  if (!h.coordinate) h.entries = positions;
  if (h.entries < 0 || h.entries > positions)
    fail("the size line announces " + std::to_string(h.entries) + " entries, but a " +
         std::to_string(h.rows) + " x " + std::to_string(h.columns) +
         (h.symmetric ? " symmetric" : "") + " matrix has " + std::to_string(positions) +
         " positions");
  const long long remaining = lines.remaining();
  const long long least_bytes = h.coordinate ? 6 : 2;
  // The last entry may end without its line end.
  if (remaining >= 0 && h.entries > (remaining + 1) / least_bytes)
    fail("the size line announces " + std::to_string(h.entries) + " entries, which the " +
         std::to_string(remaining) + " bytes after it cannot hold");
  on_header(static_cast<const MatrixMarketHeader&>(h));

  const auto index = [&](const std::string& text, long long count, const char* name) {
    long long v = 0;
    if (!detail::market_integer(text, v))
      fail(std::string("expected an integer ") + name + ", found '" + detail::market_shown(text) +
           "'");
    if (v < 1 || v > count)
      fail(std::string(name) + " " + std::to_string(v) + " is outside [1, " +
           std::to_string(count) + "]");
    return v;
  };
  long long column = 1;
  long long row = 1;
  for (long long e = 0; e < h.entries; ++e) {
    if (!lines.data(line))
      fail("the file ends after " + std::to_string(e) + " of " + std::to_string(h.entries) +
           " entries");
    const auto words = detail::market_words(line);
    double value = 0.0;
    if (h.coordinate) {
      if (words.size() != 3)
        fail("expected 'row column value', found '" + detail::market_shown(line) + "'");
      row = index(words[0], h.rows, "row");
      column = index(words[1], h.columns, "column");
      if (h.symmetric && row < column)
        fail("entry (" + std::to_string(row) + ", " + std::to_string(column) +
             ") lies above the diagonal: a symmetric Matrix Market file stores the lower "
             "triangle only");
    } else if (words.size() != 1) {
      fail("expected one value per line (array format), found '" + detail::market_shown(line) +
           "'");
    }
    if (field == "integer") {
      long long whole = 0;
      if (!detail::market_integer(words.back(), whole))
        fail("expected an integer (the field is 'integer'), found '" +
             detail::market_shown(words.back()) + "'");
      value = static_cast<double>(whole);
    } else if (!detail::market_real(words.back(), value)) {
      fail("expected a finite number, found '" + detail::market_shown(words.back()) + "'");
    }
    on_entry(row, column, value, lines.number());
    if (!h.coordinate && ++row > h.rows) {
      ++column;
      row = h.symmetric ? column : 1;
    }
  }
  if (lines.data(line))
    fail("more entries than the " + std::to_string(h.entries) + " the size line announces");
}

}  // namespace frichb::sdk
