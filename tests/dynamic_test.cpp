// Dynamic scenes: the rigid animation model (channel sampling, parent chains, glTF animation loading
// and its validation, the built-in motion) and `coneshadow compare --animate`, where every method pays
// its per-frame cost and the cone path stays exact on every frame.
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/animation.h"
#include "core/error.h"
#include "tests/cli_support.h"
#include "tests/test_context.h"

namespace cs {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr double kPi = 3.14159265358979323846;

glm::dvec4 quatAbout(glm::dvec3 axis, double angle) {
  const glm::dquat q = glm::angleAxis(angle, glm::normalize(axis));
  return {q.x, q.y, q.z, q.w};
}

void expectNear(const glm::dmat4& a, const glm::dmat4& b, double tol, const std::string& what) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) EXPECT_NEAR(a[c][r], b[c][r], tol) << what << " [" << c << "][" << r << "]";
}

AnimationChannel channel(AnimationPath path, AnimationInterpolation interp, std::vector<double> times,
                         std::vector<glm::dvec4> values, int node = 0) {
  AnimationChannel c;
  c.node = node;
  c.path = path;
  c.interpolation = interp;
  c.times = std::move(times);
  c.values = std::move(values);
  return c;
}

TEST(AnimationSampler, LinearTranslationAtAndBetweenKeysHeldAtTheEnds) {
  const AnimationChannel c = channel(AnimationPath::Translation, AnimationInterpolation::Linear, {1, 2, 4},
                                     {{0, 0, 0, 0}, {2, 4, -2, 0}, {4, 4, 2, 0}});
  EXPECT_EQ(sampleChannel(c, 2), glm::dvec4(2, 4, -2, 0));
  EXPECT_EQ(sampleChannel(c, 1.5), glm::dvec4(1, 2, -1, 0));
  EXPECT_EQ(sampleChannel(c, 3), glm::dvec4(3, 4, 0, 0));
  EXPECT_EQ(sampleChannel(c, 0), glm::dvec4(0, 0, 0, 0));   // before the first key: held
  EXPECT_EQ(sampleChannel(c, 9), glm::dvec4(4, 4, 2, 0));   // after the last: held
}

TEST(AnimationSampler, LinearRotationIsShortestArcSlerp) {
  const AnimationChannel c = channel(AnimationPath::Rotation, AnimationInterpolation::Linear, {0, 1},
                                     {quatAbout({0, 0, 1}, 0), quatAbout({0, 0, 1}, kPi / 2)});
  const glm::dvec4 mid = sampleChannel(c, 0.5), quarter = sampleChannel(c, 0.25);
  const glm::dvec4 expectMid = quatAbout({0, 0, 1}, kPi / 4), expectQuarter = quatAbout({0, 0, 1}, kPi / 8);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(mid[i], expectMid[i], 1e-12);
    EXPECT_NEAR(quarter[i], expectQuarter[i], 1e-12);
  }
  // The same end rotation stored as -q: slerp still takes the short way (45 degrees at the middle).
  AnimationChannel neg = c;
  neg.values[1] = -neg.values[1];
  const glm::dvec4 m2 = sampleChannel(neg, 0.5);
  EXPECT_NEAR(std::abs(glm::dot(m2, expectMid)), 1.0, 1e-12);
}

TEST(AnimationSampler, StepHoldsTheKeyAtOrBeforeT) {
  const AnimationChannel c = channel(AnimationPath::Scale, AnimationInterpolation::Step, {0, 1, 2},
                                     {{1, 1, 1, 0}, {2, 2, 2, 0}, {3, 3, 3, 0}});
  EXPECT_EQ(sampleChannel(c, 0.99), glm::dvec4(1, 1, 1, 0));
  EXPECT_EQ(sampleChannel(c, 1.0), glm::dvec4(2, 2, 2, 0));
  EXPECT_EQ(sampleChannel(c, 1.7), glm::dvec4(2, 2, 2, 0));
  EXPECT_EQ(sampleChannel(c, 2.5), glm::dvec4(3, 3, 3, 0));
}

