// Scene loading: malformed glTF files fail with one line naming the file and the problem, good files
// flatten to the expected world-space triangles, and the built-in scene is deterministic and usable.
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/scene.h"
#include "core/image_io.h"
#include "tests/cli_support.h"

#ifndef CONESHADOW_ASSIMP_MODELS
#define CONESHADOW_ASSIMP_MODELS "/usr/share/assimp/models/glTF2"
#endif

namespace cs {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string model(const std::string& relative) { return std::string(CONESHADOW_ASSIMP_MODELS) + "/" + relative; }

size_t lineCount(const std::string& s) {
  size_t n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

// Every normal unit length, every value finite, every index in range.
void expectWellFormed(const Scene& s) {
  ASSERT_EQ(s.positions.size(), s.normals.size());
  ASSERT_EQ(s.indices.size() % 3, 0u);
  for (uint32_t i : s.indices) ASSERT_LT(i, s.positions.size());
  for (size_t i = 0; i < s.positions.size(); ++i) {
    const glm::vec3 &p = s.positions[i], &n = s.normals[i];
    ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) << "vertex " << i;
    ASSERT_NEAR(glm::length(n), 1.0f, 1e-4f) << "normal " << i;
  }
}

// The normal stored at a triangle's first corner agrees with its winding (counter-clockwise = front).
void expectNormalsAgreeWithWinding(const Scene& s) {
  for (size_t t = 0; t < s.indices.size(); t += 3) {
    const glm::vec3 a = s.positions[s.indices[t]], b = s.positions[s.indices[t + 1]], c = s.positions[s.indices[t + 2]];
    EXPECT_GT(glm::dot(glm::cross(b - a, c - a), s.normals[s.indices[t]]), 0.0f) << "triangle " << t / 3;
  }
}

// ------------------------------------------------------------------------------------------------
// Broken files from assimp's glTF2 test models. Each must throw cs::Error whose one-line message
// names the file and the problem (the fragment pins which check caught it).
struct BrokenFile {
  const char* path;
  const char* problem;
};

void PrintTo(const BrokenFile& f, std::ostream* os) { *os << f.path; }

class GltfBroken : public ::testing::TestWithParam<BrokenFile> {};

TEST_P(GltfBroken, ThrowsOneLineErrorNamingFileAndProblem) {
  const std::string path = model(GetParam().path);
  ASSERT_TRUE(fs::exists(path)) << path;
  std::ostringstream warn;
  try {
    loadGltf(path, warn);
    FAIL() << path << " loaded, but it is broken";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(fs::path(path).filename().string()), std::string::npos) << what;
    EXPECT_NE(what.find(GetParam().problem), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

INSTANTIATE_TEST_SUITE_P(
    AssimpModels, GltfBroken,
    ::testing::Values(BrokenFile{"MissingBin/BoxTextured.gltf", "File not found"},
                      BrokenFile{"IndexOutOfRange/IndexOutOfRange.gltf", "has index 255"},
                      BrokenFile{"IndexOutOfRange/AllIndicesOutOfRange.gltf", "has index 65535"},
                      BrokenFile{"BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", "non-finite"},
                      BrokenFile{"RecursiveNodes/RecursiveNodes.gltf", "cycle"},
                      BrokenFile{"wrongTypes/badArray.gltf", "meshes[0].primitives must be an array"},
                      BrokenFile{"wrongTypes/badExtension.gltf", "KHR_texture_transform must be a JSON object"},
                      BrokenFile{"wrongTypes/badNumber.gltf", "normalTexture.index is required"},
                      BrokenFile{"wrongTypes/badObject.gltf", "pbrMetallicRoughness must be a JSON object"},
                      BrokenFile{"wrongTypes/badString.gltf", "scenes[0].name must be a string"},
                      BrokenFile{"wrongTypes/badUint.gltf", "baseColorTexture.index must be a non-negative integer"},
                      // Also lacks its .bin; the type error is found first.
                      BrokenFile{"SchemaFailures/sceneWrongType.gltf", "scene must be a non-negative integer"},
                      // Its buffer is 514 bytes, its buffer views reach 1800.
                      BrokenFile{"IncorrectVertexArrays/Cube.gltf", "reads past the end of buffer 0"},
                      // TestNoRootNode: we considered loading these through the rule "no scenes: draw every root
                      // node". NoScene.gltf names a default scene 0 but has no scenes array, a dangling index the
                      // spec forbids; SceneWithoutNodes.gltf is valid but its one scene is empty. Neither has a
                      // node or mesh, so under any reading there is nothing to draw or shadow. A user gets an error
                      // that says why, not an empty frame: a dangling scene index, and "no triangles".
                      BrokenFile{"TestNoRootNode/NoScene.gltf", "the default scene 0 does not exist"},
                      BrokenFile{"TestNoRootNode/SceneWithoutNodes.gltf", "no triangles"},
                      // Valid glTF, but Draco-compressed geometry is an extension we do not implement; the spec
                      // says a loader must refuse a file whose required extension it lacks.
                      BrokenFile{"draco/2CylinderEngine.gltf", "requires the extension KHR_draco_mesh_compression"}),
    [](const auto& param) {
      std::string name =
          fs::path(param.param.path).parent_path().string() + "_" + fs::path(param.param.path).stem().string();
      for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return name;
    });

// Whatever else lands in these folders is broken too: every .gltf / .glb in them must throw.
TEST(GltfBrokenFolders, EveryFileInBrokenFoldersThrows) {
  size_t files = 0;
  for (const char* folder : {"MissingBin", "IndexOutOfRange", "BoxWithInfinites-glTF-Binary", "RecursiveNodes",
                             "wrongTypes", "SchemaFailures", "IncorrectVertexArrays", "TestNoRootNode"}) {
    for (const auto& entry : fs::directory_iterator(model(folder))) {
      const std::string ext = entry.path().extension().string();
      if (ext != ".gltf" && ext != ".glb") continue;
      ++files;
      std::ostringstream warn;
      try {
        loadGltf(entry.path().string(), warn);
        ADD_FAILURE() << entry.path() << " loaded";
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(entry.path().filename().string()), std::string::npos) << e.what();
      }
    }
  }
  EXPECT_EQ(files, 15u);  // the files listed in GltfBroken, except Draco
}

TEST(GltfLoader, RejectsUnknownExtensionAndMissingFile) {
  std::ostringstream warn;
  try {
    loadGltf("/nonexistent/scene.obj", warn);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("scene.obj"), std::string::npos) << e.what();
  }
  try {
    loadGltf("/nonexistent/scene.gltf", warn);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/scene.gltf: cannot open"), std::string::npos) << e.what();
  }
}

// A FIFO, a folder or a file over the size limit under a scene's name is refused before a byte is read:
// a FIFO would block the reader forever, a huge file would be read whole first. Through every reader (glTF,
// BART and its includes, assimp) and the provenance hash.
TEST(SceneLoader, NonRegularAndOversizedFilesAreRefusedBeforeReading) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("coneshadow_inputs_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ostringstream warn;
  auto refused = [&](const fs::path& p, const std::string& want) {
    try {
      (void)loadSceneFile(p.string(), warn);
      ADD_FAILURE() << p << " was read";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
    }
  };
  for (const char* name : {"pipe.gltf", "pipe.glb", "pipe.aff", "pipe.obj"}) {
    ASSERT_EQ(mkfifo((dir / name).c_str(), 0600), 0) << name;
    refused(dir / name, "a FIFO");
  }
  fs::create_directories(dir / "folder.glb");
  refused(dir / "folder.glb", "a folder");
  {
    std::ofstream((dir / "huge.gltf").string()) << "{}";
  }
  fs::resize_file(dir / "huge.gltf", kMaxSceneFileBytes + 1);  // sparse: nothing is written
  refused(dir / "huge.gltf", "over the");
  std::ofstream((dir / "includes.aff").string()) << "i 0 pipe.aff\n";
  refused(dir / "includes.aff", "a FIFO");
  EXPECT_THROW(fileHash((dir / "pipe.gltf").string()), Error);
  fs::remove_all(dir);
}

// ------------------------------------------------------------------------------------------------
// Good files.

TEST(GltfLoader, TwoCylinderEngineFlattensEveryInstance) {
  std::ostringstream warn;
  const Scene s = loadGltf(model("2CylinderEngine-glTF-Binary/2CylinderEngine.glb"), warn);
  // 75,730 triangles are in its meshes; several meshes are instanced by more than one node, and the
  // flat soup holds every instance.
  EXPECT_EQ(s.triangleCount(), 121496u);
  EXPECT_NE(s.triangleCount(), 75730u);
  EXPECT_EQ(s.name, "2CylinderEngine");
  EXPECT_EQ(warn.str(), "");
  expectWellFormed(s);
  EXPECT_GT(s.diagonal(), 100.0f);
}

TEST(GltfLoader, BoxTexturedVariantsAreTwelveTriangles) {
  for (const char* file :
       {"BoxTextured-glTF/BoxTextured.gltf", "BoxTextured-glTF-Binary/BoxTextured.glb",
        "BoxTextured-glTF-Embedded/BoxTextured.gltf", "BoxTextured-glTF-pbrSpecularGlossiness/BoxTextured.gltf",
        "BoxTextured-glTF-techniqueWebGL/BoxTextured.gltf"}) {
    SCOPED_TRACE(file);
    std::ostringstream warn;
    const Scene s = loadGltf(model(file), warn);
    EXPECT_EQ(s.triangleCount(), 12u);
    EXPECT_EQ(s.name, "BoxTextured");
    expectWellFormed(s);
    expectNormalsAgreeWithWinding(s);  // the root node rotates by 90 degrees about x
    EXPECT_NEAR(s.boundsMax.x, 0.5f, 1e-6f);
    EXPECT_NEAR(s.boundsMin.y, -0.5f, 1e-6f);
  }
}

TEST(GltfLoader, ZeroNormalsAreReplacedByFlatOnesWithAWarning) {
  std::ostringstream warn;
  const Scene s = loadGltf(model("BoxBadNormals-glTF-Binary/BoxBadNormals.glb"), warn);
  EXPECT_EQ(s.triangleCount(), 12u);
  expectWellFormed(s);
  expectNormalsAgreeWithWinding(s);
  EXPECT_EQ(lineCount(warn.str()), 1u) << warn.str();
  EXPECT_NE(warn.str().find("flat normals"), std::string::npos) << warn.str();
}

// glTF-Asset-Generator Mesh_PrimitiveMode: one square (two triangles) facing +z in every triangle
// mode, indexed or not; modes 00-03 and 07-10 hold only points or lines.
TEST(GltfLoader, PrimitiveModesStripsAndFansBecomeTrianglesFacingTheirWinding) {
  for (int i = 0; i < 16; ++i) {
    const std::string name = "glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_" +
                             std::string(i < 10 ? "0" : "") + std::to_string(i) + ".gltf";
    SCOPED_TRACE(name);
    std::ostringstream warn;
    const bool pointsOrLines = i <= 3 || (i >= 7 && i <= 10);
    if (pointsOrLines) {
      // Nothing but points or lines: the scene has no triangles, which is an error.
      try {
        loadGltf(model(name), warn);
        ADD_FAILURE() << "loaded";
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("no triangles in the scene (1 point/line primitive skipped)"),
                  std::string::npos)
            << e.what();
      }
      continue;
    }
    const Scene s = loadGltf(model(name), warn);
    EXPECT_EQ(s.triangleCount(), 2u);
    EXPECT_EQ(warn.str(), "");
    expectWellFormed(s);
    expectNormalsAgreeWithWinding(s);
    for (const glm::vec3& n : s.normals) EXPECT_NEAR(n.z, 1.0f, 1e-6f);
  }
}

