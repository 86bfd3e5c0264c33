// Writers: CSV tables, JSON documents and gnuplot plots, staged so that the output folder
// holds either the whole earlier set of results or the whole new one, never a mix and never
// a half-written file.
//
// A StagedOutput owns one output folder for the time of a run. Before it creates anything it
// refuses (OutputError, user_error) a place that cannot hold the results: a path on one of
// the kernel's pseudo file systems (/proc, /sys, ...), a folder without its owner's write bit
// (refused for root too, who could write there), a folder the process cannot write, a mount
// point, and a path too long for the hidden names beside the folder or for a subfolder and a
// file of the file system's longest name (NAME_MAX) below it within PATH_MAX. It then takes
// an advisory lock (`.NAME.lock` beside the folder; a second run into the same folder is
// refused), removes the staging that an earlier, killed run left there, creates a hidden
// staging folder `.NAME.partial-PID` beside the output folder, writes a file into it as a
// probe, and gives paths inside it. commit() records the top-level names of the new set in
// the manifest `.frichb-written.json` inside it, syncs every staged file and folder to the
// disk and swaps the staging folder with the output folder in one rename (renameat2
// RENAME_EXCHANGE; where the file system lacks it, the old folder is first moved aside and
// restored by the next run if the commit is interrupted). The entries of the earlier set that
// the writer manages, that the new set holds, or that the earlier set's manifest lists (its
// own results) are removed with it; every other entry (a user's notes) is moved into the new
// folder. A StagedOutput destroyed before commit() removes its staging folder and the folders
// it made on the way to the output folder (those still empty), and leaves the output folder as
// it was.
//
// Every write is checked after it is flushed and closed; a failure throws OutputError.
// Threading: one StagedOutput per thread; distinct output folders may be staged concurrently.
#pragma once

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "frichb/core/support/interrupt.hpp"

namespace frichb::core {

// A failure to write the outputs. `user_error`: the output path itself is wrong (a file where
// a folder is expected, a folder without write permission, a folder in use by another run);
// otherwise the system failed while writing (disk full, I/O error).
class OutputError : public std::runtime_error {
 public:
  OutputError(const std::string& what, bool user_error)
      : std::runtime_error(what), user_error_(user_error) {}
  bool user_error() const { return user_error_; }

 private:
  bool user_error_;
};

// What a staged output is told besides its place.
struct StagingControl {
  // The call's stop token (support/interrupt.hpp): once a stop is requested, commit() refuses
  // and run_gnuplot, given stop(), ends its child.
  StopToken stop;
  // Test seam: called with the name of each step of commit() ("synced", "moved_aside",
  // "swapped", "kept_unmanaged", "removed_old") after it is done. A hook that throws simulates
  // a failure there; one that calls _exit simulates a kill.
  std::function<void(std::string_view step)> commit_hook;
  // Test seam: take the move-aside path of file systems without RENAME_EXCHANGE.
  bool without_exchange = false;

  StagingControl() = default;
  explicit StagingControl(StopToken stop_token) : stop(std::move(stop_token)) {}
};

class StagedOutput {
 public:
  // The manifest a committed set keeps in the output folder:
  // {"written": [{"name": top-level name, "identity": "device:inode"}, ...]}; the next set
  // removes a listed entry only while its identity is the recorded one.
  static constexpr std::string_view kManifest = ".frichb-written.json";

  // `managed`: top-level names (files or folders) this output owns in the final folder; the
  // new set replaces them and the names the earlier set's manifest lists, and everything else
  // in the final folder is kept. Throws OutputError (user_error) when the place cannot hold
  // the results (above), when the folder is in use by another run or cannot be created.
  StagedOutput(const std::filesystem::path& final_directory, std::vector<std::string> managed,
               StagingControl control = {});
  ~StagedOutput();
  StagedOutput(const StagedOutput&) = delete;
  StagedOutput& operator=(const StagedOutput&) = delete;

  // Path of `relative` inside the staging folder (parent folders are created).
  std::filesystem::path path(const std::filesystem::path& relative) const;
  const std::filesystem::path& final_directory() const { return final_; }
  // The stop token of the call this output belongs to (StagingControl::stop).
  const StopToken& stop() const { return control_.stop; }
  // Syncs the staged files and replaces the managed names of the final folder with them.
  // Throws OutputError; the final folder then holds the earlier set or, where the failure
  // came after the swap, the new one. Throws Interrupted (support/interrupt.hpp), committing
  // nothing, when a stop was requested on stop().
  void commit();

 private:
  // The checks of the place made before anything is created (above): the output folder's
  // absolute path. `given`: the path as the user wrote it, for the messages.
  static std::filesystem::path checked_place(const std::filesystem::path& given);
  static void check_location(const std::filesystem::path& place, const std::string& given);
  void release_lock() noexcept;
  // The lock, the recovery of a killed run's leftovers and the staging folder (constructor).
  void take_lock_and_stage();
  // Removes the folders the constructor made on the way to the output folder (when empty).
  void remove_created_parents() noexcept;
  // Renames `folder` (an old set holding files of the user's that could not be moved back) to
  // `.NAME.unrestored-PID`, which no later run removes, and says where.
  void keep_aside(const std::filesystem::path& folder) const noexcept;
  std::filesystem::path final_, staging_, lock_file_;
  std::vector<std::string> managed_;
  StagingControl control_;
  std::vector<std::filesystem::path> created_parents_;  // deepest first
  int lock_fd_ = -1;
  bool committed_ = false;
};

// Writes `bytes` to `file` (created or truncated), checking every write and the close.
// Throws OutputError naming the file and the system's reason.
void write_file(const std::filesystem::path& file, std::string_view bytes);
// Writes a CSV with a header row. Throws std::runtime_error if any value is NaN or Inf
// (an output file never holds them), OutputError if the file cannot be written.
void write_csv(const std::filesystem::path& file, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& rows);
void write_json(const std::filesystem::path& file, const nlohmann::json& document);
void write_text(const std::filesystem::path& file, const std::string& text);

// `text` as a gnuplot string expression that gnuplot reads back byte for byte: single-quoted
// runs (no substitution of any kind inside them) joined by `.` to double-quoted octal escapes
// for single quotes and control characters. For titles, labels, file and column names.
std::string gnuplot_string(std::string_view text);

// Runs gnuplot on `script` in the script's folder, without a shell (posix_spawn with the
// script's name as the only argument; stdin, stdout and stderr on /dev/null). Returns false
// (and warns) when gnuplot is not on PATH or fails, and when a stop is requested on `stop`
// (before it starts, or while it runs: the child is then terminated).
bool run_gnuplot(const std::filesystem::path& script, const StopToken& stop);

}  // namespace frichb::core
