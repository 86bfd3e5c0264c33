#include "fe_import/text_input.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>

#include "frichb/core/fe_import/sector_import.hpp"
#include "frichb/core/support/format.hpp"
#include "frichb/plugin/matrix_market.hpp"

namespace frichb::core::fe_import_detail {

namespace fs = std::filesystem;

void fail(const fs::path& file, long line, const std::string& what) {
  const std::string where =
      line > 0 ? file.string() + ":" + std::to_string(line) + ": " : file.string() + ": ";
  throw ImportError(printable_text(where + what));
}

LineReader::LineReader(const fs::path& file) : file_(file) {
  if (const std::string problem = regular_file_problem(file); !problem.empty())
    fe_import_detail::fail(file, 0, problem);
  in_.open(file, std::ios::binary);
  if (!in_) fe_import_detail::fail(file, 0, "cannot be opened for reading");
}

bool LineReader::next(std::string& line) {
  const sdk::LineRead read = sdk::read_bounded_line(in_, line, kMaxLineBytes);
  if (read == sdk::LineRead::kTooLong)
    fe_import_detail::fail(file_, number_ + 1,
                           "line longer than " + std::to_string(kMaxLineBytes) +
                               " bytes: not a text file of this format");
  if (read == sdk::LineRead::kEnd) return false;
  ++number_;
  return true;
}

void LineReader::fail(const std::string& what) const {
  fe_import_detail::fail(file_, number_, what);
}

std::vector<std::string> split_fields(std::string_view line) {
  std::vector<std::string> fields;
  std::string field;
  for (const char c : line) {
    if (c == ',' || std::isspace(static_cast<unsigned char>(c))) {
      if (!field.empty()) fields.push_back(std::move(field));
      field.clear();
    } else {
      field.push_back(c);
    }
  }
  if (!field.empty()) fields.push_back(std::move(field));
  return fields;
}

std::string_view trim(std::string_view text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front())))
    text.remove_prefix(1);
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back())))
    text.remove_suffix(1);
  return text;
}

std::string upper(std::string_view text) {
  std::string out(text);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return out;
}

bool parse_integer(std::string_view text, long& value) {
  const std::string s(trim(text));
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  value = std::strtol(s.c_str(), &end, 10);
  return errno == 0 && end == s.c_str() + s.size();
}

bool parse_real(std::string_view text, double& value) {
  std::string s(trim(text));
  if (s.empty()) return false;
  std::replace_if(
      s.begin(), s.end(), [](char c) { return c == 'D' || c == 'd'; }, 'E');
  char* end = nullptr;
  value = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && std::isfinite(value);
}

namespace {

// Length of the number starting at `at` ([+-]digits[.digits][E[+-]digits]), 0 if none.
std::size_t number_length(std::string_view s, std::size_t at) {
  std::size_t i = at;
  const auto digits = [&] {
    const std::size_t from = i;
    while (i < s.size() && std::isdigit(static_cast<unsigned char>(s[i]))) ++i;
    return i - from;
  };
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
  std::size_t mantissa = digits();
  if (i < s.size() && s[i] == '.') {
    ++i;
    mantissa += digits();
  }
  if (mantissa == 0) return 0;
  if (i < s.size() && std::string_view("EeDd").find(s[i]) != std::string_view::npos) {
    std::size_t j = i + 1;
    if (j < s.size() && (s[j] == '+' || s[j] == '-')) ++j;
    const std::size_t from = j;
    while (j < s.size() && std::isdigit(static_cast<unsigned char>(s[j]))) ++j;
    if (j > from) i = j;
  }
  return i - at;
}

}  // namespace

bool scan_numbers(std::string_view line, std::vector<std::string>& numbers) {
  numbers.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    if (std::isspace(static_cast<unsigned char>(line[i])) || line[i] == ',') {
      ++i;
      continue;
    }
    const std::size_t n = number_length(line, i);
    if (n == 0) return false;
    numbers.emplace_back(line.substr(i, n));
    i += n;
  }
  return true;
}

}  // namespace frichb::core::fe_import_detail
