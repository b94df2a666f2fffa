// `coneshadow view` (viewer/, docs/ARCHITECTURE.md "The viewer"): its script, its refusal without a window
// system, and, under Xvfb (xvfb-run starts one a run), that its screenshots hold the CLI's pixels, that
// what it shows follows the method and the light, and that the cone path's frame is one submission and one
// present with no allocation.
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>
#include <regex>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <stb_image.h>  // implementation compiled once, in core/tinygltf_impl.cpp

#include "core/error.h"
#include "tests/cli_support.h"
#include "viewer/script.h"

namespace fs = std::filesystem;

namespace {

using cs::test::CliRun;
using cs::test::cli;
using nlohmann::json;

// Each run gets an X server of its own, its screen larger than any window here.
const std::string kXvfb = "xvfb-run -a -s '-screen 0 640x480x24' ";

fs::path tempDir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("coneshadow_view_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string readBytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

void writeText(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

bool haveXvfb() { return std::system("command -v xvfb-run > /dev/null 2>&1") == 0; }

// The largest difference of any channel of two PNGs of one size over the columns [x0, x1) (x1 < 0: to the
// right edge); -1 when they cannot be compared.
int maxChannelDifference(const fs::path& a, const fs::path& b, int x0 = 0, int x1 = -1) {
  int wa, ha, na, wb, hb, nb;
  unsigned char* pa = stbi_load(a.string().c_str(), &wa, &ha, &na, 3);
  unsigned char* pb = stbi_load(b.string().c_str(), &wb, &hb, &nb, 3);
  int worst = -1;
  if (pa && pb && wa == wb && ha == hb) {
    worst = 0;
    if (x1 < 0) x1 = wa;
    for (int y = 0; y < ha; ++y)
      for (int x = x0; x < x1; ++x)
        for (int c = 0; c < 3; ++c) {
          const int i = (y * wa + x) * 3 + c;
          worst = std::max(worst, std::abs(int(pa[i]) - int(pb[i])));
        }
  }
  stbi_image_free(pa);
  stbi_image_free(pb);
  return worst;
}

TEST(ViewerScript, ParsesEveryCommandAndNamesTheLineOfABadOne) {
  const auto steps = cs::viewer::parseScript(
      "# a comment\n"
      "method cubesm\nset sm-resolution 256\nset sm-cache\nlight 1 2 3\nmove-light 0.5 0 -0.5\ncamera fur\n"
      "orbit 0.1 -0.2\ndisplay diff\ntime 0.5\n\nwait 4   # frames\nwait-reference\nscreenshot a.png\nsplit rmsm\nquit\n"
      "lights all\nlights 0,2\nshow-light 1\n",
      "s.txt");
  ASSERT_EQ(steps.size(), 17u);
  EXPECT_EQ(steps[0].kind, cs::viewer::ScriptStep::Method);
  EXPECT_EQ(steps[0].name, "cubesm");
  EXPECT_EQ(steps[1].value, "256");
  EXPECT_EQ(steps[2].value, "");
  EXPECT_EQ(steps[3].v, glm::vec3(1, 2, 3));
  EXPECT_EQ(steps[4].kind, cs::viewer::ScriptStep::MoveLight);
  EXPECT_EQ(steps[6].v.y, -0.2f);
  EXPECT_EQ(steps[8].kind, cs::viewer::ScriptStep::Time);
  EXPECT_EQ(steps[8].v.x, 0.5f);
  EXPECT_EQ(steps[9].frames, 4u);
  EXPECT_EQ(steps[9].line, 12);
  EXPECT_EQ(steps[12].kind, cs::viewer::ScriptStep::Split);
  EXPECT_EQ(steps[12].name, "rmsm");
  EXPECT_EQ(steps[13].kind, cs::viewer::ScriptStep::Quit);
  EXPECT_EQ(steps[14].kind, cs::viewer::ScriptStep::Lights);
  EXPECT_TRUE(steps[14].lights.empty());  // all
  EXPECT_EQ(steps[15].lights, (std::vector<uint32_t>{0, 2}));
  EXPECT_EQ(steps[16].kind, cs::viewer::ScriptStep::ShowLight);
  EXPECT_EQ(steps[16].lights, (std::vector<uint32_t>{1}));
  for (const char* bad : {"light 1 2\n", "wait -1\n", "display wireframe\n", "jump 3\n", "light 1 nan 2\n", "lights 0,,1\n",
                          "lights -1\n", "lights\n", "show-light 1,2\n", "show-light all\n", "lights 64\n"}) {
    try {
      cs::viewer::parseScript(std::string("wait 1\n") + bad, "s.txt");
      ADD_FAILURE() << "accepted: " << bad;
    } catch (const cs::Error& e) {
      EXPECT_NE(std::string(e.what()).find("s.txt:2"), std::string::npos) << e.what();
    }
  }
}

TEST(Viewer, WithoutAWindowSystemItIsOneLineAndExitOneAndBadUsageIsTwo) {
  const CliRun r = cli("view --frames 1", "env -u DISPLAY -u WAYLAND_DISPLAY ");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("no window system"), std::string::npos) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  for (const char* args : {"view --screenshot x.png",  // a screenshot of a run that never ends
                           "view --out somewhere", "view --all-lights --light 1,2,3", "view --display wireframe"}) {
    const CliRun usage = cli(args);
    EXPECT_EQ(usage.code, 2) << args << ": " << usage.out;
  }
}

TEST(Viewer, HiddenUiScreenshotsHoldTheShadowPixelsOfRender) {
  if (!haveXvfb()) GTEST_SKIP() << "xvfb-run is not installed (tools/setup.sh installs it)";
  const fs::path dir = tempDir("pixels"), out = dir / "render";
  const std::string frame = "--view fur --width 128 --height 96 --methods cone,cubesm";
  const CliRun render = cli("render " + frame + " --frames 1 --quiet --out " + out.string());
  ASSERT_EQ(render.code, 0) << render.out;
  writeText(dir / "script.txt",
            "display mask\nwait 1\nscreenshot " + (dir / "cone_mask.png").string() + "\n"
            "display shaded\nwait 1\nscreenshot " + (dir / "cone_shaded.png").string() + "\n"
            "method cubesm\ndisplay mask\nwait 1\nscreenshot " + (dir / "cubesm_mask.png").string() + "\n"
            "display diff\nwait-reference\nwait 1\nscreenshot " + (dir / "cubesm_diff.png").string() + "\nquit\n");
  const CliRun view = cli("view " + frame + " --hide-ui --script " + (dir / "script.txt").string(), kXvfb);
  ASSERT_EQ(view.code, 0) << view.out;
  // The mask's pixels are the CLI's, byte for byte, on the API's path and on the registry's.
  EXPECT_EQ(readBytes(dir / "cone_mask.png"), readBytes(out / "cone_mask.png"));
  EXPECT_EQ(readBytes(dir / "cubesm_mask.png"), readBytes(out / "cubesm_mask.png"));
  // Shading is the same formula on the GPU: within one step of the CLI's rounding.
  const int shaded = maxChannelDifference(dir / "cone_shaded.png", out / "cone_shaded.png");
  EXPECT_GE(shaded, 0);
  EXPECT_LE(shaded, 1);
  // The diff frame's row judges cubesm against the worker's Embree as render does.
  const json row = json::parse(std::ifstream(dir / "cubesm_diff.json"));
  const json rendered = json::parse(std::ifstream(out / "results.json"));
  const auto cubesm = std::find_if(rendered.begin(), rendered.end(), [](const json& r) { return r["method"] == "cubesm"; });
  ASSERT_NE(cubesm, rendered.end());
  EXPECT_TRUE(row["stats"]["reference_shown"].get<bool>()) << row.dump();
  for (const char* k : {"lit_samples", "band_samples", "misclassified", "false_shadow", "false_light"})
    EXPECT_EQ(row["error"][k], (*cubesm)["error"][k]) << k;
  EXPECT_EQ(row["provenance"]["tool"], "coneshadow view");
  fs::remove_all(dir);
}

TEST(Viewer, AMethodSwitchALightDragTheSplitScreenAndTheSceneTimeChangeWhatIsShown) {
  if (!haveXvfb()) GTEST_SKIP() << "xvfb-run is not installed (tools/setup.sh installs it)";
  const fs::path dir = tempDir("changes");
  writeText(dir / "script.txt",
            "display mask\nwait 1\nscreenshot " + (dir / "a.png").string() + "\n"
            "move-light 0.6 0 0.4\nwait 1\nscreenshot " + (dir / "b.png").string() + "\n"
            "method cubesm\nset sm-resolution 64\nwait 1\nscreenshot " + (dir / "c.png").string() + "\n"
            "method cone\nsplit cubesm\nwait 1\nscreenshot " + (dir / "d.png").string() + "\n"
            "split off\ntime 0.3\nwait 1\nscreenshot " + (dir / "e.png").string() + "\nquit\n");
  const CliRun view = cli("view --view room --width 128 --height 96 --methods cone,cubesm --hide-ui --script " +
                              (dir / "script.txt").string(), kXvfb);
  ASSERT_EQ(view.code, 0) << view.out;
  const std::string a = readBytes(dir / "a.png"), b = readBytes(dir / "b.png"), c = readBytes(dir / "c.png");
  ASSERT_FALSE(a.empty());
  EXPECT_NE(a, b) << "the light moved and the mask stayed";
  EXPECT_NE(b, c) << "the method changed and the mask stayed";
  const json row = json::parse(std::ifstream(dir / "c.json"));
  EXPECT_EQ(row["method"], "cubesm");
  EXPECT_EQ(row["stats"]["settings"]["sm-resolution"], "64");
  // Split: the cone path left of the middle (b's pixels), cubesm at its settings right of it (c's); the
  // two columns at the middle are the divider.
  EXPECT_EQ(maxChannelDifference(dir / "d.png", dir / "b.png", 0, 63), 0);
  EXPECT_EQ(maxChannelDifference(dir / "d.png", dir / "c.png", 65), 0);
  EXPECT_NE(readBytes(dir / "d.png"), b);
  // The built-in scene's motion: the cone path's mask of the same view and light at another time.
  EXPECT_NE(readBytes(dir / "e.png"), b) << "the scene moved and the mask stayed";
  fs::remove_all(dir);
}

// Two lights of the built-in scene: its own (room_light) and one across the room from it.
const std::string kLightA = "1.3,3.1,-0.7", kLightB = "0.2,3.0,0.6";

TEST(Viewer, SeveralLightsAtOnceOnTheConePathShadeTogetherAndEachMaskIsTheCLIs) {
  if (!haveXvfb()) GTEST_SKIP() << "xvfb-run is not installed (tools/setup.sh installs it)";
  const fs::path dir = tempDir("lights"), out = dir / "render";
  const std::string frame = "--view fur --width 128 --height 96 --light " + kLightA + " --light " + kLightB;
  const CliRun render = cli("render " + frame + " --methods cone --frames 1 --quiet --out " + out.string());
  ASSERT_EQ(render.code, 0) << render.out;
  writeText(dir / "script.txt",
            "lights 0\nwait 1\nscreenshot " + (dir / "one0.png").string() + "\n"
            "lights 1\nwait 1\nscreenshot " + (dir / "one1.png").string() + "\n"
            "lights all\nwait 1\nscreenshot " + (dir / "both.png").string() + "\n"
            "display mask\nshow-light 0\nwait 1\nscreenshot " + (dir / "mask0.png").string() + "\n"
            "show-light 1\nwait 1\nscreenshot " + (dir / "mask1.png").string() + "\nquit\n");
  const CliRun view = cli("view " + frame + " --hide-ui --script " + (dir / "script.txt").string(), kXvfb);
  ASSERT_EQ(view.code, 0) << view.out;
  const std::string both = readBytes(dir / "both.png");
  ASSERT_FALSE(both.empty());
  EXPECT_NE(both, readBytes(dir / "one0.png")) << "the second light added nothing";
  EXPECT_NE(both, readBytes(dir / "one1.png")) << "the first light added nothing";
  // One light shown: render's shading of that light, within one step of rounding.
  for (int k : {0, 1}) {
    const int d = maxChannelDifference(dir / ("one" + std::to_string(k) + ".png"), out / ("cone_light" + std::to_string(k) + "_shaded.png"));
    EXPECT_GE(d, 0) << k;
    EXPECT_LE(d, 1) << k;
  }
  // Two lights shown, one frame: each light's mask is render's for that light, byte for byte.
  EXPECT_EQ(readBytes(dir / "mask0.png"), readBytes(out / "cone_light0_mask.png"));
  EXPECT_EQ(readBytes(dir / "mask1.png"), readBytes(out / "cone_light1_mask.png"));
  EXPECT_NE(readBytes(dir / "mask0.png"), readBytes(dir / "mask1.png"));
  const json row = json::parse(std::ifstream(dir / "mask1.json"));
  EXPECT_EQ(row["provenance"]["lights_shown"].size(), 2u) << row.dump();
  EXPECT_EQ(row["provenance"]["mask_light"], 1);
  fs::remove_all(dir);
}

TEST(Viewer, TheConeFrameIsOneSubmissionOnePresentAndNoAllocationAndValid) {
  if (!haveXvfb()) GTEST_SKIP() << "xvfb-run is not installed (tools/setup.sh installs it)";
  // The panels shown: ImGui draws into the same render pass, in the same submission. Two lights: one
  // recordFrame takes both. Once under the validation layer, which says nothing, and once without it for
  // the host's heap (the layer allocates on the loop's thread in every call it checks).
  const std::string run = "view --width 128 --height 96 --frames 12 --stats --light " + kLightA + " --light " + kLightB;
  const std::regex stats("steady (\\d+), method cone \\(public API\\); per steady frame: submits ([0-9.]+), "
                         "presents ([0-9.]+), host syncs ([0-9.]+), device allocations ([0-9.]+) "
                         "\\(the project's\\) \\+ ([0-9.]+) \\(ImGui's\\); host allocations over the (\\d+) "
                         "[^:]*: operator new (\\d+) in the viewer \\+ (\\d+) in coneshadow::Context::recordFrame, "
                         "ImGui (\\d+); lights 2;");
  for (const bool validated : {true, false}) {
    const CliRun r = cli(run, (validated ? "env VK_INSTANCE_LAYERS=VK_LAYER_KHRONOS_validation " : "") + kXvfb);
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_EQ(r.out.find("VUID"), std::string::npos) << r.out;
    std::smatch m;
    ASSERT_TRUE(std::regex_search(r.out, m, stats)) << r.out;
    EXPECT_GE(std::stoi(m[1]), 8);
    EXPECT_EQ(std::stod(m[2]), 1.0);
    EXPECT_EQ(std::stod(m[3]), 1.0);
    EXPECT_EQ(std::stod(m[4]), 1.0);
    EXPECT_EQ(std::stod(m[5]), 0.0) << "the project's device allocations";
    EXPECT_EQ(std::stod(m[6]), 0.0) << "the ImGui backend's device allocations";
    // The last frame's GPU times, a light each, where the queue family's timestamps are valid.
    const std::regex gpu("the cone path's GPU time, last frame \\([^)]*\\): ([0-9.e+-]+) ms\\. light 0: light term "
                         "[^;]*; light 1: light term [^;\\n]* ms\\n|the cone path's GPU times: none \\(");
    std::smatch g;
    ASSERT_TRUE(std::regex_search(r.out, g, gpu)) << r.out;
    if (g[1].matched) { EXPECT_GT(std::stod(g[1]), 0.0) << r.out; }
    if (validated) continue;
    // Host heap: the coneshadow binary counts operator new on the loop's thread, ImGui its own. Neither
    // the viewer's frame nor the public API's recordFrame inside it (counted apart) allocates
    // (docs/ARCHITECTURE.md, "The viewer").
    EXPECT_GE(std::stoi(m[7]), 4) << r.out;
    EXPECT_EQ(std::stoi(m[8]), 0) << r.out;
    EXPECT_EQ(std::stoi(m[9]), 0) << "recordFrame's host allocations: " << r.out;
    EXPECT_EQ(std::stoi(m[10]), 0) << r.out;
  }
}

}  // namespace
