// conetree/: the implicit tree's index maths against an explicitly built tree, the enclosing-cone maths
// on random and degenerate cones, and the GPU build: every leaf ray lies inside every ancestor cone and
// within its [Lmin, Lmax].
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "conetree/cone_math.h"
#include "conetree/conetree.h"
#include "tests/test_context.h"

namespace cs {
namespace {

using cone::ConeNode;

// Angle between two fp32 vectors, in double (scale-free).
double angleBetween(glm::vec3 a, glm::vec3 b) {
  glm::dvec3 x(a), y(b);
  return std::atan2(glm::length(glm::cross(x, y)), glm::dot(x, y));
}
// The half-angle a stored cone stands for: atan2 of its fp32 (sin, cos) pair, in double.
double halfAngle(const ConeNode& c) { return std::atan2(double(c.sinLen.x), double(c.axisCos.w)); }

TEST(ConeTree, ImplicitIndexingMatchesAnExplicitlyGroupedTree) {
  std::vector<uint32_t> sizes = {1, 2, 3, 4, 5, 15, 16, 17, 63, 64, 65, 255, 256, 257, 1000, 4095, 4096, 4097, 65537};
  for (uint32_t n : sizes) {
    const uint32_t D = cone::treeDepth(n);
    ASSERT_GE(D, 1u);
    // 4^D >= n > 4^(D-1) (except n <= 4, where D = 1)
    EXPECT_GE(uint64_t(1) << (2 * D), n);
    if (n > 4) {
      EXPECT_LT(uint64_t(1) << (2 * (D - 1)), n);
    }
    // Group explicitly, four consecutive elements at a time, recording each node's leaf range.
    std::vector<std::vector<std::pair<uint32_t, uint32_t>>> ranges(D + 1);
    for (uint32_t i = 0; i < n; ++i) ranges[D].push_back({i, i + 1});
    for (uint32_t d = D; d-- > 0;) {
      auto& below = ranges[d + 1];
      for (size_t j = 0; j < below.size(); j += 4)
        ranges[d].push_back({below[j].first, below[std::min(j + 4, below.size()) - 1].second});
    }
    ASSERT_EQ(ranges[0].size(), 1u) << n;
    EXPECT_EQ(ranges[0][0], std::make_pair(0u, n));
    const cone::TreeShape s = cone::treeShape(n);
    uint32_t offset = 0;
    for (uint32_t d = 0; d <= D; ++d) {
      ASSERT_EQ(cone::levelCount(n, D, d), ranges[d].size()) << "n=" << n << " d=" << d;
      EXPECT_EQ(s.counts[d], ranges[d].size());
      EXPECT_EQ(cone::levelOffset(n, D, d), offset);
      EXPECT_EQ(s.offsets[d], offset);
      offset += uint32_t(ranges[d].size());
      for (uint32_t j = 0; j < ranges[d].size(); ++j) {
        glm::uvec2 r = cone::leafRange(j, n, D, d);
        EXPECT_EQ(r.x, ranges[d][j].first) << "n=" << n << " d=" << d << " j=" << j;
        EXPECT_EQ(r.y, ranges[d][j].second) << "n=" << n << " d=" << d << " j=" << j;
        if (d < D) {  // children: consecutive, and their leaf ranges tile the parent's
          glm::uvec2 c = cone::childRange(j, uint32_t(ranges[d + 1].size()));
          ASSERT_LT(c.x, c.y);
          EXPECT_EQ(ranges[d + 1][c.x].first, r.x);
          EXPECT_EQ(ranges[d + 1][c.y - 1].second, r.y);
        }
      }
    }
    EXPECT_EQ(s.nodes(), offset - n) << "interior nodes = all elements but the leaves";
    EXPECT_EQ(cone::treeNodes(n), s.nodes()) << "n=" << n;
  }
}

TEST(ConeTree, ShapeOfTheLargestTreesDoesNotOverflow) {
  for (uint32_t n : {(1u << 24) + 1, 1u << 28, (1u << 30) - 1, 1u << 30}) {
    const cone::TreeShape s = cone::treeShape(n);
    EXPECT_EQ(s.counts[0], 1u);
    EXPECT_EQ(s.counts[s.depth], n);
    glm::uvec2 last = cone::leafRange(s.counts[1] - 1, n, s.depth, 1);
    EXPECT_EQ(last.y, n);
    EXPECT_LT(last.x, last.y);
  }
  EXPECT_THROW(cone::treeShape(0), Error);
  EXPECT_THROW(cone::treeShape((1u << 30) + 1), Error);
  EXPECT_EQ(cone::treeNodes(1u << 30), cone::treeShape(1u << 30).nodes());
  EXPECT_THROW(cone::treeNodes(0), Error);
}

// A cone (axis, half-angle) as the tree stores it.
ConeNode makeCone(glm::dvec3 axis, double alpha, float lmin, float lmax) {
  ConeNode c;
  glm::dvec3 a = glm::normalize(axis);
  c.axisCos = glm::vec4(glm::vec3(a), float(std::cos(alpha)));
  c.sinLen = glm::vec4(float(std::sin(alpha)), lmin, lmax, float(alpha));
  if (alpha >= M_PI) c.axisCos.w = -1.0f, c.sinLen.x = 0.0f;
  return c;
}

// A uniformly random unit vector.
glm::dvec3 randomDirection(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  for (;;) {
    glm::dvec3 p(u(rng), u(rng), u(rng));
    if (glm::length(p) > 0.1 && glm::length(p) <= 1) return glm::normalize(p);
  }
}

TEST(ConeMath, ParentEnclosesEveryChildConeIncludingWideAndOpposite) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u01(0, 1);
  auto dir = [&] { return randomDirection(rng); };
  const double angles[] = {0, 1e-7, 1e-4, 0.01, 0.5, M_PI / 2 - 1e-4, M_PI / 2, 2.0, M_PI - 1e-3, M_PI};
  int wholeSpheres = 0;
  for (int iter = 0; iter < 20000; ++iter) {
    ConeNode c[4];
    uint32_t n = 1 + iter % 4;
    glm::dvec3 base = dir();
    for (uint32_t i = 0; i < 4; ++i) {
      glm::dvec3 a = iter % 5 == 0 ? dir() : glm::normalize(base + dir() * std::pow(10.0, -6 * u01(rng)));
      if (iter % 7 == 0 && i == 1) a = -glm::dvec3(glm::vec3(c[0].axisCos));  // exactly opposite
      double alpha = iter % 3 == 0 ? angles[rng() % 10] : u01(rng) * u01(rng) * 0.1;
      c[i] = makeCone(a, alpha, float(1 + i), float(2 + i));
      if (iter % 11 == 0 && i == 2) c[i] = cone::emptyCone();
    }
    ConeNode p = cone::coneParent(c[0], c[1], c[2], c[3], n);
    double pa = halfAngle(p);
    EXPECT_NEAR(glm::length(glm::vec3(p.axisCos)), 1.0, 1e-6);
    EXPECT_NEAR(double(p.axisCos.w) * p.axisCos.w + double(p.sinLen.x) * p.sinLen.x, 1.0, 1e-6);
    wholeSpheres += pa >= M_PI;
    for (uint32_t i = 0; i < n; ++i) {
      if (cone::coneIsEmpty(c[i])) continue;
      double reach = angleBetween(glm::vec3(p.axisCos), glm::vec3(c[i].axisCos)) + halfAngle(c[i]);
      ASSERT_LE(std::min(reach, M_PI), pa)
          << "iter " << iter << " child " << i << " of " << n << ": theta "
          << angleBetween(glm::vec3(p.axisCos), glm::vec3(c[i].axisCos)) << " child angle " << halfAngle(c[i])
          << " (cos " << c[i].axisCos.w << ", sin " << c[i].sinLen.x << ")";
      EXPECT_LE(p.sinLen.y, c[i].sinLen.y);
      EXPECT_GE(p.sinLen.z, c[i].sinLen.z);
    }
  }
  EXPECT_GT(wholeSpheres, 0) << "opposite children must give the whole sphere";
  // All children empty -> an empty parent.
  ConeNode e = cone::emptyCone();
  EXPECT_TRUE(cone::coneIsEmpty(cone::coneParent(e, e, e, e, 4)));
}

// The leaf level's parent (coneParentOfRays: the same merges as coneParent through (cos, sin) pairs):
// it holds every ray, coherent or opposite, with empty children among them, and is as tight as
// coneParent's to within its padding where the rays are coherent.
TEST(ConeMath, ParentOfRaysHoldsEveryRayAndIsAsTightAsTheParent) {
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u01(0, 1);
  auto dir = [&] { return randomDirection(rng); };
  int compared = 0;
  for (int iter = 0; iter < 20000; ++iter) {
    ConeNode c[4];
    const uint32_t n = 1 + iter % 4;
    const glm::dvec3 base = dir();
    const double spread = std::pow(10.0, -7 + 7.5 * u01(rng));  // 1e-7 .. ~3 rad
    for (uint32_t i = 0; i < 4; ++i) {
      glm::dvec3 a = glm::normalize(base + dir() * spread);
      if (iter % 7 == 0 && i == 1) a = -glm::dvec3(glm::vec3(c[0].axisCos));  // exactly opposite
      const float L = float(1 + 100 * u01(rng));
      c[i] = cone::rayCone(glm::vec4(glm::vec3(a) * L, L));
      if (iter % 11 == 0 && i == 2) c[i] = cone::emptyCone();
    }
    const ConeNode p = cone::coneParentOfRays(c[0], c[1], c[2], c[3], n, CONE_PAD);
    const double pa = halfAngle(p);
    for (uint32_t i = 0; i < n; ++i) {
      if (cone::coneIsEmpty(c[i])) continue;
      ASSERT_LE(std::min(angleBetween(glm::vec3(p.axisCos), glm::vec3(c[i].axisCos)), M_PI), pa)
          << "iter " << iter << " ray " << i << " of " << n << " (spread " << spread << ")";
      EXPECT_LE(p.sinLen.y, c[i].sinLen.y);
      EXPECT_GE(p.sinLen.z, c[i].sinLen.z);
    }
    if (iter % 7 != 0 && spread < 0.1) {
      const double reference = halfAngle(cone::coneParent(c[0], c[1], c[2], c[3], n, CONE_PAD));
      EXPECT_LE(pa, reference * (1 + 1e-3) + 4 * CONE_PAD) << "iter " << iter << " (spread " << spread << ")";
      compared++;
    }
  }
  EXPECT_GT(compared, 5000);
  ConeNode e = cone::emptyCone();
  EXPECT_TRUE(cone::coneIsEmpty(cone::coneParentOfRays(e, e, e, e, 4, CONE_PAD)));
}

// Sample positions for a tree test: coherent patches (a wall seen from a camera), scattered points,
// and degenerate samples at (or within 2 eps of) the light, with NaN among them.
std::vector<glm::vec4> samplePositions(uint32_t n, glm::vec3 light, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<glm::vec4> p(n);
  for (uint32_t i = 0; i < n; ++i) {
    switch (i % 9) {
      case 0: p[i] = glm::vec4(u(rng) * 50, u(rng) * 50, u(rng) * 50, 1); break;        // scattered
      case 1: p[i] = glm::vec4(light + glm::vec3(u(rng), u(rng), u(rng)) * 1e-3f, 1); break;  // near the light
      case 2: p[i] = glm::vec4(light, 1); break;                                           // at the light
      default: p[i] = glm::vec4(float(i % 97) * 0.01f, float(i / 97) * 0.01f, 3.0f, 1); break;  // a wall
    }
  }
  if (n > 20) p[17] = glm::vec4(NAN, 0, 0, 1);
  return p;
}

// The leaves' level reads four pixel indices at a time: samples that do not start on a 16-byte
// boundary are a clear error, not a misread tree.
TEST(ConeTree, SamplesOffTheSixteenByteBoundaryAreAClearError) {
  auto& ctx = test::context();
  cone::ConeTree tree(ctx);
  vk::Buffer positions = vk::createBuffer(ctx, 64 * 16), samples = vk::createBuffer(ctx, 64 * 4);
  vk::Commands cmd(ctx);
  try {
    tree.record(cmd, positions, vk::BufferRange(samples, 4, 32 * 4), 8, glm::vec3(0.0f), 1e-4f);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("multiple of 16"), std::string::npos) << e.what();
  }
}

