// The writers and the staged output folder: checked writes, the swap of the whole result set,
// recovery after a failure or a kill at every step of the commit, the lock against a second
// run, and gnuplot strings that gnuplot reads back byte for byte without running anything.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <climits>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "frichb/core/support/output.hpp"

namespace {

namespace fs = std::filesystem;
using frichb::core::gnuplot_string;
using frichb::core::Interrupted;
using frichb::core::OutputError;
using frichb::core::run_gnuplot;
using frichb::core::StagedOutput;
using frichb::core::StagingControl;
using frichb::core::StopSource;
using frichb::core::StopToken;
using frichb::core::write_file;

class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "frichb-output-XXXXXX").string();
    if (!mkdtemp(pattern.data())) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::string read_text(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Every file below `folder` (relative path -> content), hidden ones included.
// The record of the top-level names a set wrote, in the folder beside them, with each entry's
// identity (device and inode, which differ from run to run).
const std::string kManifest = ".frichb-written.json";

// A manifest as "written: NAME NAME ..." (its names in order; an entry without an identity
// shows as "?NAME").
std::string manifest_names(const std::string& text) {
  const auto doc = nlohmann::json::parse(text);
  std::string out = "written:";
  for (const auto& entry : doc.at("written"))
    out += " " + std::string(entry.value("identity", std::string()).empty() ? "?" : "") +
           entry.at("name").get<std::string>();
  return out;
}

// Every regular file below `folder` with its text (the manifest by its names).
std::map<std::string, std::string> snapshot(const fs::path& folder) {
  std::map<std::string, std::string> files;
  if (!fs::exists(folder)) return files;
  for (const auto& e : fs::recursive_directory_iterator(folder))
    if (e.is_regular_file()) {
      const std::string name = fs::relative(e.path(), folder).string();
      files[name] = name == kManifest ? manifest_names(read_text(e.path())) : read_text(e.path());
    }
  return files;
}

// Names beside the output folder other than the folder itself (staging, aside, lock files).
std::vector<std::string> leftovers(const fs::path& parent, const std::string& name) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(parent)) {
    const std::string n = e.path().filename().string();
    if (n != name && n.find(name) != std::string::npos) out.push_back(n);
  }
  return out;
}

const std::vector<std::string> kManaged = {"summary.json", "response.csv", "loops"};

// Writes one result set ("A" or "B") into a staged output of `folder` and commits it. Set B
// has no loops folder, so a stale loops/ of set A must not survive it.
void write_set(const fs::path& folder, const std::string& tag, StagingControl control = {}) {
  StagedOutput out(folder, kManaged, std::move(control));
  write_file(out.path("summary.json"), "{\"set\": \"" + tag + "\"}\n");
  write_file(out.path("response.csv"), "point,set\n0," + tag + "\n");
  if (tag == "A") write_file(out.path("loops/c_1.csv"), "loop of " + tag + "\n");
  out.commit();
}

std::string manifest_of(const std::vector<std::string>& names) {
  std::string out = "written:";
  for (const auto& name : names) out += " " + name;
  return out;
}

std::map<std::string, std::string> expected_set(const std::string& tag) {
  std::map<std::string, std::string> files = {{"summary.json", "{\"set\": \"" + tag + "\"}\n"},
                                              {"response.csv", "point,set\n0," + tag + "\n"}};
  if (tag == "A") files["loops/c_1.csv"] = "loop of A\n";
  files[kManifest] =
      manifest_of(tag == "A" ? std::vector<std::string>{"loops", "response.csv", "summary.json"}
                             : std::vector<std::string>{"response.csv", "summary.json"});
  return files;
}

// Set A and a user's file beside it.
fs::path prepare_folder(const TempDir& dir, const std::string& name = "out") {
  const fs::path folder = dir.path() / name;
  write_set(folder, "A");
  write_file(folder / "notes.txt", "mine\n");
  return folder;
}

TEST(StagedOutput, CommitReplacesTheManagedSetAndKeepsTheUsersFiles) {
  TempDir dir;
  const fs::path folder = prepare_folder(dir);
  auto expected = expected_set("A");
  expected["notes.txt"] = "mine\n";
  EXPECT_EQ(snapshot(folder), expected);
  write_set(folder, "B");
  expected = expected_set("B");
  expected["notes.txt"] = "mine\n";
  EXPECT_EQ(snapshot(folder), expected);
  EXPECT_TRUE(leftovers(dir.path(), "out").empty());
}

