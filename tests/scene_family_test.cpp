// The generated scene family (core/scene_family.cpp, docs/ARCHITECTURE.md "The scene family"): members are
// deterministic from their parameters, a parameter given moves nothing else, the triangle count is the
// one asked for, the camera and light are placed as documented, and the seeds span what the family claims.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/scene.h"
#include "tests/cli_support.h"

namespace cs {
namespace {

bool sameGeometry(const Scene& a, const Scene& b) {
  return a.positions.size() == b.positions.size() && a.indices == b.indices &&
         std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * sizeof(glm::vec3)) == 0;
}

TEST(SceneFamily, AMemberIsTheSameSceneEveryTimeItIsMade) {
  for (uint64_t seed : {1u, 7u, 123u}) {
    const FamilyParams p = parseFamilyArg("family:" + std::to_string(seed));
    ASSERT_TRUE(p.valid);
    const Scene a = familyScene(p), b = familyScene(parseFamilyArg("family:" + std::to_string(seed)));
    EXPECT_TRUE(sameGeometry(a, b)) << familyDescription(p);
    EXPECT_EQ(a.lights.at(0).position, b.lights.at(0).position);
    EXPECT_EQ(a.cameras.at(0).eye, b.cameras.at(0).eye);
  }
  EXPECT_FALSE(sameGeometry(familyScene(familyMember(1)), familyScene(familyMember(2))));
}

TEST(SceneFamily, AGivenParameterMovesNothingElse) {
  const FamilyParams base = parseFamilyArg("family:5");
  const Scene a = familyScene(base);
  const Scene lit = familyScene(parseFamilyArg("family:5:elevation=10:distance=500"));
  EXPECT_TRUE(sameGeometry(a, lit));
  EXPECT_EQ(a.cameras.at(0).eye, lit.cameras.at(0).eye);
  EXPECT_NE(a.lights.at(0).position, lit.lights.at(0).position);
  const Scene seen = familyScene(parseFamilyArg("family:5:view=1"));
  EXPECT_TRUE(sameGeometry(a, seen));
  EXPECT_EQ(a.lights.at(0).position, seen.lights.at(0).position);
}

// (Each object's meshes come in whole rings and rows: a few hundred triangles over up to eleven objects
// round further than a million.)
TEST(SceneFamily, TriangleCountIsTheOneAskedForWithinItsRounding) {
  for (const char* tris : {"500", "5k", "60k", "1M"})
    for (uint64_t seed : {2u, 9u}) {
      const std::string arg = "family:" + std::to_string(seed) + ":tris=" + tris;
      const FamilyParams p = parseFamilyArg(arg);
      const Scene s = familyScene(p);
      const double ratio = double(s.triangleCount()) / double(p.triangles);
      const double slack = p.triangles < 10000 ? 0.4 : 0.1;
      EXPECT_GT(ratio, 1 - slack) << arg << ": " << s.triangleCount();
      EXPECT_LT(ratio, 1 + slack) << arg << ": " << s.triangleCount();
      for (uint32_t i : s.indices) ASSERT_LT(i, s.positions.size());
      ASSERT_EQ(s.normals.size(), s.positions.size());
      for (const glm::vec3& n : s.normals) ASSERT_NEAR(glm::length(n), 1.0f, 1e-4f) << arg;
    }
}

TEST(SceneFamily, LightAndCameraArePlacedAsTheirParametersSay) {
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    const FamilyParams p = familyMember(seed);
    const Scene s = familyScene(p);
    const glm::dvec3 centre = 0.5 * (glm::dvec3(s.boundsMin) + glm::dvec3(s.boundsMax));
    const glm::dvec3 toLight = glm::dvec3(s.lights.at(0).position) - centre;
    EXPECT_NEAR(glm::length(toLight) / s.diagonal(), p.lightDistance, 1e-3 * p.lightDistance) << seed;
    EXPECT_NEAR(glm::degrees(std::asin(toLight.y / glm::length(toLight))), p.lightElevation, 1e-3) << seed;
    const Camera& c = s.cameras.at(0);
    const double dist = glm::length(glm::dvec3(c.eye) - glm::dvec3(c.target));
    EXPECT_GT(c.zfar, dist + s.diagonal()) << seed;  // the whole scene within the far plane
    EXPECT_LT(c.znear, 0.5 * dist) << seed;
    // view 0: the bounding sphere spans 0.3 of the field of view.
    const Scene far = familyScene(parseFamilyArg("family:" + std::to_string(seed) + ":view=0"));
    const double farDist = glm::length(glm::dvec3(far.cameras[0].eye) - glm::dvec3(far.cameras[0].target));
    EXPECT_NEAR(0.5 * far.diagonal() / (farDist * std::tan(0.4)), 0.3, 1e-3) << seed;
  }
}

TEST(SceneFamily, TheSeedsSpanTheFamilysParameters) {
  double viewLo = 1, viewHi = 0, elevLo = 90, elevHi = 0, distLo = 1e9, distHi = 0;
  uint64_t trisLo = ~0ull, trisHi = 0;
  std::set<bool> grounds;
  std::set<double> opens;
  for (uint64_t seed = 1; seed <= 24; ++seed) {
    const FamilyParams p = familyMember(seed);
    viewLo = std::min(viewLo, p.view), viewHi = std::max(viewHi, p.view);
    elevLo = std::min(elevLo, p.lightElevation), elevHi = std::max(elevHi, p.lightElevation);
    distLo = std::min(distLo, p.lightDistance), distHi = std::max(distHi, p.lightDistance);
    trisLo = std::min(trisLo, p.triangles), trisHi = std::max(trisHi, p.triangles);
    grounds.insert(p.ground);
    opens.insert(p.openShare);
  }
  EXPECT_LT(viewLo, 0.2);
  EXPECT_GT(viewHi, 0.8);
  EXPECT_LT(elevLo, 20);
  EXPECT_GT(elevHi, 75);
  EXPECT_LT(distLo, 3);
  EXPECT_GT(distHi, 100);
  EXPECT_LT(trisLo, 2000u);
  EXPECT_GT(trisHi, 30000u);
  EXPECT_EQ(grounds.size(), 2u);
  EXPECT_EQ(opens.size(), 3u);
}

TEST(SceneFamily, MalformedArgumentsAreOneLineNamingTheArgument) {
  EXPECT_FALSE(parseFamilyArg("heightfield:10").valid);
  EXPECT_FALSE(parseFamilyArg("scene.glb").valid);
  for (const char* bad : {"family:", "family:x", "family:3:view=2", "family:3:colour=1", "family:3:tris=12q",
                          "family:3:tris=10", "family:3:view", "family:3:elevation=abc"}) {
    try {
      parseFamilyArg(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const UsageError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(bad), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  }
}

// The CLI takes a member wherever it takes a scene, and refuses a malformed one in one line (exit 2).
TEST(SceneFamilyCli, InfoTakesAMemberAndRefusesAMalformedOneInOneLine) {
  const test::CliRun ok = test::cli("info family:7:tris=20k");
  EXPECT_EQ(ok.code, 0) << ok.out;
  EXPECT_NE(ok.out.find("scene: family-7"), std::string::npos) << ok.out;
  const test::CliRun bad = test::cli("info family:7:view=3");
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_NE(bad.out.find("'family:7:view=3': view is a number in [0, 1], not '3'"), std::string::npos) << bad.out;
  EXPECT_EQ(std::count(bad.out.begin(), bad.out.end(), '\n'), 1) << bad.out;
}

}  // namespace
}  // namespace cs
