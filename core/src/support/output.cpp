#include "frichb/core/support/output.hpp"

#include <fcntl.h>
#include <linux/magic.h>
#include <spawn.h>
#include <spdlog/spdlog.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/statfs.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <mutex>
#include <sstream>
#include <thread>

#include "frichb/core/support/interrupt.hpp"

extern char** environ;  // NOLINT(readability-redundant-declaration): POSIX, for posix_spawn

namespace frichb::core {

namespace fs = std::filesystem;

namespace {

// The staging folders of the live StagedOutputs with their final folders, so that a write
// error names the file the user asked for (a study's runs stage on several threads).
struct StagingFolder {
  fs::path staging, final;
};
std::mutex& staging_mutex() {
  static std::mutex m;
  return m;
}
std::vector<StagingFolder>& staging_folders() {
  static std::vector<StagingFolder> folders;
  return folders;
}
void register_staging(const fs::path& staging, const fs::path& final) {
  const std::lock_guard lock(staging_mutex());
  staging_folders().push_back({staging, final});
}
void unregister_staging(const fs::path& staging) noexcept {
  const std::lock_guard lock(staging_mutex());
  auto& folders = staging_folders();
  std::erase_if(folders, [&](const StagingFolder& f) { return f.staging == staging; });
}
// A path as the user knows it: a file being staged is named by its place in the final
// folder, with the staging folder it is written in.
std::string shown_path(const fs::path& p) {
  const std::lock_guard lock(staging_mutex());
  for (const StagingFolder& f : staging_folders()) {
    const fs::path relative = p.lexically_relative(f.staging);
    if (relative.empty() || *relative.begin() == "..") continue;
    const fs::path final = relative == "." ? f.final : f.final / relative;
    return final.string() + " (staged in " + f.staging.string() + ")";
  }
  return p.string();
}

std::string system_reason(int error) {
  return std::strerror(error);
}

// Disk full, quota, I/O errors are the system's; permissions and wrong kinds of path are the
// user's.
bool is_user_errno(int error) {
  return error == EACCES || error == EPERM || error == EROFS || error == ENOTDIR ||
         error == EISDIR || error == ENAMETOOLONG || error == EEXIST;
}
// While the output folder is prepared, before any work, a failure says the place cannot hold
// the results; only a full disk or a failing device is the system's.
bool is_system_errno(int error) {
  return error == ENOSPC || error == EDQUOT || error == EIO || error == ENOMEM;
}

// The kernel's pseudo file systems: their folders hold no results (and cannot be swapped).
const char* pseudo_file_system(const fs::path& p) {
  struct statfs s {};
  if (::statfs(p.c_str(), &s) != 0) return nullptr;
  static constexpr struct {
    unsigned long magic;
    const char* name;
  } kPseudo[] = {{PROC_SUPER_MAGIC, "proc"},
                 {SYSFS_MAGIC, "sysfs"},
                 {CGROUP_SUPER_MAGIC, "cgroup"},
                 {CGROUP2_SUPER_MAGIC, "cgroup2"},
                 {DEBUGFS_MAGIC, "debugfs"},
                 {TRACEFS_MAGIC, "tracefs"},
                 {SECURITYFS_MAGIC, "securityfs"},
                 {DEVPTS_SUPER_MAGIC, "devpts"},
                 {BPF_FS_MAGIC, "bpf"},
                 {PSTOREFS_MAGIC, "pstore"},
                 {EFIVARFS_MAGIC, "efivarfs"},
                 {SELINUX_MAGIC, "selinuxfs"},
                 {BINFMTFS_MAGIC, "binfmt_misc"},
                 {NSFS_MAGIC, "nsfs"}};
  const auto type = static_cast<unsigned long>(s.f_type) & 0xffffffffUL;
  for (const auto& fs_kind : kPseudo)
    if (type == fs_kind.magic) return fs_kind.name;
  return nullptr;
}

// The identity of a file or folder (not followed when it is a link): device and inode. A
// rename keeps it; a copy, an archive's extraction or a new file of the same name does not.
std::string identity_of(const fs::path& p) {
  struct stat s {};
  if (::lstat(p.c_str(), &s) != 0) return {};
  return std::to_string(static_cast<unsigned long long>(s.st_dev)) + ":" +
         std::to_string(static_cast<unsigned long long>(s.st_ino));
}

// The top-level names recorded in `folder`'s manifest by the run that wrote it that are still
// the very entries it wrote (same identity): none when the folder has no readable manifest (a
// folder of the user's, or one written before manifests), and never an entry that a manifest
// copied or written by hand names, nor one the user made anew under a written name.
std::vector<std::string> written_by(const fs::path& folder) {
  std::ifstream in(folder / std::string(StagedOutput::kManifest));
  if (!in) return {};
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  std::vector<std::string> names;
  if (!doc.is_object() || !doc.contains("written") || !doc.at("written").is_array()) return names;
  for (const auto& entry : doc.at("written")) {
    if (!entry.is_object() || !entry.contains("name") || !entry.contains("identity") ||
        !entry.at("name").is_string() || !entry.at("identity").is_string())
      continue;
    const std::string name = entry.at("name").get<std::string>();
    if (name.empty() || name.find('/') != std::string::npos || name == "." || name == "..")
      continue;
    const std::string identity = identity_of(folder / name);
    if (!identity.empty() && identity == entry.at("identity").get<std::string>())
      names.push_back(name);
  }
  return names;
}

void fsync_path(const fs::path& p, bool directory) {
  const int fd = ::open(p.c_str(), (directory ? O_RDONLY | O_DIRECTORY : O_RDONLY) | O_CLOEXEC);
  if (fd < 0) {
    const int e = errno;
    throw OutputError("cannot open " + shown_path(p) + " to sync it: " + system_reason(e),
                      is_user_errno(e));
  }
  const int rc = ::fsync(fd);
  const int e = errno;
  ::close(fd);
  // Some file systems cannot sync a folder (EINVAL); their data is still synced file by file.
  if (rc != 0 && !(directory && e == EINVAL))
    throw OutputError("cannot sync " + shown_path(p) + " to the disk: " + system_reason(e), false);
}

// fsync of every file and folder below `root` (and of `root`), children before parents.
void sync_tree(const fs::path& root) {
  std::vector<fs::path> folders = {root};
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (entry.is_symlink()) continue;
    if (entry.is_directory())
      folders.push_back(entry.path());
    else if (entry.is_regular_file())
      fsync_path(entry.path(), false);
  }
  for (auto it = folders.rbegin(); it != folders.rend(); ++it) fsync_path(*it, true);
}

void rename_or_throw(const fs::path& from, const fs::path& to) {
  if (std::rename(from.c_str(), to.c_str()) != 0) {
    const int e = errno;
    throw OutputError(
        "cannot move " + from.string() + " to " + to.string() + ": " + system_reason(e), false);
  }
}

struct FileId {
  dev_t device = 0;
  ino_t inode = 0;
  bool valid = false;
  bool operator==(const FileId& o) const {
    return valid && o.valid && device == o.device && inode == o.inode;
  }
};
FileId file_id(const fs::path& p) {
  struct stat s {};
  if (::stat(p.c_str(), &s) != 0) return {};
  return {s.st_dev, s.st_ino, true};
}

// What a run records in its lock file, for the next run to recover from a kill: the staging
// folder's name and identity (after the swap the output folder has that identity).
struct LockRecord {
  std::string staging;
  FileId staging_id;
};
LockRecord read_lock_record(int fd) {
  std::string text;
  char buffer[512];
  ::lseek(fd, 0, SEEK_SET);
  for (ssize_t got; (got = ::read(fd, buffer, sizeof buffer)) > 0;)
    text.append(buffer, static_cast<std::size_t>(got));
  LockRecord record;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {  // "key value", the value to the end of the line
    const auto space = line.find(' ');
    if (space == std::string::npos) continue;
    const std::string key = line.substr(0, space), value = line.substr(space + 1);
    if (key == "staging") {
      record.staging = value;
    } else if (key == "id") {
      std::istringstream numbers(value);
      unsigned long long device = 0, inode = 0;
      numbers >> device >> inode;
      record.staging_id = {static_cast<dev_t>(device), static_cast<ino_t>(inode), bool(numbers)};
    }
  }
  return record;
}
void write_lock_record(int fd, const fs::path& lock_file, const std::string& staging,
                       const FileId& id) {
  std::ostringstream text;
  text << "pid " << ::getpid() << "\nstaging " << staging << "\nid "
       << static_cast<unsigned long long>(id.device) << " "
       << static_cast<unsigned long long>(id.inode) << "\n";
  const std::string s = text.str();
  if (::ftruncate(fd, 0) != 0 ||
      ::pwrite(fd, s.data(), s.size(), 0) != static_cast<ssize_t>(s.size()) || ::fsync(fd) != 0) {
    const int e = errno;
    throw OutputError("cannot write the lock file " + lock_file.string() + ": " + system_reason(e),
                      is_user_errno(e));
  }
}

// Moves the entries of `old_folder` that `final_folder` lacks, that are not `managed` and that
// the run which wrote `old_folder` did not record in its manifest into `final_folder` (a
// user's files beside the results), as far as it can. True when none is left behind in
// `old_folder`.
bool move_unmanaged(const fs::path& old_folder, const fs::path& final_folder,
                    std::vector<std::string> managed) noexcept {
  bool all = true;
  std::error_code ec;
  try {
    for (std::string& name : written_by(old_folder)) managed.push_back(std::move(name));
  } catch (const std::exception& e) {  // out of memory: nothing of the old set is moved back
    spdlog::warn("cannot read the manifest of {}: {}", old_folder.string(), e.what());
    return false;
  }
  for (fs::directory_iterator it(old_folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (std::find(managed.begin(), managed.end(), name) != managed.end()) continue;
    std::error_code exists;
    if (fs::exists(fs::symlink_status(final_folder / name, exists))) continue;
    if (std::rename(it->path().c_str(), (final_folder / name).c_str()) != 0) {
      spdlog::warn("cannot move {} back into {}: {}", it->path().string(), final_folder.string(),
                   system_reason(errno));
      all = false;
    }
  }
  return all && !ec;
}

bool remove_quietly(const fs::path& p) {
  std::error_code ec;
  fs::remove_all(p, ec);
  return !ec;
}

}  // namespace

fs::path StagedOutput::checked_place(const fs::path& final_directory) {
  std::error_code ec;
  fs::path place;
  place = fs::absolute(final_directory, ec).lexically_normal();
  if (ec || place.empty())
    throw OutputError("output folder '" + final_directory.string() + "': not a usable path", true);
  if (!place.has_filename()) place = place.parent_path();  // "out/" -> "out"
  if (place == place.root_path() || place.filename() == "..")
    throw OutputError("output folder '" + final_directory.string() +
                          "': give a folder of its own, e.g. -o out/run1",
                      true);
  if (fs::is_symlink(fs::symlink_status(place, ec)))
    throw OutputError("output folder '" + final_directory.string() +
                          "' is a symbolic link: give the folder it points to",
                      true);
  const fs::path cwd = fs::current_path(ec);
  if (!ec) {
    const fs::path rel =
        fs::weakly_canonical(cwd, ec).lexically_relative(fs::weakly_canonical(place, ec));
    if (!rel.empty() && *rel.begin() != "..")
      throw OutputError("output folder '" + final_directory.string() +
                            "' contains the current folder, which the results would replace: "
                            "choose another folder, e.g. -o out/run1",
                        true);
  }
  if (fs::exists(fs::symlink_status(place, ec)) && !fs::is_directory(place, ec))
    throw OutputError("output folder '" + final_directory.string() +
                          "' exists and is not a folder: choose another path with -o",
                      true);
  check_location(place, final_directory.string());
  return place;
}

StagedOutput::StagedOutput(const fs::path& final_directory, std::vector<std::string> managed,
                           StagingControl control)
    : final_(checked_place(final_directory)),
      managed_(std::move(managed)),
      control_(std::move(control)) {
  std::error_code ec;
  const fs::path parent = final_.parent_path();
  // The folders on the way that do not exist yet, deepest first: made here, and removed again
  // when no output is committed (a refused input leaves no folder behind).
  for (fs::path p = parent;
       !p.empty() && p != p.root_path() && !fs::exists(fs::symlink_status(p, ec));
       p = p.parent_path())
    created_parents_.push_back(p);
  fs::create_directories(parent, ec);
  if (ec) {
    remove_created_parents();
    throw OutputError(
        "cannot create the folder " + parent.string() + " for the outputs: " + ec.message(), true);
  }
  try {
    take_lock_and_stage();
  } catch (...) {
    release_lock();
    remove_created_parents();
    throw;
  }
}

void StagedOutput::remove_created_parents() noexcept {
  for (const auto& folder : created_parents_) ::rmdir(folder.c_str());  // only when empty
  created_parents_.clear();
}

void StagedOutput::take_lock_and_stage() {
  std::error_code ec;
  const fs::path parent = final_.parent_path();
  const std::string name = final_.filename().string();
  lock_file_ = parent / ("." + name + ".lock");
  // The lock: flock on a file beside the folder (the folder itself is swapped by commit). A
  // lock file replaced between open and flock (a run finishing and removing it) is retried.
  for (int attempt = 0; attempt < 16 && lock_fd_ < 0; ++attempt) {
    const int fd = ::open(lock_file_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd < 0) {
      const int e = errno;
      throw OutputError("cannot write into " + parent.string() + " (lock file " +
                            lock_file_.filename().string() + "): " + system_reason(e),
                        true);
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int e = errno;
      ::close(fd);
      if (e == EWOULDBLOCK)
        throw OutputError("output folder " + final_.string() +
                              " is in use by another frichb run (it holds " + lock_file_.string() +
                              "): wait for that run, or write elsewhere with -o",
                          true);
      throw OutputError("cannot lock " + lock_file_.string() + ": " + system_reason(e), true);
    }
    struct stat held {};
    if (::fstat(fd, &held) == 0 && file_id(lock_file_) == FileId{held.st_dev, held.st_ino, true})
      lock_fd_ = fd;
    else
      ::close(fd);
  }
  if (lock_fd_ < 0)
    throw OutputError("cannot lock " + lock_file_.string() + ": it keeps being replaced", true);

  try {
    // Recovery from a run killed before or during its commit. Its staging folder is removed;
    // where the kill came after the swap, that folder holds the earlier results, and the files
    // of the user's among them are moved back first.
    const LockRecord dead = read_lock_record(lock_fd_);
    const std::string staging_prefix = "." + name + ".partial-";
    const std::string aside_prefix = "." + name + ".previous-";
    const FileId final_id = file_id(final_);
    for (const auto& entry : fs::directory_iterator(parent)) {
      const std::string entry_name = entry.path().filename().string();
      // Only "<prefix><pid>": the hidden files of a folder named like this one plus a suffix
      // (out.previous-x beside out) are that folder's, not debris of this one.
      auto pid_suffix = [&](const std::string& prefix) {
        return entry_name.size() > prefix.size() && entry_name.starts_with(prefix) &&
               std::all_of(entry_name.begin() + static_cast<std::ptrdiff_t>(prefix.size()),
                           entry_name.end(), [](char c) { return c >= '0' && c <= '9'; });
      };
      const bool staging = pid_suffix(staging_prefix);
      const bool aside = pid_suffix(aside_prefix);
      if (!staging && !aside) continue;
      const bool swapped = dead.staging_id.valid && final_id == dead.staging_id;
      if (aside && !fs::exists(final_)) {
        rename_or_throw(entry.path(), final_);
        spdlog::warn("{}: restored the earlier results that an interrupted run had moved aside",
                     final_.string());
        continue;
      }
      if (((staging && entry_name == dead.staging && swapped) || (aside && swapped)) &&
          !move_unmanaged(entry.path(), final_, managed_)) {
        keep_aside(entry.path());
        continue;
      }
      if (remove_quietly(entry.path()))
        spdlog::warn("{}: removed {} left by an interrupted run", final_.string(), entry_name);
      else
        spdlog::warn("{}: could not remove {} left by an interrupted run", final_.string(),
                     entry_name);
    }
    staging_ = parent / (staging_prefix + std::to_string(getpid()));
    fs::remove_all(staging_);
    fs::create_directories(staging_);
    // A file written and removed: the place takes files, before any work is done.
    write_file(staging_ / std::string(kManifest), "");
    fs::remove(staging_ / std::string(kManifest));
    write_lock_record(lock_fd_, lock_file_, staging_.filename().string(), file_id(staging_));
    register_staging(staging_, final_);
  } catch (const OutputError&) {
    release_lock();
    throw;
  } catch (const fs::filesystem_error& e) {
    release_lock();
    throw OutputError(
        "cannot prepare the output folder " + final_.string() + ": " + e.code().message(),
        !is_system_errno(e.code().value()));
  }
}

void StagedOutput::check_location(const fs::path& place, const std::string& given) {
  // The nearest folder that exists on the way to the output folder: where it would be made.
  fs::path existing = place;
  std::error_code ec;
  while (!fs::exists(fs::symlink_status(existing, ec)) && existing != existing.root_path())
    existing = existing.parent_path();
  if (const char* kind = pseudo_file_system(existing))
    throw OutputError("output folder '" + given + "' lies on the kernel's " + kind +
                          " file system (" + existing.string() +
                          "), which holds no results: choose another path with -o",
                      true);
  // Every name this output makes must fit the file system: its hidden names beside the folder
  // (the longest is .NAME.unrestored-PID) and, below the staging folder, a subfolder and a file
  // of the longest name the file system takes.
  long name_max = ::pathconf(existing.c_str(), _PC_NAME_MAX);
  if (name_max <= 0) name_max = NAME_MAX;
  constexpr std::size_t kHiddenExtra = 23;  // "." + NAME + ".unrestored-" + a pid of 10 digits
  const std::size_t longest_hidden = place.filename().string().size() + kHiddenExtra;
  if (longest_hidden > static_cast<std::size_t>(name_max))
    throw OutputError("output folder '" + given + "': its name is too long (" +
                          std::to_string(place.filename().string().size()) +
                          " characters; the hidden names beside it add up to " +
                          std::to_string(kHiddenExtra) + " to it and the file system takes " +
                          std::to_string(name_max) + "): choose a shorter name with -o",
                      true);
  const std::size_t longest_path =
      place.parent_path().string().size() + 1 + longest_hidden + 2 * (1 + name_max);
  if (longest_path >= PATH_MAX)
    throw OutputError("output folder '" + given + "': its path is too long (" +
                          std::to_string(place.string().size()) +
                          " characters; the files below it may add " +
                          std::to_string(longest_path - place.string().size()) +
                          " and the system takes paths of at most " + std::to_string(PATH_MAX - 1) +
                          "): choose a shorter path with -o",
                      true);
  // An existing folder: its files are moved between the earlier and the new set, and the
  // folder itself is renamed. The owner's write bit is checked as well as the access: root
  // may write where its owner has forbidden it.
  struct stat folder {};
  if (::stat(place.c_str(), &folder) != 0) return;
  char mode[8];
  std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(folder.st_mode & 07777));
  if ((folder.st_mode & S_IWUSR) == 0)
    throw OutputError("output folder '" + given + "' is write-protected (mode " + mode +
                          "): make it writable (chmod u+w) or choose another folder with -o",
                      true);
  if (::faccessat(AT_FDCWD, place.c_str(), W_OK | X_OK, AT_EACCESS) != 0) {
    const int e = errno;
    throw OutputError("output folder '" + given + "' is not writable (mode " + mode +
                          "): " + system_reason(e) + "; choose another folder with -o",
                      true);
  }
  struct stat above {};
  if (::stat(place.parent_path().c_str(), &above) == 0 && above.st_dev != folder.st_dev)
    throw OutputError("output folder '" + given +
                          "' is a mount point, which cannot be replaced by the new results: "
                          "give a folder inside it, e.g. -o " +
                          (fs::path(given) / "run1").string(),
                      true);
}