// A name the writer does not list as managed (a folder of results only some runs write) is
// still the earlier run's: the next set removes it, and keeps the user's files and folders.
TEST(StagedOutput, CommitRemovesEveryNameTheEarlierSetWrote) {
  TempDir dir;
  const fs::path folder = dir.path() / "out";
  {
    StagedOutput out(folder, kManaged);
    write_file(out.path("summary.json"), "A\n");
    write_file(out.path("contact_states/290Hz_1.csv"), "states of A\n");
    out.commit();
  }
  write_file(folder / "notes.txt", "mine\n");
  fs::create_directories(folder / "mine");
  write_file(folder / "mine" / "plot.txt", "my plot\n");
  {
    StagedOutput out(folder, kManaged);
    write_file(out.path("summary.json"), "B\n");
    out.commit();
  }
  const std::map<std::string, std::string> expected = {{"summary.json", "B\n"},
                                                       {"notes.txt", "mine\n"},
                                                       {"mine/plot.txt", "my plot\n"},
                                                       {kManifest, manifest_of({"summary.json"})}};
  EXPECT_EQ(snapshot(folder), expected);
  EXPECT_TRUE(leftovers(dir.path(), "out").empty());
}

// A manifest that is not the one the run wrote beside its entries - copied with a folder, taken
// from an archive, written by hand: the entries it names are the user's, and the next run
// keeps them; names with a '/' or "..", which the run never writes, are never followed.
TEST(StagedOutput, OnlyTheEntriesTheEarlierRunWroteAreRemoved) {
  TempDir dir;
  const auto write_with_states = [](const fs::path& folder, const std::string& tag) {
    StagedOutput out(folder, kManaged);
    write_file(out.path("summary.json"), tag + "\n");
    if (tag == "A") write_file(out.path("contact_states/290Hz_1.csv"), "states of A\n");
    out.commit();
  };
  const fs::path results = dir.path() / "results";
  write_with_states(results, "A");
  const fs::path copied = dir.path() / "copied";
  fs::copy(results, copied, fs::copy_options::recursive);  // new inodes, the same manifest
  write_file(copied / "data.csv", "mine\n");
  const fs::path hand = dir.path() / "hand";
  fs::create_directories(hand);
  write_file(hand / kManifest,
             R"({"written": [{"name": "data.csv", "identity": "1:1"}, {"name": "..", )"
             R"("identity": "1:2"}, {"name": "../results", "identity": "1:3"}]})");
  write_file(hand / "data.csv", "mine too\n");
  write_with_states(copied, "B");
  write_with_states(hand, "B");
  EXPECT_EQ(read_text(copied / "data.csv"), "mine\n");
  EXPECT_EQ(read_text(copied / "contact_states" / "290Hz_1.csv"), "states of A\n")
      << "a copy's contact_states/ is not the run's own";
  EXPECT_EQ(read_text(hand / "data.csv"), "mine too\n");
  EXPECT_EQ(read_text(results / "contact_states" / "290Hz_1.csv"), "states of A\n")
      << "a name outside the folder was followed";
  // The run's own folder: its contact_states/ goes.
  write_with_states(results, "B");
  EXPECT_FALSE(fs::exists(results / "contact_states"));
  EXPECT_EQ(read_text(results / "summary.json"), "B\n");
}

TEST(StagedOutput, DestroyedBeforeCommitLeavesTheFolderAsItWas) {
  TempDir dir;
  const fs::path folder = prepare_folder(dir);
  const auto before = snapshot(folder);
  {
    StagedOutput out(folder, kManaged);
    write_file(out.path("summary.json"), "half");
  }
  EXPECT_EQ(snapshot(folder), before);
  EXPECT_TRUE(leftovers(dir.path(), "out").empty());
}

// A failure at each step of the commit: the folder holds the whole earlier set (failure
// before the swap) or the whole new one (after it), the user's file in both cases, and
// nothing is left beside it.
TEST(StagedOutput, AFailureAtEveryStepOfTheCommitLeavesOneWholeSet) {
  for (const bool exchange : {true, false}) {
    for (const std::string step :
         {"synced", "moved_aside", "swapped", "kept_unmanaged", "removed_old"}) {
      if (exchange && step == "moved_aside") continue;  // a step of the fallback only
      SCOPED_TRACE(step + (exchange ? " (exchange)" : " (move aside)"));
      TempDir dir;
      const fs::path folder = prepare_folder(dir);
      StagingControl control;
      control.commit_hook = [step](std::string_view at) {
        if (at == step) throw OutputError("injected failure at " + step, false);
      };
      control.without_exchange = !exchange;
      EXPECT_THROW(write_set(folder, "B", control), OutputError);
      const bool before_swap = step == "synced" || step == "moved_aside";
      auto expected = expected_set(before_swap ? "A" : "B");
      expected["notes.txt"] = "mine\n";
      EXPECT_EQ(snapshot(folder), expected);
      EXPECT_TRUE(leftovers(dir.path(), "out").empty()) << leftovers(dir.path(), "out").front();
    }
  }
}

