// `coneshadow visibility`: the exact visibility of samples of the caller's own, as a user runs it. A floor
// with a square occluder above it, samples whose answer is known in closed form, two lights; the columns
// against Embree's with --reference; and every bad input one line, no output, nothing of the user's replaced.
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "tests/cli_support.h"

namespace fs = std::filesystem;

namespace {

using cs::test::CliRun;
using cs::test::cli;

struct Files {
  fs::path dir, scene, samples, out;
  explicit Files(const std::string& name) {
    dir = fs::temp_directory_path() / ("coneshadow_visibility_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    scene = dir / "floor.obj";
    samples = dir / "samples.txt";
    out = dir / "answer.csv";
    // A floor 8 x 8 at y = 0 and a square occluder 1 x 1 at y = 1, both facing up.
    std::ofstream(scene) << "v -4 0 -4\nv 4 0 -4\nv 4 0 4\nv -4 0 4\n"
                            "v -0.5 1 -0.5\nv 0.5 1 -0.5\nv 0.5 1 0.5\nv -0.5 1 0.5\n"
                            "f 1 3 2\nf 1 4 3\nf 5 7 6\nf 5 8 7\n";
  }
  ~Files() { fs::remove_all(dir); }
  void writeSamples(const std::string& text) const { std::ofstream(samples) << text; }
};

std::string readText(const fs::path& p) {
  std::ifstream f(p);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

// The rows after the comment line.
std::string table(const std::string& csv) { return csv.substr(csv.find('\n') + 1); }

constexpr const char* kSamples =
    "# x y z nx ny nz\n"
    "0 0 0 0 1 0\n"       // under the occluder: shadowed from (0,4,0), lit from (3,4,3)
    "\n"
    "3,0,3,0,1,0\n"       // away from it: lit from both
    "3\t0\t3\t0 -1 0\n"   // the same point facing down: faces neither light
    "0 2 0 0 1 0\n";      // above the occluder: lit from both

const std::string kLights = " --light 0,4,0 --light 3,4,3";

TEST(Visibility, SamplesOfAFileGetTheirClosedFormAnswerForEachLight) {
  Files f("closed_form");
  f.writeSamples(kSamples);
  const CliRun r = cli("visibility " + f.scene.string() + " --samples " + f.samples.string() + kLights + " --out " + f.out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(table(readText(f.out)),
            "facing_0,facing_1,visible_0,visible_1\n"
            "1,1,0,1\n"
            "1,1,1,1\n"
            "0,0,0,0\n"
            "1,1,1,1\n");
  EXPECT_NE(r.out.find("light 0: 2 of 4 samples visible"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("light 1: 3 of 4 samples visible"), std::string::npos) << r.out;

  // Without --out: the same CSV on stdout.
  const CliRun toStdout = cli("visibility " + f.scene.string() + " --samples " + f.samples.string() + kLights);
  ASSERT_EQ(toStdout.code, 0) << toStdout.out;
  EXPECT_NE(toStdout.out.find(table(readText(f.out))), std::string::npos) << toStdout.out;
}

TEST(Visibility, ReferenceColumnsAreEmbreesAnswerForTheSameSamples) {
  Files f("reference");
  f.writeSamples(kSamples);
  const CliRun r = cli("visibility " + f.scene.string() + " --samples " + f.samples.string() + kLights +
                       " --reference --out " + f.out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(table(readText(f.out)),
            "facing_0,facing_1,visible_0,visible_1,embree_0,embree_1,band_0,band_1\n"
            "1,1,0,1,0,1,0,0\n"
            "1,1,1,1,1,1,0,0\n"
            "0,0,0,0,0,0,0,0\n"
            "1,1,1,1,1,1,0,0\n");
  EXPECT_NE(r.out.find("against Embree 0 wrong outside the band"), std::string::npos) << r.out;
}

TEST(Visibility, ABadSampleLineIsOneLineNamingFileAndLineAndWritesNothing) {
  Files f("bad_line");
  for (const auto& [text, says] : std::initializer_list<std::pair<std::string, std::string>>{
           {"0 0 0 0 1 0\n1 2 3 4 5\n", ":2: expected six finite numbers"},
           {"0 0 0 0 1 0\n\n1 2 3 4 5 6 7\n", ":3: expected six finite numbers"},
           {"0 0 nan 0 1 0\n", ":1: expected six finite numbers"},
           {"0 0 0 0 1 0x\n", ":1: expected six finite numbers"},
           {"0 0 0 0 0 0\n", ":1: the normal is zero"},
           {"# nothing\n", "no sample in the file"}}) {
    f.writeSamples(text);
    const CliRun r = cli("visibility " + f.scene.string() + " --samples " + f.samples.string() + " --light 0,4,0 --out " +
                         f.out.string());
    EXPECT_EQ(r.code, 1) << text << r.out;
    EXPECT_NE(r.out.find(says), std::string::npos) << text << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
    EXPECT_FALSE(fs::exists(f.out)) << text;
  }
  const CliRun missing = cli("visibility " + f.scene.string() + " --samples " + (f.dir / "none.txt").string());
  EXPECT_EQ(missing.code, 1) << missing.out;
  EXPECT_NE(missing.out.find("cannot open the samples file"), std::string::npos) << missing.out;
  const CliRun noSamples = cli("visibility " + f.scene.string());
  EXPECT_EQ(noSamples.code, 2) << noSamples.out;
  EXPECT_NE(noSamples.out.find("--samples"), std::string::npos) << noSamples.out;
}

TEST(Visibility, AFileTheCommandDidNotWriteIsNeverReplaced) {
  Files f("keep");
  f.writeSamples(kSamples);
  const std::string args = "visibility " + f.scene.string() + " --samples " + f.samples.string() + " --light 0,4,0";
  std::ofstream(f.out) << "the user's own notes\n";
  const CliRun kept = cli(args + " --out " + f.out.string());
  EXPECT_EQ(kept.code, 1) << kept.out;
  EXPECT_NE(kept.out.find("was not written by coneshadow visibility"), std::string::npos) << kept.out;
  EXPECT_EQ(readText(f.out), "the user's own notes\n");
  const CliRun itself = cli(args + " --out " + f.samples.string());
  EXPECT_EQ(itself.code, 2) << itself.out;
  EXPECT_EQ(readText(f.samples), kSamples);

  // Its own earlier answer is replaced.
  fs::remove(f.out);
  ASSERT_EQ(cli(args + " --out " + f.out.string()).code, 0);
  const CliRun again = cli(args + " --light 3,4,3 --out " + f.out.string());
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_NE(readText(f.out).find("facing_0,facing_1,"), std::string::npos);
}

}  // namespace
