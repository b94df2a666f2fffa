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

// Every file and folder under `dir`, with each file's contents: what a victim folder must still hold.
std::vector<std::string> snapshot(const fs::path& dir) {
  std::vector<std::string> out;
  for (auto& e : fs::recursive_directory_iterator(dir)) {
    std::string line = fs::relative(e.path(), dir).string();
    if (e.is_regular_file()) {
      std::ifstream f(e.path());
      line += "=" + std::string(std::istreambuf_iterator<char>(f), {});
    }
    out.push_back(line);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// A folder of a user's: notes, a subfolder, the results.json and meta.json an older coneshadow wrote
// without its marker, and a one-triangle scene over a ground quad.
fs::path makeVictim(const fs::path& dir) {
  fs::create_directories(dir / "drafts");
  writeText(dir / "notes.txt", "mine");
  writeText(dir / "drafts" / "chapter.tex", "also mine");
  writeText(dir / "results.json", "[]");
  writeText(dir / "meta.json", "{}");
  writeText(dir / "scene.obj",
            "v -4 0 -4\nv 4 0 -4\nv 4 0 4\nv -4 0 4\nv -1 1 -1\nv 1 1 -1\nv 0 1 1\nf 1 3 2\nf 1 4 3\nf 5 7 6\n");
  return dir / "scene.obj";
}

TEST(StagedDir, OnlyTheMarkerSaysAFolderIsConeshadowsNotAResultsFile) {
  TempFolder t;
  const fs::path victim = t.path / "victim";
  makeVictim(victim);
  const std::vector<std::string> before = snapshot(victim);
  EXPECT_THROW(cs::StagedDir s(victim.string()), cs::Error);
  EXPECT_EQ(snapshot(victim), before);
}

TEST(StagedDir, AFileAddedToAnEarlierOutputKeepsTheFolderFromBeingReplaced) {
  TempFolder t;
  const fs::path target = t.path / "out";
  {
    cs::StagedDir s(target.string());
    writeText(fs::path(s.path()) / "a.png", "img");
    s.commit();
  }
  writeText(target / "my_notes.txt", "added by the user");
  const std::vector<std::string> before = snapshot(target);
  try {
    cs::StagedDir s(target.string());
    FAIL() << "a folder holding a file coneshadow did not write was accepted";
  } catch (const cs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("my_notes.txt"), std::string::npos) << e.what();
  }
  EXPECT_EQ(snapshot(target), before);
  fs::remove(target / "my_notes.txt");
  cs::StagedDir again(target.string());  // what it wrote alone: replaceable again
  again.commit();
  // A marker of an earlier version, which lists nothing, still marks the folder as coneshadow's.
  writeText(target / cs::kOutputMarker, "written by coneshadow: the next run into this folder replaces it as a whole\n");
  writeText(target / "old.png", "img");
  cs::StagedDir legacy(target.string());
}

TEST(StagedDir, AnOutputFolderNeverHoldsTheCurrentFolderOrTheScene) {
  TempFolder t;
  const fs::path target = t.path / "out";
  {
    cs::StagedDir s(target.string());
    s.commit();
  }
  const fs::path cwd = fs::current_path();
  fs::current_path(target);
  EXPECT_THROW(cs::StagedDir s("."), cs::Error);
  EXPECT_THROW(cs::StagedDir s(target.string()), cs::Error);
  fs::current_path(cwd);
  writeText(target / "scene.obj", "v 0 0 0\n");
  try {
    cs::StagedDir s(target.string(), {(target / "scene.obj").string()});
    FAIL() << "an output folder holding the scene was accepted";
  } catch (const cs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("scene.obj"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::exists(target / "scene.obj"));
}

TEST(StagedDir, NoCommandReplacesAUsersFolderOrTheScenesFolder) {
  TempFolder t;
  const fs::path victim = t.path / "notes";
  const fs::path scene = makeVictim(victim);
  const std::vector<std::string> before = snapshot(victim);
  const std::string small = " --width 16 --height 16 --quiet";
  const std::string cd = "cd '" + victim.string() + "' && ";
  struct Case {
    std::string args, launcher;
  };
  const std::vector<Case> cases = {
      {"render" + small + " --out .", cd},
      {"render scene.obj" + small + " --out .", cd},
      {"render " + scene.string() + small + " --out " + victim.string(), ""},
      {"render" + small + " --out " + (t.path / "fresh").string() + " --dump " + victim.string(), ""},
      {"render" + small + " --out " + victim.string() + "/./", ""},
      {"compare" + small + " --methods cone --out " + victim.string(), ""},
      {"compare " + scene.string() + small + " --methods cone --out .", cd},
      {"compare" + small + " --methods cone --animate 2 --out " + victim.string(), ""},
  };
  for (const Case& c : cases) {
    cs::test::CliRun r = cs::test::cli(c.args, c.launcher);
    EXPECT_NE(r.code, 0) << c.args << "\n" << r.out;
    EXPECT_NE(r.out.find("replaces its output folder as a whole"), std::string::npos) << c.args << "\n" << r.out;
    EXPECT_EQ(snapshot(victim), before) << c.args;
    EXPECT_FALSE(fs::exists(t.path / "fresh")) << c.args << ": no partial output";
  }
  // A folder coneshadow wrote that holds the scene (copied in later) is refused too, the scene kept.
  const fs::path out = t.path / "out";
  ASSERT_EQ(cs::test::cli("render" + small + " --out " + out.string()).code, 0);
  fs::copy_file(scene, out / "scene.obj");
  cs::test::CliRun r = cs::test::cli("render " + (out / "scene.obj").string() + small + " --out " + out.string());
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("holds the scene"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(out / "scene.obj"));
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