void StagedOutput::keep_aside(const fs::path& folder) const noexcept {
  const fs::path kept = final_.parent_path() / ("." + final_.filename().string() + ".unrestored-" +
                                                std::to_string(getpid()));
  if (std::rename(folder.c_str(), kept.c_str()) == 0)
    spdlog::warn(
        "{}: files of yours that were beside the earlier results could not be moved "
        "into the new ones; they are kept in {}",
        final_.string(), kept.string());
  else
    spdlog::warn("{}: files of yours that were beside the earlier results are kept in {}",
                 final_.string(), folder.string());
}

StagedOutput::~StagedOutput() {
  if (!staging_.empty()) unregister_staging(staging_);
  if (!committed_ && !staging_.empty()) remove_quietly(staging_);
  release_lock();
  if (!committed_) remove_created_parents();
}

void StagedOutput::release_lock() noexcept {
  if (lock_fd_ < 0) return;
  // Removed while held: a run that opened it before and locks it after this finds it replaced
  // (the identity check above) and tries again.
  ::unlink(lock_file_.c_str());
  ::close(lock_fd_);
  lock_fd_ = -1;
}

fs::path StagedOutput::path(const fs::path& relative) const {
  fs::path p = staging_ / relative;
  fs::create_directories(p.parent_path());
  return p;
}