TEST(GltfLoader, CamerasPerspectiveKeptOrthographicSkippedWithOneWarning) {
  std::ostringstream warn;
  const Scene s = loadGltf(model("cameras/Cameras.gltf"), warn);
  EXPECT_EQ(s.triangleCount(), 2u);
  ASSERT_EQ(s.cameras.size(), 1u);
  const Camera& c = s.cameras[0];
  EXPECT_EQ(c.name, "camera0");
  EXPECT_EQ(s.findCamera("camera0"), &s.cameras[0]);
  EXPECT_EQ(s.findCamera("camera1"), nullptr);
  EXPECT_NEAR(glm::distance(c.eye, glm::vec3(0.5f, 0.5f, 3.0f)), 0.0f, 1e-6f);
  const glm::vec3 forward = glm::normalize(c.target - c.eye);
  EXPECT_NEAR(forward.z, -1.0f, 1e-6f);
  EXPECT_NEAR(c.up.y, 1.0f, 1e-6f);
  EXPECT_FLOAT_EQ(c.yfov, 0.7f);
  EXPECT_FLOAT_EQ(c.znear, 0.01f);
  EXPECT_FLOAT_EQ(c.zfar, 100.0f);
  EXPECT_EQ(lineCount(warn.str()), 1u) << warn.str();
  EXPECT_NE(warn.str().find("orthographic"), std::string::npos) << warn.str();
}