// A kill (the child process ends at the step without any cleanup): right after it the folder
// holds one whole set (or, in the move-aside fallback killed between its two renames, no
// folder until the next run restores it); the next run into the folder restores the user's
// file and removes what the killed run left.
TEST(StagedOutput, AKillAtEveryStepOfTheCommitIsRecoveredByTheNextRun) {
  for (const std::string name : {"out", "my out"})  // a name with a space too
    for (const bool exchange : {true, false}) {
      for (const std::string step :
           {"synced", "moved_aside", "swapped", "kept_unmanaged", "removed_old"}) {
        if (exchange && step == "moved_aside") continue;
        SCOPED_TRACE(name + ": " + step + (exchange ? " (exchange)" : " (move aside)"));
        TempDir dir;
        const fs::path folder = prepare_folder(dir, name);
        const pid_t child = fork();
        ASSERT_GE(child, 0);
        if (child == 0) {
          StagingControl control;
          control.commit_hook = [step](std::string_view at) {
            if (at == step) _exit(9);
          };
          control.without_exchange = !exchange;
          write_set(folder, "B", control);
          _exit(0);
        }
        int status = 0;
        ASSERT_EQ(waitpid(child, &status, 0), child);
        ASSERT_TRUE(WIFEXITED(status));
        ASSERT_EQ(WEXITSTATUS(status), 9);
        const bool before_swap = step == "synced" || step == "moved_aside";
        auto files = snapshot(folder);
        files.erase("notes.txt");  // after the swap it waits in the old folder until recovery
        if (step == "moved_aside")
          EXPECT_FALSE(fs::exists(folder));
        else
          EXPECT_EQ(files, expected_set(before_swap ? "A" : "B"));
        // The next run recovers, then fails before its own commit: the folder as recovered.
        { StagedOutput next(folder, kManaged); }
        auto expected = expected_set(before_swap ? "A" : "B");
        expected["notes.txt"] = "mine\n";
        EXPECT_EQ(snapshot(folder), expected);
        EXPECT_TRUE(leftovers(dir.path(), name).empty()) << leftovers(dir.path(), name).front();
      }
    }
}

TEST(StagedOutput, ASecondRunIntoAFolderInUseIsRefused) {
  TempDir dir;
  StagedOutput first(dir.path() / "out", kManaged);
  try {
    StagedOutput second(dir.path() / "out", kManaged);
    FAIL() << "a second staged output of the same folder was allowed";
  } catch (const OutputError& e) {
    EXPECT_TRUE(e.user_error());
    EXPECT_NE(std::string(e.what()).find("in use by another frichb run"), std::string::npos)
        << e.what();
  }
  // Another process too (flock is per open file, so this checks the same path from a child).
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    try {
      StagedOutput other(dir.path() / "out", kManaged);
    } catch (const OutputError& e) {
      _exit(e.user_error() ? 2 : 3);
    }
    _exit(0);
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  EXPECT_EQ(WEXITSTATUS(status), 2);
}

TEST(StagedOutput, PathsThatCannotHoldTheResultsAreUserErrors) {
  TempDir dir;
  write_file(dir.path() / "afile", "x");
  for (const fs::path& bad : {dir.path() / "afile", dir.path() / "afile" / "sub", fs::path("/")}) {
    SCOPED_TRACE(bad.string());
    try {
      StagedOutput out(bad, kManaged);
      FAIL() << "accepted";
    } catch (const OutputError& e) {
      EXPECT_TRUE(e.user_error()) << e.what();
    }
  }
  // A symbolic link: the swap would replace the link and move the files it points to.
  fs::create_directories(dir.path() / "elsewhere");
  fs::create_symlink(dir.path() / "elsewhere", dir.path() / "link");
  EXPECT_THROW(StagedOutput(dir.path() / "link", kManaged), OutputError);
  // The current folder (or one above it) would be swapped away under the process.
  const fs::path cwd = fs::current_path();
  fs::create_directories(dir.path() / "here" / "deeper");
  fs::current_path(dir.path() / "here" / "deeper");
  EXPECT_THROW(StagedOutput(".", kManaged), OutputError);
  EXPECT_THROW(StagedOutput(dir.path() / "here", kManaged), OutputError);
  fs::current_path(cwd);
}