void StagedOutput::commit() {
  // A stop while the set was written (gnuplot runs a while): nothing is committed.
  control_.stop.throw_if_stopped();
  const auto step_done = [this](std::string_view step) {
    if (control_.commit_hook) control_.commit_hook(step);
  };
  const fs::path parent = final_.parent_path();
  // Every top-level name of the new set is the writer's to replace, and is recorded for the
  // next run into the folder to remove.
  // Each with its identity, which the swap's renames keep: the next run removes an entry only
  // while it is the one written here.
  std::vector<std::pair<std::string, std::string>> written;
  for (const auto& entry : fs::directory_iterator(staging_)) {
    std::string name = entry.path().filename().string();
    if (name == kManifest) continue;
    if (std::find(managed_.begin(), managed_.end(), name) == managed_.end())
      managed_.push_back(name);
    written.emplace_back(name, identity_of(entry.path()));
  }
  std::sort(written.begin(), written.end());
  nlohmann::json list = nlohmann::json::array();
  for (const auto& [name, identity] : written)
    list.push_back({{"name", name}, {"identity", identity}});
  write_json(staging_ / std::string(kManifest), nlohmann::json{{"written", list}});
  managed_.emplace_back(kManifest);
  sync_tree(staging_);
  step_done("synced");
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(final_, ec))) {
    rename_or_throw(staging_, final_);
    committed_ = true;
    fsync_path(parent, true);
    step_done("swapped");
    release_lock();
    return;
  }
  fs::path old_set = staging_;
  if (control_.without_exchange ||
      ::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, final_.c_str(), RENAME_EXCHANGE) != 0) {
    const int e = control_.without_exchange ? EINVAL : errno;
    if (e != EINVAL && e != ENOSYS && e != ENOTSUP)
      throw OutputError(
          "cannot swap " + staging_.string() + " and " + final_.string() + ": " + system_reason(e),
          false);
    // No atomic exchange on this file system: move the old folder aside first; the next run
    // into the folder puts it back if this one is killed in between.
    old_set = parent / ("." + final_.filename().string() + ".previous-" + std::to_string(getpid()));
    rename_or_throw(final_, old_set);
    try {
      step_done("moved_aside");
      rename_or_throw(staging_, final_);
    } catch (...) {
      std::rename(old_set.c_str(), final_.c_str());
      throw;
    }
  }
  // From here the new set is in place: finish what remains even if a step fails.
  committed_ = true;
  try {
    fsync_path(parent, true);
    step_done("swapped");
    if (!move_unmanaged(old_set, final_, managed_)) {
      keep_aside(old_set);
    } else {
      step_done("kept_unmanaged");
      fs::remove_all(old_set);
      step_done("removed_old");
    }
  } catch (...) {
    std::error_code missing;
    if (fs::exists(old_set, missing)) {
      if (move_unmanaged(old_set, final_, managed_))
        remove_quietly(old_set);
      else
        keep_aside(old_set);
    }
    release_lock();
    throw;
  }
  release_lock();
}

