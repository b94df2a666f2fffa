// shadowmaps/: adaptive shadow maps (paper 001). The host's tree under random refinement (memory never
// above the limit, parents before children, roots never evicted, LRU before replacement, the hash finds
// every node); on the GPU: refinement where the shadow edges are, convergence over frames of a static
// view below a 2048² cube map's error at less memory, a pool of a few nodes still shadowing every
// sample, a moved light flushing the tree, and limits as errors naming the setting.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.h"
#include "shadowmaps/asm.h"
#include "shadowmaps/asm_shared.h"
#include "shadowmaps/cube_sm.h"
#include "tests/shadowmap_test_support.h"
#include "tests/test_context.h"

namespace cs {
namespace {

using namespace smtest;

// Every resident node's parent is resident and one level up over the cell that holds it; child counts
// agree; the hash finds every node in its slot; at most `slots` nodes.
void expectTreeInvariants(const AsmTree& tree, uint32_t cells, const char* what) {
  const auto& nodes = tree.nodes();
  std::vector<uint32_t> children(nodes.size(), 0);
  for (uint32_t s = 0; s < nodes.size(); ++s) {
    const AsmTree::Node& n = nodes[s];
    if (s < 6) {
      ASSERT_EQ(n.key, sm::pageKey(s, 0, 0, 0)) << what << ": root " << s;
      continue;
    }
    if (n.key == SM_INVALID_KEY) continue;
    const AsmTree::Node& p = nodes[n.parent];
    ASSERT_NE(p.key, SM_INVALID_KEY) << what << ": slot " << s << " has no parent";
    EXPECT_EQ(sm::keyFace(p.key), sm::keyFace(n.key)) << what;
    EXPECT_EQ(sm::keyLevel(p.key) + 1, sm::keyLevel(n.key)) << what;
    EXPECT_EQ(sm::keyPageX(n.key) / cells, sm::keyPageX(p.key)) << what;
    EXPECT_EQ(sm::keyPageY(n.key) / cells, sm::keyPageY(p.key)) << what;
    children[n.parent]++;
  }
  for (uint32_t s = 0; s < nodes.size(); ++s) {
    if (nodes[s].key != SM_INVALID_KEY) {
      EXPECT_EQ(nodes[s].children, children[s]) << what << ": slot " << s;
    }
  }
  EXPECT_LE(tree.resident(), nodes.size());
  const uint32_t capacity = 4 * uint32_t(nodes.size());
  uint32_t pow2 = 1;
  while (pow2 < capacity) pow2 *= 2;
  const std::vector<uint32_t> table = tree.hashTable(pow2);
  for (uint32_t s = 0; s < nodes.size(); ++s) {
    if (nodes[s].key == SM_INVALID_KEY) continue;
    uint32_t h = sm::asmHash(nodes[s].key, pow2), found = UINT32_MAX;
    for (uint32_t probe = 0; probe < pow2 && table[2 * h] != SM_INVALID_KEY; ++probe, h = (h + 1) & (pow2 - 1))
      if (table[2 * h] == nodes[s].key) {
        found = table[2 * h + 1];
        break;
      }
    EXPECT_EQ(found, s) << what;
  }
}

TEST(AsmTree, RandomRefinementKeepsTheTreeWithinItsSlots) {
  std::mt19937 rng(3);
  const uint32_t cells = 4;
  AsmTree tree(20, cells, 5);
  for (uint64_t frame = 1; frame <= 300; ++frame) {
    // Some nodes used this frame, candidates from random resident nodes.
    std::vector<uint32_t> used(tree.nodes().size(), 0);
    std::vector<AsmTree::Candidate> candidates;
    for (uint32_t s = 0; s < tree.nodes().size(); ++s) {
      if (tree.nodes()[s].key == SM_INVALID_KEY) continue;
      used[s] = rng() % 3 == 0;
      if (rng() % 2) candidates.push_back({s, uint32_t(rng() % (cells * cells)), 1 + rng() % 100});
    }
    tree.markUsed(used, frame);
    const uint32_t before = tree.resident();
    const AsmTree::Refinement r = tree.refine(candidates, frame, 1 + rng() % 6);
    EXPECT_LE(r.created.size(), 6u);
    EXPECT_EQ(tree.resident(), before + r.created.size() - r.evicted - r.replaced);
    for (const auto& [key, slot] : r.created) {
      EXPECT_GE(slot, 6u) << "a root's slot was given away";
      EXPECT_EQ(tree.nodes()[slot].key, key);
      EXPECT_LE(sm::keyLevel(key), 5u);
    }
    expectTreeInvariants(tree, cells, "random refinement");
    if (frame == 150) {
      tree.reset();
      EXPECT_EQ(tree.resident(), 6u);
    }
  }
}

TEST(AsmTree, EvictsTheLeastRecentlyUnusedLeafBeforeReplacingAUsedOne) {
  AsmTree tree(8, 2, 4);  // the six roots and two children
  // Two children of face 0's root, created at frames 1 and 2.
  auto r = tree.refine({{0, 0, 10}}, 1, 8);
  ASSERT_EQ(r.created.size(), 1u);
  const uint32_t first = r.created[0].second;
  r = tree.refine({{0, 3, 20}}, 2, 8);
  ASSERT_EQ(r.created.size(), 1u);
  const uint32_t second = r.created[0].second;
  // Frame 5: both used in frame 4 (the last frame): a new cell of benefit 15 replaces the weaker (10).
  std::vector<uint32_t> used(8, 0);
  used[first] = used[second] = 1;
  tree.markUsed(used, 4);
  r = tree.refine({{1, 0, 15}}, 5, 8);
  ASSERT_EQ(r.created.size(), 1u);
  EXPECT_EQ(r.replaced, 1u);
  EXPECT_EQ(r.created[0].second, first);
  // A cell weaker than every node in use is refused.
  tree.markUsed(std::vector<uint32_t>(8, 1), 5);
  r = tree.refine({{2, 0, 5}}, 6, 8);
  EXPECT_TRUE(r.created.empty());
  EXPECT_EQ(r.refused, 1u);
  // Frame 9: nothing used since frame 5: the least recently used goes first, whatever its benefit.
  used.assign(8, 0);
  used[second] = 1;
  tree.markUsed(used, 7);  // `second` used at 7, the other at 5
  r = tree.refine({{3, 1, 1}}, 9, 8);
  ASSERT_EQ(r.created.size(), 1u);
  EXPECT_EQ(r.evicted, 1u);
  EXPECT_EQ(r.created[0].second, first);
  expectTreeInvariants(tree, 2, "eviction");
  // A node with a resident child is never evicted; the candidate's own node neither.
  r = tree.refine({{first, 0, 1000}}, 20, 8);  // a child under the newest node: the only leaf to take is `second`
  ASSERT_EQ(r.created.size(), 1u);
  EXPECT_EQ(r.created[0].second, second);
  expectTreeInvariants(tree, 2, "grandchild");
}

TEST(AsmTree, DepthStopsWhereFp32FaceCoordinatesDo) {
  EXPECT_EQ(asmMaxDepth(256, 4), 6u);  // 256 · 4^6 = 2^20 texels a side
  EXPECT_EQ(asmMaxDepth(512, 8), 4u);  // 512 · 8^4 = 2^21
  EXPECT_EQ(asmMaxDepth(16, 2), 12u);  // the keys' 12 levels
  AsmTree tree(10, 4, 1);
  auto r = tree.refine({{0, 5, 3}}, 1, 4);
  ASSERT_EQ(r.created.size(), 1u);
  r = tree.refine({{r.created[0].second, 0, 3}}, 2, 4);  // depth 2 is beyond the limit
  EXPECT_TRUE(r.created.empty());
}

// ---- on the GPU ---------------------------------------------------------------------------------------

Camera zoomedSquareCamera() {
  Camera zoom;
  zoom.eye = {2.3f, 0.9f, 2.4f};
  zoom.target = {1.325f, 0.0f, 0.5f};  // on the shadow's edge x = 1.325
  zoom.yfov = 0.05f;
  zoom.znear = 0.05f;
  zoom.zfar = 60.0f;
  return zoom;
}

// Refinement goes where the shadow's edges are: on the analytic square-above-plane scene, every node
// below the roots covers a lit sample on the edge of the square's shadow (one whose 4-neighbours the
// reference classifies differently).
TEST(Asm, RefinesTheCellsThatHoldShadowEdges) {
  Frame f = renderFrame(squareAbovePlane(), squareCamera(), kSquareLight, 160, 128);
  std::vector<glm::vec3> edgeDirs;
  const int w = int(f.host.width), h = int(f.host.height);
  for (int y = 1; y + 1 < h; ++y)
    for (int x = 1; x + 1 < w; ++x) {
      const int i = y * w + x;
      if (!f.host.isLit(i)) continue;
      const bool shadow = f.reference[i] < 0.5f;
      bool edge = false;
      for (int j : {i - 1, i + 1, i - w, i + w}) edge |= f.host.isLit(j) && (f.reference[j] < 0.5f) != shadow;
      if (edge) edgeDirs.push_back(glm::vec3(f.host.position[i]) - f.light);
    }
  ASSERT_GT(edgeDirs.size(), 100u);
  AsmOptions o;
  o.keepTree = true;
  o.budgetMs = 0;
  o.lodBias = 2;  // texels four times finer than the pixels: 256² roots do not reach that here
  auto m = makeAdaptiveShadowMap(test::context(), o);
  MethodOutput out;
  for (int frame = 0; frame < 3; ++frame) out = m->run(f.input());
  size_t children = 0;
  for (const auto& k : out.stats["node_keys"]) {
    const uint32_t key = k.get<uint32_t>(), level = sm::keyLevel(key);
    if (level == 0) continue;
    ++children;
    const double across = std::pow(double(o.cells), double(level));
    const double margin = 2.0 / (o.nodeResolution * across);  // the footprint may sit two texels outside
    const double s0 = sm::keyPageX(key) / across - margin, s1 = (sm::keyPageX(key) + 1) / across + margin;
    const double t0 = sm::keyPageY(key) / across - margin, t1 = (sm::keyPageY(key) + 1) / across + margin;
    bool holdsEdge = false;
    for (const glm::vec3& d : edgeDirs) {
      if (sm::cubeFace(d) != sm::keyFace(key)) continue;
      const glm::vec2 st = sm::faceST(sm::faceSpace(sm::keyFace(key), d));
      holdsEdge |= st.x >= s0 && st.x <= s1 && st.y >= t0 && st.y <= t1;
    }
    EXPECT_TRUE(holdsEdge) << "node at level " << level << " (" << sm::keyPageX(key) << ", " << sm::keyPageY(key)
                           << ") of face " << sm::keyFace(key) << " holds no shadow edge";
  }
  EXPECT_GT(children, 2u);
  EXPECT_GT(out.stats["straddling"].get<uint64_t>(), 0u);
}

// Paper 001's claim on a zoomed view: over frames of a static view the error falls (never rising by more
// than a few samples), and after convergence it is below a 2048² cube map's, in less memory.
TEST(Asm, ConvergesBelowTheCubeMapsErrorOnAZoomedViewInLessMemory) {
  std::vector<Frame> frames;
  frames.push_back(renderFrame(squareAbovePlane(), zoomedSquareCamera(), kSquareLight, 160, 128));
  frames.push_back(builtinFrame("edge", 160, 128));
  for (Frame& f : frames) {
    CubeSmOptions co;
    co.resolution = 2048;
    co.fitFaces = false;
    const MethodOutput cube = makeCubeShadowMap(test::context(), co)->run(f.input());
    const ErrorStats ec = f.compare(cube.visibility);
    AsmOptions o;
    o.fitFaces = false;  // the whole faces: refinement alone must find the view's edges
    auto m = makeAdaptiveShadowMap(test::context(), o);
    std::vector<double> err;
    MethodOutput out;
    for (int k = 0; k < 6; ++k) {
      out = m->run(f.input());
      err.push_back(f.compare(out.visibility).misclassifiedFraction);
      EXPECT_EQ(out.stats["frame"], k + 1);
    }
    std::printf("%s zoomed: cubesm 2048² %.5f (%.0f MiB); asm per frame", f.scene.name.c_str(),
                ec.misclassifiedFraction, cube.stats["face_bytes"].get<double>() / (1 << 20));
    for (double e : err) std::printf(" %.5f", e);
    std::printf(" (%.0f MiB pool, depth %d)\n", out.stats["pool_bytes"].get<double>() / (1 << 20),
                out.stats["deepest"].get<int>());
    const double tolerance = 5.0 / double(f.host.litCount());  // a few samples: PCF weights move at node edges
    for (size_t k = 1; k < err.size(); ++k) EXPECT_LE(err[k], err[k - 1] + tolerance) << f.scene.name << " frame " << k;
    EXPECT_LT(err.back(), 0.5 * err.front()) << f.scene.name << ": refinement must pay";
    EXPECT_LT(err.back(), ec.misclassifiedFraction) << f.scene.name;
    EXPECT_LT(out.stats["pool_bytes"].get<uint64_t>(), cube.stats["face_bytes"].get<uint64_t>());
    EXPECT_GE(out.stats["deepest"].get<int>(), 2) << f.scene.name;
  }
}

// A far light (as CubeSm/Rmsm.FittedFacesKeepAFarLightsErrorToTheirResolution): the square-above-plane
// scene from 10^2 to 10^4 diagonals sees the scene through a sliver of one face. Fitted faces (the
// default) start that face's tree at the scene's own window; the whole face spends its depth reaching
// the scene and, past 10^3 diagonals, cannot resolve the square's shadow at any depth fp32 allows.
TEST(Asm, FittedFacesKeepAFarLightsShadows) {
  for (float k : {1e2f, 1e3f, 1e4f}) {
    Frame f = renderFrame(squareAbovePlane(), squareCamera(), farSquareLight(k), 128, 96);
    size_t shadowed = 0;
    for (size_t i = 0; i < f.host.size(); ++i) shadowed += f.host.isLit(i) && f.reference[i] < 0.5f;
    ASSERT_GT(shadowed, 500u) << k << " diagonals: the view must hold the square's shadow";
    double error[2] = {};
    for (bool fit : {false, true}) {
      AsmOptions o;
      o.fitFaces = fit;
      auto m = makeAdaptiveShadowMap(test::context(), o);
      MethodOutput out;
      for (int frame = 0; frame < 4; ++frame) out = m->run(f.input());
      error[fit] = f.compare(out.visibility).misclassifiedFraction;
    }
    std::printf("far light %g diagonals: asm misclassified after 4 frames fitted %.5f, whole faces %.5f\n", k, error[1],
                error[0]);
    EXPECT_LT(error[1], 0.01) << k << " diagonals";
    if (k >= 1e3f) {
      EXPECT_GT(error[0], 2 * error[1]) << k << " diagonals";
    }
  }
}

// A pool of eight nodes (the roots and two children) under two views taking turns: nodes are evicted
// and replaced, the pool never grows, and every lit sample is still answered.
TEST(Asm, ATinyPoolEvictsAndStillShadowsEverySample) {
  Frame a = renderFrame(squareAbovePlane(), squareCamera(), kSquareLight, 128, 96);
  Frame b = renderFrame(squareAbovePlane(), zoomedSquareCamera(), kSquareLight, 128, 96);
  AsmOptions o;
  o.nodeResolution = 128;
  o.memoryBytes = 8ull * 129 * 129 * 4;
  o.lodBias = 2;  // both views ask for nodes
  auto m = makeAdaptiveShadowMap(test::context(), o);
  uint64_t evictedOrReplaced = 0;
  for (int k = 0; k < 8; ++k) {
    Frame& f = (k % 2) ? b : a;
    MethodOutput out = m->run(f.input());
    EXPECT_EQ(out.stats["pool_slots"], 8);
    EXPECT_LE(out.stats["nodes_resident"].get<int>(), 8);
    evictedOrReplaced += out.stats["nodes_evicted"].get<uint64_t>() + out.stats["nodes_replaced"].get<uint64_t>();
    const ErrorStats e = f.compare(out.visibility);
    EXPECT_EQ(e.litSamples, f.host.litCount());
    EXPECT_LT(e.misclassifiedFraction, 0.05) << "frame " << k;
  }
  EXPECT_GT(evictedOrReplaced, 0u) << "two views in turn must make the eight slots change hands";
}

// The light moves: the tree no longer holds the scene and starts again from the roots.
TEST(Asm, AMovedLightFlushesTheTree) {
  Frame f = renderFrame(squareAbovePlane(), zoomedSquareCamera(), kSquareLight, 96, 64);
  auto m = makeAdaptiveShadowMap(test::context(), AsmOptions{});
  MethodOutput out;
  for (int k = 0; k < 3; ++k) out = m->run(f.input());
  EXPECT_EQ(out.stats["frame"], 3);
  EXPECT_GT(out.stats["nodes_resident"].get<int>(), 6);
  f.light += glm::vec3(0.01f, 0, 0);
  out = m->run(f.input());
  EXPECT_EQ(out.stats["frame"], 1);
  EXPECT_EQ(out.stats["flushes"], 2);
}

// Paper 001 §4.2's ID + depth test: with no bias at all the depth comparison alone shadows receivers
// with their own triangles (acne), and the ID test lights them; where the IDs differ (across triangle
// and mesh boundaries, and under real occluders) the depth comparison still decides, so the true
// shadow stays. Its pool of IDs doubles the bytes a node.
TEST(Asm, TheIdTestLightsTheSamplesOwnTriangleWhereTheDepthAloneSelfShadows) {
  if (!test::context().geometryShader) GTEST_SKIP() << "no geometryShader: no triangle IDs";
  for (const char* view : {"wall", "room"}) {
    Frame f = builtinFrame(view, 160, 120);
    AsmOptions o;
    o.constantBias = 0;
    o.slopeBias = 0;
    o.pcf = false;
    auto depthOnly = makeAdaptiveShadowMap(test::context(), o);
    o.idTest = true;
    auto idDepth = makeAdaptiveShadowMap(test::context(), o);
    MethodOutput a, b;
    for (int k = 0; k < 3; ++k) a = depthOnly->run(f.input()), b = idDepth->run(f.input());
    const ErrorStats ea = f.compare(a.visibility), eb = f.compare(b.visibility);
    std::printf("%s, no bias: depth alone %llu false shadows, %llu false light; ID + depth %llu, %llu\n", view,
                (unsigned long long)ea.falseShadow, (unsigned long long)ea.falseLight,
                (unsigned long long)eb.falseShadow, (unsigned long long)eb.falseLight);
    size_t shadowed = 0;  // lit samples the reference shadows
    for (size_t i = 0; i < f.host.size(); ++i) shadowed += f.host.isLit(i) && f.reference[i] < 0.5f;
    EXPECT_GT(ea.falseShadow, 200u) << view << ": without bias the depth test alone must show acne";
    EXPECT_LT(eb.falseShadow, ea.falseShadow / 20) << view;
    EXPECT_LT(eb.misclassified, ea.misclassified / 10) << view;
    // Where a small occluder falls inside the texel of the sample's own triangle the ID test lights it
    // (the paper's price); the shadows stay but for a few percent of their samples.
    EXPECT_LT(double(eb.falseLight), 0.03 * double(shadowed)) << view << ": " << shadowed << " shadowed samples";
    EXPECT_EQ(b.stats["id_test"], true);
    EXPECT_EQ(b.stats["pool_bytes"].get<uint64_t>() / b.stats["pool_slots"].get<uint64_t>(),
              2 * a.stats["pool_bytes"].get<uint64_t>() / a.stats["pool_slots"].get<uint64_t>());
  }
}

TEST(Asm, SettingsOutsideTheirLimitsAreErrorsNamingTheSetting) {
  auto message = [](AsmOptions o) -> std::string {
    try {
      makeAdaptiveShadowMap(test::context(), o);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  AsmOptions o;
  o.memoryBytes = 6ull * 257 * 257 * 4;  // the roots only
  EXPECT_NE(message(o).find("--asm-memory"), std::string::npos) << message(o);
  o = AsmOptions{};
  o.cells = 3;  // does not divide 256
  EXPECT_NE(message(o).find("--asm-cells"), std::string::npos) << message(o);
  o = AsmOptions{};
  o.nodeResolution = 8;
  EXPECT_NE(message(o).find("--asm-node-res"), std::string::npos) << message(o);
  o = AsmOptions{};
  o.memoryBytes = 1ull << 40;  // beyond one storage binding
  EXPECT_NE(message(o).find("--asm-memory"), std::string::npos) << message(o);
  EXPECT_EQ(message(AsmOptions{}), "");
}

}  // namespace
}  // namespace cs