TEST(ConeTree, EveryLeafRayInsideEveryAncestorOnTheGpu) {
  auto& ctx = test::context();
  const glm::vec3 light(0.3f, -0.2f, 0.1f);
  const float minLength = 2e-4f;
  cone::ConeTree tree(ctx);
  for (uint32_t n : {1u, 3u, 4u, 5u, 16u, 17u, 1000u, 4096u, 4097u, 30001u}) {
    std::vector<glm::vec4> pos = samplePositions(n, light, n);
    std::vector<uint32_t> order(n);
    for (uint32_t i = 0; i < n; ++i) order[i] = uint32_t(uint64_t(i) * 7919u % n);  // a permutation (n < 7919 or coprime)
    vk::Buffer positions = vk::createBuffer(ctx, pos.size() * sizeof(glm::vec4));
    vk::Buffer samples = vk::createBuffer(ctx, order.size() * 4);
    vk::upload(ctx, positions, pos.data(), pos.size() * sizeof(glm::vec4));
    vk::upload(ctx, samples, order.data(), order.size() * 4);
    {
      vk::Commands cmd(ctx);
      tree.record(cmd, positions, samples, n, light, minLength);
      cmd.submit();
    }
    const cone::TreeShape& s = tree.shape();
    std::vector<ConeNode> gpu = vk::download<ConeNode>(ctx, tree.nodes(), s.nodes());
    std::vector<ConeNode> cpu = cone::buildTreeOnHost(pos, order, light, minLength);
    ASSERT_EQ(cpu.size(), gpu.size());
    for (const auto* nodes : {&gpu, &cpu}) {
      uint64_t checked = 0;
      for (uint32_t leaf = 0; leaf < n; ++leaf) {
        glm::vec4 ray = cone::leafRay(glm::vec3(pos[order[leaf]]), light);
        if (!cone::leafRayUsable(ray, minLength)) continue;
        uint32_t j = leaf;
        for (uint32_t d = s.depth; d-- > 0;) {
          j /= 4;  // the ancestor at depth d
          const ConeNode& c = (*nodes)[s.offsets[d] + j];
          ASSERT_FALSE(cone::coneIsEmpty(c)) << "n=" << n << " leaf " << leaf << " depth " << d;
          ASSERT_LE(angleBetween(glm::vec3(ray), glm::vec3(c.axisCos)), halfAngle(c))
              << (nodes == &gpu ? "gpu" : "cpu") << " n=" << n << " leaf " << leaf << " depth " << d;
          // The GPU's nodes hold the lengths of its own leaf rays, whose sqrt Vulkan lets be 5 ulp off
          // (and the dot product's sum go in any order): against this CPU length they may be a few ulp
          // off. Every GPU kernel takes the ray from the same leafRay, so the tree bounds its rays.
          const float slack = nodes == &gpu ? ray.w * 0x1p-20f : 0.0f;  // 16 ulp
          ASSERT_LE(c.sinLen.y, ray.w + slack) << (nodes == &gpu ? "gpu" : "cpu") << " n=" << n << " leaf " << leaf;
          ASSERT_GE(c.sinLen.z, ray.w - slack) << (nodes == &gpu ? "gpu" : "cpu") << " n=" << n << " leaf " << leaf;
          checked++;
        }
      }
      if (n > 3) {
        EXPECT_GT(checked, 0u);
      }
    }
    // Nodes whose every ray is degenerate are empty, on both sides.
    for (uint32_t k = 0; k < s.nodes(); ++k) EXPECT_EQ(cone::coneIsEmpty(gpu[k]), cone::coneIsEmpty(cpu[k])) << k;
  }
}