void write_file(const fs::path& file, std::string_view bytes) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    const int e = errno;
    throw OutputError("cannot create " + shown_path(file) + ": " + system_reason(e),
                      is_user_errno(e));
  }
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t wrote = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (wrote < 0 && errno == EINTR) continue;
    if (wrote <= 0) {
      const int e = wrote < 0 ? errno : ENOSPC;
      ::close(fd);
      throw OutputError("cannot write " + shown_path(file) + " (" + std::to_string(done) + " of " +
                            std::to_string(bytes.size()) + " bytes written): " + system_reason(e),
                        false);
    }
    done += static_cast<std::size_t>(wrote);
  }
  if (::close(fd) != 0) {
    const int e = errno;
    throw OutputError("cannot write " + shown_path(file) + " (on close): " + system_reason(e),
                      false);
  }
}

void write_csv(const fs::path& file, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& rows) {
  std::ostringstream out;
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
  write_file(file, out.str());
}

void write_json(const fs::path& file, const nlohmann::json& document) {
  // Text that is not UTF-8 (a file name, a plugin's message) is replaced, not thrown on.
  write_file(file, document.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

void write_text(const fs::path& file, const std::string& text) {
  write_file(file, text);
}

std::string gnuplot_string(std::string_view text) {
  std::string out;
  bool open = false;  // inside a single-quoted run
  for (const char ch : text) {
    const auto byte = static_cast<unsigned char>(ch);
    if (byte < 0x20 || byte == 0x7f || ch == '\'') {
      if (open) out += "'";
      open = false;
      char escape[8];
      std::snprintf(escape, sizeof escape, "\"\\%03o\"", byte);
      out += (out.empty() ? "" : ".") + std::string(escape);
      continue;
    }
    if (!open) {
      out += out.empty() ? "'" : ".'";
      open = true;
    }
    out += ch;
  }
  if (open) out += "'";
  return out.empty() ? "''" : out;
}

namespace {

// The gnuplot executable on PATH, or empty.
std::string find_on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::istringstream folders(path && *path ? path : "/usr/local/bin:/usr/bin:/bin");
  std::string folder;
  while (std::getline(folders, folder, ':')) {
    if (folder.empty()) continue;  // an empty entry would be the current folder: not searched
    const fs::path candidate = fs::path(folder) / program;
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec) && ::access(candidate.c_str(), X_OK) == 0)
      return candidate.string();
  }
  return {};
}

}  // namespace

