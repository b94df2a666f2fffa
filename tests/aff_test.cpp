// BART's AFF scenes (core/aff_loader.cpp): every construct the BART files use, on small files written
// here with known answers; every malformed input a one-line error naming file and line; and the three
// BART scenes of ../shared/scenes/bart with their triangle counts (the robots' against paper 002's).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/resource.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/scene.h"

namespace cs {
namespace {

namespace fs = std::filesystem;
using glm::vec3;

class Aff : public ::testing::Test {
 protected:
  fs::path dir;
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("coneshadow_aff_" + std::to_string(::getpid()) + "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  std::string write(const std::string& name, const std::string& text) {
    fs::path p = dir / name;
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text;
    return p.string();
  }
  Scene load(const std::string& path, std::optional<double> time = std::nullopt) {
    std::ostringstream warn;
    return loadAff(path, warn, time);
  }
  // The error loading `text` gives, with its file and line.
  std::string errorOf(const std::string& text, const std::string& name = "bad.aff") {
    const std::string p = write(name, text);
    try {
      load(p);
    } catch (const Error& e) {
      return e.what();
    }
    return "(no error)";
  }
};

bool near(vec3 a, vec3 b, float tol = 1e-5f) { return glm::length(a - b) <= tol; }

bool hasVertex(const Scene& s, vec3 v, float tol = 1e-5f) {
  for (const vec3& p : s.positions)
    if (near(p, v, tol)) return true;
  return false;
}

const char* kView =
    "v\nfrom 0 1 -5\nat 0 1 0\nup 0 1 0\nangle 45\nhither 0.1\nresolution 640 480\n"
    "b 0.1 0.2 0.3\nam 1 1 1\n"
    "l 1 2 3\nl -1 4 0 0.5 0.25 1\n";

TEST_F(Aff, PolygonsTexturedTrianglesAndTheViewAndLights) {
  const std::string p = write("scene.aff", std::string(kView) +
                                               "f 1 1 1 0.5 0.5 10 0 1\n"
                                               "fm 0.1 0.1 0.1  0.5 0.5 0.5  0.2 0.2 0.2  20 0 1\n"
                                               "% a comment: p 3 is not read here\n"
                                               "p 4\n -1 0 -1\n 1 0 -1\n 1 0 1\n -1 0 1\n"
                                               "pp 3\n 0 0 0 0 0 2\n 1 0 0 0 0 2\n 0 1 0 0 0 2\n"
                                               "tt wood.ppm\n 0 2 0 0 0\n 1 2 0 1 0\n 0 3 0 0 1\n"
                                               "# kitchen-style comment\n"
                                               "p 2\n 0 0 0\n 1 1 1\n");
  std::ostringstream warn;
  Scene s = loadAff(p, warn);
  EXPECT_EQ(s.triangleCount(), 2u + 1u + 1u) << "a quad is a fan of two, then pp and tt";
  EXPECT_NE(warn.str().find("fewer than 3"), std::string::npos) << warn.str();
  ASSERT_EQ(s.cameras.size(), 1u);
  EXPECT_EQ(s.cameras[0].name, "view");
  EXPECT_TRUE(near(s.cameras[0].eye, vec3(0, 1, -5)));
  EXPECT_TRUE(near(s.cameras[0].target, vec3(0, 1, 0)));
  EXPECT_NEAR(s.cameras[0].yfov, 45.0 * M_PI / 180.0, 1e-6);
  EXPECT_FLOAT_EQ(s.cameras[0].znear, 0.1f);
  ASSERT_EQ(s.lights.size(), 2u);
  EXPECT_TRUE(near(s.lights[0].position, vec3(1, 2, 3)));
  EXPECT_TRUE(near(s.lights[1].position, vec3(-1, 4, 0)));
  EXPECT_TRUE(near(s.lights[1].color, vec3(0.5f, 0.25f, 1)));
  // pp's normals are the file's (normalised); the others flat.
  for (size_t i = 6; i < 9; ++i) EXPECT_TRUE(near(s.normals[i], vec3(0, 0, 1))) << i;
  for (size_t i = 0; i < 6; ++i) EXPECT_NEAR(std::abs(s.normals[i].y), 1.0f, 1e-6f) << i;
  EXPECT_TRUE(hasVertex(s, vec3(0, 3, 0)));
}

TEST_F(Aff, MeshesWithNormalsTextureCoordinatesAndATextureName) {
  const std::string p = write("mesh.aff",
                              "m\nvertices 4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
                              "normals 2\n0 0 3\n0 0 -1\n"
                              "texturecoords 3 brick.ppm\n0 0\n1 0\n1 1\n"
                              "triangles 2\n0 1 2  0 0 0  0 1 2\n0 2 3  1 1 1  0 2 1\n"
                              "m\nvertices 3\n5 0 0\n6 0 0\n5 1 0\ntriangles 1\n0 1 2\n");
  Scene s = load(p);
  ASSERT_EQ(s.triangleCount(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(near(s.normals[i], vec3(0, 0, 1)));
  for (int i = 3; i < 6; ++i) EXPECT_TRUE(near(s.normals[i], vec3(0, 0, -1)));
  for (int i = 6; i < 9; ++i) EXPECT_TRUE(near(s.normals[i], vec3(0, 0, 1))) << "flat, from the winding";
  EXPECT_TRUE(hasVertex(s, vec3(6, 0, 0)));
}

TEST_F(Aff, ConesAndSpheresAreTessellatedOnTheirSurfaces) {
  Scene s = load(write("shapes.aff", "c 0 0 0 1  0 2 0 0.5\ns 5 0 0 2\n"));
  size_t cone = 0, sphere = 0;
  for (const vec3& p : s.positions) {
    if (p.x < 2.5f) {
      ++cone;
      const float r = std::sqrt(p.x * p.x + p.z * p.z);
      EXPECT_NEAR(r, 1.0f - 0.25f * p.y, 1e-5f) << "on the cone's side at height " << p.y;
      EXPECT_TRUE(std::abs(p.y) < 1e-6f || std::abs(p.y - 2.0f) < 1e-6f);
    } else {
      ++sphere;
      EXPECT_NEAR(glm::length(p - vec3(5, 0, 0)), 2.0f, 1e-5f);
    }
  }
  EXPECT_EQ(cone, 16u * 2u * 3u) << "16 sides of two triangles";
  EXPECT_GT(sphere, 0u);
}

TEST_F(Aff, StaticTransformsNestScaleThenRotateThenTranslate) {
  // xs: scale 2, then 90 degrees about +z, then translate (10, 0, 0); inside it, a translation by
  // (0, 0, 5): the vertex (1, 0, 0) lands at (10, 2, 5)... of the inner block's frame placed by the outer.
  Scene s = load(write("xs.aff",
                       "xs 2 2 2  0 0 1 90  10 0 0\n{\n  p 3\n 1 0 0\n 0 1 0\n 0 0 1\n"
                       "  xs 1 1 1  1 0 0 0  0 0 5\n  {\n    p 3\n 1 0 0\n 0 1 0\n 0 0 1\n  }\n}\n"
                       "p 3\n 1 0 0\n 0 1 0\n 0 0 1\n"));
  ASSERT_EQ(s.triangleCount(), 3u);
  EXPECT_TRUE(hasVertex(s, vec3(10, 2, 0), 1e-4f));   // (1,0,0) -> (2,0,0) -> (0,2,0) -> (10,2,0)
  EXPECT_TRUE(hasVertex(s, vec3(8, 0, 0), 1e-4f));    // (0,1,0) -> (0,2,0) -> (-2,0,0) -> (8,0,0)
  EXPECT_TRUE(hasVertex(s, vec3(10, 0, 2), 1e-4f));
  EXPECT_TRUE(hasVertex(s, vec3(10, 2, 10), 1e-4f));  // the inner block: (1,0,5) first
  EXPECT_TRUE(hasVertex(s, vec3(1, 0, 0)));            // outside every block
  EXPECT_FALSE(hasVertex(s, vec3(0, 2, 0), 1e-4f)) << "rotated before it is translated";
  // The flat normal follows the rotation: (1, 1, 1) turned 90 degrees about z.
  for (size_t i = 0; i < s.positions.size(); ++i) {
    if (near(s.positions[i], vec3(8, 0, 0), 1e-4f)) {
      EXPECT_TRUE(near(s.normals[i], glm::normalize(vec3(-1, 1, 1)), 1e-5f));
    }
  }
}

TEST_F(Aff, AnimatedTransformsAndTrianglesArePlacedAtTheSceneTime) {
  const std::string p = write(
      "anim.aff",
      "a 0 2 10\n"
      "x mover\n{\n p 3\n 0 0 0\n 1 0 0\n 0 1 0\n}\n"
      "tpa 2\n 0\n 0 5 0 0 0 1\n 1 5 0 0 0 1\n 0 6 0 0 0 1\n"
      "   2\n 0 7 0 0 0 1\n 1 7 0 0 0 1\n 0 8 0 0 0 1\n"
      "k mover\n{\n transl 2\n 0 0 0 0 0 0 0\n 2 4 0 0 0 0 0\n"
      " rot 2\n 0 0 0 1 0 0 0 0\n 2 0 0 1 90 0 0 0\n}\n"
      "x still\n{\n p 3\n 0 0 9\n 1 0 9\n 0 1 9\n}\n");
  Scene start = load(p);  // the `a` range starts at 0
  ASSERT_EQ(start.triangleCount(), 3u);
  EXPECT_TRUE(hasVertex(start, vec3(1, 0, 0)));
  EXPECT_TRUE(hasVertex(start, vec3(0, 5, 0)));
  Scene mid = load(p, 1.0);
  // Translation halfway (2, 0, 0); rotation halfway, 45 degrees about z: (1,0,0) -> (cos45, sin45, 0).
  EXPECT_TRUE(hasVertex(mid, vec3(2, 0, 0)));
  EXPECT_TRUE(hasVertex(mid, vec3(2 + std::sqrt(0.5f), std::sqrt(0.5f), 0)));
  EXPECT_FALSE(hasVertex(mid, vec3(1, 0, 0)));
  EXPECT_TRUE(hasVertex(mid, vec3(0, 6, 0))) << "tpa: linear between its keys";
  Scene after = load(p, 5.0);  // past the last key: held
  EXPECT_TRUE(hasVertex(after, vec3(4, 0, 0)));
  EXPECT_TRUE(hasVertex(after, vec3(4, 1, 0)));
  EXPECT_TRUE(hasVertex(after, vec3(0, 7, 0)));
  EXPECT_TRUE(hasVertex(after, vec3(0, 0, 9))) << "x without keyframes stays put";
}

TEST_F(Aff, KochanekBartelsTranslationPassesThroughItsKeysAndBendsBetween) {
  const std::string p = write("kb.aff",
                              "x m\n{\n p 3\n 0 0 0\n 0 0 0.001\n 0.001 0 0\n}\n"
                              "k m\n{\n transl 3\n 0 0 0 0 0 0 0\n 1 1 1 0 0 0 0\n 2 2 0 0 0 0 0\n}\n");
  EXPECT_TRUE(near(load(p, 1.0).positions[0], vec3(1, 1, 0), 1e-6f)) << "through the key";
  const vec3 q = load(p, 0.5).positions[0];
  EXPECT_NEAR(q.x, 0.5f, 1e-5f);
  EXPECT_GT(q.y, 0.5f) << "a spline, not a straight line: it bulges towards the peak (Catmull-Rom at t=c=b=0)";
  // Tension 1 at every key: zero tangents, so the middle of the first segment is the middle of its keys.
  const std::string tense = write("kb1.aff",
                                  "x m\n{\n p 3\n 0 0 0\n 0 0 0.001\n 0.001 0 0\n}\n"
                                  "k m\n{\n transl 3\n 0 0 0 0 1 0 0\n 1 1 1 0 1 0 0\n 2 2 0 0 1 0 0\n}\n");
  EXPECT_TRUE(near(load(tense, 0.5).positions[0], vec3(0.5f, 0.5f, 0), 1e-5f));
}

TEST_F(Aff, IncludesAreRelativeToTheIncludingFileAndTheCameraTrackMakesAView) {
  write("parts/leg.aff", "p 3\n 0 0 0\n 1 0 0\n 0 1 0\ni 0 foot.aff\n");
  write("parts/foot.aff", "p 3\n 0 0 1\n 1 0 1\n 0 1 1\n");
  const std::string p = write("root.aff", std::string(kView) +
                                              "xs 1 1 1  0 1 0 0  0 3 0\n{\n i 1 parts/leg.aff\n}\n"
                                              "k camera\n{\n transl 1\n 0 0 2 10 0 0 0\n rot 1\n 0 0 1 0 180 0 0 0\n}\n");
  Scene s = load(p);
  ASSERT_EQ(s.triangleCount(), 2u);
  EXPECT_TRUE(hasVertex(s, vec3(0, 3, 1))) << "the included file's include, under the block's transform";
  ASSERT_EQ(s.cameras.size(), 2u);
  EXPECT_EQ(s.cameras[1].name, "animated");
  EXPECT_TRUE(near(s.cameras[1].eye, vec3(0, 2, 10)));
  EXPECT_TRUE(near(s.cameras[1].target, vec3(0, 2, 11), 1e-5f)) << "-z turned 180 degrees about y";
}

TEST_F(Aff, MalformedFilesAreOneLineErrorsNamingFileAndLine) {
  struct Case {
    const char* text;
    const char* says;
  };
  const Case cases[] = {
      {"p 3\n 0 0 0\n 1 0 0\n 0 1 0\nfrobnicate 1 2\n", "bad.aff:5: unknown keyword 'frobnicate'"},
      {"p 3\n 0 0 0\n 1 zero 0\n 0 1 0\n", "bad.aff:3: expected a vertex, got 'zero'"},
      {"p 3\n 0 0 0\n 1 0 0\n", "the file ends where a vertex was expected"},
      {"p -3\n", "bad.aff:1: expected a polygon's vertex count"},
      {"p 3\n 0 0 0\n 1 0 0\n 0 1 nan\n", "bad.aff:4: a vertex is not finite"},
      {"m\nvertices 3\n0 0 0\n1 0 0\n0 1 0\ntriangles 1\n0 1 3\n", "bad.aff:7: a vertex index 3 is out of range"},
      {"m\nvertices 1\n0 0 0\nquads 1\n", "expected 'triangles' in a mesh, got 'quads'"},
      {"xs 1 1 1 0 0 1 0 0 0 0\n{\np 3\n 0 0 0\n 1 0 0\n 0 1 0\n", "bad.aff:6: a '{' block is not closed"},
      {"p 3\n 0 0 0\n 1 0 0\n 0 1 0\n}\n", "bad.aff:5: '}' closes no block"},
      {"xs 1 1 1 0 0 1 0 0 0 0\np 3\n", "bad.aff:2: expected '{', got 'p'"},
      {"i 0 missing.aff\n", "bad.aff:1: cannot open"},
      {"i 0 bad.aff\n", "bad.aff:1: an include cycle: "},
      {[] {
         static std::string deep;
         for (int i = 0; i < 300; ++i) deep += "xs 1 1 1 0 0 1 0 0 0 0 {\n";
         return deep.c_str();
       }(),
       "blocks nest deeper than 256 levels"},
      {"b 0 0 0\n", "the scene has no triangles"},
      {"k m\n{\n spin 1\n 0 0 0 0 0 0 0\n}\n", "bad.aff:3: expected transl, rot, scale or '}'"},
      {"v\nfrom 0 0 0\nat 0 0 1\nup 0 1 0\nangle 190\nhither 1\nresolution 2 2\n", "bad.aff:5: field of view"},
      {"v\nfrom 0 0 0\nlookat 0 0 1\n", "bad.aff:3: expected 'at', got 'lookat'"},
  };
  for (const Case& c : cases) {
    const std::string e = errorOf(c.text);
    EXPECT_NE(e.find(c.says), std::string::npos) << "input:\n" << c.text << "error: " << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << "one line: " << e;
  }
  std::ostringstream warn;
  EXPECT_THROW(loadAff((dir / "no_such.aff").string(), warn), Error);
}

// fuzz/aff_fuzzer's out-of-memory: 60 KB of spheres that included itself was read 33 times over, 6 GB of
// triangles, before the include depth limit refused it. A cycle is now refused at its first repeat, directly
// or through other files; a long chain of distinct files still meets the depth limit.
TEST_F(Aff, AnIncludeCycleIsRefusedAtItsFirstRepeat) {
  std::string spheres;
  for (int i = 0; i < 100; ++i) spheres += "s 0 0 0 1\n";
  const std::string self = errorOf(spheres + "i 0 bad.aff\n");
  EXPECT_NE(self.find("bad.aff:101: an include cycle: '"), std::string::npos) << self;
  write("b.aff", "p 3\n 0 0 0\n 1 0 0\n 0 1 0\ni 0 a.aff\n");
  const std::string through = errorOf("i 0 b.aff\n", "a.aff");
  EXPECT_NE(through.find("b.aff:5: an include cycle: '"), std::string::npos) << through;
  EXPECT_NE(through.find("a.aff' includes itself"), std::string::npos) << through;
  EXPECT_EQ(through.find('\n'), std::string::npos) << through;
  for (int i = 0; i < 32; ++i) write("chain" + std::to_string(i) + ".aff", "i 0 chain" + std::to_string(i + 1) + ".aff\n");
  write("chain32.aff", "p 3\n 0 0 0\n 1 0 0\n 0 1 0\n");
  const std::string chain = errorOf("i 0 chain0.aff\n");
  EXPECT_NE(chain.find("includes nest deeper than 32 files"), std::string::npos) << chain;
}

// Found while sizing fuzz/aff_fuzzer's limits: "m vertices 67108864" in a 30-byte file allocated 1.6 GB
// (17 s under the sanitizers) before it missed its first vertex. Counts are claims: storage grows with what
// the file holds. The peak memory of this process (ctest runs each test alone) shows it.
TEST_F(Aff, AMeshCountLargerThanTheFileAllocatesNothingUpFront) {
  rusage before{};
  getrusage(RUSAGE_SELF, &before);
  const std::string vertices = errorOf("m\nvertices 67108864\n0 0 0\n");
  EXPECT_NE(vertices.find("bad.aff:3: the file ends where a vertex was expected"), std::string::npos) << vertices;
  const std::string normals = errorOf("m\nvertices 3\n0 0 0\n1 0 0\n0 1 0\nnormals 67108864\n0 0 1\n");
  EXPECT_NE(normals.find("the file ends where a normal was expected"), std::string::npos) << normals;
  rusage after{};
  getrusage(RUSAGE_SELF, &after);
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 256 * 1024) << "KiB more at the peak";
}

// ---- the BART scenes ------------------------------------------------------------------------------------

const std::string kBart = CONESHADOW_BART_SCENES;

TEST(AffBart, TheThreeScenesLoadWithTheirTriangleCountsViewsAndLights) {
  if (!fs::exists(kBart + "/museum/museum5.aff")) GTEST_SKIP() << "no BART scenes at " << kBart;
  struct Expect {
    const char* file;
    size_t triangles;
    size_t lights;
  };
  // Museum: 10,143 polygons (fans), 8 cones of 32 triangles and 1,024 animated triangles; robots:
  // paper 002 reports 71,706 triangles; kitchen: about 110k (docs/ARCHITECTURE.md, "Scenes", has the counts).
  for (const Expect& e : {Expect{"museum/museum5.aff", 11564, 2}, Expect{"robot/Robot.aff", 71708, 1},
                          Expect{"kitchen/kitchen.aff", 110561, 6}}) {
    std::ostringstream warn;
    Scene s = loadAff(kBart + "/" + e.file, warn);
    EXPECT_EQ(s.triangleCount(), e.triangles) << e.file;
    EXPECT_EQ(s.lights.size(), e.lights) << e.file;
    ASSERT_EQ(s.cameras.size(), 2u) << e.file << ": the view and the camera track";
    EXPECT_EQ(s.cameras[0].name, "view");
    EXPECT_EQ(s.cameras[1].name, "animated");
    EXPECT_GT(s.diagonal(), 1.0f);
    for (size_t i = 0; i < s.normals.size(); ++i) ASSERT_NEAR(glm::length(s.normals[i]), 1.0f, 1e-3f) << e.file << " " << i;
  }
  std::ostringstream warn;
  Scene robots = loadAff(kBart + "/robot/Robot.aff", warn);
  EXPECT_NEAR(double(robots.triangleCount()), 71706.0, 71706.0 * 1e-3) << "paper 002's count";
  // The museum's animated art moves: two times give two different scenes of the same size.
  Scene a = loadAff(kBart + "/museum/museum5.aff", warn, 0.0), b = loadAff(kBart + "/museum/museum5.aff", warn, 2.0);
  ASSERT_EQ(a.positions.size(), b.positions.size());
  size_t moved = 0;
  for (size_t i = 0; i < a.positions.size(); ++i) moved += glm::length(a.positions[i] - b.positions[i]) > 1e-4f;
  EXPECT_EQ(moved, 1024u * 3u) << "only the 1,024 animated triangles move";
}

}  // namespace
}  // namespace cs