// ------------------------------------------------------------------------------------------------
// Small files written by the test: node transforms, mirroring, cameras, lights, and one check each.

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

template <class T>
void append(std::vector<unsigned char>& bytes, std::initializer_list<T> values) {
  for (T v : values) {
    unsigned char raw[sizeof(T)];
    std::memcpy(raw, &v, sizeof(T));
    bytes.insert(bytes.end(), raw, raw + sizeof(T));
  }
}

// One triangle (0,0,0) (1,0,0) (0,1,0), normals +z, indices 0 1 2 as u16, in an embedded buffer.
// Mesh 0 has normals; mesh 1 also has a primitive without normals (flat) and a points and a
// line-strip primitive (skipped). Nodes: 0 = translate (10,0,0) * rotate 90 deg about y * scale 2,
// mesh 0; 1 = translate (0,5,0) with child 2 = scale (-1,1,1), mesh 1 (mirrored); 3 = camera with
// an infinite far plane; 4 = point light; 5 = spot light.
json tinyDocument() {
  std::vector<unsigned char> bin;
  append<float>(bin, {0, 0, 0, 1, 0, 0, 0, 1, 0});  // positions, bytes 0..35
  append<float>(bin, {0, 0, 1, 0, 0, 1, 0, 0, 1});  // normals, bytes 36..71
  append<uint16_t>(bin, {0, 1, 2, 0});              // indices, bytes 72..77 (+2 padding)
  json doc = json::parse(R"({
    "asset": {"version": "2.0"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [
      {"type": "point", "name": "bulb", "color": [1, 0.5, 0.25], "intensity": 3},
      {"type": "spot", "spot": {}}]}},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 3, 4, 5]}],
    "nodes": [
      {"name": "trs", "translation": [10, 0, 0], "scale": [2, 2, 2], "mesh": 0},
      {"name": "up", "translation": [0, 5, 0], "children": [2]},
      {"name": "mirror", "scale": [-1, 1, 1], "mesh": 1},
      {"camera": 0, "translation": [0, 1, 8]},
      {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [1, 2, 3]},
      {"extensions": {"KHR_lights_punctual": {"light": 1}}}],
    "cameras": [{"type": "perspective", "name": "cam", "perspective": {"yfov": 0.5, "znear": 0.1}}],
    "meshes": [
      {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]},
      {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2},
                      {"attributes": {"POSITION": 0}},
                      {"attributes": {"POSITION": 0}, "mode": 0},
                      {"attributes": {"POSITION": 0}, "mode": 3}]}],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
      {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
      {"bufferView": 2, "componentType": 5123, "count": 3, "type": "SCALAR"}],
    "bufferViews": [
      {"buffer": 0, "byteOffset": 0, "byteLength": 36},
      {"buffer": 0, "byteOffset": 36, "byteLength": 36},
      {"buffer": 0, "byteOffset": 72, "byteLength": 6}],
    "buffers": [{"byteLength": 80}]
  })");
  const double h = std::sqrt(0.5);
  doc["nodes"][0]["rotation"] = {0, h, 0, h};  // x, y, z, w: 90 degrees about +y
  doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64(bin);
  return doc;
}

// A fresh folder per test, removed afterwards.
class TinyGltf : public ::testing::Test {
 protected:
  fs::path dir;
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = info->name();
    std::replace(name.begin(), name.end(), '/', '_');
    dir = fs::temp_directory_path() / ("coneshadow_scene_test_" + std::to_string(::getpid()) + "_" + name);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  std::string write(const json& doc, const std::string& name = "tiny.gltf") const {
    const std::string path = (dir / name).string();
    std::ofstream(path) << doc.dump(2);
    return path;
  }
};

