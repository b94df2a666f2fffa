// Two-pass traversal (002 §3.4; ConeOptions::twoPass, variants "PreciseEATP" and "PreciseSEATP"): the
// blockers' pass finishes rays, the update drops them and rebuilds the tree, the rest of the triangles
// go through the smaller tree -- with the one-pass mask bit for bit, zero misclassified samples outside
// the band against Embree, fewer pairs tested where a large occluder hides many small triangles, at any
// traversal memory; and the update is skipped (and said so) when pass one finishes too few rays.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "judge/metrics.h"
#include "tests/cone_test_support.h"
#include "tests/test_context.h"
#include "traversal/cone_method.h"
#include "traversal/traversal.h"

namespace cs {
namespace {

using glm::vec3;
using Frame = test::ReferenceFrame;

using test::ConeRun;
using test::runExactCone;
using test::sameBits;

ConeOptions variant(const char* name) {
  ConeOptions o;
  EXPECT_TRUE(applyConeVariant(name, o)) << name;
  return o;
}

// A receiving wall (z = -6) lit by a light at the origin, a large quad (z = -0.5) in front of the light,
// and a cloud of small triangles between the two, most of them inside the quad's shadow: the pass over
// the blockers finishes the rays the quad hides, and the cloud's triangles then meet a smaller tree.
Scene occludedCloudScene() {
  Scene s;
  s.name = "occluded cloud";
  auto quad = [&](vec3 o, vec3 du, vec3 dv) { test::addQuad(s, o, du, dv); };
  quad({-12, -12, -6}, {24, 0, 0}, {0, 24, 0});         // the receiving wall, facing the light
  quad({-1.5f, -1.5f, -0.5f}, {3, 0, 0}, {0, 3, 0});    // the large occluder close to the light
  for (int i = 0; i < 30; ++i)                         // 1,800 small triangles, z in [-4.8, -1.8]
    for (int j = 0; j < 30; ++j) {
      const vec3 c(-5.8f + 0.4f * i, -5.8f + 0.4f * j, -1.8f - 0.1f * float((i * 7 + j * 3) % 31));
      quad(c, {0.12f, 0.02f, 0.0f}, {0.03f, 0.12f, 0.01f});
    }
  s.computeBounds();
  return s;
}

TEST(TwoPass, FinishesRaysInPassOneAndKeepsTheMaskWithFewerPairs) {
  Scene scene = occludedCloudScene();
  Frame f(scene, test::lookAt({6, 2, 3}, {0, 0, -6}, 1.2f), vec3(0), 128);
  ConeRun plain = runExactCone(f, variant("PreciseSorted"), "cloud PreciseSorted");
  ConeRun sea = runExactCone(f, variant("PreciseSEA"), "cloud PreciseSEA");
  size_t shadowed = 0;
  for (float v : plain.mask) shadowed += v == 0.0f;
  ASSERT_GT(shadowed, 2000u) << "the occluder must shadow much of the view";
  ConeOptions stp = variant("PreciseSorted");
  stp.twoPass = true;
  for (const ConeOptions& o : {variant("PreciseSEATP"), variant("PreciseEATP"), stp}) {
    ConeRun r = runExactCone(f, o, "cloud " + coneVariantName(o));
    EXPECT_TRUE(sameBits(plain.mask, r.mask)) << coneVariantName(o) << ": two-pass changed the mask";
    const nlohmann::json& tp = r.stats["two_pass"];
    ASSERT_TRUE(tp.is_object());
    EXPECT_GE(tp["blockers"].get<uint32_t>(), 2u) << "the occluder's two triangles";
    EXPECT_LE(tp["blockers"].get<uint32_t>(), scene.triangleCount() / 8);
    EXPECT_GT(tp["rays_finished_pass_one"].get<uint32_t>(), shadowed / 2);
    EXPECT_EQ(tp["update"].get<std::string>(), "rebuilt");
    EXPECT_LT(tp["tree_nodes_pass_two"].get<uint64_t>(), r.stats["tree_nodes"].get<uint64_t>());
    const uint64_t sum = tp["pass_one"]["pairs_tested"].get<uint64_t>() + tp["pass_two"]["pairs_tested"].get<uint64_t>();
    EXPECT_EQ(sum, r.pairs) << "the top-level count is the two passes' sum";
    if (o.sorted) {
      EXPECT_LT(r.pairs, plain.pairs) << coneVariantName(o) << " must test fewer pairs than PreciseSorted";
    }
    if (o.sorted && o.earlyAccept) {
      EXPECT_LE(r.pairs, sea.pairs) << "two-pass on top of early accept";
    }
  }
}

TEST(TwoPass, SkipsTheUpdateOrThePassWhenItCannotPayAndSaysSo) {
  Scene scene = occludedCloudScene();
  Frame f(scene, test::lookAt({6, 2, 3}, {0, 0, -6}, 1.2f), vec3(0), 96);
  ConeRun plain = runExactCone(f, variant("PreciseSorted"), "cloud PreciseSorted");
  ConeOptions skip = variant("PreciseSEATP");
  skip.updateMinFinished = 1.0f;  // pass one never finishes every ray here
  ConeRun r = runExactCone(f, skip, "cloud PreciseSEATP no update");
  EXPECT_TRUE(sameBits(plain.mask, r.mask));
  EXPECT_EQ(r.stats["two_pass"]["update"].get<std::string>().rfind("skipped", 0), 0u) << r.stats["two_pass"].dump();
  ConeOptions none = variant("PreciseSEATP");
  none.blockerSolidAngle = 12.0f;  // nothing subtends that much
  r = runExactCone(f, none, "cloud PreciseSEATP no blockers");
  EXPECT_TRUE(sameBits(plain.mask, r.mask));
  EXPECT_EQ(r.stats["two_pass"]["blockers"].get<uint32_t>(), 0u);
  EXPECT_NE(r.stats["two_pass"]["update"].get<std::string>().find("no triangle qualifies"), std::string::npos);
}

TEST(TwoPass, BitIdenticalAtATinyTraversalMemoryAndAcrossRuns) {
  Scene scene = occludedCloudScene();
  Frame f(scene, test::lookAt({6, 2, 3}, {0, 0, -6}, 1.2f), vec3(0), 96);
  ConeRun plain = runExactCone(f, variant("PreciseSorted"), "cloud PreciseSorted");
  const uint32_t depth = cone::treeDepth(uint32_t(f.host.litCount()));
  ConeOptions small = variant("PreciseSEATP");
  small.traversalMemoryBytes = 9000;
  ConeOptions least = variant("PreciseSEATP");
  test::useLeastArena(least, depth);
  for (const ConeOptions& o : {small, least}) {
    ConeRun r = runExactCone(f, o, "cloud PreciseSEATP " + std::to_string(o.traversalMemoryBytes) + " B");
    EXPECT_TRUE(sameBits(plain.mask, r.mask)) << o.traversalMemoryBytes << " bytes: mask differs";
    EXPECT_EQ(r.stats["two_pass"]["update"].get<std::string>(), "rebuilt");
  }
  // The same method object twice (cached blockers, reused buffers): the same bits.
  auto method = makeConeMethod(test::context(), variant("PreciseSEATP"));
  std::vector<float> a = method->run(f.input).visibility, b = method->run(f.input).visibility;
  EXPECT_TRUE(sameBits(a, b));
  EXPECT_TRUE(sameBits(plain.mask, a));
}

}  // namespace
}  // namespace cs
