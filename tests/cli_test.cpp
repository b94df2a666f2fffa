// The coneshadow CLI as a newcomer runs it: exit codes, one-line errors, files written (and not written).
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>

#include "tests/cli_support.h"

namespace fs = std::filesystem;

namespace {

using cs::test::CliRun;
using cs::test::cli;

fs::path tempDir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("coneshadow_cli_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

const std::string kModels = CONESHADOW_ASSIMP_MODELS;

TEST(Cli, HelpDocumentsCommandsAndExitCodes) {
  CliRun r = cli("help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("coneshadow render"), std::string::npos);
  EXPECT_NE(r.out.find("exit codes"), std::string::npos);
  EXPECT_EQ(cli("render --help").code, 0);
}

TEST(Cli, UsageErrorsExitWithTwo) {
  for (const char* args : {"", "frobnicate", "render --width", "render --width 0", "render --width x",
                           "render --light 1,2", "render --light 1,2,nan", "render --bogus",
                           "render --method no-such-method", "render --frames 0", "info",
                           "render --traversal-memory -5", "render --method cone --test=sphere --early-accept=on",
                           "render --method cone --variant=Nope", "render --method cone --front-face-culling=maybe",
                           "render --rmsm-lod-bias x", "render --rmsm-lod-bias 9", "render --rmsm-analysis 3",
                           "render --rmsm-analysis 32", "render --rmsm-analysis 0",
                           // size settings past their own limits, refused before any work (issue 17)
                           "render --traversal-memory 1", "render --traversal-memory 0.5", "render --rmsm-page 33",
                           "render --rmsm-pool 1", "compare --rmsm-pool 1K", "compare --rmsm-max-res 100",
                           // a flag given empty runs nothing; an extra argument is refused (issue 48)
                           "render --method ''", "render --methods ''", "compare --methods ''",
                           "info builtin extra", "devices extra"}) {
    CliRun r = cli(args);
    EXPECT_EQ(r.code, 2) << "args: " << args << "\n" << r.out;
    EXPECT_NE(r.out.find("coneshadow: "), std::string::npos) << args;
    EXPECT_EQ(r.out.find(".cpp:"), std::string::npos) << args << ": a usage error names the flag, not the source";
    EXPECT_EQ(r.out.find("[1/5]"), std::string::npos) << args << ": refused before any work\n" << r.out;
  }
}

// The light straight above the closed room, a hair off the axis (issue 48): every wall is grazed and its
// rays meet the ceiling at the edge, where fp32 decides; the band holds most samples. The result says
// undecided everywhere a verdict is given: the result line, results.json and .csv, the report's verdict,
// never "exact".
TEST(Cli, AFrameWhoseBandCoversItsSamplesIsUndecidedInEveryResult) {
  fs::path out = tempDir("undecided");
  CliRun r = cli("render --light 1.3,1e8,-0.7 --methods cone --width 32 --height 32 --frames 1 --quiet --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("UNDECIDED: the ambiguity band covers"), std::string::npos) << r.out;
  auto j = nlohmann::json::parse(std::ifstream(out / "results.json"));
  EXPECT_TRUE(j[1]["error"]["undecided"].get<bool>());
  EXPECT_GT(j[1]["error"]["band_fraction"].get<double>(), 0.5);
  EXPECT_NE(j[1]["error"]["undecided_reason"].get<std::string>().find("no count outside the band"), std::string::npos);
  std::ifstream csv(out / "results.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_NE(header.find("error.band_fraction"), std::string::npos) << header;
  EXPECT_NE(header.find("error.undecided"), std::string::npos) << header;
  fs::remove_all(out);
  // A decided frame says so too: its band's share, no verdict of its own.
  r = cli("render --view ceiling --methods cone --width 32 --height 32 --frames 1 --quiet --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("UNDECIDED"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("% of the lit samples"), std::string::npos) << r.out;
  j = nlohmann::json::parse(std::ifstream(out / "results.json"));
  EXPECT_FALSE(j[1]["error"]["undecided"].get<bool>());
  fs::remove_all(out);
  r = cli("compare --light 1.3,1e8,-0.7 --views wall --methods cone --width 32 --height 32 --frames 1 --quiet --out " +
          out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  std::ifstream md(out / "report.md");
  const std::string report((std::istreambuf_iterator<char>(md)), {});
  EXPECT_NE(report.find("| wall | undecided: the ambiguity band covers"), std::string::npos) << report.substr(0, 2000);
  EXPECT_EQ(report.find("| wall | cone"), std::string::npos) << "no method is called exact on an undecided view";
  fs::remove_all(out);
}

TEST(Cli, ATinyLightCoordinateIsAFiniteNumber) {
  // 1e-45 underflows fp32 to a denormal: finite, so a light like any other.
  fs::path out = tempDir("tinylight");
  CliRun r = cli("render --method cone --width 8 --height 8 --frames 1 --quiet --light 1e-45,3,1e-300 --out " + out.string());
  EXPECT_EQ(r.code, 0) << r.out;
  fs::remove_all(out);
}

// CONESHADOW_PROFILE_DISPATCHES=1 (docs/DEVELOPING.md, "Where a frame's time goes"): the cone frame's
// kernels each get a row of wall time and calls at exit, and the frame's mask is the one a run without
// it gives (each dispatch submitted alone changes when the work runs, never what it computes).
TEST(Cli, TheDispatchProfileTimesEachConeKernelAndLeavesTheMaskAlone) {
  fs::path plain = tempDir("profile_plain"), profiled = tempDir("profile_on");
  const std::string args = "render --method cone --view wall --width 24 --height 24 --frames 2 --quiet --profile-stages on --dump ";
  CliRun a = cli(args + (plain / "d").string() + " --out " + plain.string());
  CliRun b = cli(args + (profiled / "d").string() + " --out " + profiled.string(), "CONESHADOW_PROFILE_DISPATCHES=1 ");
  ASSERT_EQ(a.code, 0) << a.out;
  ASSERT_EQ(b.code, 0) << b.out;
  EXPECT_EQ(a.out.find("dispatch profile"), std::string::npos) << a.out;
  ASSERT_NE(b.out.find("dispatch profile (a submission per dispatch"), std::string::npos) << b.out;
  for (const char* kernel : {"cone tree build", "traverse test", "radix_count", "  total"})
    EXPECT_NE(b.out.find(kernel, b.out.find("dispatch profile")), std::string::npos) << kernel << "\n" << b.out;
  auto bytes = [](const fs::path& f) {
    std::ifstream in(f, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), {});
  };
  const std::string mask = bytes(plain / "d" / "visibility_cone.pfm");
  EXPECT_FALSE(mask.empty());
  EXPECT_EQ(mask, bytes(profiled / "d" / "visibility_cone.pfm"));
  fs::remove_all(plain);
  fs::remove_all(profiled);
}

TEST(Cli, ALightTooFarForFp32RayLengthsIsAUsageErrorBeforeAnyOutput) {
  // 2^62 is the limit (method/epsilon.h); 4e18 from the built-in scene is inside it, 5e18 past it.
  fs::path out = tempDir("farlight");
  CliRun r = cli("render --method cone --width 8 --height 8 --frames 1 --light 5e18,0,0 --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--light: the light at (5e+18, 0, 0)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("move it closer"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out));
  r = cli("render --method cone --width 8 --height 8 --frames 1 --light 4e18,0,0 --out " + out.string());
  EXPECT_EQ(r.code, 0) << r.out;
  fs::remove_all(out);
}

TEST(Cli, MalformedSceneIsOneLineNamingTheFileAndLeavesNoOutput) {
  fs::path out = tempDir("malformed");
  std::string file = kModels + "/IndexOutOfRange/IndexOutOfRange.gltf";
  if (!fs::exists(file)) {
    for (auto& e : fs::directory_iterator(kModels + "/IndexOutOfRange")) file = e.path().string();
  }
  CliRun r = cli("render " + file + " --out " + out.string() + " --frames 1");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find(fs::path(file).filename().string()), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("coneshadow: error: "), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out)) << "no output folder for a scene that did not load";
  CliRun missing = cli("render /no/such/scene.glb --out " + out.string());
  EXPECT_EQ(missing.code, 1);
  EXPECT_NE(missing.out.find("/no/such/scene.glb"), std::string::npos) << missing.out;
}

TEST(Cli, InfoPrintsTheFlattenedTriangleCountAndBoundsOf2CylinderEngine) {
  CliRun r = cli("info " + kModels + "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("triangles: 121496"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("bounds: min"), std::string::npos) << r.out;
}

TEST(Cli, RenderWritesImagesResultsAndDump) {
  fs::path out = tempDir("render"), dump = tempDir("dump");
  CliRun r = cli("render --view fur --width 64 --height 48 --frames 1 --quiet --out " + out.string() + " --dump " +
              dump.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("result: embree"), std::string::npos) << r.out;
  for (const char* f : {"embree_shaded.png", "embree_mask.png", "embree_diff.png", "results.json", "results.csv"})
    EXPECT_GT(fs::file_size(out / f), 0u) << f;
  for (const char* f : {"position.pfm", "normal.pfm", "visibility_embree.pfm", "band.pfm", "meta.json"})
    EXPECT_GT(fs::file_size(dump / f), 0u) << f;
  std::ifstream js(out / "results.json");
  auto j = nlohmann::json::parse(js);
  ASSERT_TRUE(j.is_array());
  EXPECT_EQ(j[0]["method"], "embree");
  EXPECT_EQ(j[0]["width"], 64);
  EXPECT_EQ(j[0]["view"], "fur");
  std::ifstream ms(dump / "meta.json");
  auto meta = nlohmann::json::parse(ms);
  EXPECT_TRUE(meta.contains("light"));
  EXPECT_TRUE(meta.contains("camera"));
  for (auto& e : fs::directory_iterator(out))
    EXPECT_EQ(e.path().filename().string().rfind(".staging", 0), std::string::npos) << "staging left behind";
  fs::remove_all(out);
  fs::remove_all(dump);
}

TEST(Cli, RenderRunsSeveralMethodsOnOneSetOfSamplesAndTheConePathIsExact) {
  fs::path out = tempDir("methods");
  CliRun r = cli("render --methods cone,cubesm,rmsm --view room --width 48 --height 40 --frames 1 --sm-resolution 256 --out " +
                 out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  std::ifstream js(out / "results.json");
  auto j = nlohmann::json::parse(js);
  ASSERT_EQ(j.size(), 4u) << "embree's row, then one per method";
  const std::vector<std::string> order = {"embree", "cone", "cubesm", "rmsm"};
  for (size_t i = 0; i < order.size(); ++i) {
    const std::string method = order[i];
    EXPECT_EQ(j[i]["method"], method);
    for (auto f : {"_shaded.png", "_mask.png", "_diff.png"}) EXPECT_TRUE(fs::exists(out / (method + f))) << method << f;
    EXPECT_TRUE(j[i]["stats"]["deterministic"].get<bool>()) << method;
    // One set of samples: the same lit samples and band in every row.
    EXPECT_EQ(j[i]["error"]["lit_samples"], j[0]["error"]["lit_samples"]) << method;
    EXPECT_EQ(j[i]["stats"]["band_samples"], j[0]["stats"]["band_samples"]) << method;
    EXPECT_TRUE(j[i]["stats"]["work"].is_string()) << method << ": every method reports its work";
    for (const auto& stage : j[i]["stages"]) EXPECT_TRUE(stage["kind"].is_string()) << method;
  }
  EXPECT_EQ(j[1]["error"]["misclassified_outside_band"], 0) << r.out;
  EXPECT_EQ(j[2]["stats"]["resolution"], 256) << "--sm-resolution reached the cube map";
  for (const char* m : {"result: cone", "result: cubesm", "result: rmsm"}) EXPECT_NE(r.out.find(m), std::string::npos) << r.out;
  fs::remove_all(out);
}

TEST(Cli, BothOptionFormsAndAnyCaseGiveTheSameRun) {
  fs::path a = tempDir("form_a"), b = tempDir("form_b");
  CliRun ra = cli("render --methods cone --variant PreciseSEA --traversal-memory 256K --view wall --width 24 --height 16 "
                  "--frames 1 --quiet --out " + a.string());
  CliRun rb = cli("render --methods=Cone --variant=preciseSEA --traversal-memory=256k --view=wall --width=24 --height=16 "
                  "--frames=1 --quiet --out=" + b.string());
  ASSERT_EQ(ra.code, 0) << ra.out;
  ASSERT_EQ(rb.code, 0) << rb.out;
  std::ifstream ja(a / "results.json"), jb(b / "results.json");
  auto x = nlohmann::json::parse(ja), y = nlohmann::json::parse(jb);
  ASSERT_EQ(x.size(), 2u);
  ASSERT_EQ(y.size(), 2u);
  for (auto* j : {&x, &y}) {
    EXPECT_EQ((*j)[1]["method"], "cone");
    EXPECT_EQ((*j)[1]["stats"]["variant"], "PreciseSEA");
    EXPECT_EQ((*j)[1]["stats"]["traversal_memory_bytes"], 256 * 1024);
  }
  EXPECT_EQ(x[1]["error"], y[1]["error"]);
  fs::remove_all(a);
  fs::remove_all(b);
}

TEST(Cli, VersionAndPerCommandHelp) {
  CliRun v = cli("--version");
  EXPECT_EQ(v.code, 0);
  EXPECT_EQ(v.out.rfind("coneshadow ", 0), 0u) << v.out;
  CliRun render = cli("render --help"), helpRender = cli("help render"), compare = cli("compare --help");
  EXPECT_EQ(render.code, 0);
  EXPECT_EQ(render.out, helpRender.out);
  // Every registered method's settings, grouped by method; compare's own runs only on compare.
  for (const char* flag : {"--variant", "--sm-resolution", "--rmsm-pool", "--plane-bias", "cone settings", "--methods"})
    EXPECT_NE(render.out.find(flag), std::string::npos) << flag << "\n" << render.out;
  EXPECT_EQ(render.out.find("--animate"), std::string::npos);
  EXPECT_NE(compare.out.find("--animate"), std::string::npos) << compare.out;
  EXPECT_EQ(cli("info --help").code, 0);
  EXPECT_EQ(cli("help nosuch").code, 2);
}

// Knobs that never change the mask (issue 52) are listed apart, in one group after every setting users
// choose; the ones that change the answer or the memory stay with their method. They keep their names
// and still work.
TEST(Cli, KnobsThatNeverChangeTheMaskAreListedApartUnderTuning) {
  const std::string tuning = "Tuning (benchmarks and tests; never changes the mask):";
  for (const char* command : {"render", "compare"}) {
    CliRun r = cli(std::string(command) + " --help");
    ASSERT_EQ(r.code, 0) << r.out;
    const size_t group = r.out.find(tuning);
    ASSERT_NE(group, std::string::npos) << command << "\n" << r.out;
    EXPECT_EQ(r.out.find(tuning, group + 1), std::string::npos) << command << ": one tuning group";
    for (const char* knob : {"--leaf-rays", "--last-expansion-lanes", "--last-expansion-test", "--super-clusters",
                             "--clusters", "--ray-order", "--profile-stages", "--test", "--early-accept", "--two-pass",
                             "--blocker-solid-angle", "--update-min-finished", "--sm-cull"}) {
      const size_t at = r.out.find(std::string("  ") + knob + " ");
      ASSERT_NE(at, std::string::npos) << command << ": " << knob;
      EXPECT_GT(at, group) << command << ": " << knob << " is a tuning knob";
    }
    for (const char* user : {"--variant", "--memory-budget", "--traversal-memory", "--front-face-culling", "--leaf-test",
                             "--sm-resolution", "--rmsm-pool", "--width", "--light", "--frames"}) {
      const size_t at = r.out.find(std::string("  ") + user + " ");
      ASSERT_NE(at, std::string::npos) << command << ": " << user;
      EXPECT_LT(at, group) << command << ": " << user << " changes results or memory: not a tuning knob";
    }
  }
  EXPECT_GT(cli("compare --help").out.find("  --interleave "), cli("compare --help").out.find(tuning));
  fs::path a = tempDir("tuning_a"), b = tempDir("tuning_b");
  CliRun ra = cli("render --methods cone --view wall --width 24 --height 16 --frames 1 --quiet --out " + a.string());
  CliRun rb = cli("render --methods cone --leaf-rays 16 --clusters off --ray-order hilbert --view wall --width 24 --height 16 "
                  "--frames 1 --quiet --out " + b.string());
  ASSERT_EQ(ra.code, 0) << ra.out;
  ASSERT_EQ(rb.code, 0) << rb.out;
  auto ja = nlohmann::json::parse(std::ifstream(a / "results.json")), jb = nlohmann::json::parse(std::ifstream(b / "results.json"));
  EXPECT_EQ(ja[1]["error"], jb[1]["error"]) << "the same mask, judged the same";
  fs::remove_all(a);
  fs::remove_all(b);
}

TEST(Cli, ASettingNoChosenMethodTakesIsAUsageErrorNamingIt) {
  struct Case {
    const char* args;
    const char* names;
  };
  for (const Case& c : {Case{"render --methods cone --sm-resolution 256", "--sm-resolution is a setting of cubesm"},
                        Case{"render --sm-no-pcf", "--sm-no-pcf is a setting of cubesm"},
                        Case{"render --methods cubesm --variant PreciseSEA", "--variant is a setting of cone"},
                        Case{"compare --methods cone --rmsm-cached", "--rmsm-cached is a setting of rmsm"},
                        Case{"render --methods rmsm --rmsm-analysis 3", "rmsm: --rmsm-analysis"},
                        Case{"render --methods nosuch", "unknown method 'nosuch'"},
                        Case{"render --methods rmsn", "did you mean rmsm?"},
                        Case{"render --sm-resolutoin 4", "did you mean --sm-resolution?"},
                        Case{"render --animate 2", "--animate is an option of compare"}}) {
    CliRun r = cli(c.args);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.out;
    EXPECT_NE(r.out.find(c.names), std::string::npos) << c.args << "\n" << r.out;
    EXPECT_EQ(r.out.find("[1/5]"), std::string::npos) << c.args << ": refused before any work";
  }
  // A shared setting reaches every chosen method that takes it, and is fine when one of them does.
  fs::path out = tempDir("shared");
  CliRun r = cli("render --methods cone,cubesm --plane-bias --sm-resolution 64 --view wall --width 16 --height 16 "
                 "--frames 1 --quiet --out " + out.string());
  EXPECT_EQ(r.code, 0) << r.out;
  std::ifstream js(out / "results.json");
  auto j = nlohmann::json::parse(js);
  EXPECT_EQ(j[2]["stats"]["plane_bias"], true);
  fs::remove_all(out);
}

TEST(Cli, BartSceneRendersAtASceneTimeFromItsCameraTrack) {
  const std::string museum = std::string(CONESHADOW_BART_SCENES) + "/museum/museum5.aff";
  if (!fs::exists(museum)) GTEST_SKIP() << "no BART scenes at " << CONESHADOW_BART_SCENES;
  fs::path out = tempDir("bart");
  CliRun r = cli("render " + museum + " --method cone --view animated --time 2.5 --width 48 --height 40 --frames 1 --out " +
                 out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  auto j = nlohmann::json::parse(std::ifstream(out / "results.json"));
  EXPECT_EQ(j[1]["scene"], "museum5.aff");
  EXPECT_EQ(j[1]["view"], "animated");
  EXPECT_EQ(j[1]["error"]["misclassified_outside_band"], 0) << r.out;
  fs::remove_all(out);
  CliRun info = cli("info " + museum);
  EXPECT_EQ(info.code, 0) << info.out;
  EXPECT_NE(info.out.find("triangles: 11564"), std::string::npos) << info.out;
  // --time is for .aff scenes only.
  for (const std::string& args : {std::string("render --time 1 --frames 1"), "render " + museum + " --time soon",
                                  "render " + kModels + "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb --time 1"}) {
    CliRun bad = cli(args);
    EXPECT_EQ(bad.code, 2) << args << "\n" << bad.out;
    EXPECT_NE(bad.out.find("coneshadow: "), std::string::npos) << args;
  }
  // A malformed .aff: one line naming file and line, exit 1, no output folder.
  fs::path dir = tempDir("bad_aff");
  fs::create_directories(dir);
  std::ofstream(dir / "broken.aff") << "p 3\n 0 0 0\n 1 0 0\n 0 1 0\nwhat 1\n";
  fs::path badOut = dir / "out";
  CliRun broken = cli("render " + (dir / "broken.aff").string() + " --frames 1 --out " + badOut.string());
  EXPECT_EQ(broken.code, 1) << broken.out;
  EXPECT_NE(broken.out.find("broken.aff:5: unknown keyword 'what'"), std::string::npos) << broken.out;
  EXPECT_FALSE(fs::exists(badOut));
  fs::remove_all(dir);
}

TEST(Cli, UnknownViewListsTheViews) {
  CliRun r = cli("render --view nowhere --frames 1 --out " + tempDir("view").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("wall"), std::string::npos) << r.out;
}

TEST(Cli, UnwritableOutputIsAClearFailure) {
  CliRun r = cli("render --width 16 --height 16 --frames 1 --out /proc/coneshadow-cannot-write-here");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("/proc/coneshadow-cannot-write-here"), std::string::npos) << r.out;
  // --out and --dump are all or nothing together: a dump that cannot be written leaves no results.
  fs::path out = tempDir("dump_fails");
  r = cli("render --width 16 --height 16 --frames 1 --out " + out.string() + " --dump /proc/coneshadow-cannot-dump-here");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_FALSE(fs::exists(out / "results.json")) << "--out was written although --dump failed";
  EXPECT_FALSE(fs::exists(out / "embree_shaded.png"));
  fs::remove_all(out);
}

// Many timed frames hold one mask, not one per frame: the output is the same as with one frame.
TEST(Cli, ManyFramesKeepOneMask) {
  fs::path a = tempDir("frames_a"), b = tempDir("frames_b");
  ASSERT_EQ(cli("render --methods cone --view fur --width 24 --height 24 --frames 1 --quiet --out " + a.string()).code, 0);
  ASSERT_EQ(cli("render --methods cone --view fur --width 24 --height 24 --frames 9 --quiet --out " + b.string()).code, 0);
  std::ifstream ja(a / "results.json"), jb(b / "results.json");
  auto x = nlohmann::json::parse(ja), y = nlohmann::json::parse(jb);
  EXPECT_EQ(x[1]["error"], y[1]["error"]);
  EXPECT_EQ(y[1]["stats"]["frames"], 9);
  EXPECT_TRUE(y[1]["stats"]["deterministic"].get<bool>());
  fs::remove_all(a);
  fs::remove_all(b);
}

}  // namespace

namespace {

const std::string kAssimpModels = "/usr/share/assimp/models";

// A user's own scene in another format: OBJ, PLY and STL through assimp, with a floor under the model
// (--ground-plane) so there is a shadow to judge; the cone path exact, the provenance naming the file.
TEST(Cli, UserScenesInObjPlyAndStlLoadAndRender) {
  for (const char* rel : {"/OBJ/spider.obj", "/PLY/cube.ply", "/STL/Spider_binary.stl"}) {
    const std::string file = kAssimpModels + rel;
    if (!fs::exists(file)) GTEST_SKIP() << "no assimp test models at " << kAssimpModels;
    fs::path out = tempDir("user_scene");
    CliRun r = cli("render " + file + " --ground-plane --methods cone --width 40 --height 32 --frames 1 --quiet --out " +
                   out.string());
    ASSERT_EQ(r.code, 0) << file << "\n" << r.out;
    std::ifstream js(out / "results.json");
    auto j = nlohmann::json::parse(js);
    ASSERT_EQ(j.size(), 2u) << file;
    EXPECT_EQ(j[1]["error"]["misclassified_outside_band"], 0) << file;
    EXPECT_GT(j[1]["error"]["lit_samples"].get<uint64_t>(), 0u) << file;
    EXPECT_GT(j[0]["error"]["lit_samples"].get<uint64_t>() - j[0]["error"]["false_light"].get<uint64_t>(), 0u);
    const auto& p = j[1]["provenance"];
    EXPECT_EQ(p["scene_path"], file);
    EXPECT_EQ(p["scene_hash"].get<std::string>().size(), 16u);
    EXPECT_EQ(p["ground_plane"], true);
    EXPECT_GT(p["triangles"].get<uint64_t>(), 2u) << "the model's triangles and the floor's two";
    EXPECT_EQ(p["schema_version"], 2);
    EXPECT_NE(p["tool"].get<std::string>().find("coneshadow "), std::string::npos);
    EXPECT_NE(p["command_line"].get<std::string>().find("--ground-plane"), std::string::npos);
    fs::remove_all(out);
  }
  CliRun info = cli("info " + kAssimpModels + "/PLY/cube.ply");
  EXPECT_EQ(info.code, 0) << info.out;
  EXPECT_NE(info.out.find("triangles: 12"), std::string::npos) << info.out;
}

// Bad user scenes: one line each naming the file, exit 1, nothing written.
TEST(Cli, BadUserScenesAreOneLineEachAndWriteNothing) {
  const fs::path dir = tempDir("bad_scenes");
  fs::create_directories(dir);
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return (dir / name).string();
  };
  struct Case {
    std::string file, says;
  };
  const std::vector<Case> cases = {
      {write("garbage.ply", "ply\nformat nonsense\nthis is not a PLY file\n"), "garbage.ply"},
      {write("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\np 1 2 3\n"), "no triangles"},
      {write("scene.xyz", "hello"), "unknown file type '.xyz'"},
      {write("old.gltf", R"({"asset": {"version": "1.0"}, "meshes": {}})"), "glTF 1.0"},
      {write("future.gltf", R"({"asset": {"version": "3.0"}})"), "glTF version '3.0'"},
  };
  for (const Case& c : cases) {
    fs::path out = tempDir("bad_out");
    CliRun r = cli("render " + c.file + " --frames 1 --out " + out.string());
    EXPECT_EQ(r.code, 1) << c.file << "\n" << r.out;
    EXPECT_NE(r.out.find(c.says), std::string::npos) << c.file << "\n" << r.out;
    EXPECT_NE(r.out.find("coneshadow: error: "), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(out)) << c.file;
  }
  // A file whose only light is directional: refused with the way out, and fine with --light.
  const std::string duck = kAssimpModels + "/Collada/duck.dae";
  if (fs::exists(duck)) {
    fs::path out = tempDir("duck");
    CliRun r = cli("render " + duck + " --width 16 --height 16 --frames 1 --out " + out.string());
    EXPECT_EQ(r.code, 1) << r.out;
    EXPECT_NE(r.out.find("directional"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("--light"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(out));
    r = cli("render " + duck + " --light 0,400,0 --width 16 --height 16 --frames 1 --quiet --out " + out.string());
    EXPECT_EQ(r.code, 0) << r.out;
    fs::remove_all(out);
  }
  fs::remove_all(dir);
}

}  // namespace

namespace cs::test {
namespace {

// Out of memory, host or device, at whatever point of a run the memory runs out (driver start-up,
// Embree's thread pool, a Vulkan allocation, a host allocation): one line naming what failed and what
// to do, exit 1, no output folder -- or, with enough memory, a complete result. The process's address
// space is capped with prlimit (util-linux) from 100 MB, where the driver cannot start (or, below that,
// the dynamic loader cannot map the libraries: not the program's to report), to 2 GB, where the run
// completes. Not under AddressSanitizer, whose shadow memory needs terabytes of address space.
TEST(Cli, EveryMemoryLimitGivesACompleteResultOrOneClearLineAndNoOutput) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer reserves more address space than any cap leaves";
#else
  namespace fs = std::filesystem;
  if (std::system("command -v prlimit > /dev/null 2>&1") != 0) GTEST_SKIP() << "prlimit (util-linux) is not installed";
  const fs::path out = fs::temp_directory_path() / "coneshadow_memory_limit_test";
  bool failed = false, completed = false;
  auto capped = [](uint64_t mb, const std::string& args) {
    CliRun r = cli(args, "prlimit --as=" + std::to_string(mb << 20) + " ");
    // The dynamic loader could not map the libraries: the program never started (not its to report).
    if (r.code == 127 && r.out.find("error while loading shared libraries") != std::string::npos) r.code = -2;
    return r;
  };
  for (uint64_t mb = 100; mb <= 2000; mb += 150) {
    fs::remove_all(out);
    const CliRun r = capped(mb, "render --methods cone,cubesm --width 96 --height 96 --frames 1 --quiet --out " + out.string());
    ASSERT_NE(r.code, -1) << mb << " MB: killed by a signal (a crash, not an error):\n" << r.out;
    if (r.code == -2) continue;
    if (r.code == 0) {
      completed = true;
      EXPECT_TRUE(fs::exists(out / "results.json")) << mb << " MB: exit 0 without results.json";
      continue;
    }
    failed = true;
    EXPECT_EQ(r.code, 1) << mb << " MB:\n" << r.out;
    const size_t at = r.out.find("coneshadow: error: ");
    ASSERT_NE(at, std::string::npos) << mb << " MB: no error line:\n" << r.out;
    const std::string line = r.out.substr(at, r.out.find('\n', at) - at);
    EXPECT_NE(line.find('('), std::string::npos) << mb << " MB: the error names no remedy: " << line;
    EXPECT_EQ(line.find("std::bad_alloc"), std::string::npos) << mb << " MB: a bare exception name: " << line;
    EXPECT_FALSE(fs::exists(out)) << mb << " MB: a failed run left its --out folder";
  }
  fs::remove_all(out);
  EXPECT_TRUE(failed) << "no cap was small enough to fail: the test did not see the failure path";
  EXPECT_TRUE(completed) << "no cap was large enough to complete";

  // The glTF reader under the same caps (a std::bad_alloc thrown inside the parse once escaped through
  // a destructor and aborted): an answer or an error, never a signal.
  const std::string engine = std::string(CONESHADOW_ASSIMP_MODELS) + "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
  for (uint64_t mb = 60; mb <= 400; mb += 20) {
    const CliRun r = capped(mb, "info " + engine);
    ASSERT_NE(r.code, -1) << mb << " MB, info: killed by a signal:\n" << r.out;
    EXPECT_TRUE(r.code == -2 || r.code == 0 || (r.code == 1 && r.out.find("coneshadow: error: ") != std::string::npos))
        << mb << " MB, info: exit " << r.code << ":\n" << r.out;
  }
#endif
}

// A process that cannot start a thread (no memory left for a thread's stack, or its thread limit
// reached): the first thread the CLI starts is its own, the interrupt cleanup's, before any driver or
// library loads; that failing ends the run with one line saying what and what to do, exit 1, no output
// folder -- where it used to abort before anything could report it. With threads allowed, the same run
// completes. (Later thread starts belong to the driver and the libraries: Embree reports its own; seen
// on lavapipe, its queue thread can wait forever for a worker that never started.)
TEST(Cli, AProcessThatCannotStartThreadsGetsOneClearLine) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's runtime must come first: no library can be preloaded before it";
#else
  namespace fs = std::filesystem;
  const fs::path out = fs::temp_directory_path() / "coneshadow_thread_start_test";
  fs::remove_all(out);
  const std::string args = "render --methods cone --width 32 --height 32 --frames 1 --quiet --out " + out.string();
  const std::string preload = std::string("LD_PRELOAD=") + CONESHADOW_THREAD_START_FAILURE + " ";
  const CliRun none = cli(args, preload + "CONESHADOW_THREADS_ALLOWED=0 ");
  EXPECT_EQ(none.code, 1) << none.out;
  const size_t at = none.out.find("coneshadow: error: ");
  ASSERT_NE(at, std::string::npos) << none.out;
  const std::string line = none.out.substr(at, none.out.find('\n', at) - at);
  EXPECT_NE(line.find("thread"), std::string::npos) << line;
  EXPECT_NE(line.find("ulimit"), std::string::npos) << line;
  EXPECT_FALSE(fs::exists(out)) << "a failed run left its --out folder";
  const CliRun all = cli(args, preload + "CONESHADOW_THREADS_ALLOWED=1000000 ");
  EXPECT_EQ(all.code, 0) << all.out;
  EXPECT_TRUE(fs::exists(out / "results.json"));
  fs::remove_all(out);
#endif
}

}  // namespace
}  // namespace cs::test