// Camera names are data, never paths (issue 17): compare names its files after the views through
// fileStem, so a camera called "../../escape" or "/tmp/..." writes nothing outside --out, a name with a
// slash still renders, and two names that differ only in unsafe characters keep their own files.
TEST_F(TinyGltf, CameraNamesNeverBecomePathsOutsideTheOutputFolder) {
  EXPECT_EQ(fileStem("../../escape"), "_._.._escape");
  EXPECT_EQ(fileStem("/etc/passwd"), "_etc_passwd");
  EXPECT_EQ(fileStem(""), "unnamed");
  EXPECT_EQ(fileStem(".."), "_.");
  EXPECT_EQ(fileStem("cam 1@2x"), "cam_1@2x");
  EXPECT_EQ(fileStem(std::string(200, 'a')).size(), 64u);
  json doc = tinyDocument();
  const std::string absolute = (dir / "absolute_target").string();
  const std::vector<std::string> names = {"../../escape", absolute, "a/b", "a_b"};
  for (size_t i = 0; i < names.size(); ++i) {
    doc["cameras"].push_back({{"type", "perspective"}, {"name", names[i]}, {"perspective", {{"yfov", 0.6}, {"znear", 0.1}}}});
    doc["nodes"].push_back({{"camera", int(i + 1)}, {"translation", {0.2 * double(i), 1, 8}}});
    doc["scenes"][0]["nodes"].push_back(int(doc["nodes"].size()) - 1);
  }
  const fs::path out = dir / "nested" / "out";
  fs::create_directories(out.parent_path());
  const std::string file = write(doc);
  test::CliRun r = test::cli("compare " + file + " --methods embree,cone --width 16 --height 16 --frames 1 --quiet --out " +
                             out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  // Nothing beside or above the output folder, no folder inside it, and no file named after a path.
  for (auto& e : fs::directory_iterator(out.parent_path())) EXPECT_EQ(e.path(), out) << "written outside --out";
  for (auto& e : fs::directory_iterator(dir))
    EXPECT_TRUE(e.path() == out.parent_path() || e.path().filename() == "tiny.gltf") << e.path();
  EXPECT_FALSE(fs::exists(absolute + "_embree_shaded.png"));
  EXPECT_FALSE(fs::exists(dir.parent_path() / "escape_embree_shaded.png"));
  size_t images = 0;
  for (auto& e : fs::directory_iterator(out)) {
    EXPECT_TRUE(e.is_regular_file()) << e.path();
    images += e.path().extension() == ".png";
  }
  EXPECT_TRUE(fs::exists(out / "a_b_embree_shaded.png"));
  EXPECT_TRUE(fs::exists(out / "a_b-2_embree_shaded.png"));  // "a/b" and "a_b" keep their own files
  EXPECT_TRUE(fs::exists(out / "_._.._escape_cone@64M_mask.png"));
  // The report and results keep the names as they are.
  const json results = json::parse(std::ifstream(out / "results.json"));
  std::vector<std::string> views;
  for (auto& row : results) views.push_back(row.at("view").get<std::string>());
  for (const std::string& n : names) EXPECT_NE(std::find(views.begin(), views.end(), n), views.end()) << n;
  EXPECT_GT(images, 4 * names.size());
}

// glTF's schema counts 1.0 as an integer; tinygltf read "indices": 2.0 as absent, "byteOffset": 36.0 as 0
// and "mode": 4.0 as the default. The loader hands tinygltf the integers it validated, in .gltf and .glb.
TEST_F(TinyGltf, IntegersWrittenAsWholeFloatsReadAsTheIntegersTheyAre) {
  std::ostringstream warn;
  const Scene plain = loadGltf(write(tinyDocument()), warn);
  json doc = tinyDocument();
  doc["scene"] = 0.0;
  doc["scenes"][0]["nodes"] = {0.0, 1.0, 3.0, 4.0, 5.0};
  doc["nodes"][0]["mesh"] = 0.0;
  doc["nodes"][1]["children"] = {2.0};
  doc["meshes"][0]["primitives"][0]["indices"] = 2.0;
  doc["meshes"][0]["primitives"][0]["mode"] = 4.0;
  doc["meshes"][1]["primitives"][0]["indices"] = 2.0;
  doc["meshes"][1]["primitives"][2]["mode"] = 0.0;
  doc["accessors"][1]["bufferView"] = 1.0;
  doc["accessors"][2]["count"] = 3.0;
  doc["accessors"][2]["componentType"] = 5123.0;
  doc["bufferViews"][1]["byteOffset"] = 36.0;
  doc["bufferViews"][2]["byteOffset"] = 72.0;
  doc["bufferViews"][2]["byteLength"] = 6.0;
  ASSERT_NE(doc.dump().find("\"byteOffset\":72.0"), std::string::npos) << "the test must write floats";
  std::string glb;
  {  // the same document as a GLB of one JSON chunk (its buffer stays a data URI)
    std::string text = doc.dump();
    while (text.size() % 4) text += ' ';
    auto u32 = [&](uint32_t v) {
      for (int k = 0; k < 4; ++k) glb += char(v >> (8 * k));
    };
    glb = "glTF";
    u32(2);
    u32(uint32_t(12 + 8 + text.size()));
    u32(uint32_t(text.size()));
    glb += "JSON" + text;
  }
  const std::string glbPath = (dir / "floats.glb").string();
  std::ofstream(glbPath, std::ios::binary) << glb;
  for (const std::string& path : {write(doc, "floats.gltf"), glbPath}) {
    const Scene s = loadGltf(path, warn);
    EXPECT_EQ(s.indices, plain.indices) << path;
    EXPECT_EQ(s.positions, plain.positions) << path;
    EXPECT_EQ(s.normals, plain.normals) << path;
  }
  // An index tinygltf's int cannot hold (2^32 + 2 read as 2) is refused, not wrapped.
  for (const json& index : {json(4294967298ull), json(4294967298.0)}) {
    json big = tinyDocument();
    big["meshes"][0]["primitives"][0]["indices"] = index;
    try {
      loadGltf(write(big, "big.gltf"), warn);
      ADD_FAILURE() << "indices " << index.dump() << " loaded";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("indices must be a non-negative integer below 2^31"), std::string::npos)
          << e.what();
    }
  }
}