// A folder without the owner's write bit is the user's word that it must not change, even
// for root, whom the kernel lets write there: refused before anything is created.
TEST(StagedOutput, AWriteProtectedFolderIsRefusedNamingIt) {
  TempDir dir;
  const fs::path folder = dir.path() / "final";
  fs::create_directories(folder);
  write_file(folder / "v1.csv", "keep\n");
  fs::permissions(folder, fs::perms::owner_write | fs::perms::group_write | fs::perms::others_write,
                  fs::perm_options::remove);
  try {
    StagedOutput out(folder, kManaged);
    FAIL() << "accepted";
  } catch (const OutputError& e) {
    EXPECT_TRUE(e.user_error());
    EXPECT_NE(std::string(e.what()).find("'" + folder.string() + "' is write-protected"),
              std::string::npos)
        << e.what();
  }
  fs::permissions(folder, fs::perms::owner_write, fs::perm_options::add);
  EXPECT_EQ(snapshot(folder), (std::map<std::string, std::string>{{"v1.csv", "keep\n"}}));
  EXPECT_TRUE(leftovers(dir.path(), "final").empty());
}

// The kernel's pseudo file systems hold no results: refused before anything is created.
TEST(StagedOutput, AFolderOnAPseudoFileSystemIsRefused) {
  // Where /proc or /sys is not mounted the folder would be made: only the mounted ones.
  if (!fs::is_directory("/proc/self")) GTEST_SKIP() << "/proc is not mounted";
  for (const fs::path& bad :
       {fs::path("/proc"), fs::path("/proc/results"), fs::path("/sys/kernel/results")}) {
    SCOPED_TRACE(bad.string());
    if (!fs::is_directory(bad.parent_path())) continue;
    try {
      StagedOutput out(bad, kManaged);
      FAIL() << "accepted";
    } catch (const OutputError& e) {
      EXPECT_TRUE(e.user_error()) << e.what();
      EXPECT_NE(std::string(e.what()).find("'" + bad.string() + "'"), std::string::npos)
          << e.what();
    }
  }
  EXPECT_FALSE(fs::exists("/.proc.lock"));
}