// Node 1 (rest: translation (1,0,0), 90 degrees about z) under node 0 (translated over time); one
// triangle on node 1.
AnimatedScene twoNodeScene() {
  AnimatedScene a;
  a.nodes.resize(2);
  a.nodes[1].parent = 0;
  a.nodes[1].translation = {1, 0, 0};
  a.nodes[1].rotation = glm::angleAxis(kPi / 2, glm::dvec3(0, 0, 1));
  a.channels.push_back(channel(AnimationPath::Translation, AnimationInterpolation::Linear, {0, 2},
                               {{0, 0, 0, 0}, {0, 0, 4, 0}}, 0));
  a.rest.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  a.rest.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
  a.rest.indices = {0, 1, 2};
  a.localPositions = a.rest.positions;
  a.localNormals = a.rest.normals;
  a.ranges.push_back({1, 0, 3, 0, 3, false});
  a.start = 0;
  a.end = 2;
  return a;
}

TEST(AnimatedScene, ParentChainComposesAndPosesVertices) {
  const AnimatedScene a = twoNodeScene();
  ASSERT_TRUE(a.animated());
  const std::vector<glm::dmat4> w = a.worldMatrices(1.0);
  const glm::dmat4 parent = glm::translate(glm::dmat4(1), glm::dvec3(0, 0, 2));
  const glm::dmat4 child = glm::translate(glm::dmat4(1), glm::dvec3(1, 0, 0)) *
                           glm::rotate(glm::dmat4(1), kPi / 2, glm::dvec3(0, 0, 1));
  expectNear(w[0], parent, 1e-12, "node 0");
  expectNear(w[1], parent * child, 1e-12, "node 1");
  const Scene s = a.sceneAt(1.0);
  // (1,0,0) turns to (0,1,0), then moves by (1,0,0) and (0,0,2).
  EXPECT_NEAR(glm::length(s.positions[1] - glm::vec3(1, 1, 2)), 0.0f, 1e-6f);
  EXPECT_NEAR(glm::length(s.positions[2] - glm::vec3(0, 0, 2)), 0.0f, 1e-6f);
  EXPECT_NEAR(glm::length(s.normals[0] - glm::vec3(0, 0, 1)), 0.0f, 1e-6f);
  EXPECT_EQ(s.boundsMax, glm::vec3(1, 1, 2));
  EXPECT_DOUBLE_EQ(a.frameTime(0, 3), 0.0);
  EXPECT_DOUBLE_EQ(a.frameTime(2, 3), 2.0);  // not cyclic: the last frame is the last key
}

std::string model(const std::string& relative) { return std::string(CONESHADOW_ASSIMP_MODELS) + "/" + relative; }

TEST(AnimatedGltf, SimpleSkinJointRotationAtKeyframesFollowsItsParents) {
  std::ostringstream warn;
  const AnimatedScene a = loadAnimatedGltf(model("simple_skin/simple_skin.gltf"), warn);
  ASSERT_EQ(a.channels.size(), 1u);
  EXPECT_EQ(a.channels[0].node, 2);
  EXPECT_EQ(a.channels[0].path, AnimationPath::Rotation);
  EXPECT_EQ(a.channels[0].times.size(), 12u);
  EXPECT_DOUBLE_EQ(a.start, 0.0);
  EXPECT_DOUBLE_EQ(a.end, 5.5);
  // Node 2 sits under node 1 (translation (0, 1, 0)); its key at t = 1 is 90 degrees about z, at t = 0.5
  // 45 degrees (stored to 3 decimals in the file).
  const glm::dmat4 up = glm::translate(glm::dmat4(1), glm::dvec3(0, 1, 0));
  expectNear(a.worldMatrices(1.0)[2], up * glm::rotate(glm::dmat4(1), kPi / 2, glm::dvec3(0, 0, 1)), 1e-6, "t=1");
  expectNear(a.worldMatrices(0.5)[2], up * glm::rotate(glm::dmat4(1), kPi / 4, glm::dvec3(0, 0, 1)), 1e-3, "t=0.5");
  // The skinned mesh hangs off node 0, which no channel moves: nothing in the soup is animated.
  EXPECT_FALSE(a.animated());
  EXPECT_EQ(a.rest.triangleCount(), 8u);
}