TEST_F(TinyGltf, NodeTransformsPlaceTrianglesInWorldSpace) {
  std::ostringstream warn;
  const Scene s = loadGltf(write(tinyDocument()), warn);
  EXPECT_EQ(s.name, "tiny");
  // Mesh 0 once under "trs", mesh 1 (two triangle primitives) under "mirror".
  ASSERT_EQ(s.triangleCount(), 3u);
  expectWellFormed(s);

  // T * R * S: p -> (10,0,0) + Ry(90) * 2p, where Ry(90) maps (x,y,z) to (z,y,-x).
  const glm::vec3 expected[3] = {{10, 0, 0}, {10, 0, -2}, {10, 2, 0}};
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(glm::distance(s.positions[s.indices[size_t(k)]], expected[k]), 0.0f, 1e-5f) << "corner " << k;
  for (int k = 0; k < 3; ++k)  // the normal +z, rotated, ignores the uniform scale
    EXPECT_NEAR(glm::distance(s.normals[s.indices[size_t(k)]], glm::vec3(1, 0, 0)), 0.0f, 1e-5f);
  expectNormalsAgreeWithWinding(s);
}

TEST_F(TinyGltf, MirroredNodeFlipsWindingSoNormalsAgree) {
  std::ostringstream warn;
  const Scene s = loadGltf(write(tinyDocument()), warn);
  ASSERT_EQ(s.triangleCount(), 3u);
  // Triangles 1 (file normals) and 2 (flat normals) are mesh 1 under (0,5,0) * scale(-1,1,1): corners
  // (0,5,0), (-1,5,0), (0,6,0), whose file order now winds clockwise seen from +z.
  for (size_t t = 1; t < 3; ++t) {
    std::vector<glm::vec3> corners;
    for (size_t k = 0; k < 3; ++k) corners.push_back(s.positions[s.indices[3 * t + k]]);
    for (const glm::vec3& p : {glm::vec3(0, 5, 0), glm::vec3(-1, 5, 0), glm::vec3(0, 6, 0)})
      EXPECT_TRUE(
          std::any_of(corners.begin(), corners.end(), [&](const glm::vec3& c) { return glm::distance(c, p) < 1e-6f; }));
    // A mirror keeps the normal +z (inverse-transpose of diag(-1,1,1)); the winding is flipped to match.
    EXPECT_NEAR(s.normals[s.indices[3 * t]].z, 1.0f, 1e-6f) << "triangle " << t;
  }
  expectNormalsAgreeWithWinding(s);
}

TEST_F(TinyGltf, CamerasLightsAndSkippedPrimitivesEachOneWarningLine) {
  std::ostringstream warn;
  const Scene s = loadGltf(write(tinyDocument()), warn);
  ASSERT_EQ(s.cameras.size(), 1u);
  const Camera& c = s.cameras[0];
  EXPECT_EQ(c.name, "cam");
  EXPECT_NEAR(glm::distance(c.eye, glm::vec3(0, 1, 8)), 0.0f, 1e-6f);
  EXPECT_NEAR(glm::normalize(c.target - c.eye).z, -1.0f, 1e-6f);
  EXPECT_FLOAT_EQ(c.znear, 0.1f);
  // No zfar in the file (infinite): a finite far plane that reaches past the whole scene.
  EXPECT_TRUE(std::isfinite(c.zfar));
  for (const glm::vec3& corner : {s.boundsMin, s.boundsMax}) EXPECT_GT(c.zfar, glm::distance(c.eye, corner));

  ASSERT_EQ(s.lights.size(), 1u);  // the spot light is skipped
  EXPECT_EQ(s.lights[0].name, "bulb");
  EXPECT_NEAR(glm::distance(s.lights[0].position, glm::vec3(1, 2, 3)), 0.0f, 1e-6f);
  EXPECT_EQ(s.lights[0].color, glm::vec3(1, 0.5f, 0.25f));
  EXPECT_FLOAT_EQ(s.lights[0].intensity, 3.0f);

  // One line for both skipped point/line primitives, one for the spot light.
  const std::string w = warn.str();
  EXPECT_EQ(lineCount(w), 2u) << w;
  EXPECT_NE(w.find("skipped 2 point/line primitives"), std::string::npos) << w;
  EXPECT_NE(w.find("skipped 1 spot/directional light"), std::string::npos) << w;
}

TEST_F(TinyGltf, NoScenesDrawsEveryRootNode) {
  json doc = tinyDocument();
  doc.erase("scene");
  doc.erase("scenes");
  std::ostringstream warn;
  const Scene s = loadGltf(write(doc), warn);
  EXPECT_EQ(s.triangleCount(), 3u);  // roots 0, 1 (with child 2), 3, 4, 5: as with the scene
  EXPECT_EQ(s.lights.size(), 1u);
}

