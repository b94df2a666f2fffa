// All-or-nothing output: a folder replaced as a whole in one step, foreign folders refused, nested
// --out/--dump folders, and an interrupted run that leaves no staging folder behind.
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "app/staged_dir.h"
#include "core/error.h"
#include "tests/cli_support.h"

extern char** environ;

namespace fs = std::filesystem;

namespace {

struct TempFolder {
  fs::path path;
  TempFolder() : path(fs::temp_directory_path() / ("coneshadow_staged_" + std::to_string(::getpid()))) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempFolder() { fs::remove_all(path); }
};

void writeText(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> out;
  for (auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

TEST(StagedDir, ANewFolderAppearsOnlyAtCommitWithItsMarker) {
  TempFolder t;
  const fs::path target = t.path / "out";
  {
    cs::StagedDir s(target.string() + "/");  // a trailing separator names the same folder
    EXPECT_EQ(fs::path(s.path()).parent_path(), t.path) << "staged beside the target, not inside it";
    writeText(fs::path(s.path()) / "a.txt", "new");
    EXPECT_FALSE(fs::exists(target));
    s.commit();
  }
  EXPECT_EQ(entries(target), (std::vector<std::string>{cs::kOutputMarker, "a.txt"}));
  EXPECT_EQ(entries(t.path), (std::vector<std::string>{"out"})) << "no staging folder left";
}

TEST(StagedDir, ARunReplacesItsPreviousOutputAsAWholeAndAFailedOneLeavesItAsItWas) {
  TempFolder t;
  const fs::path target = t.path / "out";
  {
    cs::StagedDir s(target.string());
    writeText(fs::path(s.path()) / "old.txt", "old");
    s.commit();
  }
  {
    cs::StagedDir s(target.string());
    writeText(fs::path(s.path()) / "partial.txt", "never committed");
  }  // no commit: a failed run
  EXPECT_EQ(entries(target), (std::vector<std::string>{cs::kOutputMarker, "old.txt"}));
  EXPECT_EQ(entries(t.path), (std::vector<std::string>{"out"}));
  {
    cs::StagedDir s(target.string());
    writeText(fs::path(s.path()) / "new.txt", "new");
    s.commit();
  }
  EXPECT_EQ(entries(target), (std::vector<std::string>{cs::kOutputMarker, "new.txt"})) << "old files do not mix in";
  EXPECT_EQ(entries(t.path), (std::vector<std::string>{"out"})) << "the previous output was removed";
}

TEST(StagedDir, AFolderConeshadowDidNotWriteIsRefusedAndLeftAlone) {
  TempFolder t;
  const fs::path mine = t.path / "mine";
  fs::create_directories(mine);
  writeText(mine / "thesis.tex", "precious");
  try {
    cs::StagedDir s(mine.string());
    FAIL() << "a foreign folder was accepted";
  } catch (const cs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("did not write"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(mine.string()), std::string::npos) << e.what();
  }
  EXPECT_EQ(entries(mine), (std::vector<std::string>{"thesis.tex"}));
  EXPECT_EQ(entries(t.path), (std::vector<std::string>{"mine"}));
  // A file where the folder should be, and the root, are refused too; an empty folder is taken.
  writeText(t.path / "file", "x");
  EXPECT_THROW(cs::StagedDir((t.path / "file").string()), cs::Error);
  EXPECT_THROW(cs::StagedDir("/"), cs::Error);
  fs::create_directories(t.path / "empty");
  cs::StagedDir empty((t.path / "empty").string());
  empty.commit();
  EXPECT_TRUE(fs::exists(t.path / "empty" / cs::kOutputMarker));
}

TEST(StagedDir, PathWithinComparesNormalPaths) {
  EXPECT_TRUE(cs::pathWithin("/a/b/c", "/a/b"));
  EXPECT_TRUE(cs::pathWithin("/a/b/", "/a/b"));
  EXPECT_TRUE(cs::pathWithin("/a/b/x/../c", "/a/b"));
  EXPECT_FALSE(cs::pathWithin("/a/bc", "/a/b"));
  EXPECT_FALSE(cs::pathWithin("/a", "/a/b"));
}

TEST(StagedDir, RenderWritesNestedOutAndDumpFoldersTogether) {
  TempFolder t;
  const fs::path out = t.path / "out";
  cs::test::CliRun r = cs::test::cli("render --width 16 --height 16 --quiet --out " + out.string() + " --dump " +
                                     (out / "dump").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(out / "results.json"));
  EXPECT_TRUE(fs::exists(out / "dump" / "meta.json"));
  r = cs::test::cli("render --width 16 --height 16 --quiet --out " + (t.path / "d").string() + " --dump " + t.path.string() +
                    "/d/../d");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(t.path / "d" / "results.json"));
  EXPECT_TRUE(fs::exists(t.path / "d" / "meta.json"));
  EXPECT_EQ(entries(t.path), (std::vector<std::string>{"d", "out"})) << "no staging folder left";
}

TEST(StagedDir, AnInterruptedRunLeavesNoStagingFolderAndExitsWithTheSignal) {
  TempFolder t;
  const fs::path out = t.path / "cmp";
  const std::string cli = CONESHADOW_CLI;
  std::vector<std::string> args = {cli, "compare", "--width", "96", "--height", "96", "--frames", "200", "--views", "fur",
                                   "--methods", "cone", "--quiet", "--out", out.string()};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, cli.c_str(), &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  // Wait for the staging folder (the run has started writing), then interrupt.
  bool staged = false;
  for (int i = 0; i < 600 && !staged; ++i) {
    for (auto& e : fs::directory_iterator(t.path)) staged = staged || e.path().filename().string().find(".staging-") != std::string::npos;
    if (!staged) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_TRUE(staged) << "the run never staged its output";
  ::kill(pid, SIGTERM);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "killed by the signal instead of cleaning up";
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGTERM);
  EXPECT_TRUE(entries(t.path).empty()) << "left behind: " << (entries(t.path).empty() ? "" : entries(t.path)[0]);
}

}  // namespace