TEST(AnimatedGltf, MorphWeightChannelsAreIgnoredWithOneWarning) {
  std::ostringstream warn;
  const AnimatedScene a = loadAnimatedGltf(model("glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube.gltf"), warn);
  EXPECT_TRUE(a.channels.empty());
  EXPECT_FALSE(a.animated());
  EXPECT_NE(warn.str().find("weights channel"), std::string::npos) << warn.str();
}

// A triangle on node 1 under node 0, which one animation moves; `edit` breaks it.
struct TinyGltf {
  fs::path dir;
  json doc;
  TinyGltf() {
    dir = fs::temp_directory_path() / ("coneshadow_anim_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    // Buffer: positions (3 x vec3), times (3 floats), translations (3 x vec3), rotations (3 x vec4).
    std::vector<float> data = {0, 0, 0, 1, 0, 0, 0, 1, 0,  // 36 bytes
                               0, 1, 2,                    // 12 bytes at 36
                               0, 0, 0, 0, 0, 1, 0, 0, 4,  // 36 bytes at 48
                               0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};  // 48 bytes at 84
    std::ofstream(dir / "tiny.bin", std::ios::binary)
        .write(reinterpret_cast<const char*>(data.data()), std::streamsize(data.size() * 4));
    doc = json::parse(R"({
      "asset": {"version": "2.0"},
      "scenes": [{"nodes": [0]}],
      "nodes": [{"children": [1]}, {"mesh": 0, "translation": [0, 0, 1]}],
      "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
      "buffers": [{"uri": "tiny.bin", "byteLength": 132}],
      "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                      {"buffer": 0, "byteOffset": 36, "byteLength": 12},
                      {"buffer": 0, "byteOffset": 48, "byteLength": 36},
                      {"buffer": 0, "byteOffset": 84, "byteLength": 48}],
      "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                     "min": [0, 0, 0], "max": [1, 1, 0]},
                    {"bufferView": 1, "componentType": 5126, "count": 3, "type": "SCALAR"},
                    {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC3"},
                    {"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC4"}],
      "animations": [{"channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}],
                      "samplers": [{"input": 1, "output": 2, "interpolation": "LINEAR"}]}]
    })");
  }
  ~TinyGltf() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  std::string write() const {
    const std::string path = (dir / "tiny.gltf").string();
    std::ofstream(path) << doc.dump();
    return path;
  }
};

TEST(AnimatedGltf, HandWrittenTranslationAnimationMovesTheTriangle) {
  TinyGltf g;
  std::ostringstream warn;
  const AnimatedScene a = loadAnimatedGltf(g.write(), warn);
  ASSERT_TRUE(a.animated());
  EXPECT_DOUBLE_EQ(a.end, 2.0);
  const Scene s = a.sceneAt(1.5);  // translation (0, 0, 2.5), plus node 1's (0, 0, 1)
  EXPECT_NEAR(glm::length(s.positions[1] - glm::vec3(1, 0, 3.5)), 0.0f, 1e-6f);
  EXPECT_EQ(s.triangleCount(), 1u);
}