TEST_F(TinyGltf, SparseAccessorOverridesItsBase) {
  json doc = tinyDocument();
  // Vertex 1 of accessor 0 becomes (0,0,1): sparse index 1 (u16, bytes 72..73 hold 0, so use 74..75
  // holding 1) and value from the normals view (0,0,1).
  doc["accessors"][0]["sparse"] = {{"count", 1},
                                   {"indices", {{"bufferView", 2}, {"byteOffset", 2}, {"componentType", 5123}}},
                                   {"values", {{"bufferView", 1}}}};
  std::ostringstream warn;
  const Scene s = loadGltf(write(doc), warn);
  // Under node "trs": p -> (10,0,0) + Ry(90) * 2p; (0,0,1) -> (12,0,0).
  EXPECT_NEAR(glm::distance(s.positions[s.indices[1]], glm::vec3(12, 0, 0)), 0.0f, 1e-5f);
}

// An accessor without a buffer view is zeros (glTF 2.0 §3.6.2.3), here with sparse values over two of them:
// vertex 0 stays at the origin, vertices 1 and 2 come from the positions' view, the triangle is the original.
TEST_F(TinyGltf, AccessorWithoutBufferViewIsZerosUnderItsSparseValues) {
  json doc = tinyDocument();
  doc["accessors"][0].erase("bufferView");
  doc["accessors"][0]["sparse"] = {{"count", 2},
                                   {"indices", {{"bufferView", 2}, {"byteOffset", 2}, {"componentType", 5123}}},
                                   {"values", {{"bufferView", 0}, {"byteOffset", 12}}}};
  std::ostringstream warn;
  const Scene s = loadGltf(write(doc), warn);
  const glm::vec3 expected[3] = {{10, 0, 0}, {10, 0, -2}, {10, 2, 0}};  // as NodeTransformsPlaceTrianglesInWorldSpace
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(glm::distance(s.positions[s.indices[size_t(k)]], expected[k]), 0.0f, 1e-5f) << "corner " << k;
}