// The device build (ConeTree::recordDevice): the ray count read on the GPU, the shape written there and
// every height below the top an indirect dispatch recorded for the deepest tree the bound allows, the top
// heights one workgroup's (tree_top.comp). Shape words equal treeShape() and the nodes are bit-identical
// to the build from the host count (a dispatch a depth), for counts well below the bound (a shallower
// tree than recorded for), at it, and zero (no tree); trees whose top starts at heights 2, 3 and 4, in
// the world frame and in the far-light frame. Both builds' sample boxes hold exactly their nodes' samples.
TEST(ConeTree, DeviceBuildFromTheGpuCountEqualsTheHostBuild) {
  auto& ctx = test::context();
  const glm::vec3 light(0.3f, -0.2f, 0.1f);
  const float minLength = 2e-4f;
  cone::ConeTree hostTree(ctx), deviceTree(ctx);
  // And in the far-light frame (its own build and top kernels), for the trees whose top has heights.
  const glm::vec3 farLight(3000.0f, 9000.0f, 2000.0f);
  const cone::FrameChoice farFrame = cone::chooseFrame(farLight, glm::vec3(-50.0f), glm::vec3(50.0f));
  ASSERT_TRUE(farFrame.far);
  for (const bool far : {false, true})
  for (uint32_t n : {0u, 1u, 3u, 4u, 5u, 16u, 17u, 1000u, 4097u, 30001u}) {
    if (far && n < 1000u) continue;
    const glm::vec3 rayLight = far ? farLight : light;
    const cone::FrameChoice* frame = far ? &farFrame : nullptr;
    const uint32_t bound = n == 30001u ? n : 4 * n + 77;
    std::vector<glm::vec4> pos = samplePositions(std::max(bound, 1u), light, n + 1);
    std::vector<uint32_t> order(std::max(bound, 1u));
    for (uint32_t i = 0; i < order.size(); ++i) order[i] = uint32_t(uint64_t(i) * 7919u % order.size());
    vk::Buffer positions = vk::createBuffer(ctx, pos.size() * sizeof(glm::vec4));
    vk::Buffer samples = vk::createBuffer(ctx, order.size() * 4);
    vk::Buffer count = vk::createBuffer(ctx, 16);
    vk::upload(ctx, positions, pos.data(), pos.size() * sizeof(glm::vec4));
    vk::upload(ctx, samples, order.data(), order.size() * 4);
    const uint32_t words[4] = {7u, n, 9u, 9u};  // the count at word 1
    vk::upload(ctx, count, words, sizeof(words));
    {
      const vk::HostCost before = ctx.cost;
      vk::Commands cmd(ctx);
      deviceTree.recordDevice(cmd, positions, samples, count, 1, bound, rayLight, minLength, frame);
      // 30001 rays: depth 8, topHeight 4: the shape, heights 1-3 and the top's one (a height each: 9).
      if (bound == 30001u) {
        EXPECT_EQ((ctx.cost - before).dispatches, 5u);
      }
      cmd.submit();
    }
    EXPECT_EQ(deviceTree.maxDepth(), cone::treeDepth(bound));
    const std::vector<uint32_t> shape = vk::download<uint32_t>(ctx, deviceTree.shapeBuffer(), SHAPE_WORDS);
    ASSERT_EQ(shape[SHAPE_LEAVES], n);
    if (n == 0) {
      EXPECT_EQ(shape[SHAPE_DEPTH], 0u);
      EXPECT_EQ(shape[SHAPE_NODES], 0u);
      for (uint32_t h = 1; h <= cone::treeDepth(bound); ++h) EXPECT_EQ(shape[SHAPE_BUILD_ARGS + 4 * h], 0u) << h;
      continue;
    }
    const cone::TreeShape s = cone::treeShape(n);
    ASSERT_EQ(shape[SHAPE_DEPTH], s.depth) << n;
    EXPECT_EQ(shape[SHAPE_NODES], s.nodes()) << n;
    for (uint32_t d = 0; d <= s.depth; ++d) {
      EXPECT_EQ(shape[SHAPE_COUNTS + d], s.counts[d]) << n << " depth " << d;
      EXPECT_EQ(shape[SHAPE_OFFSETS + d], s.offsets[d]) << n << " depth " << d;
    }
    // A dispatch a height below topHeight, the rest one workgroup's (slot 0), none where the tree is lower.
    const uint32_t top = cone::topHeight(n);
    for (uint32_t h = 1; h <= s.depth; ++h)
      EXPECT_EQ(shape[SHAPE_BUILD_ARGS + 4 * h + 3], h < top ? s.counts[s.depth - h] : 0u) << n << " height " << h;
    EXPECT_EQ(shape[SHAPE_BUILD_ARGS], s.depth >= top ? 1u : 0u) << n;
    if (s.depth >= top) {
      EXPECT_LE(cone::countAtHeight(n, top), uint32_t(CONE_TOP_NODES)) << n;
      EXPECT_TRUE(top == 2 || cone::countAtHeight(n, top - 1) > CONE_TOP_NODES) << n;
    }
    {
      vk::Commands cmd(ctx);
      hostTree.record(cmd, positions, samples, n, rayLight, minLength, frame);
      cmd.submit();
    }
    const std::vector<ConeNode> a = vk::download<ConeNode>(ctx, hostTree.nodes(), s.nodes());
    const std::vector<ConeNode> b = vk::download<ConeNode>(ctx, deviceTree.nodes(), s.nodes());
    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(ConeNode)), 0) << "n=" << n << (far ? ", far frame" : "");
    // Both builds leave each sorted ray as the leaves read it: its sample's position bits, its pixel.
    for (const cone::ConeTree* tree : {&hostTree, &deviceTree}) {
      const std::vector<glm::uvec4> rays = vk::download<glm::uvec4>(ctx, tree->rays(), n);
      for (uint32_t i = 0; i < n; ++i) {
        const glm::vec4 p = pos[order[i]];
        ASSERT_EQ(rays[i], glm::uvec4(glm::floatBitsToUint(p.x), glm::floatBitsToUint(p.y), glm::floatBitsToUint(p.z), order[i]))
            << (tree == &hostTree ? "host" : "device") << "-count build, n=" << n << ", ray " << i;
      }
      // And each interior node's sample box (cone_layout.h, boxOffset): the exact bounds of its rays'
      // positions, at every height from 2, the top's included.
      const std::vector<glm::vec4> boxes =
          vk::download<glm::vec4>(ctx, tree->boxes(), 2 * cone::boxOffset(n, s.depth + 1));
      for (uint32_t h = CONE_BOX_FIRST_HEIGHT; h <= s.depth; ++h)
        for (uint32_t j = 0; j < cone::countAtHeight(n, h); ++j) {
          glm::vec3 lo(INFINITY), hi(-INFINITY);
          for (uint32_t i = j << (2 * h); i < std::min(n, (j + 1) << (2 * h)); ++i)
            lo = glm::min(lo, glm::vec3(pos[order[i]])), hi = glm::max(hi, glm::vec3(pos[order[i]]));
          const uint32_t b = 2 * (cone::boxOffset(n, h) + j);
          ASSERT_TRUE(glm::vec3(boxes[b]) == lo && glm::vec3(boxes[b + 1]) == hi)
              << (tree == &hostTree ? "host" : "device") << "-count build, n=" << n << ", height " << h << " node " << j;
        }
    }
  }
}