// A folder whose path leaves no room below it for a file name of the longest length the file
// system takes would fail only when its files are written: refused at once.
TEST(StagedOutput, AFolderPathThatLeavesNoRoomForItsFilesIsRefused) {
  TempDir dir;
  fs::path deep = dir.path();
  while (deep.string().size() < PATH_MAX - 300) deep /= std::string(200, 'd');
  try {
    StagedOutput out(deep / "out", kManaged);
    FAIL() << "accepted";
  } catch (const OutputError& e) {
    EXPECT_TRUE(e.user_error());
    EXPECT_NE(std::string(e.what()).find("too long"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir.path() / std::string(200, 'd')));
}

TEST(Writers, AFullDeviceIsAnIoErrorNamingTheFile) {
  try {
    write_file("/dev/full", std::string(100000, 'x'));
    FAIL() << "a write to /dev/full succeeded";
  } catch (const OutputError& e) {
    EXPECT_FALSE(e.user_error());
    EXPECT_NE(std::string(e.what()).find("/dev/full"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("No space left on device"), std::string::npos) << e.what();
  }
}

// A file-size limit (RLIMIT_FSIZE: writes past it fail as on a full disk) in a child process:
// the second run into a folder fails and the earlier results stay whole.
TEST(Writers, AWriteThatFailsHalfwayKeepsTheEarlierSet) {
  TempDir dir;
  const fs::path folder = prepare_folder(dir);
  const auto before = snapshot(folder);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    std::signal(SIGXFSZ, SIG_IGN);
    rlimit limit{64, 64};
    setrlimit(RLIMIT_FSIZE, &limit);
    try {
      StagedOutput out(folder, kManaged);
      write_file(out.path("summary.json"), std::string(1000, 'y'));
      out.commit();
    } catch (const OutputError& e) {
      _exit(e.user_error() ? 2 : 5);
    }
    _exit(0);
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  EXPECT_EQ(WEXITSTATUS(status), 5);
  EXPECT_EQ(snapshot(folder), before);
  EXPECT_TRUE(leftovers(dir.path(), "out").empty());
}

// Strings an attacker would put in a scene name or a DOF name. gnuplot prints each back
// exactly (its own `print` into a file), and none of the commands inside them runs.
TEST(GnuplotString, HostileTextIsReadBackByteForByteAndRunsNothing) {
  TempDir dir;
  const fs::path marker = dir.path() / "PWNED";
  const std::string m = marker.string();
  const std::vector<std::string> texts = {
      "plain",
      "",
      "it's",
      "x'; system('touch " + m + "'); print '",
      "\"; system(\"touch " + m + "\"); print \"",
      "`touch " + m + "`",
      "$(touch " + m + ")",
      "a;b;c",
      "line\nsystem('touch " + m + "')\n",
      "tab\tcr\r bell\a del\x7f",
      "back\\slash \\' \\\"",
      "@x macro",
      "caf\xc3\xa9 \xe2\x88\x9e \xf0\x9f\x94\xa5",
      "''''",
  };
  std::ostringstream script;
  script << "x = \"system('touch " << m << "')\"\n";
  script << "set print 'printed.txt'\n";
  for (const auto& t : texts) script << "print " << gnuplot_string(t) << "\n";
  const fs::path gp = dir.path() / "strings.gp";
  write_file(gp, script.str());
  ASSERT_TRUE(run_gnuplot(gp, StopToken())) << script.str();
  std::string expected;
  for (const auto& t : texts) expected += t + "\n";
  EXPECT_EQ(read_text(dir.path() / "printed.txt"), expected);
  EXPECT_FALSE(fs::exists(marker));
}

// The script runs in its own folder, by name: a folder name with shell syntax is only a name.
TEST(RunGnuplot, RunsInTheScriptsFolderWithoutAShell) {
  TempDir dir;
  const fs::path folder = dir.path() / "a b';touch PWNED;'$(touch PWNED2)";
  fs::create_directories(folder);
  write_file(folder / "-s.gp", "set print 'done.txt'\nprint 'ok'\n");
  ASSERT_TRUE(run_gnuplot(folder / "-s.gp", StopToken()));
  EXPECT_EQ(read_text(folder / "done.txt"), "ok\n");
  EXPECT_FALSE(fs::exists(dir.path() / "PWNED"));
  EXPECT_FALSE(fs::exists(folder / "PWNED"));
  EXPECT_FALSE(fs::exists(folder / "PWNED2"));
}

// A stop requested while gnuplot runs ends it (it would pause for a minute) and run_gnuplot
// returns false at once; a stopped token starts no gnuplot at all.
TEST(RunGnuplot, AStopEndsTheChild) {
  TempDir dir;
  write_file(dir.path() / "slow.gp",
             "set print 'started.txt'\nprint 'yes'\nunset print\npause 60\n"
             "set print 'finished.txt'\nprint 'yes'\n");
  const StopSource source;
  const auto t0 = std::chrono::steady_clock::now();
  std::jthread stopper([&] {
    // Once gnuplot has started its script.
    while (!fs::exists(dir.path() / "started.txt") &&
           std::chrono::steady_clock::now() - t0 < std::chrono::seconds(20))
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    source.request_stop(SIGTERM);
  });
  EXPECT_FALSE(run_gnuplot(dir.path() / "slow.gp", source.token()));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_TRUE(fs::exists(dir.path() / "started.txt"));
  EXPECT_FALSE(fs::exists(dir.path() / "finished.txt"));
  EXPECT_LT(seconds, 30.0);  // not the minute's pause
  write_file(dir.path() / "quick.gp", "set print 'ran.txt'\nprint 'yes'\n");
  EXPECT_FALSE(run_gnuplot(dir.path() / "quick.gp", source.token()));
  EXPECT_FALSE(fs::exists(dir.path() / "ran.txt"));
}

// A staged set whose token is stopped before the commit is not committed: the folder keeps the
// earlier set and the user's file, and nothing staged is left behind.
TEST(StagedOutput, AStoppedCallCommitsNothing) {
  TempDir dir;
  const fs::path folder = prepare_folder(dir);
  const auto before = snapshot(folder);
  const StopSource source;
  {
    StagedOutput out(folder, kManaged, StagingControl(source.token()));
    write_file(out.path("summary.json"), "{\"set\": \"B\"}\n");
    source.request_stop(SIGINT);
    EXPECT_THROW(out.commit(), Interrupted);
  }
  EXPECT_EQ(snapshot(folder), before);
  EXPECT_TRUE(leftovers(dir.path(), "out").empty()) << leftovers(dir.path(), "out").front();
}

}  // namespace