// Loading `path` fails with one line that starts with the path and names `problem`.
void expectLoadError(const std::string& path, const std::string& problem) {
  std::ostringstream warn;
  try {
    loadGltf(path, warn);
    FAIL() << "loaded";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(path + ": ", 0), 0u) << what;
    EXPECT_NE(what.find(problem), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

// A file that nests its extras 20,000 levels deep (40 KB) is refused with one line, before a recursive
// copy of them can overflow the stack; 100 levels still load. The text is written by hand: serialising
// such a document would recurse as deep.
TEST_F(TinyGltf, DeeplyNestedExtrasAreRefusedNotACrash) {
  const std::string good = tinyDocument().dump();
  for (int levels : {100, 20000}) {
    const std::string nested = std::string(size_t(levels), '[') + std::string(size_t(levels), ']');
    const std::string path = (dir / ("nested" + std::to_string(levels) + ".gltf")).string();
    std::ofstream(path) << "{\"extras\":" << nested << "," << good.substr(1);
    std::ostringstream warn;
    if (levels == 100) {
      EXPECT_GT(loadGltf(path, warn).indices.size(), 0u);
      continue;
    }
    expectLoadError(path, "nests more than 128 levels deep (under \"extras\")");
  }
}

// Each mutation of the good document must fail with its own message.
struct Mutation {
  const char* name;
  void (*apply)(json&);
  const char* problem;
};

void PrintTo(const Mutation& m, std::ostream* os) { *os << m.name; }

class TinyGltfBroken : public TinyGltf, public ::testing::WithParamInterface<Mutation> {};

TEST_P(TinyGltfBroken, ThrowsNamingFileAndProblem) {
  json doc = tinyDocument();
  GetParam().apply(doc);
  const std::string path = write(doc, std::string(GetParam().name) + ".gltf");
  expectLoadError(path, GetParam().problem);
}

INSTANTIATE_TEST_SUITE_P(
    Validation, TinyGltfBroken,
    ::testing::Values(
        Mutation{"AccessorPastView", [](json& d) { d["accessors"][0]["count"] = 4; },
                 "accessor 0 (4 elements) reads past the end of buffer view 0"},
        Mutation{"ViewPastBuffer", [](json& d) { d["bufferViews"][2]["byteLength"] = 9; },
                 "buffer view 2 (bytes 72 + 9) reads past the end of buffer 0"},
        Mutation{"PositionNotFloat", [](json& d) { d["accessors"][0]["componentType"] = 5123; },
                 "accessor 0 (POSITION) must be VEC3 of FLOAT"},
        Mutation{"NormalNotVec3", [](json& d) { d["accessors"][1]["type"] = "VEC2"; },
                 "accessor 1 (NORMAL) must be VEC3 of FLOAT"},
        Mutation{"IndicesSigned", [](json& d) { d["accessors"][2]["componentType"] = 5122; },
                 "accessor 2 (indices) must be SCALAR of unsigned"},
        Mutation{
            "IndexPastVertices",
            [](json& d) {  // mesh 0 reads only two positions
              d["accessors"].push_back({{"bufferView", 0}, {"componentType", 5126}, {"count", 2}, {"type", "VEC3"}});
              d["meshes"][0]["primitives"][0]["attributes"] = {{"POSITION", 3}};
            },
            "accessor 2 (indices) has index 2 at position 2, but there are only 2 vertices"},
        Mutation{"TriangleListNotMultipleOf3", [](json& d) { d["accessors"][2]["count"] = 2; },
                 "mesh 0 primitive 0 is a triangle list of 2 vertices"},
        Mutation{"NodeWithTwoParents", [](json& d) { d["nodes"][0]["children"] = {2}; },
                 "node 2 is a child of both node 0 and node 1"},
        Mutation{"SelfParent", [](json& d) { d["nodes"][2]["children"] = {2}; }, "node 2 is a child of both"},
        Mutation{"MissingMesh", [](json& d) { d["nodes"][0]["mesh"] = 7; }, "node 0 refers to mesh 7"},
        Mutation{"MissingBuffer", [](json& d) { d["bufferViews"][0]["buffer"] = 1; },
                 "buffer view 0 refers to buffer 1, which does not exist"},
        Mutation{"MissingBinFile", [](json& d) { d["buffers"][0]["uri"] = "nowhere.bin"; }, "nowhere.bin"},
        Mutation{"MatrixOf15", [](json& d) { d["nodes"][1]["matrix"] = std::vector<double>(15, 0.0); },
                 "nodes[1].matrix must be an array of 16 numbers"},
        Mutation{"BadMode", [](json& d) { d["meshes"][0]["primitives"][0]["mode"] = 7; }, "mode must be one of"},
        Mutation{"NotJson", [](json& d) { d = "just a string"; }, "the top level must be a JSON object"},
        Mutation{"VertexOverflowsFloat",
                 [](json& d) {
                   d["nodes"][0]["scale"] = {1e300, 1e300, 1e300};
                 },
                 "mesh 0 has a vertex that overflows in world space"},
        Mutation{"TransformOverflows",
                 [](json& d) {
                   d["nodes"][1]["scale"] = {1e300, 1, 1};
                   d["nodes"][2]["scale"] = {1e300, 1, 1};
                 },
                 "node 2 has a world transform that overflows"},
        Mutation{"RequiredMeshopt", [](json& d) { d["extensionsRequired"] = {"EXT_meshopt_compression"}; },
                 "requires the extension EXT_meshopt_compression"},
        Mutation{"BadLightIndex", [](json& d) { d["nodes"][4]["extensions"]["KHR_lights_punctual"]["light"] = 5; },
                 "node 4 refers to light 5"},
        Mutation{"CameraZeroFov", [](json& d) { d["cameras"][0]["perspective"]["yfov"] = 0; }, "camera 0 has yfov"},
        // Zeros the file does not store: a 2 KB file asking for 300 million of them took 24 GB before the
        // kernel killed `coneshadow info`; 10^11 of them threw std::bad_alloc (now past the 2^31 bound
        // every integer property has).
        Mutation{"ZerosPastTheBuffers",
                 [](json& d) {
                   d["accessors"][0].erase("bufferView");
                   d["accessors"][0]["count"] = 300000000;
                 },
                 "accessor 0 has no buffer view and 300000000 elements of 12 bytes, more than the file's buffers "
                 "hold (80 bytes)"},
        Mutation{"CountPastTwoToThe31",
                 [](json& d) {
                   d["accessors"][0].erase("bufferView");
                   d["accessors"][0]["count"] = 100000000000;
                 },
                 "accessors[0].count must be a non-negative integer below 2^31, not 100000000000"},
        Mutation{"NoTriangles",
                 [](json& d) {
                   d["scenes"][0]["nodes"] = {3, 4};
                 },
                 "no triangles"}),
    [](const auto& param) { return std::string(param.param.name); });

// ------------------------------------------------------------------------------------------------
// The built-in scene.

TEST(BuiltinScene, IsDeterministic) {
  const Scene a = builtinScene(), b = builtinScene();
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.indices, b.indices);
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (size_t i = 0; i < a.cameras.size(); ++i) {
    EXPECT_EQ(a.cameras[i].name, b.cameras[i].name);
    EXPECT_EQ(a.cameras[i].eye, b.cameras[i].eye);
    EXPECT_EQ(a.cameras[i].target, b.cameras[i].target);
  }
  ASSERT_EQ(a.lights.size(), 1u);
  EXPECT_EQ(a.lights[0].position, b.lights[0].position);
}

TEST(BuiltinScene, WellFormedWithExpectedSize) {
  const Scene s = builtinScene();
  EXPECT_EQ(s.name, "builtin");
  expectWellFormed(s);
  expectNormalsAgreeWithWinding(s);
  // Room 12 + table 60 + ~40 small shapes + 3000 two-triangle hairs.
  EXPECT_GE(s.triangleCount(), 6500u);
  EXPECT_LE(s.triangleCount(), 20000u);
  // The room: 20 x 8 x 14, and nothing outside it.
  EXPECT_EQ(s.boundsMin, glm::vec3(-10, 0, -7));
  EXPECT_EQ(s.boundsMax, glm::vec3(10, 8, 7));
}

TEST(BuiltinScene, RoomIsTwelveLargeTrianglesFacingInward) {
  const Scene s = builtinScene();
  const glm::vec3 centre = 0.5f * (s.boundsMin + s.boundsMax);
  size_t large = 0;
  for (size_t t = 0; t < s.indices.size(); t += 3) {
    const glm::vec3 a = s.positions[s.indices[t]], b = s.positions[s.indices[t + 1]], c = s.positions[s.indices[t + 2]];
    if (0.5f * glm::length(glm::cross(b - a, c - a)) < 50) continue;  // the smallest wall half is 56
    ++large;
    EXPECT_GT(glm::dot(s.normals[s.indices[t]], centre - a), 0.0f) << "triangle " << t / 3;
  }
  EXPECT_EQ(large, 12u);
}

TEST(BuiltinScene, OneLightInsideTheRoom) {
  const Scene s = builtinScene();
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].name, "room_light");
  const glm::vec3 p = s.lights[0].position;
  EXPECT_TRUE(glm::all(glm::greaterThan(p, s.boundsMin)) && glm::all(glm::lessThan(p, s.boundsMax)));
}