// The spread of each depth (ConeTree::recordSpread, tree_spread.comp): the sum over the depth's nodes of
// 1 - cos(half-angle) equals the host's sum over the very nodes built, exactly where a depth has at most
// CONE_SPREAD_SAMPLES nodes (to fp32 rounding) and within a few percent where it is estimated from
// strided nodes; depths past the tree keep their words. A rebuild with keepWhenZero and a device count of
// 0 leaves the shape and the nodes of the build before it untouched.
TEST(ConeTree, SpreadPerDepthAndAKeptTreeOnAZeroCount) {
  auto& ctx = test::context();
  const glm::vec3 light(0.3f, -0.2f, 0.1f);
  const float minLength = 2e-4f;
  for (uint32_t n : {5u, 1000u, 70001u}) {
    std::vector<glm::vec4> pos = samplePositions(n, light, n + 3);
    std::vector<uint32_t> order(n);
    for (uint32_t i = 0; i < n; ++i) order[i] = uint32_t(uint64_t(i) * 7919u % n);
    vk::Buffer positions = vk::createBuffer(ctx, pos.size() * sizeof(glm::vec4));
    vk::Buffer samples = vk::createBuffer(ctx, n * 4);
    vk::Buffer count = vk::createBuffer(ctx, 16);
    vk::Buffer words = vk::createBuffer(ctx, 4 * (2 + 2 * (SHAPE_MAX_DEPTH + 1)));
    vk::upload(ctx, positions, pos.data(), pos.size() * sizeof(glm::vec4));
    vk::upload(ctx, samples, order.data(), n * 4);
    const uint32_t counts[4] = {n, 0u, 0u, 0u};
    vk::upload(ctx, count, counts, sizeof(counts));
    std::vector<uint32_t> marked(2 + 2 * (SHAPE_MAX_DEPTH + 1), 0xABCDu);
    vk::upload(ctx, words, marked.data(), marked.size() * 4);
    cone::ConeTree tree(ctx);
    vk::Buffer scaled = vk::createBuffer(ctx, 4 * (2 + 2 * (SHAPE_MAX_DEPTH + 1)));
    {
      vk::Commands cmd(ctx);
      tree.recordDevice(cmd, positions, samples, count, 0, n, light, minLength);
      tree.recordSpread(cmd, words, 2);
      tree.recordSpread(cmd, scaled, 2, 0.25f);  // in units of scale^2: 16 times the sums
      cmd.submit();
    }
    const std::vector<uint32_t> gotScaled = vk::download<uint32_t>(ctx, scaled, marked.size());
    const cone::TreeShape s = cone::treeShape(n);
    const std::vector<ConeNode> nodes = vk::download<ConeNode>(ctx, tree.nodes(), s.nodes());
    const std::vector<uint32_t> got = vk::download<uint32_t>(ctx, words, marked.size());
    EXPECT_EQ(got[0], 0xABCDu);
    EXPECT_EQ(got[1], 0xABCDu);
    for (uint32_t d = 0; d <= SHAPE_MAX_DEPTH; ++d) {
      const uint64_t v = uint64_t(got[2 + 2 * d]) | (uint64_t(got[3 + 2 * d]) << 32);
      if (d >= s.depth) {
        EXPECT_EQ(got[2 + 2 * d], 0xABCDu) << "depth " << d << " is past the tree";
        continue;
      }
      double want = 0;
      for (uint32_t j = 0; j < s.counts[d]; ++j) {
        const ConeNode& c = nodes[s.offsets[d] + j];
        if (!cone::coneIsEmpty(c)) want += 1.0 - std::cos(halfAngle(c));
      }
      const double spread = double(v) / double(CONE_SPREAD_UNIT);
      const double tolerance = s.counts[d] <= CONE_SPREAD_SAMPLES ? 1e-4 : 0.05;
      EXPECT_NEAR(spread, want, tolerance * want + 1e-9) << "n=" << n << " depth " << d << " of " << s.depth;
      const uint64_t vs = uint64_t(gotScaled[2 + 2 * d]) | (uint64_t(gotScaled[3 + 2 * d]) << 32);
      EXPECT_NEAR(double(vs) / double(CONE_SPREAD_UNIT), 16.0 * want, tolerance * 16.0 * want + 1e-9)
          << "scaled, n=" << n << " depth " << d;
    }
    // A rebuild the GPU decided against (count 0 with keepWhenZero): the tree stands.
    const std::vector<uint32_t> shapeBefore = vk::download<uint32_t>(ctx, tree.shapeBuffer(), SHAPE_WORDS);
    {
      vk::Commands cmd(ctx);
      tree.recordDevice(cmd, positions, samples, count, 1, n, glm::vec3(9, 9, 9), minLength, nullptr, true);
      cmd.submit();
    }
    const std::vector<uint32_t> shapeAfter = vk::download<uint32_t>(ctx, tree.shapeBuffer(), SHAPE_WORDS);
    for (uint32_t w = 0; w < SHAPE_BUILD_ARGS; ++w) EXPECT_EQ(shapeAfter[w], shapeBefore[w]) << "shape word " << w;
    const std::vector<ConeNode> kept = vk::download<ConeNode>(ctx, tree.nodes(), s.nodes());
    EXPECT_EQ(std::memcmp(kept.data(), nodes.data(), nodes.size() * sizeof(ConeNode)), 0) << "n=" << n;
  }
}

