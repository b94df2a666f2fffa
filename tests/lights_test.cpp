// Every point light of a scene (issue 49, item 3): --light given several times and --all-lights. Each
// light is a frame of its own, judged against Embree for that light: one row per (method, light), with
// the masks of separate one-light runs, the light's index and position in every row, its images and
// dump named by its index; a single light keeps the names it always had. A method runs a view's lights
// together: the cone path records them in one submission.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "tests/cli_support.h"

namespace fs = std::filesystem;

namespace {

using cs::test::CliRun;
using cs::test::cli;
using nlohmann::json;

fs::path tempDir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("coneshadow_lights_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

json readJson(const fs::path& p) { return json::parse(std::ifstream(p)); }

std::string readBytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

std::string base64(const std::vector<unsigned char>& bytes) {
  static const char table[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const size_t n = std::min<size_t>(3, bytes.size() - i);
    uint32_t v = 0;
    for (size_t k = 0; k < 3; ++k) v = v << 8 | (k < n ? bytes[i + k] : 0u);
    for (size_t k = 0; k < 4; ++k) out += k <= n ? table[(v >> (18 - 6 * k)) & 63] : '=';
  }
  return out;
}

template <typename T>
void append(std::vector<unsigned char>& bin, const std::vector<T>& values) {
  const size_t at = bin.size();
  bin.resize(at + values.size() * sizeof(T));
  std::memcpy(bin.data() + at, values.data(), values.size() * sizeof(T));
}

// A floor (4 x 4 at y = 0) and a square occluder above it (1 x 1 at y = 1), a camera looking down on
// them, and the given point lights (KHR_lights_punctual), as a .gltf file in `dir`.
fs::path writeScene(const fs::path& dir, const std::vector<std::vector<float>>& lights) {
  fs::create_directories(dir);
  std::vector<unsigned char> bin;
  append<float>(bin, {-2, 0, -2, 2, 0, -2, 2, 0, 2, -2, 0, 2,                      // floor
                      -0.5f, 1, -0.5f, 0.5f, 1, -0.5f, 0.5f, 1, 0.5f, -0.5f, 1, 0.5f});  // occluder
  for (int v = 0; v < 8; ++v) append<float>(bin, {0, 1, 0});                    // normals: +y
  append<uint16_t>(bin, {0, 2, 1, 0, 3, 2, 4, 6, 5, 4, 7, 6});
  json doc = json::parse(R"({
    "asset": {"version": "2.0"},
    "scene": 0,
    "scenes": [{"nodes": [0, 1]}],
    "nodes": [
      {"mesh": 0},
      {"camera": 0, "translation": [0, 4, 5], "rotation": [-0.34202, 0, 0, 0.93969]}],
    "cameras": [{"type": "perspective", "name": "above", "perspective": {"yfov": 0.9, "znear": 0.05}}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3", "min": [-2, 0, -2], "max": [2, 1, 2]},
      {"bufferView": 1, "componentType": 5126, "count": 8, "type": "VEC3"},
      {"bufferView": 2, "componentType": 5123, "count": 12, "type": "SCALAR"}],
    "bufferViews": [
      {"buffer": 0, "byteOffset": 0, "byteLength": 96},
      {"buffer": 0, "byteOffset": 96, "byteLength": 96},
      {"buffer": 0, "byteOffset": 192, "byteLength": 24}],
    "buffers": [{"byteLength": 216}]
  })");
  doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64(bin);
  if (!lights.empty()) {
    doc["extensionsUsed"] = {"KHR_lights_punctual"};
    for (size_t i = 0; i < lights.size(); ++i) {
      doc["extensions"]["KHR_lights_punctual"]["lights"].push_back(
          {{"type", "point"}, {"name", "bulb" + std::to_string(i)}, {"intensity", 1}});
      doc["scenes"][0]["nodes"].push_back(doc["nodes"].size());
      doc["nodes"].push_back({{"translation", lights[i]}, {"extensions", {{"KHR_lights_punctual", {{"light", i}}}}}});
    }
  }
  const fs::path file = dir / (lights.empty() ? "dark.gltf" : "lit.gltf");
  std::ofstream(file) << doc.dump(1);
  return file;
}

TEST(Lights, TwoLightFlagsGiveTwoRowsPerMethodWithTheMasksOfTwoOneLightRuns) {
  const std::vector<std::string> lights = {"1,2.5,0.5", "-1.5,2,1"};
  const std::string common = " --methods cone,cubesm --sm-resolution 256 --view room --width 32 --height 24 --frames 1 --quiet";
  const fs::path out = tempDir("two"), dump = tempDir("two_dump");
  CliRun r = cli("render" + common + " --light " + lights[0] + " --light=" + lights[1] + " --out " + out.string() +
                 " --dump " + dump.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const json rows = readJson(out / "results.json");
  ASSERT_EQ(rows.size(), 6u) << "per light: the reference's row, then one per method";
  const std::vector<std::string> methods = {"embree", "cone", "cubesm"};
  for (size_t l = 0; l < lights.size(); ++l) {
    const fs::path one = tempDir("one" + std::to_string(l)), oneDump = tempDir("one_dump" + std::to_string(l));
    CliRun single = cli("render" + common + " --light " + lights[l] + " --out " + one.string() + " --dump " + oneDump.string());
    ASSERT_EQ(single.code, 0) << single.out;
    const json alone = readJson(one / "results.json");
    ASSERT_EQ(alone.size(), 3u);
    for (size_t m = 0; m < methods.size(); ++m) {
      const json& row = rows[l * methods.size() + m];
      const std::string what = methods[m] + " under light " + std::to_string(l);
      EXPECT_EQ(row["method"], methods[m]) << what;
      EXPECT_EQ(row["stats"]["light_index"], l) << what;
      EXPECT_EQ(row["stats"]["light"], alone[m]["provenance"]["light"]) << what;
      EXPECT_EQ(row["provenance"]["light"], alone[m]["provenance"]["light"]) << what;
      EXPECT_EQ(alone[m]["stats"]["light_index"], 0) << what;
      EXPECT_EQ(row["error"], alone[m]["error"]) << what << ": judged against Embree for that light";
      // The masks bit for bit: the dump's floats, and the mask images.
      const std::string visibility = "visibility_" + methods[m] + ".pfm";
      EXPECT_EQ(readBytes(dump / ("light" + std::to_string(l)) / visibility), readBytes(oneDump / visibility)) << what;
      EXPECT_EQ(readBytes(out / (methods[m] + "_light" + std::to_string(l) + "_mask.png")),
                readBytes(one / (methods[m] + "_mask.png")))
          << what;
      // One light keeps today's names.
      EXPECT_FALSE(fs::exists(one / (methods[m] + "_light0_mask.png"))) << what;
      EXPECT_FALSE(fs::exists(out / (methods[m] + "_mask.png"))) << what << ": no unsuffixed image beside the lights'";
    }
    EXPECT_EQ(rows[l * 3 + 1]["error"]["misclassified_outside_band"], 0) << "the cone path is exact under light " << l;
    // The cone path takes both lights in one frame; the cube map a light at a time, each as alone.
    EXPECT_EQ(rows[l * 3 + 1]["stats"]["lights_in_frame"], 2);
    EXPECT_EQ(rows[l * 3 + 1]["stats"]["submits_per_frame"], 1);
    EXPECT_FALSE(rows[l * 3 + 2]["stats"].contains("lights_in_frame"));
    EXPECT_EQ(rows[l * 3 + 2]["stats"]["submits_per_frame"], alone[2]["stats"]["submits_per_frame"]);
    EXPECT_FALSE(fs::exists(oneDump / "light0"));
    EXPECT_NE(r.out.find("result: cone on builtin/room light " + std::to_string(l) + " ("), std::string::npos) << r.out;
    fs::remove_all(one);
    fs::remove_all(oneDump);
  }
  fs::remove_all(out);
  fs::remove_all(dump);
}

// The cone path records a view's lights together (ShadowMethod::runLights): three lights make one
// submission and one host wait a frame, and each light's mask is bit for bit a run of that light alone;
// a two-pass variant (its host decides between submissions) runs a frame a light and says so.
TEST(Lights, TheConePathRecordsAViewsLightsInOneSubmissionWithTheMasksOfOneLightRuns) {
  const std::vector<std::string> lights = {"1,2.5,0.5", "-1.5,2,1", "0.5,3,-1"};
  const std::string common = " --methods cone --view room --width 64 --height 64 --frames 2 --quiet";
  std::string flags;
  for (const std::string& l : lights) flags += " --light " + l;
  const fs::path out = tempDir("together"), dump = tempDir("together_dump");
  CliRun r = cli("render" + common + flags + " --out " + out.string() + " --dump " + dump.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const json rows = readJson(out / "results.json");
  ASSERT_EQ(rows.size(), 6u) << "per light: the reference's row and the cone path's";
  for (size_t l = 0; l < lights.size(); ++l) {
    const std::string what = "light " + std::to_string(l);
    const json& row = rows[2 * l + 1];
    ASSERT_EQ(row["method"], "cone") << what;
    const json& st = row["stats"];
    EXPECT_EQ(st["submits_per_frame"], 1) << what << ": one submission for the view's three lights";
    EXPECT_EQ(st["host_syncs_per_frame"], 1) << what;
    EXPECT_EQ(st["allocations_per_frame"], 0) << what << ": warm frames allocate nothing";
    EXPECT_EQ(st["lights_in_frame"], 3) << what;
    EXPECT_EQ(st["lights_frame"]["together"], true) << what;
    EXPECT_EQ(st["traversal_path"], "one submission for 3 lights") << what;
    EXPECT_NEAR(row["total_ms"].get<double>() * 3, st["lights_frame"]["frame_ms"].get<double>(),
                1e-6 * st["lights_frame"]["frame_ms"].get<double>())
        << what << ": a light's time is its even share of the frame on a device without trusted timestamps";
    const fs::path one = tempDir("alone" + std::to_string(l)), oneDump = tempDir("alone_dump" + std::to_string(l));
    CliRun single = cli("render" + common + " --light " + lights[l] + " --out " + one.string() + " --dump " +
                        oneDump.string());
    ASSERT_EQ(single.code, 0) << single.out;
    const json alone = readJson(one / "results.json");
    EXPECT_EQ(alone[1]["stats"]["submits_per_frame"], 1) << what;
    EXPECT_FALSE(alone[1]["stats"].contains("lights_in_frame")) << what;
    EXPECT_EQ(row["error"], alone[1]["error"]) << what;
    EXPECT_EQ(readBytes(dump / ("light" + std::to_string(l)) / "visibility_cone.pfm"),
              readBytes(oneDump / "visibility_cone.pfm"))
        << what;
    fs::remove_all(one);
    fs::remove_all(oneDump);
  }
  const fs::path twoPass = tempDir("two_pass");
  r = cli("render" + common + flags + " --variant PreciseEATP --out " + twoPass.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const json tp = readJson(twoPass / "results.json");
  for (size_t l = 0; l < lights.size(); ++l) {
    const json& st = tp[2 * l + 1]["stats"];
    EXPECT_EQ(st["lights_frame"]["together"], false) << l;
    EXPECT_NE(st["lights_frame"]["why"].get<std::string>().find("two-pass"), std::string::npos) << st.dump();
    EXPECT_GT(st["submits_per_frame"].get<uint64_t>(), 3u) << "several submissions a light";
    EXPECT_EQ(tp[2 * l + 1]["error"]["misclassified_outside_band"], 0) << l;
  }
  fs::remove_all(out);
  fs::remove_all(dump);
  fs::remove_all(twoPass);
}

TEST(Lights, AllLightsTakesEveryPointLightOfTheFile) {
  const fs::path dir = tempDir("all");
  const std::vector<std::vector<float>> lights = {{0.3f, 3, 0.2f}, {-1, 2.5f, 0.5f}};
  const fs::path scene = writeScene(dir, lights);
  const fs::path out = dir / "render";
  CliRun r = cli("render " + scene.string() + " --all-lights --methods cone --width 24 --height 24 --frames 1 --quiet --out " +
                 out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  json rows = readJson(out / "results.json");
  ASSERT_EQ(rows.size(), 4u) << "per light: the reference's row and the cone path's";
  for (size_t k = 0; k < rows.size(); ++k) {
    const size_t l = k / 2;
    EXPECT_EQ(rows[k]["method"], k % 2 ? "cone" : "embree");
    EXPECT_EQ(rows[k]["stats"]["light_index"], l);
    for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(rows[k]["stats"]["light"][c].get<float>(), lights[l][c]) << k;
    EXPECT_GT(rows[k]["error"]["lit_samples"].get<uint64_t>(), 0u) << k;
  }
  EXPECT_EQ(rows[1]["error"]["misclassified_outside_band"], 0);
  EXPECT_EQ(rows[3]["error"]["misclassified_outside_band"], 0);
  EXPECT_NE(readBytes(out / "embree_light0_mask.png"), readBytes(out / "embree_light1_mask.png"))
      << "two lights, two shadows";
  EXPECT_TRUE(fs::exists(out / "cone_light1_shaded.png"));

  // compare too: each view under each light, its section and files named by the light.
  const fs::path cmp = dir / "compare";
  r = cli("compare " + scene.string() + " --all-lights --methods cone --width 16 --height 16 --frames 1 --quiet --out " +
          cmp.string());
  ASSERT_EQ(r.code, 0) << r.out;
  rows = readJson(cmp / "results.json");
  ASSERT_EQ(rows.size() % 2, 0u);
  for (size_t k = 0; k < rows.size(); ++k) EXPECT_EQ(rows[k]["stats"]["light_index"], k < rows.size() / 2 ? 0 : 1) << k;
  EXPECT_TRUE(fs::exists(cmp / "above_light0_closeups.png"));
  EXPECT_TRUE(fs::exists(cmp / "above_light1_closeups.png"));
  std::ifstream md(cmp / "report.md");
  const std::string report((std::istreambuf_iterator<char>(md)), {});
  EXPECT_NE(report.find("## above, light 1"), std::string::npos) << report.substr(0, 3000);
  fs::remove_all(dir);
}

TEST(Lights, AllLightsOnAFileWithoutALightIsOneClearLineAndNoOutput) {
  const fs::path dir = tempDir("none");
  const fs::path scene = writeScene(dir, {});
  const fs::path out = dir / "out";
  for (const char* command : {"render", "compare"}) {
    const CliRun r = cli(std::string(command) + " " + scene.string() + " --all-lights --methods cone --width 16 --height 16 "
                         "--frames 1 --quiet --out " + out.string());
    EXPECT_EQ(r.code, 2) << command << "\n" << r.out;
    EXPECT_EQ(r.out.rfind("coneshadow: --all-lights: scene ", 0), 0u) << command << "\n" << r.out;
    EXPECT_NE(r.out.find("has no point light"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find('\n'), r.out.size() - 1) << command << ": one line\n" << r.out;
    EXPECT_FALSE(fs::exists(out)) << command;
  }
  // Lights given and lights taken are one or the other; the one-light runs take one.
  for (const char* args : {"render --all-lights --light 1,2,3", "compare --animate 2 --light 1,2,3 --light 1,3,3",
                           "compare --scaling --all-lights", "compare --light-distances 2 --light 1,2,3 --light 1,3,3"}) {
    const CliRun r = cli(std::string(args) + " --out " + out.string());
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_FALSE(fs::exists(out)) << args;
  }
  fs::remove_all(dir);
}

}  // namespace
