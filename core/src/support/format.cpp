// Numbers, file bytes and file kinds as messages write them (format.hpp).
#include "frichb/core/support/format.hpp"

#include <cstdio>
#include <sstream>
#include <system_error>

namespace frichb::core {

std::string format_number(double x, int precision) {
  std::ostringstream os;
  os.precision(precision);
  os << x;
  return os.str();
}

namespace {

// Bytes of the valid UTF-8 sequence of a printable code point at `at` (>= 2), 0 if none.
std::size_t printable_utf8_length(std::string_view s, std::size_t at) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char lead = byte(at);
  std::size_t length = 0;
  char32_t code = 0;
  if (lead >= 0xC2 && lead <= 0xDF) {
    length = 2;
    code = lead & 0x1FU;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    length = 3;
    code = lead & 0x0FU;
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    length = 4;
    code = lead & 0x07U;
  } else {
    return 0;
  }
  if (at + length > s.size()) return 0;
  for (std::size_t k = 1; k < length; ++k) {
    if ((byte(at + k) & 0xC0U) != 0x80U) return 0;
    code = (code << 6U) | (byte(at + k) & 0x3FU);
  }
  const bool overlong = (length == 3 && code < 0x800) || (length == 4 && code < 0x10000);
  const bool surrogate = code >= 0xD800 && code <= 0xDFFF;
  const bool c1_control = code >= 0x80 && code < 0xA0;
  if (overlong || surrogate || c1_control || code > 0x10FFFF) return 0;
  return length;
}

}  // namespace

std::string printable_text(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t k = 0; k < text.size();) {
    const auto c = static_cast<unsigned char>(text[k]);
    if (c >= 0x20 && c < 0x7F && c != '\\') {
      out.push_back(static_cast<char>(c));
      ++k;
      continue;
    }
    if (c >= 0x80) {
      if (const std::size_t n = printable_utf8_length(text, k); n > 0) {
        out.append(text.substr(k, n));
        k += n;
        continue;
      }
    }
    if (c == '\t') {
      out += "\\t";
    } else {
      char escaped[5];
      std::snprintf(escaped, sizeof escaped, "\\x%02X", static_cast<unsigned>(c));
      out += escaped;
    }
    ++k;
  }
  return out;
}

std::string regular_file_problem(const std::filesystem::path& file) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status status = fs::status(file, ec);
  if (status.type() == fs::file_type::not_found) return "does not exist";
  if (ec) return "cannot be examined: " + ec.message();
  if (status.type() == fs::file_type::directory) return "is a folder";
  if (status.type() != fs::file_type::regular)
    return "is a device, a FIFO or a socket, not a regular file";
  return "";
}

}  // namespace frichb::core
