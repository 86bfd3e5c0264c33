// Writers: CSV tables, JSON documents and gnuplot plots, staged so that a failed run leaves
// no half-written output. Files are written into a hidden staging folder beside the output
// folder and moved into place by commit(); a StagedOutput destroyed before commit() removes
// its staging folder.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace frichb::core {

class StagedOutput {
 public:
  // `managed`: top-level names (files or folders) this output owns in the final folder;
  // commit() removes them there first, so nothing of an earlier run is left beside the new
  // files. Other files in the final folder are never touched.
  StagedOutput(std::filesystem::path final_directory, std::vector<std::string> managed);
  ~StagedOutput();
  StagedOutput(const StagedOutput&) = delete;
  StagedOutput& operator=(const StagedOutput&) = delete;

  // Path of `relative` inside the staging folder (parent folders are created).
  std::filesystem::path path(const std::filesystem::path& relative) const;
  const std::filesystem::path& final_directory() const { return final_; }
  // Moves every staged file into the final folder (replacing files of the same name).
  void commit();

 private:
  std::filesystem::path final_, staging_;
  std::vector<std::string> managed_;
  bool committed_ = false;
};

// Writes a CSV with a header row. Throws std::runtime_error if any value is NaN or Inf
// (an output file never holds them) or the file cannot be written.
void write_csv(const std::filesystem::path& file, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& rows);
void write_json(const std::filesystem::path& file, const nlohmann::json& document);
void write_text(const std::filesystem::path& file, const std::string& text);
// Runs gnuplot on `script` in its folder; false (and a warning) when gnuplot is missing
// or fails.
bool run_gnuplot(const std::filesystem::path& script);

}  // namespace frichb::core
