// Line-by-line reading of the vendor text files with the file and line number in every error.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace frichb::core::fe_import_detail {

// Throws ImportError "FILE:LINE: what" (or "FILE: what" for line 0), with the bytes of the
// file name and of `what` that a terminal would interpret escaped (printable_text).
[[noreturn]] void fail(const std::filesystem::path& file, long line, const std::string& what);

// The longest line a vendor text file may have; longer lines are refused (the formats'
// lines are at most a few hundred characters).
inline constexpr std::size_t kMaxLineBytes = 64 * 1024;

// A text file read line by line, counting lines (the first is 1). Only regular files are
// opened: a folder, device, FIFO or socket is refused before reading.
class LineReader {
 public:
  explicit LineReader(const std::filesystem::path& file);
  // false at the end (a read error, which the stream buffer reports as the end, ends it too); a
  // line longer than kMaxLineBytes throws.
  bool next(std::string& line);
  long number() const { return number_; }
  const std::filesystem::path& file() const { return file_; }
  [[noreturn]] void fail(const std::string& what) const;

 private:
  std::filesystem::path file_;
  std::ifstream in_;
  long number_ = 0;
};

// The fields of a line separated by commas and/or blanks (empty fields dropped).
std::vector<std::string> split_fields(std::string_view line);
std::string_view trim(std::string_view text);
std::string upper(std::string_view text);

// Whole-field conversions; false when `text` is not entirely a number (Fortran D exponents
// are read as E; a non-finite value is refused).
bool parse_integer(std::string_view text, long& value);
bool parse_real(std::string_view text, double& value);

// The numbers of a line whose fixed-width fields may touch ("1.0E+00-2.0E+00"), in order;
// false when something else than numbers and blanks is found.
bool scan_numbers(std::string_view line, std::vector<std::string>& numbers);

}  // namespace frichb::core::fe_import_detail