TEST(ConeTree, CoherentRaysGiveTightCones) {
  // 64 x 64 samples on a wall 3 units from the light: neighbouring rays ~ 0.01 / 3 rad apart, so a node
  // over 4^k of them (a 2^k x 2^k patch in Morton order) spans ~ 2^k * 0.0033 rad.
  std::vector<glm::vec4> pos;
  std::vector<uint32_t> order;
  for (uint32_t i = 0; i < 4096; ++i) {
    uint32_t x = 0, y = 0;
    for (uint32_t b = 0; b < 6; ++b) x |= ((i >> (2 * b)) & 1u) << b, y |= ((i >> (2 * b + 1)) & 1u) << b;
    pos.push_back(glm::vec4(float(x) * 0.01f, float(y) * 0.01f, 3.0f, 1));
    order.push_back(i);
  }
  std::vector<ConeNode> nodes = cone::buildTreeOnHost(pos, order, glm::vec3(0), 1e-4f);
  const cone::TreeShape s = cone::treeShape(4096);
  for (uint32_t d = 0; d < s.depth; ++d) {
    double size = std::ldexp(1.0, int(s.depth - d));  // samples per side under a node
    double expect = 0.5 * size * 0.01 * std::sqrt(2.0) / 3.0;
    for (uint32_t j = 0; j < s.counts[d]; ++j) {
      double a = halfAngle(nodes[s.offsets[d] + j]);
      EXPECT_LE(a, expect * 1.6 + 1e-4) << "depth " << d;
    }
  }
}

}  // namespace
}  // namespace cs