// An animation whose scale key carries the triangle to 1e37 (issue 48): past what fp32 rays reach from
// the light. compare --animate stops with one line at the first such frame, before Embree or a method
// traces it, and every owner dies in order (no abort, no output folder).
TEST(AnimatedGltf, AnAnimationPastFp32RangeIsOneClearErrorNotACrash) {
  TinyGltf g;
  const float keys[9] = {1, 1, 1, 1, 1, 1, 1e37f, 1e37f, 1e37f};
  std::fstream(g.dir / "tiny.bin", std::ios::binary | std::ios::in | std::ios::out)
      .seekp(48)
      .write(reinterpret_cast<const char*>(keys), sizeof keys);
  g.doc["animations"][0]["channels"][0]["target"]["path"] = "scale";
  const std::string path = g.write();
  const fs::path out = g.dir / "out";
  for (const std::string methods : {"cone", "cone,cubesm"}) {
    const test::CliRun r = test::cli("compare " + path + " --animate 3 --methods " + methods +
                                     " --light 0.3,2,0.5 --width 24 --height 24 --quiet --out " + out.string());
    EXPECT_EQ(r.code, 1) << r.out;
    EXPECT_NE(r.out.find("coneshadow: error: tiny at t = 2"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("check its keys"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(out));
  }
}

void expectLoadError(TinyGltf& g, const std::string& fragment) {
  const std::string path = g.write();
  std::ostringstream warn;
  try {
    loadAnimatedGltf(path, warn);
    ADD_FAILURE() << "no error; expected one containing '" << fragment << "'";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(fragment), std::string::npos) << what;
    EXPECT_NE(what.find("tiny.gltf"), std::string::npos) << what;
  }
}

TEST(AnimatedGltf, BrokenAnimationsFailWithOneClearError) {
  {
    TinyGltf g;  // key times 0, 1, 1
    std::ofstream(g.dir / "tiny.bin", std::ios::binary | std::ios::in | std::ios::out).seekp(44).write("\0\0\x80\x3f", 4);
    expectLoadError(g, "times do not increase: key 2");
  }
  {
    TinyGltf g;
    g.doc["animations"][0]["channels"][0]["sampler"] = 3;
    expectLoadError(g, "channel 0 refers to sampler 3, which does not exist");
  }
  {
    TinyGltf g;
    g.doc["animations"][0]["channels"][0]["target"]["node"] = 7;
    expectLoadError(g, "targets node 7, which does not exist");
  }
  {
    TinyGltf g;
    g.doc["animations"][0]["channels"][0]["target"]["path"] = "rotation";  // VEC3 output for a rotation
    expectLoadError(g, "must be VEC4 of FLOAT");
  }
  {
    TinyGltf g;
    g.doc["animations"][0]["samplers"][0]["output"] = 3;  // VEC4: right count, wrong type for translation
    expectLoadError(g, "must be VEC3 of FLOAT");
  }
  {
    TinyGltf g;
    g.doc["animations"][0]["samplers"][0]["interpolation"] = "CUBICSPLINE";  // needs 9 outputs for 3 keys
    expectLoadError(g, "CUBICSPLINE needs 3 per key");
  }
  {
    TinyGltf g;
    g.doc["animations"][0]["samplers"][0]["input"] = 0;  // VEC3 as key times
    expectLoadError(g, "must be SCALAR of FLOAT");
  }
}

TEST(BuiltinMotion, MovesTheShapesKeepsTheRoomAndUnitNormals) {
  const AnimatedScene a = builtinAnimatedScene();
  ASSERT_TRUE(a.animated());
  EXPECT_TRUE(a.cyclic);
  const Scene rest = builtinScene();
  ASSERT_EQ(a.rest.positions, rest.positions);  // the static scene is untouched
  const Scene s0 = a.sceneAt(a.frameTime(0, 4)), s1 = a.sceneAt(a.frameTime(1, 4));
  ASSERT_EQ(s1.triangleCount(), rest.triangleCount());
  ASSERT_EQ(s1.indices, rest.indices);
  size_t moved = 0;
  for (size_t i = 0; i < rest.positions.size(); ++i) {
    EXPECT_NEAR(glm::length(s0.positions[i] - rest.positions[i]), 0.0f, 1e-5f) << "t = 0 is the rest pose, vertex " << i;
    moved += glm::length(s1.positions[i] - rest.positions[i]) > 1e-3f;
    ASSERT_NEAR(glm::length(s1.normals[i]), 1.0f, 1e-4f) << "normal " << i;
  }
  for (size_t i = 0; i < 36; ++i) EXPECT_EQ(s1.positions[i], rest.positions[i]) << "room vertex " << i;
  EXPECT_GT(moved, rest.positions.size() / 2);
  // Normals follow the winding.
  for (size_t t = 0; t < s1.indices.size(); t += 3) {
    const glm::vec3 p = s1.positions[s1.indices[t]], q = s1.positions[s1.indices[t + 1]], r = s1.positions[s1.indices[t + 2]];
    ASSERT_GE(glm::dot(glm::cross(q - p, r - p), s1.normals[s1.indices[t]]), 0.0f) << "triangle " << t / 3;
  }
}

// ------------------------------------------------------------------------------------------------
// compare --animate through the CLI, at 64x64.

struct OutDir {
  fs::path path = fs::temp_directory_path() / ("coneshadow_dynamic_" + std::to_string(::getpid()));
  ~OutDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

json readJson(const fs::path& p) {
  std::ifstream in(p);
  return json::parse(in);
}

size_t fileLines(const fs::path& p) {
  std::ifstream in(p);
  size_t n = 0;
  for (std::string line; std::getline(in, line);) ++n;
  return n;
}

bool hasStage(const json& row, const std::string& name) {
  for (const json& s : row["stages"])
    if (s["name"] == name) return true;
  return false;
}

TEST(DynamicCompare, FlagsOutsideADynamicCompareAreUsageErrors) {
  for (const char* args : {"compare --moving-camera", "render --animate 2", "compare --animate 2 --scaling",
                           "compare --animate 0"}) {
    const test::CliRun r = test::cli(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
  }
  const test::CliRun help = test::cli("help compare");
  EXPECT_NE(help.out.find("--animate N"), std::string::npos);
  EXPECT_NE(help.out.find("--moving-camera"), std::string::npos);
}

TEST(DynamicCompare, BuiltinMotionEveryMethodPaysPerFrameAndTheConePathIsExactOnEveryFrame) {
  OutDir out;
  const test::CliRun r = test::cli("compare --animate 3 --width 64 --height 64 --methods cone,embree,rmsm --views wall "
                                   "--quiet --out " + out.path.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("result: dynamic compare of 3 method row(s) over 3 frame(s)"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("frame 1/3"), std::string::npos) << "--quiet prints no progress:\n" << r.out;
  ASSERT_TRUE(fs::exists(out.path / "dynamic.md"));
  std::ifstream md(out.path / "dynamic.md");
  const std::string report((std::istreambuf_iterator<char>(md)), std::istreambuf_iterator<char>());
  // RMSM's page passes: a stage of their own where timestamps time stages inside a submission, else the
  // wall clock of the submission that renders the pages and looks them up (vk::Context::timestampsTrusted).
  const char* pages = test::context().timestampsTrusted() ? "superpages" : "pages_and_lookup";
  for (const char* cell : {"| cone |", "| embree |", "| rmsm |", "bvh_build", "upload", pages})
    EXPECT_NE(report.find(cell), std::string::npos) << cell << "\n" << report;
  EXPECT_EQ(fileLines(out.path / "results.csv"), 1u + 3 * 3);

  std::map<std::string, std::vector<int>> frames;
  for (const json& row : readJson(out.path / "results.json")) {
    const std::string m = row["method"];
    frames[m].push_back(row["stats"]["frame"].get<int>());
    EXPECT_TRUE(row["stats"].contains("time"));
    if (m == "cone") {
      EXPECT_EQ(row["error"]["misclassified_outside_band"], 0) << "frame " << row["stats"]["frame"];
      EXPECT_TRUE(hasStage(row, "upload")) << "the moved triangles are uploaded every frame";
    }
    if (m == "embree") {
      EXPECT_TRUE(hasStage(row, "bvh_build"));
    }
    if (m == "rmsm") {
      EXPECT_TRUE(hasStage(row, pages));
    }
  }
  for (const char* m : {"cone", "embree", "rmsm"}) EXPECT_EQ(frames[m], (std::vector<int>{0, 1, 2})) << m;
}

TEST(DynamicCompare, AnimatedFileRunsOverItsKeyTimes) {
  TinyGltf g;
  OutDir out;
  const test::CliRun r = test::cli("compare " + g.write() + " --animate 3 --width 64 --height 64 --methods cone,embree "
                                   "--quiet --out " + out.path.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("the file's animation at evenly spaced times over t = 0.000..2.000"), std::string::npos) << r.out;
  std::vector<double> times;
  for (const json& row : readJson(out.path / "results.json"))
    if (row["method"] == "cone") times.push_back(row["stats"]["time"].get<double>());
  EXPECT_EQ(times, (std::vector<double>{0.0, 1.0, 2.0}));  // not a cycle: first to last key
}

TEST(DynamicCompare, BartMuseumPlaysItsAnimatedArtAndItsCameraTrack) {
  const std::string museum = std::string(CONESHADOW_BART_SCENES) + "/museum/museum5.aff";
  if (!fs::exists(museum)) GTEST_SKIP() << "no BART scenes at " << CONESHADOW_BART_SCENES;
  OutDir out;
  const test::CliRun r = test::cli("compare " + museum + " --animate 3 --width 64 --height 64 --methods cone,embree "
                                   "--quiet --out " + out.path.string());
  ASSERT_EQ(r.code, 0) << r.out;
  // The museum's `a -1 5` range, first to last.
  EXPECT_NE(r.out.find("over t = -1.000..5.000"), std::string::npos) << r.out;
  std::map<std::string, std::vector<double>> times;
  std::map<std::string, std::set<uint64_t>> lit;
  for (const json& row : readJson(out.path / "results.json")) {
    if (row["method"] != "cone") continue;
    const std::string view = row["view"];
    times[view].push_back(row["stats"]["time"].get<double>());
    lit[view].insert(row["stats"]["lit_samples"].get<uint64_t>());
    EXPECT_EQ(row["error"]["misclassified_outside_band"], 0) << view << " t " << row["stats"]["time"];
    EXPECT_TRUE(hasStage(row, "upload")) << "the animated art moves every frame";
  }
  EXPECT_EQ(times["view"], (std::vector<double>{-1.0, 2.0, 5.0}));
  EXPECT_EQ(times["animated"], (std::vector<double>{-1.0, 2.0, 5.0}));
  EXPECT_EQ(lit["animated"].size(), 3u) << "the camera track moves the view: every frame sees other samples";
  EXPECT_EQ(test::cli("compare " + museum + " --animate 2 --time 1").code, 2) << "--time is for one placement";
}

TEST(DynamicCompare, StaticFileNeedsMovingCameraThenRmsmRunsRebuiltAndCached) {
  OutDir out;
  const std::string box = model("BoxTextured-glTF-Binary/BoxTextured.glb");
  const test::CliRun refused = test::cli("compare " + box + " --animate 2 --out " + out.path.string());
  EXPECT_EQ(refused.code, 2) << refused.out;
  EXPECT_NE(refused.out.find("--moving-camera"), std::string::npos) << refused.out;

  const test::CliRun r = test::cli("compare " + box + " --animate 2 --moving-camera --width 64 --height 64 "
                                   "--methods cone,rmsm --out " + out.path.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("frame 2/2"), std::string::npos) << r.out;
  std::map<std::string, int> rows;
  for (const json& row : readJson(out.path / "results.json")) {
    rows[row["stats"]["setting"].get<std::string>()]++;
    // The scene does not move: the cone path never re-uploads its triangles after the warm-up.
    if (row["method"] == "cone") {
      EXPECT_FALSE(hasStage(row, "upload"));
    }
  }
  EXPECT_EQ(rows, (std::map<std::string, int>{{"cone", 2}, {"rmsm", 2}, {"rmsm (cached)", 2}}));
}

}  // namespace
}  // namespace cs
