// Numbers, file bytes and file kinds as messages write them.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace frichb::core {

// `x` with `precision` significant digits in the shortest of fixed and scientific notation
// (std::ostream's default floating-point format): 330, 0.001, 1e-06, 2.5e+07.
std::string format_number(double x, int precision = 6);

// `text` safe to print on a terminal: control characters (C0, DEL and the C1 range), bytes
// that are not valid UTF-8 and backslashes are written as `\xNN` (a tab as `\t`); printable
// ASCII and valid UTF-8 of printable code points are kept as they are. For file contents and
// names echoed in messages.
std::string printable_text(std::string_view text);

// Why `file` cannot be read as a text file: "" for a regular file (symbolic links followed),
// otherwise "does not exist", "is a folder", "is a device, a FIFO or a socket, not a regular
// file" (reading /dev/zero or a pipe would never end) or "cannot be examined: <reason>". The
// answer holds when it is given: check it just before opening, and bound the reading anyway.
std::string regular_file_problem(const std::filesystem::path& file);

}  // namespace frichb::core