bool run_gnuplot(const fs::path& script, const StopToken& stop) {
  const std::string gnuplot = find_on_path("gnuplot");
  if (gnuplot.empty()) {
    spdlog::warn("gnuplot not found on PATH: kept {} but made no PNG", script.filename().string());
    return false;
  }
  if (stop.stop_requested()) return false;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  const std::string folder = script.has_parent_path() ? script.parent_path().string() : ".";
  posix_spawn_file_actions_addchdir_np(&actions, folder.c_str());
  // "./name": a script name is never read as an option.
  std::string argument = "./" + script.filename().string();
  std::string program = gnuplot;
  char* argv[] = {program.data(), argument.data(), nullptr};
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, gnuplot.c_str(), &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    spdlog::warn("cannot start gnuplot for {}: {}", script.string(), system_reason(spawned));
    return false;
  }
  int status = 0;
  while (true) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    if (done < 0 && errno != EINTR) {
      spdlog::warn("lost track of gnuplot on {}: {}", script.string(), system_reason(errno));
      return false;
    }
    if (stop.stop_requested()) {
      ::kill(pid, SIGTERM);
      while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
      }
      return false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    spdlog::warn("gnuplot failed on {} ({})", script.string(),
                 WIFEXITED(status) ? "exit code " + std::to_string(WEXITSTATUS(status))
                                   : "signal " + std::to_string(WTERMSIG(status)));
    return false;
  }
  return true;
}

}  // namespace frichb::core
