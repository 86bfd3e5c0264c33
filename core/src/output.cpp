#include "frichb/core/output.hpp"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <stdexcept>

namespace frichb::core {

namespace fs = std::filesystem;

StagedOutput::StagedOutput(fs::path final_directory, std::vector<std::string> managed)
    : final_(std::move(final_directory)), managed_(std::move(managed)) {
  const fs::path parent = final_.has_parent_path() ? final_.parent_path() : fs::path(".");
  fs::create_directories(parent);
  staging_ = parent / ("." + final_.filename().string() + ".partial-" + std::to_string(getpid()));
  fs::remove_all(staging_);
  fs::create_directories(staging_);
}

StagedOutput::~StagedOutput() {
  if (committed_) return;
  std::error_code ec;
  fs::remove_all(staging_, ec);
}

fs::path StagedOutput::path(const fs::path& relative) const {
  fs::path p = staging_ / relative;
  fs::create_directories(p.parent_path());
  return p;
}

void StagedOutput::commit() {
  fs::create_directories(final_);
  for (const auto& name : managed_) fs::remove_all(final_ / name);
  for (const auto& entry : fs::recursive_directory_iterator(staging_)) {
    const fs::path target = final_ / fs::relative(entry.path(), staging_);
    if (entry.is_directory()) {
      fs::create_directories(target);
    } else {
      fs::rename(entry.path(), target);
    }
  }
  fs::remove_all(staging_);
  committed_ = true;
}

void write_csv(const fs::path& file, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& rows) {
  std::ofstream out(file);
  if (!out) throw std::runtime_error("cannot write " + file.string());
  for (std::size_t i = 0; i < header.size(); ++i) out << (i ? "," : "") << header[i];
  out << "\n" << std::setprecision(12);
  for (const auto& row : rows) {
    for (std::size_t i = 0; i < row.size(); ++i) {
      if (!std::isfinite(row[i]))
        throw std::runtime_error("refusing to write a non-finite value to " + file.string() +
                                 " (column " + header[i] + ")");
      out << (i ? "," : "") << row[i];
    }
    out << "\n";
  }
  if (!out) throw std::runtime_error("error while writing " + file.string());
}

void write_json(const fs::path& file, const nlohmann::json& document) {
  std::ofstream out(file);
  if (!out) throw std::runtime_error("cannot write " + file.string());
  // Text that is not UTF-8 (a file name, a plugin's message) is replaced, not thrown on.
  out << document.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
}

void write_text(const fs::path& file, const std::string& text) {
  std::ofstream out(file);
  if (!out) throw std::runtime_error("cannot write " + file.string());
  out << text;
}

bool run_gnuplot(const fs::path& script) {
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    spdlog::warn("gnuplot not found: kept {} but made no PNG", script.filename().string());
    return false;
  }
  const std::string command = "cd '" + script.parent_path().string() + "' && gnuplot '" +
                              script.filename().string() + "' 2>/dev/null";
  if (std::system(command.c_str()) != 0) {
    spdlog::warn("gnuplot failed on {}", script.string());
    return false;
  }
  return true;
}

}  // namespace frichb::core