namespace cs {
namespace {

// The far frame's shear (cone_layout.h, ConeFrame): its fp32 rows point at the scene's centre only to
// ~2^-24 rad, so under them alone a light D away sits up to D 2^-24 off the z axis and every coordinate
// relative to it rounds to an ulp of that (0.004 across at 10^13 from a room, where the room's detail is
// 10^-6: the precise test then rejected pairs the leaf test hits). The shear leaves what fp32 k does:
// at most D 2^-48 per component. And the frame takes the light to lightFrame: the fp32 map, in double.
TEST(ConeFrameChoice, TheShearPutsAFarLightOnTheAxis) {
  const glm::vec3 lo(-10, 0, -7), hi(10, 8, 7);
  const glm::dvec3 C(0.5 * (glm::dvec3(lo) + glm::dvec3(hi)));
  int far = 0;
  for (double D : {1e3, 1e6, 1e9, 1e13, 1e16, 4e18})
    for (glm::dvec3 dir : {glm::dvec3(1, 0.3, 0), glm::dvec3(0.3, 1, 0.2), glm::dvec3(-0.7, 0.35, 0.6), glm::dvec3(0, 0, -1),
                           glm::dvec3(1e-3, 1, -2e-3)}) {
      const glm::vec3 light(C + D * glm::normalize(dir));
      const cone::FrameChoice f = cone::chooseFrame(light, lo, hi);
      ASSERT_TRUE(f.far) << D;
      far++;
      const glm::vec4 lf = f.frame.lightFrame;
      EXPECT_LE(std::abs(lf.x), std::ldexp(D, -48)) << "light at " << D << " along (" << dir.x << ", " << dir.y << ", " << dir.z << ")";
      EXPECT_LE(std::abs(lf.y), std::ldexp(D, -48)) << "light at " << D;
      EXPECT_NEAR(-lf.z, D, D * 1e-6) << "light at " << D;
      // The fp32 map in double: the light goes to lightFrame; a corner of the bounds stays within the
      // bounds' radius across z of the light (so its coordinates relative to the light round to an ulp of
      // the scene, not of D 2^-24).
      auto toFrame = [&](glm::dvec3 p) {
        const glm::dvec3 d = p - glm::dvec3(glm::vec3(f.frame.centre));
        const double z = glm::dot(glm::dvec3(glm::vec3(f.frame.rowZ)), d);
        return glm::dvec3(glm::dot(glm::dvec3(glm::vec3(f.frame.rowX)), d) - double(f.frame.rowY.w) * z,
                          glm::dot(glm::dvec3(glm::vec3(f.frame.rowY)), d) - double(f.frame.rowZ.w) * z, z);
      };
      const glm::dvec3 l = toFrame(glm::dvec3(light));
      EXPECT_NEAR(l.x, lf.x, std::ldexp(std::abs(lf.x), -20) + 1e-30) << D;
      EXPECT_NEAR(l.y, lf.y, std::ldexp(std::abs(lf.y), -20) + 1e-30) << D;
      const glm::dvec3 corner = toFrame(glm::dvec3(hi)) - l;
      EXPECT_LE(std::abs(corner.x) + std::abs(corner.y), 2.0 * glm::length(glm::dvec3(hi) - C) + std::ldexp(D, -46)) << D;
      // And the GPU's formula (cone_math.h) agrees with the double map on the corner, to fp32.
      const glm::vec3 g = cone::toConeFrame(hi, f.frame) - glm::vec3(lf);
      EXPECT_NEAR(g.x, corner.x, 1e-4 * glm::length(glm::dvec3(hi) - C)) << D;
      EXPECT_NEAR(g.y, corner.y, 1e-4 * glm::length(glm::dvec3(hi) - C)) << D;
    }
  EXPECT_EQ(far, 30);
}

}  // namespace
}  // namespace cs