TEST(BuiltinScene, NamedViewsExistInOrderInsideTheRoom) {
  const Scene s = builtinScene();
  const std::vector<std::string> names = builtinViewNames();
  EXPECT_EQ(names, (std::vector<std::string>{"wall", "fur", "room", "ceiling", "edge"}));
  ASSERT_EQ(s.cameras.size(), names.size());
  for (size_t i = 0; i < names.size(); ++i) {
    EXPECT_EQ(s.cameras[i].name, names[i]);
    const Camera* c = s.findCamera(names[i]);
    ASSERT_NE(c, nullptr) << names[i];
    EXPECT_TRUE(glm::all(glm::greaterThan(c->eye, s.boundsMin)) && glm::all(glm::lessThan(c->eye, s.boundsMax)));
    EXPECT_GT(c->zfar, s.diagonal());
  }
}

// Möller-Trumbore; t of the hit or a negative value.
float rayTriangle(const glm::vec3& o, const glm::vec3& d, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  const glm::vec3 e1 = b - a, e2 = c - a, p = glm::cross(d, e2);
  const float det = glm::dot(e1, p);
  if (std::abs(det) < 1e-12f) return -1;
  const glm::vec3 s = o - a, q = glm::cross(s, e1);
  const float u = glm::dot(s, p) / det, v = glm::dot(d, q) / det;
  if (u < 0 || v < 0 || u + v > 1) return -1;
  return glm::dot(e2, q) / det;
}

// A coarse CPU ray caster: every view sees only closed-room geometry (no ray escapes), and among the
// samples facing the light, a fair share is lit and a fair share is in shadow.
TEST(BuiltinScene, EveryViewSeesLitAndShadowedSurfaces) {
  const Scene s = builtinScene();
  const glm::vec3 light = s.lights[0].position;
  auto firstHit = [&](const glm::vec3& o, const glm::vec3& d, float maxT, size_t* triangle) {
    float best = maxT;
    for (size_t t = 0; t < s.indices.size(); t += 3) {
      const float h =
          rayTriangle(o, d, s.positions[s.indices[t]], s.positions[s.indices[t + 1]], s.positions[s.indices[t + 2]]);
      if (h > 0 && h < best) {
        best = h;
        if (triangle) *triangle = t;
      }
    }
    return best;
  };
  const int w = 24, h = 16;
  for (const Camera& c : s.cameras) {
    SCOPED_TRACE(c.name);
    const glm::vec3 f = glm::normalize(c.target - c.eye), r = glm::normalize(glm::cross(f, c.up)), u = glm::cross(r, f);
    const float th = std::tan(0.5f * c.yfov), aspect = float(w) / h;
    int facing = 0, lit = 0, shadowed = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const glm::vec3 d =
            glm::normalize(f + r * ((2 * (x + 0.5f) / w - 1) * th * aspect) + u * ((1 - 2 * (y + 0.5f) / h) * th));
        size_t tri = 0;
        const float t = firstHit(c.eye, d, 1e30f, &tri);
        ASSERT_LT(t, 1e30f) << "a ray left the room";
        EXPECT_GT(t, c.znear);
        glm::vec3 n = s.normals[s.indices[tri]];
        if (glm::dot(n, d) > 0) n = -n;  // the hairs are seen from both sides
        const glm::vec3 p = c.eye + t * d + 1e-4f * n;
        const glm::vec3 toLight = light - p;
        if (glm::dot(n, toLight) <= 0) continue;
        ++facing;
        const float dist = glm::length(toLight);
        (firstHit(p, toLight / dist, dist, nullptr) < dist ? shadowed : lit) += 1;
      }
    EXPECT_GT(facing, w * h / 2);
    EXPECT_GT(lit, facing / 20);
    EXPECT_GT(shadowed, facing / 20);
  }
}

TEST(AutomaticCameraAndLight, FrameTheBounds) {
  Scene s;
  s.boundsMin = glm::vec3(-1, 0, -2);
  s.boundsMax = glm::vec3(3, 2, 2);
  const glm::vec3 centre(1, 1, 0);
  const Camera c = automaticCamera(s);
  EXPECT_FLOAT_EQ(c.yfov, 0.8f);
  EXPECT_NEAR(glm::distance(c.target, centre), 0.0f, 1e-6f);
  // The bounding sphere fits the vertical field of view and lies between near and far.
  const float dist = glm::distance(c.eye, centre), radius = 0.5f * s.diagonal();
  EXPECT_GE(std::asin(radius / dist), 0.0f);
  EXPECT_LE(std::asin(radius / dist), 0.5f * c.yfov);
  EXPECT_LT(c.znear, dist - radius);
  EXPECT_GT(c.zfar, dist + radius);
  EXPECT_GT(c.eye.y, centre.y);  // from above, on a diagonal
  EXPECT_NE(c.eye.x, centre.x);
  EXPECT_NE(c.eye.z, centre.z);
  const PointLight l = automaticLight(s);
  EXPECT_GT(l.position.y, s.boundsMax.y);
  EXPECT_GT(l.position.x, s.boundsMin.x);
  EXPECT_LT(l.position.x, s.boundsMax.x);
  EXPECT_GT(l.position.z, s.boundsMin.z);
  EXPECT_LT(l.position.z, s.boundsMax.z);
}

TEST(Scene, ComputeBoundsAndFindCamera) {
  Scene s;
  s.positions = {{1, 2, 3}, {-1, 5, 0}, {0, 0, 7}};
  s.computeBounds();
  EXPECT_EQ(s.boundsMin, glm::vec3(-1, 0, 0));
  EXPECT_EQ(s.boundsMax, glm::vec3(1, 5, 7));
  s.cameras.push_back(Camera{.name = "a"});
  s.cameras.push_back(Camera{.name = "b"});
  EXPECT_EQ(s.findCamera("b"), &s.cameras[1]);
  EXPECT_EQ(s.findCamera("c"), nullptr);
}

}  // namespace
}  // namespace cs
