// traversal/: the precise cone/triangle test is conservative (random and degenerate pairs against a
// brute-force search, on the CPU twin and on the GPU), the leaf test is watertight and counts hits in
// (eps, L - eps), the arena sizing stays within its budget, and the mask is bit-identical at any arena size.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "harness/harness.h"

#include "raster/raster.h"
#include "method/epsilon.h"
#include "tests/precise_probe.comp.h"
#include "tests/test_context.h"
#include "traversal/cone_engine.h"
#include "traversal/cone_method.h"
#include "traversal/precise_test.h"
#include "traversal/sphere_test.h"
#include "traversal/traversal.h"
#include "tests/cone_property_support.h"
#include "tests/cone_test_support.h"
#include "conetree/cone_layout.h"

namespace cs {
namespace {

using cone::ConeNode;
using glm::dvec3;
using glm::vec3;
using glm::vec4;
using test::BruteForce;
using test::kindName;
using test::kKinds;
using test::Pair;
using test::PairGenerator;

// The depths a frame's traversal tested: the tree's, less one or two where the leaves took sixteen or 64
// rays a pair (traversal.h, LeafRays) -- the depth the cluster and expansion rules count "above the
// leaves" from.
uint32_t testedDepths(const MethodOutput& out) {
  const uint32_t tree = out.stats["tree_depth"].get<uint32_t>(), rays = out.stats["leaf_rays"].get<uint32_t>();
  return traversal::leafStepOf(tree, rays == 64 ? 3u : rays == 16 ? 2u : 1u);
}

TEST(PreciseConeTriangle, NeverRejectsAPairThatABruteForceSearchFindsIntersecting) {
  // CONE_PROPERTY_PAIRS / CONE_PROPERTY_SEED run a longer sweep (e.g. 300000 pairs) by hand.
  const char* pairsEnv = std::getenv("CONE_PROPERTY_PAIRS");
  const char* seedEnv = std::getenv("CONE_PROPERTY_SEED");
  PairGenerator gen(seedEnv ? std::strtoull(seedEnv, nullptr, 10) : 20240611);
  BruteForce brute;
  const int n = pairsEnv ? std::atoi(pairsEnv) : 12000;
  int hits = 0, misses = 0, rejected = 0;
  int missesByKind[kKinds] = {}, rejectedByKind[kKinds] = {};
  for (int i = 0; i < n; ++i) {
    Pair p = gen.make();
    bool keep = cone::preciseConeTriangle(p.cone, p.v[0], p.v[1], p.v[2], p.eps);
    if (brute.hit(p)) {
      hits++;
      ASSERT_TRUE(keep) << "pair " << i << " (" << kindName(p.kind) << ") intersects but was rejected: alpha "
                        << p.cone.sinLen.w << " Lmax " << p.cone.sinLen.z << " eps " << p.eps;
    } else {
      misses++, missesByKind[p.kind]++;
      if (!keep) rejected++, rejectedByKind[p.kind]++;
    }
  }
  // Conservative but not trivially so: most pairs without an intersection are rejected.
  EXPECT_GT(hits, n / 4);
  EXPECT_GT(rejected, misses / 2) << rejected << " of " << misses;
  for (int k : {0, 3, 7, 8, 10, 12}) EXPECT_GT(rejectedByKind[k], missesByKind[k] / 2) << kindName(k);
}

// The cluster order's curve: every cell of the grid gets its own position, and consecutive positions
// are cells that share a face (a Morton order fails the second at every block boundary).
TEST(ClusterOrder, TheHilbertCurveVisitsEveryCellOnceFromNeighbourToNeighbour) {
  for (int bits : {1, 2, 3, 5}) {
    const uint32_t side = 1u << bits;
    std::vector<glm::ivec3> cellAt(size_t(side) * side * side, glm::ivec3(-1));
    for (uint32_t x = 0; x < side; ++x)
      for (uint32_t y = 0; y < side; ++y)
        for (uint32_t z = 0; z < side; ++z) {
          const uint64_t h = traversal::hilbertIndex3(x, y, z, bits);
          ASSERT_LT(h, cellAt.size()) << bits;
          ASSERT_EQ(cellAt[h], glm::ivec3(-1)) << "position " << h << " twice, " << bits << " bits";
          cellAt[h] = glm::ivec3(x, y, z);
        }
    for (size_t h = 1; h < cellAt.size(); ++h) {
      const glm::ivec3 d = glm::abs(cellAt[h] - cellAt[h - 1]);
      ASSERT_EQ(d.x + d.y + d.z, 1) << "positions " << h - 1 << " and " << h << ", " << bits << " bits";
    }
  }
  // The cluster order's grid: 2^10 a side, positions below 2^30.
  EXPECT_LT(traversal::hilbertIndex3(1023, 1023, 1023, 10), uint64_t(1) << 30);
  EXPECT_NE(traversal::hilbertIndex3(1023, 0, 0, 10), traversal::hilbertIndex3(0, 0, 1023, 10));
}

// Clusters (traversal.h, "Clusters"): the sphere of a cluster holding a triangle that some ray of the
// cone hits is never rejected by the sphere test -- for clusters of that triangle alone, of it and
// random triangles around it (up to 50x its size away), of coincident and of degenerate (point, line)
// triangles -- and a cluster is rejected for many pairs no ray hits.
TEST(ClusterSphere, NeverRejectsAClusterHoldingATriangleARayOfTheConeHits) {
  PairGenerator gen(20261202);
  BruteForce brute;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  int hits = 0, misses = 0, rejected = 0;
  for (int i = 0; i < 8000; ++i) {
    Pair p = gen.make();
    std::vector<glm::vec4> verts = {glm::vec4(p.v[0], 1), glm::vec4(p.v[1], 1), glm::vec4(p.v[2], 1)};
    const float size = std::max({glm::length(p.v[1] - p.v[0]), glm::length(p.v[2] - p.v[0]), 1e-6f});
    const int shape = i % 5;  // 0: the triangle alone, 1-2: with neighbours, 3: coincident copies, 4: a point
    if (shape == 1 || shape == 2) {
      const float spread = size * (shape == 1 ? 2.0f : 50.0f);
      for (int k = 0; k < 3 * 20; ++k) verts.push_back(glm::vec4(p.v[k % 3] + spread * vec3(u(rng), u(rng), u(rng)), 1));
    } else if (shape == 3) {
      for (int k = 0; k < 9; ++k) verts.push_back(verts[size_t(k % 3)]);
    } else if (shape == 4) {
      p.v[1] = p.v[2] = p.v[0];
      verts = {glm::vec4(p.v[0], 1), glm::vec4(p.v[0], 1), glm::vec4(p.v[0], 1)};
    }
    const glm::dvec4 b = traversal::clusterBounds(verts.data(), verts.size());
    // Relative to the apex already: the GPU's vertices are these fp32 values themselves.
    const glm::vec4 sphere = traversal::clusterSphere(glm::dvec3(b), b.w, glm::length(glm::dvec3(b)) + b.w);
    const bool keep = cone::sphereConeTriangle(p.cone, sphere, p.eps);
    if (brute.hit(p)) {
      hits++;
      ASSERT_TRUE(keep) << "pair " << i << " (" << kindName(p.kind) << ", cluster shape " << shape
                        << ") is hit but its cluster was rejected";
      // and the triangle's own sphere test, which the traversal ANDs, keeps it too
      ASSERT_TRUE(cone::sphereConeTriangle(p.cone, p.v[0], p.v[1], p.v[2], p.eps)) << i;
    } else {
      misses++;
      if (!keep) rejected++;
    }
  }
  EXPECT_GT(hits, 1000);
  EXPECT_GT(rejected, misses / 4) << rejected << " of " << misses;
}

// The far frame's cluster spheres (traversal.h, clusterSphereFar): padded across z only, their centre's z
// rounded as far as the GPU's vertices' z may be from the host's exact one (half an ulp of it either way).
// A cluster holding a triangle some ray of the cone hits is never rejected, from 1 to 10^6 (the generator)
// and scaled by powers of two up to ~10^18 (exact: every length and eps with it), and many pairs no ray
// hits still are.
TEST(ClusterSphere, FarFrameSpheresPaddedAcrossZAloneNeverRejectAHitCluster) {
  test::FarPairGenerator gen(20261206);
  BruteForce brute;
  std::mt19937 rng(11);
  int hits = 0, misses = 0, rejected = 0, rejectedPaddedByD = 0;
  for (int i = 0; i < 12000; ++i) {
    test::FarPair f = gen.make();
    Pair& p = f.pair;
    const float k = std::ldexp(1.0f, int(rng() % 40));  // 1 .. 2^39
    for (vec3& v : p.v) v *= k;
    p.cone.sinLen.y *= k, p.cone.sinLen.z *= k;
    p.eps *= k;
    std::vector<glm::vec4> verts = {glm::vec4(p.v[0], 1), glm::vec4(p.v[1], 1), glm::vec4(p.v[2], 1)};
    const glm::dvec4 b = traversal::clusterBounds(verts.data(), verts.size());
    glm::dvec3 rel(b);
    const double ulpZ = std::ldexp(1.0, std::ilogb(std::max(std::abs(rel.z), 1e-30)) - 23);
    rel.z += ulpZ * (double(rng() % 1001) / 1000.0 - 0.5);  // the host's exact z against the GPU's rounded one
    const glm::vec4 sphere = traversal::clusterSphereFar(rel, b.w, glm::length(glm::dvec2(rel)) + b.w);
    const bool keep = cone::sphereConeTriangle(p.cone, sphere, p.eps, f.scale);
    if (brute.hit(p)) {
      hits++;
      ASSERT_TRUE(keep) << "far pair " << i << " (kind " << p.kind << ", scaled by " << k << ") is hit but its cluster was rejected";
    } else {
      misses++;
      rejected += !keep;
      // padded by 2^-16 of the whole distance, as before
      rejectedPaddedByD += !cone::sphereConeTriangle(p.cone, traversal::clusterSphere(rel, b.w, glm::length(rel) + b.w), p.eps, f.scale);
    }
  }
  std::printf("  far clusters: %d hit, %d of %d others rejected (%d padded by the distance)\n", hits, rejected, misses,
              rejectedPaddedByD);
  EXPECT_GT(hits, 1000);
  EXPECT_GT(rejected, misses / 8) << rejected << " of " << misses;
  EXPECT_GE(rejected, rejectedPaddedByD);
}

// A cluster's groups (traversal.h, ClusterWorld): each fp32 group bound holds its four triangles'
// vertices, measured in double, for clusters of 1 to 16 triangles at magnitudes from 1e-3 to 1e7 (where
// rounding the centre to fp32 moves it by more than the group's size); a group with no triangles has the
// cluster's bound; and on a cluster in order along a line (as the Hilbert order makes them) the groups are
// tighter than the cluster.
TEST(ClusterSphere, EveryGroupBoundHoldsItsTrianglesInFp32) {
  std::mt19937 rng(20261204);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int tighter = 0, spread = 0;
  for (int i = 0; i < 4000; ++i) {
    const double magnitude = std::pow(10.0, -3.0 + 10.0 * (i % 11) / 10.0);
    const double size = magnitude * std::pow(10.0, -1.0 - 7.0 * ((i / 11) % 8) / 7.0);
    const size_t triangles = 1 + size_t(i) % CLUSTER_SIZE;
    const glm::dvec3 base(magnitude * u(rng), magnitude * u(rng), magnitude * u(rng));
    // Even i: vertices anywhere in the cube; odd i: triangle t around t on a line, as an ordered cluster is.
    const bool line = i % 2 == 1;
    std::vector<glm::vec4> verts(3 * triangles);
    for (size_t v = 0; v < verts.size(); ++v) {
      const glm::dvec3 at = line ? glm::dvec3(double(v / 3), 0, 0) + 0.5 * glm::dvec3(u(rng), u(rng), u(rng))
                                 : glm::dvec3(u(rng), u(rng), u(rng));
      verts[v] = glm::vec4(glm::vec3(base + size * at), 1.0f);
    }
    const traversal::ClusterWorld w = traversal::clusterWorld(verts.data(), triangles);
    for (size_t g = 0; g < CLUSTER_GROUPS; ++g) {
      const glm::dvec3 c(glm::vec3(w.groups[g]));
      const double r = w.groups[g].w;
      ASSERT_GE(r, 0.0);
      if (g * GROUP_SIZE >= triangles) {
        EXPECT_LE(glm::length(c - glm::dvec3(w.whole)), std::ldexp(glm::length(glm::dvec3(w.whole)), -22)) << i;
        EXPECT_GE(r, w.whole.w) << i;
        continue;
      }
      for (size_t v = 3 * g * GROUP_SIZE; v < std::min(verts.size(), 3 * (g + 1) * GROUP_SIZE); ++v)
        ASSERT_LE(glm::length(glm::dvec3(glm::vec3(verts[v])) - c), r)
            << "cluster " << i << " (" << triangles << " triangles at " << magnitude << "), group " << g << ", vertex " << v;
      if (line && triangles == CLUSTER_SIZE && size > 1e-4 * magnitude) {
        spread++;
        if (r < 0.9 * w.whole.w) tighter++;
      }
    }
  }
  EXPECT_GT(tighter, spread / 2) << tighter << " of " << spread;
}

// A super cluster's bound (traversal.h, superBounds) holds every vertex of its 1 to 4 clusters, spread
// out or on top of one another, at magnitudes from 1e-3 to 1e7.
TEST(ClusterSphere, ASuperClusterBoundHoldsItsClusters) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 2000; ++i) {
    const double magnitude = std::pow(10.0, -3.0 + 10.0 * (i % 11) / 10.0);
    const double size = magnitude * std::pow(10.0, -1.0 - 6.0 * ((i / 11) % 7) / 6.0);
    const size_t count = 1 + size_t(i) % SUPER_CLUSTERS;
    const glm::dvec3 base(magnitude * u(rng), magnitude * u(rng), magnitude * u(rng));
    std::vector<std::vector<glm::vec4>> verts(count);
    std::vector<traversal::ClusterWorld> worlds;
    for (size_t q = 0; q < count; ++q) {
      const glm::dvec3 at = i % 3 == 0 ? glm::dvec3(0) : 4.0 * glm::dvec3(u(rng), u(rng), u(rng));
      verts[q].resize(3 * CLUSTER_SIZE);
      for (glm::vec4& v : verts[q]) v = glm::vec4(glm::vec3(base + size * (at + glm::dvec3(u(rng), u(rng), u(rng)))), 1.0f);
      worlds.push_back(traversal::clusterWorld(verts[q].data(), CLUSTER_SIZE));
    }
    const glm::dvec4 b = traversal::superBounds(worlds.data(), count);
    for (size_t q = 0; q < count; ++q)
      for (const glm::vec4& v : verts[q])
        ASSERT_LE(glm::length(glm::dvec3(glm::vec3(v)) - glm::dvec3(b)), b.w) << "super cluster " << i << ", cluster " << q;
  }
}

// A triangle seen from far away, as the far frame holds it: z about the light's distance D for all three
// vertices. Its bounding sphere stays about the triangle's own size, whatever D: the centre made from a
// third of the sum once landed an ulp of D off the vertices (3 D rounds to an ulp of 3 D) and the radius
// grew to that, 64 at 10^9.
TEST(SphereConeTriangle, TheBoundingSphereOfAFarTriangleIsItsOwnSize) {
  std::mt19937 rng(43);
  std::uniform_real_distribution<float> u(-10.0f, 10.0f);
  for (float D : {1e4f, 1.04403059e9f, 1e10f, 1.04403059e11f, 3e17f, 4e18f}) {
    const float z = D;  // a float: the frame's z of every vertex once rounded
    for (int t = 0; t < 200; ++t) {
      const vec3 v0(u(rng), u(rng), z), v1(u(rng), u(rng), z), v2(u(rng), u(rng), z);
      const float size = std::max(glm::length(v1 - v0), std::max(glm::length(v2 - v0), glm::length(v2 - v1)));
      const float scale = std::min(1.0f, 4.0f * 14.0f / D);  // the frame's angular scale for bounds of radius 14
      const glm::vec4 s = cone::boundingSphere(v0, v1, v2, scale);
      EXPECT_LE(s.w, size * 1.01f + 1e-3f) << "D " << D << " triangle " << t;
      for (vec3 v : {v0, v1, v2}) EXPECT_LE(glm::length(glm::dvec3(v) - glm::dvec3(vec3(s))), double(s.w)) << "D " << D;
    }
  }
}

// The far-light frame (traversal.h): with the margins scaled by the frame's angular scale, the precise
// and sphere tests still never reject a pair a brute-force search finds intersecting, and they reject
// more of the others than with scale 1 (the point of the frame: there narrow cones far from the apex keep
// everything within 2^-16 of their distance).
TEST(PreciseConeTriangle, FarFrameMarginsStayConservativeAndReject) {
  const char* pairsEnv = std::getenv("CONE_PROPERTY_PAIRS");
  test::FarPairGenerator gen(20261204);
  BruteForce brute;
  const int n = pairsEnv ? std::atoi(pairsEnv) : 12000;
  int hits = 0, misses = 0, rejected = 0, rejectedUnscaled = 0;
  int missesByKind[5] = {}, rejectedByKind[5] = {};
  for (int i = 0; i < n; ++i) {
    test::FarPair f = gen.make();
    const Pair& p = f.pair;
    const bool keep = cone::preciseConeTriangle(p.cone, cone::preciseTriangle(p.v[0], p.v[1], p.v[2], f.scale), p.eps);
    const bool keepSphere = cone::sphereConeTriangle(p.cone, cone::boundingSphere(p.v[0], p.v[1], p.v[2], f.scale),
                                                     p.eps, f.scale);
    if (brute.hit(p)) {
      hits++;
      ASSERT_TRUE(keep) << "far pair " << i << " (kind " << p.kind << ") intersects but the precise test rejected it";
      ASSERT_TRUE(keepSphere) << "far pair " << i << " (kind " << p.kind << ") intersects but the sphere test rejected it";
    } else {
      misses++, missesByKind[p.kind]++;
      rejected += !(keep && keepSphere);
      rejectedByKind[p.kind] += !(keep && keepSphere);
      rejectedUnscaled += !(cone::preciseConeTriangle(p.cone, p.v[0], p.v[1], p.v[2], p.eps) &&
                            cone::sphereConeTriangle(p.cone, p.v[0], p.v[1], p.v[2], p.eps));
    }
  }
  std::printf("  far frame: %d pairs, %d intersecting; of the %d others %d rejected (%d with scale 1)\n", n, hits, misses,
              rejected, rejectedUnscaled);
  for (int k = 0; k < 5; ++k) std::printf("    kind %d: %d of %d rejected\n", k, rejectedByKind[k], missesByKind[k]);
  // The scattered pairs (kind 0) are nearly all rejected; kinds 1-4 are near misses by design.
  EXPECT_GT(hits, n / 10);
  EXPECT_GT(rejectedByKind[0], missesByKind[0] * 9 / 10);
  EXPECT_GT(rejected, misses / 3);
  EXPECT_GT(rejected, rejectedUnscaled);
}

TEST(PreciseConeTriangle, RejectsTheClearCasesOfEachTest) {
  auto cone = [](dvec3 a, double alpha, double lmax) { return PairGenerator::cone(glm::normalize(a), alpha, lmax); };
  const ConeNode narrow = cone({0, 0, 1}, 0.1, 10);
  // Beside the cone: an edge plane separates.
  EXPECT_FALSE(cone::preciseConeTriangle(narrow, {2, -1, 5}, {3, -1, 5}, {2, 1, 5}));
  // Straddling the axis: kept.
  EXPECT_TRUE(cone::preciseConeTriangle(narrow, {-1, -1, 5}, {1, -1, 5}, {0, 1, 5}));
  // Beyond Lmax (the near-point test): rejected; nearer than Lmax: kept.
  EXPECT_FALSE(cone::preciseConeTriangle(narrow, {-1, -1, 12}, {1, -1, 12}, {0, 1, 12}));
  EXPECT_TRUE(cone::preciseConeTriangle(narrow, {-1, -1, 9.9f}, {1, -1, 9.9f}, {0, 1, 9.9f}));
  // Behind the apex: rejected (complementary cone of the cone rounded up to pi/2).
  EXPECT_FALSE(cone::preciseConeTriangle(narrow, {-1, -1, -1}, {1, -1, -1}, {0, 1, -1}));
  // The triangle shadow (002 Fig. 4): a corner region where no single edge separates the projected
  // triangle from the unit circle, but the tangent plane towards the vertex does.
  const ConeNode c2 = cone({0, 0, 1}, 0.2, 100);
  EXPECT_FALSE(cone::preciseConeTriangle(c2, {0.25f, 0.25f, 1}, {5, 0.3f, 1}, {0.3f, 5, 1}));
  // A wide cone (past pi/2): only the complementary cone can reject.
  const ConeNode wide = cone({0, 0, 1}, 2.0, 10);
  EXPECT_FALSE(cone::preciseConeTriangle(wide, {0.1f, 0, -1}, {-0.1f, 0.1f, -1}, {0, -0.1f, -1}));
  EXPECT_FALSE(cone::preciseConeTriangle(wide, {1, 0, -1}, {-1, 1, -1}, {0, -1, -1}));  // 45 deg from -z: all outside
  EXPECT_TRUE(cone::preciseConeTriangle(wide, {3, 0, -1}, {-1, 1, -1}, {0, -1, -1}));   // 71.6 deg: one inside
  // The whole sphere keeps everything within Lmax, rejects what is beyond.
  const ConeNode all = cone({0, 1, 0}, M_PI, 10);
  EXPECT_TRUE(cone::preciseConeTriangle(all, {1, 1, 1}, {2, 1, 1}, {1, 2, 1}));
  EXPECT_FALSE(cone::preciseConeTriangle(all, {20, 1, 1}, {20, 2, 1}, {20, 1, 2}));  // its plane is beyond Lmax
  // (A triangle far away in a plane that passes near the apex is kept: the test bounds the plane.)
  EXPECT_TRUE(cone::preciseConeTriangle(all, {20, 1, 1}, {21, 1, 1}, {20, 2, 1}));
  // Empty cones reject everything; NaN vertices are kept (never rejected on garbage).
  EXPECT_FALSE(cone::preciseConeTriangle(cone::emptyCone(), {-1, -1, 5}, {1, -1, 5}, {0, 1, 5}));
  EXPECT_TRUE(cone::preciseConeTriangle(narrow, {NAN, -1, 5}, {1, -1, 5}, {0, 1, 5}));
}

// The same pairs through the GPU kernel: the GPU's precise test keeps every pair the brute force finds
// intersecting, and its leaf test agrees with the CPU twin on the rays the brute force found.
TEST(PreciseConeTriangle, GpuKernelIsConservativeToo) {
  auto& ctx = test::context();
  PairGenerator gen(777);
  BruteForce brute;
  const uint32_t n = 6000;
  std::vector<ConeNode> cones(n);
  std::vector<vec4> verts(3 * n), rays(n, vec4(0, 0, 1, 1));
  std::vector<uint8_t> found(n), leafFound(n);
  for (uint32_t i = 0; i < n; ++i) {
    Pair p = gen.make();
    cones[i] = p.cone;
    for (int k = 0; k < 3; ++k) verts[3 * i + k] = vec4(p.v[k], k == 0 ? p.eps : (k == 1 ? BruteForce::leafEps(p) : 0.0f));
    vec4 ray(0);
    found[i] = brute.hit(p, &ray);
    if (ray.w > 0) rays[i] = ray, leafFound[i] = 1;
  }
  vk::Buffer bc = vk::createBuffer(ctx, n * sizeof(ConeNode)), bv = vk::createBuffer(ctx, verts.size() * 16),
             br = vk::createBuffer(ctx, n * 16), out = vk::createBuffer(ctx, n * 4);
  vk::upload(ctx, bc, cones.data(), n * sizeof(ConeNode));
  vk::upload(ctx, bv, verts.data(), verts.size() * 16);
  vk::upload(ctx, br, rays.data(), n * 16);
  vk::Kernel probe = vk::createKernel(ctx, "precise probe", spv_precise_probe_comp, 4, sizeof(traversal::TraversePush));
  traversal::TraversePush push{};
  push.count = n;
  {
    vk::Commands cmd(ctx);
    vk::Grid g = vk::gridFor(n, TRAVERSE_THREADS, ctx.maxWorkgroups());
    cmd.dispatch(probe, {bc, bv, br, out}, push, g.x, g.y);
    cmd.submit();
  }
  std::vector<uint32_t> r = vk::download<uint32_t>(ctx, out, n);
  uint32_t agree = 0, leafChecked = 0, leafAgree = 0;
  for (uint32_t i = 0; i < n; ++i) {
    bool cpuKeep = cone::preciseConeTriangle(cones[i], vec3(verts[3 * i]), vec3(verts[3 * i + 1]),
                                             vec3(verts[3 * i + 2]), verts[3 * i].w);
    if (found[i]) {
      ASSERT_TRUE(r[i] & 1u) << "GPU rejected intersecting pair " << i;
    }
    agree += bool(r[i] & 1u) == cpuKeep;
    if (leafFound[i]) {  // found by either leaf test (BruteForce::leaf): the GPU's two against the CPU's
      leafChecked++;
      const vec3 v0(verts[3 * i]), v1(verts[3 * i + 1]), v2(verts[3 * i + 2]);
      const float le = verts[3 * i + 1].w;
      leafAgree += bool(r[i] & 2u) == cone::leafHit(vec3(rays[i]), vec3(0), rays[i], le, v0, v1, v2) &&
                   bool(r[i] & 4u) == cone::leafHitFromLight(vec3(rays[i]), vec3(0), rays[i], le, v0, v1, v2) &&
                   bool(r[i] & 8u) == cone::leafHitFromSample(vec3(rays[i]), vec3(0), rays[i], le, v0, v1, v2) &&
                   (r[i] & 14u) != 0;
    }
  }
  EXPECT_GE(agree, n - n / 100) << "GPU and CPU twins should agree on almost every pair";
  EXPECT_GE(leafAgree + leafChecked / 100 + 1, leafChecked) << leafChecked << " pairs found by the fp32 leaf test alone";
}

TEST(LeafRayHitsTriangle, CountsHitsOnlyStrictlyBetweenEpsAndLMinusEps) {
  // Triangle in the plane z = 5 around the z axis; rays from the light at the origin along +z.
  const vec3 a(-1, -1, 5), b(1, -1, 5), c(0, 1, 5);
  const float eps = 0.01f;
  auto hit = [&](float L) { return cone::leafRayHitsTriangle(vec4(0, 0, L, L), eps, a, b, c); };
  EXPECT_TRUE(hit(10));        // the triangle halfway
  EXPECT_TRUE(hit(5.02f));     // 0.02 beyond the sample side of the triangle: inside (eps, L - eps)
  EXPECT_FALSE(hit(5.005f));   // the sample within eps of the triangle: its own surface, not counted
  EXPECT_FALSE(hit(4.9f));     // the triangle beyond the sample
  // Near the light: the triangle at distance 0.005 < eps from the light does not count.
  const vec3 a2(-1, -1, 0.005f), b2(1, -1, 0.005f), c2(0, 1, 0.005f);
  EXPECT_FALSE(cone::leafRayHitsTriangle(vec4(0, 0, 10, 10), eps, a2, b2, c2));
  // A ray lying in the triangle's plane, and one from a light in that plane: never a hit.
  EXPECT_FALSE(cone::leafRayHitsTriangle(vec4(10, 0, 0, 10), eps, vec3(-1, -1, 0), vec3(5, -1, 0), vec3(0, 1, 0)));
  // A degenerate (zero-area) triangle and a sample at the light: never a hit, never NaN trouble.
  EXPECT_FALSE(cone::leafRayHitsTriangle(vec4(0, 0, 10, 10), eps, a, a, c));
  EXPECT_FALSE(cone::leafRayHitsTriangle(vec4(0, 0, 0, 0), eps, a, b, c));
}

// The rim of a fan of k triangles around `centre`, a little off the z = centre.z plane.
std::vector<vec3> fanRim(vec3 centre, int k) {
  std::vector<vec3> rim;
  for (int i = 0; i < k; ++i) {
    float t = 2.0f * float(M_PI) * float(i) / float(k);
    rim.push_back(centre + vec3(std::cos(t), std::sin(t), 0.1f * std::sin(3.0f * t)));
  }
  return rim;
}

TEST(LeafRayHitsTriangle, IsWatertightAcrossSharedEdgesAndVertices) {
  // A fan of triangles around a vertex on the z = 3 plane, and rays aimed exactly at the shared edges
  // and at the shared vertex from a light off-axis: every ray hits at least one triangle of the fan.
  const vec3 centre(0.3f, -0.2f, 3.0f);
  const int k = 7;
  const std::vector<vec3> rim = fanRim(centre, k);
  const vec3 light(0.11f, 0.07f, -0.5f);
  int rays = 0;
  for (int i = 0; i < k; ++i) {
    for (float f : {0.0f, 0.125f, 0.37f, 0.5f, 0.999f}) {
      vec3 target = centre + f * (rim[i] - centre);  // on the shared edge (centre, rim[i])
      vec4 ray = cone::leafRay(light + 2.0f * (target - light), light);
      bool any = false;
      for (int j = 0; j < k; ++j)
        any = any || cone::leafRayHitsTriangle(ray, 1e-4f, centre - light, rim[j] - light, rim[(j + 1) % k] - light);
      EXPECT_TRUE(any) << "edge " << i << " at " << f;
      rays++;
    }
  }
  EXPECT_EQ(rays, 5 * k);
}

// (And the test from the sample: the same cases, the same answers.)
TEST(LeafHitFromLight, CountsHitsOnlyStrictlyBetweenEpsAndLMinusEps) {
  for (bool fromSample : {false, true}) {
  SCOPED_TRACE(fromSample ? "from the sample" : "from the light");
  // The same cases as leafRayHitsTriangle's above, from world coordinates with the light at (1, 2, 3).
  const vec3 o(1, 2, 3);
  const vec3 a = o + vec3(-1, -1, 5), b = o + vec3(1, -1, 5), c = o + vec3(0, 1, 5);
  const float eps = 0.01f;
  auto hit = [&](vec3 p, vec3 P0, vec3 P1, vec3 P2) {
    return fromSample ? cone::leafHitFromSample(p, o, cone::leafRay(p, o), eps, P0, P1, P2)
                      : cone::leafHitFromLight(p, o, cone::leafRay(p, o), eps, P0, P1, P2);
  };
  EXPECT_TRUE(hit(o + vec3(0, 0, 10), a, b, c));      // the triangle halfway
  EXPECT_TRUE(hit(o + vec3(0, 0, 5.02f), a, b, c));   // 0.02 beyond it: inside (eps, L - eps)
  EXPECT_FALSE(hit(o + vec3(0, 0, 5.005f), a, b, c)); // within eps of it: the sample's own surface
  EXPECT_FALSE(hit(o + vec3(0, 0, 4.9f), a, b, c));   // beyond the sample
  EXPECT_FALSE(hit(o + vec3(0, 0, 5), a, b, c));      // on it
  EXPECT_FALSE(hit(o + vec3(0, 0, -10), a, b, c));    // behind the light
  EXPECT_FALSE(hit(o + vec3(3, 0, 10), a, b, c));     // beside it
  EXPECT_TRUE(hit(o + vec3(0, 0, 10), a, c, b));      // either winding
  // Near the light: a triangle 0.005 < eps from it does not count.
  EXPECT_FALSE(hit(o + vec3(0, 0, 10), o + vec3(-1, -1, 0.005f), o + vec3(1, -1, 0.005f), o + vec3(0, 1, 0.005f)));
  // A ray in the triangle's plane, a light in it, a degenerate triangle, a sample at the light: never.
  EXPECT_FALSE(hit(o + vec3(10, 0, 0), o + vec3(-1, -1, 0), o + vec3(5, -1, 0), o + vec3(0, 1, 0)));
  EXPECT_FALSE(hit(o + vec3(1, 0.5f, 10), o + vec3(-1, -1, 0), o + vec3(5, -1, 0), o + vec3(0, 1, 0)));
  EXPECT_FALSE(hit(o + vec3(0, 0, 10), a, a, c));
  EXPECT_FALSE(hit(o, a, b, c));
  }
}

TEST(LeafHitFromLight, IsWatertightAcrossSharedEdgesAndVertices) {
  // leafRayHitsTriangle's fan above, and a fan of two windings (a mesh whose neighbours disagree).
  const vec3 centre(0.3f, -0.2f, 3.0f);
  const int k = 7;
  const std::vector<vec3> rim = fanRim(centre, k);
  for (const vec3 light : {vec3(0.11f, 0.07f, -0.5f), vec3(-2.3f, 1.7f, 0.4f), vec3(0.29f, -0.21f, 9.0f)}) {
    for (bool mixed : {false, true}) {
      int rays = 0;
      for (int i = 0; i < k; ++i) {
        for (float f : {0.0f, 0.125f, 0.37f, 0.5f, 0.999f}) {
          vec3 target = centre + f * (rim[i] - centre);  // on the shared edge (centre, rim[i]); f = 0: the vertex
          const vec3 p = light + 2.0f * (target - light);
          vec4 ray = cone::leafRay(p, light);
          bool any = false, anySample = false;
          for (int j = 0; j < k; ++j) {
            const vec3 q = rim[j], r = rim[(j + 1) % k];
            any = any || (mixed && j % 2 ? cone::leafHitFromLight(p, light, ray, 1e-4f, centre, r, q)
                                         : cone::leafHitFromLight(p, light, ray, 1e-4f, centre, q, r));
            anySample = anySample || (mixed && j % 2 ? cone::leafHitFromSample(p, light, ray, 1e-4f, centre, r, q)
                                                     : cone::leafHitFromSample(p, light, ray, 1e-4f, centre, q, r));
          }
          EXPECT_TRUE(any) << "edge " << i << " at " << f << (mixed ? ", mixed windings" : "");
          EXPECT_TRUE(anySample) << "from the sample: edge " << i << " at " << f << (mixed ? ", mixed windings" : "");
          rays++;
        }
      }
      EXPECT_EQ(rays, 5 * k);
    }
  }
}

// The two leaf tests answer alike wherever the answer is not decided by rounding: random triangles and
// samples in a unit box, lights in it and up to a few diagonals out (the world frame's), and every
// (sample, triangle) whose exact ray (in double) meets the triangle's plane more than a margin from its
// edges, with both ends of (eps, L - eps) more than that margin from the plane, gets the exact answer
// from both.
// Receivers too: a sample on a triangle (fp32 barycentric point) is never shadowed by it, the light
// grazing its plane included.
TEST(LeafHitFromLight, AgreesWithTheTwoEndsTestAndTheExactAnswerAwayFromEdgesAndEnds) {
  std::mt19937 rng(20261205);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  auto point = [&](float spread) { return vec3(u(rng), u(rng), u(rng)) * 2.0f * spread - vec3(spread - 0.5f); };
  const float eps = 1e-4f;
  const double margin = 1e-4;  // of the unit box's size
  int decided = 0, hits = 0, receivers = 0;
  for (int i = 0; i < 40000; ++i) {
    const vec3 light = point(i % 3 == 0 ? 2.0f : 0.5f);
    vec3 p = point(0.5f);
    // The triangle: anywhere, or around a point of the segment from the light to the sample (hits).
    const float size = std::exp(std::log(1e-3f) + u(rng) * std::log(1e3f));
    const vec3 centre = i % 2 ? light + u(rng) * (p - light) : point(0.5f);
    vec3 P[3];
    for (vec3& x : P) x = centre + size * (vec3(u(rng), u(rng), u(rng)) - 0.5f);
    const bool receiver = i % 4 == 0;  // the sample on the triangle's plane, within rounding
    if (receiver) p = P[0] + u(rng) * (P[1] - P[0]) + u(rng) * 0.5f * (P[2] - P[0]);
    const vec4 ray = cone::leafRay(p, light);
    if (!cone::leafRayUsable(ray, 2.0f * eps)) continue;
    const bool fromLight = cone::leafHitFromLight(p, light, ray, eps, P[0], P[1], P[2]);
    const bool twoEnds = cone::leafHit(p, light, ray, eps, P[0], P[1], P[2]);
    const bool fromSample = cone::leafHitFromSample(p, light, ray, eps, P[0], P[1], P[2]);
    // The exact ray light + t (p - light), t in (0, 1), against the triangle, in double.
    const dvec3 L0(light), d = dvec3(p) - dvec3(light), e1 = dvec3(P[1]) - dvec3(P[0]), e2 = dvec3(P[2]) - dvec3(P[0]);
    const dvec3 n = glm::cross(e1, e2);
    const double len = glm::length(d), det = -glm::dot(d, n);
    if (!(std::abs(det) > 1e-9 * len * glm::length(n))) continue;  // (nearly) in the plane: undecided
    const dvec3 s = L0 - dvec3(P[0]);
    const double t = glm::dot(s, n) / det, b1 = -glm::dot(d, glm::cross(s, e2)) / det,
                 b2 = -glm::dot(d, glm::cross(e1, s)) / det;
    const dvec3 x = L0 + t * d;
    // Distance of the crossing from the triangle's edges (negative inside), and from the interval's ends.
    auto edgeDistance = [&](dvec3 a, dvec3 b) {
      const dvec3 e = b - a, m = glm::normalize(glm::cross(n, e));  // inward normal of edge (a, b) in the plane
      return -glm::dot(x - a, m);
    };
    const dvec3 A(P[0]), B(P[1]), C(P[2]);
    const double outside = std::max({edgeDistance(A, B), edgeDistance(B, C), edgeDistance(C, A)});
    const double tau = t * len;
    const bool exactHit = b1 >= 0 && b2 >= 0 && b1 + b2 <= 1 && tau > eps && tau < len - eps;
    if (receiver && t > 0 && len - tau < 0.5 * eps) {
      // The plane crossed within half eps of the sample: its own surface, never a shadow, at any angle.
      receivers++;
      EXPECT_FALSE(fromLight) << "case " << i << ": a receiver shadowed by its own triangle, " << len - tau
                              << " from the crossing";
      EXPECT_FALSE(twoEnds) << "case " << i;
      EXPECT_FALSE(fromSample) << "case " << i;
      continue;
    }
    // The interval's ends as distances from the plane (the band's nudges are along the normal too).
    const double sinAngle = std::abs(det) / (len * glm::length(n));
    const double slack = std::min({std::abs(outside), std::abs(tau - eps) * sinAngle, std::abs(len - eps - tau) * sinAngle});
    if (!(slack > margin) || !std::isfinite(slack)) continue;
    decided++;
    hits += exactHit;
    ASSERT_EQ(fromLight, exactHit) << "case " << i << ": tau " << tau << " of " << len << ", outside by " << outside;
    ASSERT_EQ(twoEnds, exactHit) << "case " << i;
    ASSERT_EQ(fromSample, exactHit) << "case " << i;
  }
  std::printf("  %d decided, %d of them hits; %d receivers\n", decided, hits, receivers);
  EXPECT_GT(decided, 15000);
  EXPECT_GT(hits, 2000);
  EXPECT_GT(receivers, 5000);
}

// The far light's test (traversal.h, LeafTest::FromSample) answers as the two ends' test and the exact
// ray do wherever rounding does not decide: samples and triangles in a unit box, lights 10 to 10^6
// box sizes away in every direction, triangles anywhere or around a point of the ray within a box size
// of its sample (the blockers a far light's samples have), receivers (the sample on the triangle), and
// every (sample, triangle) whose exact ray passes the triangle's edges and both ends of (eps, L - eps)
// by more than a margin gets the exact answer. Edge functions taken through the light instead (the
// from-light test) round to an ulp of the light's distance: at 10^6 they miss hits well inside.
TEST(LeafHitFromSample, AgreesWithTheTwoEndsTestAndTheExactAnswerForFarLights) {
  std::mt19937 rng(20261209);
  int decided = 0, hits = 0, receivers = 0, fromLightWrong = 0;
  for (int i = 0; i < 40000; ++i) {
    const test::FarLeafCase c = test::makeFarLeafCase(rng, i);
    if (!c.usable) continue;
    const bool fromSample = cone::leafHitFromSample(c.p, c.light, c.ray, c.eps, c.P[0], c.P[1], c.P[2]);
    const bool twoEnds = cone::leafHit(c.p, c.light, c.ray, c.eps, c.P[0], c.P[1], c.P[2]);
    const bool fromLight = cone::leafHitFromLight(c.p, c.light, c.ray, c.eps, c.P[0], c.P[1], c.P[2]);
    if (c.receiver) {
      receivers++;
      EXPECT_FALSE(fromSample) << "case " << i << ": a receiver shadowed by its own triangle";
      EXPECT_FALSE(twoEnds) << "case " << i;
      continue;
    }
    if (!c.decided) continue;
    decided++;
    hits += c.exactHit;
    fromLightWrong += fromLight != c.exactHit;
    ASSERT_EQ(fromSample, c.exactHit) << "case " << i << ": light " << c.away << " away, tau " << c.tau << " of "
                                      << c.length << ", outside by " << c.outside;
    ASSERT_EQ(twoEnds, c.exactHit) << "case " << i;
  }
  std::printf("  %d decided, %d of them hits; %d receivers; the from-light test wrong on %d\n", decided, hits,
              receivers, fromLightWrong);
  EXPECT_GT(decided, 15000);
  EXPECT_GT(hits, 2000);
  EXPECT_GT(receivers, 5000);
}

// The leaves drop the test from the sample's per-edge choice of end where the pair's sample box says
// every sample takes the sample's end (leafSamplesNearer); the answer must then be the same bit for bit,
// for every sample in the box. Boxes of 10^-4 to 1 around the far-light cases' samples, points at their
// corners and inside, under far lights and lights among the geometry (where the guard says yes and no);
// and it says no for samples around the light, an empty box, a NaN box.
TEST(LeafHitFromSample, FromTheSampleEndAnswersAlikeInBoxesNearerTheSamples) {
  std::mt19937 rng(20261210);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int nearer = 0, compared = 0, hits = 0, nearLights = 0, farther = 0;
  for (int i = 0; i < 20000; ++i) {
    test::FarLeafCase c = test::makeFarLeafCase(rng, i);
    // Every third case a light among the geometry (0.2 to 2 from the sample), where the guard varies.
    if (i % 3 == 0) c.light = c.p + (0.2f + 1.8f * u(rng)) * glm::normalize(vec3(u(rng), u(rng), u(rng)) - 0.5f);
    const float half = std::exp(std::log(1e-4f) + u(rng) * std::log(1e4f));
    const vec3 lo = c.p - half, hi = c.p + half;
    const cone::LeafEdges e = cone::leafEdges(c.P[0], c.P[1], c.P[2], c.light);
    const cone::LeafTriangle t = cone::leafPlane(c.P[0], c.P[1], c.P[2], c.light);
    if (!cone::leafSamplesNearer(e, lo, hi)) {
      farther += i % 3 == 0;
      continue;
    }
    nearer++;
    nearLights += i % 3 == 0;
    for (int k = 0; k < 12; ++k) {
      const vec3 q = k < 8 ? vec3(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z)
                           : lo + vec3(u(rng), u(rng), u(rng)) * (hi - lo);
      const vec3 x = k == 11 ? c.p : glm::clamp(q, lo, hi);
      const vec4 ray = cone::leafRay(x, c.light);
      if (!cone::leafRayUsable(ray, 2.0f * c.eps)) continue;
      const bool end = cone::leafHitFromSampleEnd(t, e, x, ray, c.eps);
      compared++;
      hits += end;
      ASSERT_EQ(end, cone::leafHitFromSample(t, e, x, ray, c.eps)) << "case " << i << ", point " << k;
    }
  }
  std::printf("  %d boxes nearer the samples (%d under a light among the geometry, where %d were not), %d "
              "samples compared, %d hits\n", nearer, nearLights, farther, compared, hits);
  EXPECT_GT(nearer, 12000);
  EXPECT_GT(nearLights, 1000);
  EXPECT_GT(farther, 500);
  EXPECT_GT(hits, 2000);
  // Samples around the light: some edge's end is nearer the light than some sample of the box.
  const vec3 P0(0, 0, 0), P1(1, 0, 0), P2(0, 1, 0), light(0.2f, 0.2f, 3.0f);
  const cone::LeafEdges e = cone::leafEdges(P0, P1, P2, light);
  EXPECT_FALSE(cone::leafSamplesNearer(e, vec3(-1, -1, 2.5f), vec3(2, 2, 3.5f)));
  EXPECT_TRUE(cone::leafSamplesNearer(e, vec3(0.1f, 0.1f, -0.01f), vec3(0.2f, 0.2f, 0.01f)));
  EXPECT_TRUE(cone::leafSamplesNearer(e, vec3(-1, -1, -1), vec3(2, 2, 1)));
  EXPECT_FALSE(cone::leafSamplesNearer(e, vec3(0.2f), vec3(0.1f)));  // empty
  EXPECT_FALSE(cone::leafSamplesNearer(e, vec3(NAN), vec3(0.1f)));
}

// Small triangles far from the light, crossed at a grazing angle well inside: a hit for both tests. The
// edge functions from the light round to an ulp of |P - light| |edge|, so |N.w| of a ray a degree off
// the plane of a triangle a thousandth of its distance to the light is no larger than that rounding --
// which is no reason to doubt the hit: where the three signs agree and the plane is crossed (dl, ds, each
// past its own bound) the crossing is inside. The first case is the sample of family:1:tris=1M at 512²
// that the cone path once left lit (docs/ARCHITECTURE.md, "Grazing hits on small triangles").
TEST(LeafHitFromLight, FindsGrazingHitsOnSmallTrianglesFarFromTheLight) {
  {
    const vec3 light(0.6520491242408752f, 6.822934150695801f, -0.6157954335212708f);
    const vec3 p(0.8966633081436157f, 0.0f, -0.6418735980987549f);
    const vec3 P0(0.8925246f, 0.118786618f, -0.641308069f), P1(0.890049219f, 0.120922647f, -0.642772019f),
        P2(0.8925246f, 0.120922647f, -0.641308069f);
    const float eps = 0.000467712438f;  // the policy's for that scene (diagonal 4.677)
    const vec4 ray = cone::leafRay(p, light);
    EXPECT_TRUE(cone::leafHitFromLight(p, light, ray, eps, P0, P1, P2));
    EXPECT_TRUE(cone::leafHit(p, light, ray, eps, P0, P1, P2));
    EXPECT_TRUE(cone::leafHitFromSample(p, light, ray, eps, P0, P1, P2));
  }
  // Random ones: a triangle of size 1e-3 .. 1e-2 around a point X of the ray light -> p (5 to 95 % of the
  // way), its plane at 0.1 to 2 degrees to the ray, lights 2 to 8 from the samples in a unit box; kept
  // when the fp32 ray (in double) passes every edge plane through the light at more than 2e-6 rad (16
  // ulp: the edge functions' signs are exact) and crosses the plane more than 10 eps from both ends.
  std::mt19937 rng(20261207);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const float eps = 1e-4f;
  int cases = 0;
  for (int i = 0; i < 20000; ++i) {
    const dvec3 p0 = dvec3(u(rng), u(rng), u(rng)) - 0.5;
    const dvec3 dir = glm::normalize(dvec3(u(rng), u(rng), u(rng)) - 0.5);
    const vec3 pf(p0), lightf(p0 + (2.0 + 6.0 * u(rng)) * dir);
    const dvec3 light(lightf), q = dvec3(pf) - light, d = glm::normalize(q);
    const double len = glm::length(q);
    const dvec3 X = light + (0.05 + 0.9 * u(rng)) * q;
    vec3 ua, va;
    orthonormalBasis(vec3(d), ua, va);
    const double phi = 6.283185307179586 * u(rng), angle = (0.1 + 1.9 * u(rng)) * 0.017453292519943295;
    const dvec3 n = std::cos(angle) * (std::cos(phi) * dvec3(ua) + std::sin(phi) * dvec3(va)) + std::sin(angle) * d;
    const dvec3 e1 = glm::normalize(d - glm::dot(d, n) * n), e2 = glm::cross(n, e1);
    const double size = 1e-3 * std::pow(10.0, u(rng));
    dvec3 V[3];
    for (int k = 0; k < 3; ++k) {
      const double t = 2.0943951023931957 * k + 0.6 * (u(rng) - 0.5), r = size * (0.7 + 0.6 * u(rng));
      V[k] = r * (std::cos(t) * e1 + std::sin(t) * e2);
    }
    const double w0 = 0.1 + u(rng), w1 = 0.1 + u(rng), w2 = 0.1 + u(rng);
    const dvec3 at = (w0 * V[0] + w1 * V[1] + w2 * V[2]) / (w0 + w1 + w2);
    vec3 P[3];
    for (int k = 0; k < 3; ++k) P[k] = vec3(X + V[k] - at);
    const dvec3 A(P[0]), B(P[1]), C(P[2]), N = glm::cross(B - A, C - A);
    const double t = glm::dot(A - light, N) / glm::dot(q, N);
    double sep = 1e300;  // the ray's least angle to an edge plane through the light, signed: > 0 inside
    for (int k = 0; k < 3; ++k) {
      const dvec3 a = dvec3(P[(k + 1) % 3]) - light, b = dvec3(P[(k + 2) % 3]) - light, m = glm::cross(a, b);
      const double side = glm::dot(m, dvec3(P[k]) - light) > 0 ? 1.0 : -1.0;
      sep = std::min(sep, side * glm::dot(m, q) / (glm::length(m) * len));
    }
    if (!(sep > 2e-6 && t * len > 10 * eps && t * len < len - 10 * eps)) continue;
    cases++;
    const vec4 ray = cone::leafRay(pf, lightf);
    ASSERT_TRUE(cone::leafHitFromLight(pf, lightf, ray, eps, P[0], P[1], P[2]))
        << "case " << i << ": size " << size << ", " << angle / 0.017453292519943295 << " degrees, at " << t * len
        << " of " << len << ", " << sep << " rad inside its edges";
    ASSERT_TRUE(cone::leafHit(pf, lightf, ray, eps, P[0], P[1], P[2])) << "case " << i;
    ASSERT_TRUE(cone::leafHitFromSample(pf, lightf, ray, eps, P[0], P[1], P[2])) << "case " << i;
  }
  std::printf("  %d grazing hits\n", cases);
  EXPECT_GT(cases, 15000);
}

// The leaves' cull (sphere_test.h, leafRayMissesSphere) never drops a ray either leaf test hits: random
// triangles of 10^-4 to 1 around a point of the ray (hits, and misses just past an edge), in scenes of
// 10^-3 to 10^3 with lights 1 to 10^6 of their size away and lights among the geometry. And it does cull:
// a triangle four of its sizes off the ray, its size over 10^-3 of its distance from the light, is dropped.
TEST(LeafSphere, NeverCullsARayALeafTestHitsAndCullsTheFarOnes) {
  std::mt19937 rng(20261207);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int hits = 0, culled = 0, far = 0;
  for (int i = 0; i < 60000; ++i) {
    const double scale = std::pow(10.0, 6.0 * u(rng) - 3.0);
    const dvec3 p0 = scale * (dvec3(u(rng), u(rng), u(rng)) - 0.5);
    const dvec3 dir = glm::normalize(dvec3(u(rng), u(rng), u(rng)) - 0.5);
    const double away = i % 4 == 0 ? 0.1 + u(rng) : std::pow(10.0, 6.0 * u(rng));
    const vec3 pf(p0), lightf(p0 + scale * away * dir);
    const dvec3 light(lightf), q = dvec3(pf) - light;
    const dvec3 X = light + (0.02 + 0.96 * u(rng)) * q;
    const double size = scale * std::pow(10.0, -4.0 * u(rng));
    const bool off = i % 5 == 0;  // the triangle moved four sizes across the ray
    vec3 ua, va;
    orthonormalBasis(vec3(glm::normalize(q)), ua, va);
    const dvec3 shift = off ? 4.0 * size * dvec3(ua) : dvec3(0.0);
    vec3 P[3];
    for (vec3& x : P) x = vec3(X + shift + size * (dvec3(u(rng), u(rng), u(rng)) - 0.5));
    const float eps = float(1e-4 * scale);
    const vec4 ray = cone::leafRay(pf, lightf);
    if (!cone::leafRayUsable(ray, 2.0f * eps)) continue;
    const vec3 a[3] = {P[0] - lightf, P[1] - lightf, P[2] - lightf};
    const bool misses = cone::leafRayMissesSphere(cone::leafSphere(a[0], a[1], a[2]), vec3(ray));
    const bool hit = cone::leafHit(pf, lightf, ray, eps, P[0], P[1], P[2]) ||
                     cone::leafHitFromLight(pf, lightf, ray, eps, P[0], P[1], P[2]) ||
                     cone::leafHitFromSample(pf, lightf, ray, eps, P[0], P[1], P[2]);
    hits += hit;
    ASSERT_FALSE(hit && misses) << "case " << i << ": scale " << scale << ", light " << away << " sizes away, triangle "
                                << size;
    if (off && size > 1e-3 * scale * std::max(1.0, away)) {  // clear of the margins, 2^-16 of the distance
      far++;
      culled += misses;
    }
  }
  std::printf("  %d hits kept, %d of %d triangles off the ray culled\n", hits, culled, far);
  EXPECT_GT(hits, 10000);
  EXPECT_EQ(culled, far);
  EXPECT_GT(far, 2000);
}

// The plane cull (precise_test.h, leafPlaneMissesBox) never drops a box holding a point either leaf test
// hits -- the box's samples, its corners and random points in it, against lights near and up to 1e5 sizes
// away at any angle to the plane -- and drops what it is for where a box can say it: on an axis-aligned
// plane (a ground, a wall), boxes of receivers (samples on the plane a few ulp off it, as a rasterised
// surface gives them) under a light clear of the plane, and boxes on the light's side of it. (A box of
// samples on an oblique plane reaches across it: nothing a box can cull.)
TEST(LeafPlaneCull, NeverDropsABoxWithAHitAndDropsReceiversAndTheLightsSide) {
  std::mt19937 rng(20261208);
  int culled[5] = {}, cases[5] = {}, clear[5] = {}, clearCulled[5] = {}, hits = 0;
  for (int i = 0; i < 25000; ++i) {
    const test::PlaneBox c = test::makePlaneBox(rng, i);
    if (!c.valid) continue;
    const bool cull = cone::leafPlaneMissesBox(cone::leafPlane(c.P[0], c.P[1], c.P[2], c.light), c.lo, c.hi, c.light, c.eps);
    bool anyHit = false;
    for (const vec3& x : c.points) {
      const vec4 ray = cone::leafRay(x, c.light);
      if (!cone::leafRayUsable(ray, 2.0f * c.eps)) continue;
      anyHit = anyHit || cone::leafHit(x, c.light, ray, c.eps, c.P[0], c.P[1], c.P[2]) ||
               cone::leafHitFromLight(x, c.light, ray, c.eps, c.P[0], c.P[1], c.P[2]) ||
               cone::leafHitFromSample(x, c.light, ray, c.eps, c.P[0], c.P[1], c.P[2]);
    }
    hits += anyHit;
    ASSERT_FALSE(cull && anyHit) << "case " << i << " (kind " << c.kind << "): " << c.describe;
    cases[c.kind]++;
    culled[c.kind] += cull;
    if (c.clear) {
      clear[c.kind]++;
      clearCulled[c.kind] += cull;
    }
  }
  std::printf("  culled: anywhere %d of %d, receivers %d of %d, light's side %d of %d, hit rays %d of %d, "
              "beyond by about eps %d of %d; %d boxes with a hit\n", culled[0], cases[0], culled[1], cases[1],
              culled[2], cases[2], culled[3], cases[3], culled[4], cases[4], hits);
  std::printf("  clear of the margins: receivers %d of %d culled, light's side %d of %d\n", clearCulled[1], clear[1],
              clearCulled[2], clear[2]);
  EXPECT_GT(clearCulled[1], 0.8 * clear[1]) << "receivers under a light clear of the plane kept";
  EXPECT_GT(clearCulled[2], 0.99 * clear[2]) << "boxes on the light's side kept";
  EXPECT_GT(clear[1], 500);
  EXPECT_EQ(culled[3], 0);
  EXPECT_GT(hits, 5000);
}

// The choice (traversal.h leafTestFor): from the light among the geometry, from the sample for a far
// light, the two ends' where coordinates leave the range of either.
TEST(LeafHitFromLight, RunsWhereTheLightIsAmongTheGeometry) {
  const vec3 lo(-1, 0, -2), hi(3, 2, 1);
  auto pick = [&](vec3 light, vec3 l = vec3(-1, 0, -2), vec3 h = vec3(3, 2, 1)) {
    return traversal::leafTestFor(cone::chooseFrame(light, l, h).far, l, h, light);
  };
  EXPECT_EQ(pick(vec3(1, 1, 0)), traversal::LeafTest::FromLight);    // inside
  EXPECT_EQ(pick(vec3(10, 10, 10)), traversal::LeafTest::FromLight); // ~3 half-diagonals out
  EXPECT_EQ(pick(vec3(1e3f, 0, 0)), traversal::LeafTest::FromSample);  // the far frame's
  EXPECT_EQ(pick(vec3(1e11f, 3e11f, 0)), traversal::LeafTest::FromSample);
  EXPECT_EQ(pick(vec3(2e12f, 0, 0)), traversal::LeafTest::TwoEnds);   // a light past 2^40
  EXPECT_EQ(pick(vec3(1, 1, 0), lo * 1e-5f, hi * 1e-5f), traversal::LeafTest::TwoEnds);  // a tiny scene
  EXPECT_EQ(pick(vec3(1e12f + 1e11f, 0, 0), vec3(1e12f, 0, 0), vec3(1e12f + 3e11f, 1e11f, 1e11f)),
            traversal::LeafTest::TwoEnds);                           // coordinates past 2^40
  EXPECT_EQ(pick(vec3(1, 1, 0), vec3(1), vec3(0)), traversal::LeafTest::TwoEnds);  // no bounds
  EXPECT_STREQ(traversal::leafTestName(traversal::LeafTest::FromLight), "from_light");
  EXPECT_STREQ(traversal::leafTestName(traversal::LeafTest::TwoEnds), "two_ends");
  EXPECT_STREQ(traversal::leafTestName(traversal::LeafTest::FromSample), "from_sample");
}

TEST(TraversalArena, PlanStaysWithinTheBudgetAndTheBinding) {
  for (uint64_t bytes : {uint64_t(8) << 10, uint64_t(64) << 10, uint64_t(1) << 20, uint64_t(64) << 20,
                         uint64_t(1) << 30, uint64_t(8) << 30}) {
    traversal::ArenaPlan p = traversal::planArena(bytes, uint64_t(128) << 20);
    EXPECT_LE(p.bytes, bytes);
    EXPECT_LE(p.pairCapacity * 8, uint64_t(128) << 20);
    EXPECT_LE(uint64_t(p.chunkCapacity) * 4, uint64_t(128) << 20);
    EXPECT_GE(p.pairCapacity, traversal::kMinPairs);
    EXPECT_GE(p.chunkCapacity, 1u);
    if (bytes <= (uint64_t(64) << 20)) {
      EXPECT_GE(p.bytes, bytes / 2) << "most of a small budget is used";
    }
  }
  EXPECT_THROW(traversal::planArena(64, uint64_t(128) << 20), Error);
  EXPECT_EQ(traversal::minimumPairs(1), 1u);
  EXPECT_EQ(traversal::minimumPairs(8), 29u);
  EXPECT_EQ(traversal::reserveBelow(8, 7), 0u);  // depth 7 feeds the leaves: nothing below it in the arena
  EXPECT_EQ(traversal::reserveBelow(8, 6), 4u);  // room for one node's children at depth 7
  EXPECT_EQ(traversal::reserveBelow(8, 5), 8u);
}

// A small scene with a lot of traversal work: a grid floor, a wall and floating slivers.
Scene busyScene() {
  Scene s;
  s.name = "busy";
  auto quad = [&](vec3 o, vec3 u, vec3 v, int nu, int nv) {
    for (int i = 0; i < nu; ++i)
      for (int j = 0; j < nv; ++j) {
        uint32_t b = uint32_t(s.positions.size());
        vec3 p = o + u * (float(i) / nu) + v * (float(j) / nv);
        s.positions.insert(s.positions.end(), {p, p + u / float(nu), p + u / float(nu) + v / float(nv), p + v / float(nv)});
        s.indices.insert(s.indices.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
      }
  };
  quad({-4, 0, -4}, {8, 0, 0}, {0, 0, 8}, 12, 12);
  quad({-4, 0, -2}, {8, 0, 0}, {0, 3, 0}, 6, 4);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1, 1);
  for (int i = 0; i < 40; ++i) {  // floating cards
    vec3 c(u(rng) * 3, 1.5f + u(rng) * 0.8f, u(rng) * 3);
    quad(c, vec3(u(rng), u(rng), u(rng)) * 0.5f, vec3(u(rng), u(rng), u(rng)) * 0.5f, 2, 2);
  }
  for (int i = 0; i < 300; ++i) {
    vec3 c(u(rng) * 3, 1.0f + u(rng) * 0.8f, u(rng) * 3);
    uint32_t b = uint32_t(s.positions.size());
    s.positions.insert(s.positions.end(), {c, c + vec3(u(rng), u(rng), u(rng)) * 0.3f, c + vec3(u(rng), u(rng), u(rng)) * 0.02f});
    s.indices.insert(s.indices.end(), {b, b + 1, b + 2});
  }
  s.normals.assign(s.positions.size(), vec3(0, 1, 0));
  s.computeBounds();
  return s;
}

// busyScene() at 96 x 80, seen from above, lit from above the cards.
// The second frame of a cone method made with `o` (the first warms its batch size and pipelines).
MethodOutput secondFrame(const ConeOptions& o, const FrameInput& frame) {
  auto method = makeConeMethod(test::context(), o);
  runCounted(*method, frame);
  return runCounted(*method, frame);
}

struct BusyFrame {
  Scene scene = busyScene();
  Raster raster{test::context(), scene};
  DeviceGBuffer dev;
  GBuffer host;
  FrameInput frame;
  BusyFrame() {
    Camera cam;
    cam.eye = {5, 6, 7};
    cam.target = {0, 0.5f, 0};
    cam.yfov = 0.9f;
    const vec3 light(0.5f, 4.0f, 1.0f);
    raster.render(cam, light, 96, 80, dev, &host);
    frame = frameInputOf(scene, host, dev, test::context(), light, EpsilonPolicy::forScene(scene).eps);
  }
};

TEST(ConeMethod, MaskIsBitIdenticalAtAnyTraversalMemoryAndPeakStaysUnderTheBound) {
  auto& ctx = test::context();
  BusyFrame busy;
  const GBuffer& host = busy.host;
  const FrameInput& frame = busy.frame;

  // The default bound, 1000x smaller, a few KiB, and the very least an arena can be: one node's children
  // per depth (traversal::minimumPairs) with chunks of a single pair.
  const uint32_t depth = cone::treeDepth(uint32_t(host.litCount()));
  std::vector<ConeOptions> configs(4);
  // The chunked path has no clusters and no leaf choice (it takes 64 rays a pair): the very same pairs.
  for (ConeOptions& o : configs) {
    o.clusters = false;
    o.leafRays = traversal::LeafRays::SixtyFour;
  }
  configs[0].traversalMemoryBytes = traversal::kDefaultMemoryBytes;
  configs[1].traversalMemoryBytes = traversal::kDefaultMemoryBytes / 1000;
  configs[2].traversalMemoryBytes = 9000;
  test::useLeastArena(configs[3], depth);
  std::vector<float> first;
  uint64_t firstTested = 0;
  for (const ConeOptions& o : configs) {
    const uint64_t bytes = o.traversalMemoryBytes;
    auto method = makeConeMethod(ctx, o);
    MethodOutput out = method->run(frame);
    const nlohmann::json& t = out.stats["traversal"];
    std::printf("  arena %llu pairs, chunks of %u: %llu submits, peak %llu of %llu bytes, %.0f ms\n",
                (unsigned long long)out.stats["pair_capacity"].get<uint64_t>(), out.stats["chunk_capacity"].get<uint32_t>(),
                (unsigned long long)t["submits"].get<uint64_t>(), (unsigned long long)t["peak_bytes"].get<uint64_t>(),
                (unsigned long long)bytes, out.totalMs);
    EXPECT_LE(t["peak_bytes"].get<uint64_t>(), bytes);
    EXPECT_LE(out.stats["traversal_peak_bytes"].get<uint64_t>(), bytes);
    if (first.empty()) {
      first = out.visibility;
      firstTested = out.stats["pairs_tested"];
      EXPECT_GT(out.stats["leaf_tests"].get<uint64_t>(), 0u);
      size_t shadowed = std::count(first.begin(), first.end(), 0.0f);
      EXPECT_GT(shadowed, 100u) << "the scene must cast shadows for this test to mean anything";
      continue;
    }
    // The one-submission path holds a whole depth per step; past that it overflows on the GPU and the
    // frame's traversal is redone chunked -- the two smallest arenas must take that way.
    const bool chunked = out.stats["traversal_path"].get<std::string>().rfind("chunked", 0) == 0;
    if (bytes <= 9000) { EXPECT_TRUE(chunked) << bytes << " bytes: " << out.stats["traversal_path"]; }
    // More than two submits a tested depth (a whole depth a chunk would take one each, and the leaves one).
    if (chunked) {
      EXPECT_GT(t["submits"].get<uint64_t>(), 2 * t["passes"].size() + 2) << "a small arena must split the work (" << bytes << " bytes)";
    }
    if (chunked && bytes > 9000 && o.arena.pairCapacity == 0) {
      // The batches shrink after an overflow: a few frames later the same arena fits in one submission.
      MethodOutput later;
      for (int k = 0; k < 6; ++k) later = runCounted(*method, frame);
      std::printf("    then: %s, %llu triangles a batch\n", later.stats["traversal_path"].get<std::string>().c_str(),
                  (unsigned long long)later.stats["traversal_batch_triangles"].get<uint64_t>());
      EXPECT_EQ(later.stats["traversal_path"], "one submission") << bytes << " bytes";
      EXPECT_EQ(later.stats["submits_per_frame"], 1u) << bytes << " bytes";
      EXPECT_EQ(later.visibility, first) << bytes << " bytes";
      EXPECT_EQ(later.stats["pairs_tested"].get<uint64_t>(), firstTested) << bytes << " bytes";
    }
    ASSERT_EQ(out.visibility.size(), first.size());
    EXPECT_EQ(std::memcmp(out.visibility.data(), first.data(), first.size() * sizeof(float)), 0)
        << "mask differs at " << bytes << " bytes";
    EXPECT_EQ(out.stats["pairs_tested"].get<uint64_t>(), firstTested) << "the same pairs, only in another order";
  }
}

// Four, sixteen or 64 rays a leaf pair (traversal.h, LeafRays): the same mask on the one-submission path
// and on the chunked one at the least arena; the 16-ray traversal is the four-ray one without its last
// step, the 64-ray one without its last two -- the same tests down to the leaf step, whose inputs are the
// leaf pairs -- on either path.
TEST(ConeMethod, LeafPairsOfFourSixteenOrSixtyFourRaysGiveTheSameMaskAndSkipTheLastSteps) {
  auto& ctx = test::context();
  BusyFrame busy;
  const GBuffer& host = busy.host;
  const FrameInput& frame = busy.frame;
  const uint32_t depth = cone::treeDepth(uint32_t(host.litCount()));
  ASSERT_GE(depth, 4u);

  auto run = [&](traversal::LeafRays rays, bool least) {
    ConeOptions o;
    o.clusters = false;  // the chunked path has none: the very same pairs on both paths
    o.leafRays = rays;
    if (least) test::useLeastArena(o, depth);
    auto method = makeConeMethod(ctx, o);
    runCounted(*method, frame);
    return runCounted(*method, frame);
  };
  const MethodOutput four = run(traversal::LeafRays::Four, false);
  ASSERT_EQ(four.stats["traversal_path"], "one submission");
  EXPECT_GT(std::count(four.visibility.begin(), four.visibility.end(), 0.0f), 100);
  EXPECT_EQ(four.stats["leaf_rays"], 4u);
  const nlohmann::json& a = four.stats["traversal"];
  ASSERT_EQ(a["passes"].size(), depth);
  const uint64_t lit = host.litCount();
  for (const auto& [rays, levels] : {std::pair{traversal::LeafRays::Sixteen, 2u}, std::pair{traversal::LeafRays::SixtyFour, 3u}}) {
    const uint64_t span = uint64_t(1) << (2 * levels);
    const std::string what = std::to_string(span) + " rays";
    const MethodOutput many = run(rays, false);
    ASSERT_EQ(many.stats["traversal_path"], "one submission") << what;
    EXPECT_EQ(many.visibility, four.visibility) << what;
    EXPECT_EQ(many.stats["leaf_rays"], span) << what;
    const nlohmann::json& b = many.stats["traversal"];
    const uint32_t tested = depth - (levels - 1);
    ASSERT_EQ(b["passes"].size(), tested) << what;
    for (uint32_t d = 0; d < tested; ++d) EXPECT_EQ(b["passes"][d], a["passes"][d]) << what << ", depth " << d;
    EXPECT_EQ(b["leaf_pairs"], a["passes"][tested]["inputs"]) << what << ": the first skipped step's inputs go to the leaves";
    uint64_t skipped = 0;
    for (uint32_t d = tested; d < depth; ++d) skipped += a["passes"][d]["pairs_tested"].get<uint64_t>();
    EXPECT_EQ(b["pairs_tested"].get<uint64_t>() + skipped, a["pairs_tested"].get<uint64_t>()) << what;
    // Every ray under a leaf pair's node tested, but past the last ray: the pairs of the last node each
    // lack the same span - lit % span rays.
    const uint64_t full = span * b["leaf_pairs"].get<uint64_t>(), tests = b["leaf_tests"].get<uint64_t>();
    ASSERT_LE(tests, full) << what;
    if (lit % span == 0) {
      EXPECT_EQ(tests, full) << what;
    } else {
      EXPECT_EQ((full - tests) % (span - lit % span), 0u) << what;
    }
    EXPECT_GT(b["leaf_tests"].get<uint64_t>(), a["leaf_tests"].get<uint64_t>()) << what;
    // The chunked path at the least arena: the same mask and counts.
    const MethodOutput got = run(rays, true);
    ASSERT_EQ(got.stats["traversal_path"].get<std::string>().rfind("chunked", 0), 0u) << what;
    EXPECT_EQ(got.visibility, four.visibility) << what;
    EXPECT_EQ(got.stats["leaf_rays"], many.stats["leaf_rays"]) << what;
    EXPECT_EQ(got.stats["pairs_tested"], many.stats["pairs_tested"]) << what;
    EXPECT_EQ(got.stats["leaf_tests"], many.stats["leaf_tests"]) << what;
    EXPECT_EQ(got.stats["traversal"]["leaf_pairs"], many.stats["traversal"]["leaf_pairs"]) << what;
  }

  // Auto: chosen from the frame's counts on a CPU device (ConeMethod.LeafChoice*), four on a GPU.
  const MethodOutput automatic = run(traversal::LeafRays::Auto, false);
  if (ctx.properties.deviceType != VK_PHYSICAL_DEVICE_TYPE_CPU) { EXPECT_EQ(automatic.stats["leaf_rays"], 4u); }
  EXPECT_EQ(automatic.visibility, four.visibility);
}

// The leaf choice (traversal.h, LeafRays::Auto): whatever it chooses, the mask is the four-ray one, and the
// frame stays one submission with one host sync. Forced by its costs to take the leaves at the first step
// it may (64 rays) or never before the last (four), it tests the very pairs of --leaf-rays 64 or 4
// (clusters off: with clusters the expansion rules count from the choice's first step); with costs between,
// the stats count every leaf pair under the span it went with and say why.
TEST(ConeMethod, LeafChoiceGivesTheSameMaskWhateverItChoosesInOneSubmission) {
  BusyFrame busy;
  const uint32_t depth = cone::treeDepth(uint32_t(busy.host.litCount()));
  ASSERT_GE(depth, 5u);
  auto run = [&](traversal::LeafRays rays, std::optional<traversal::LeafChoiceCosts> costs, bool clusters) {
    ConeOptions o;
    o.clusters = clusters;
    o.leafRays = rays;
    o.leafChoiceCosts = costs;
    return secondFrame(o, busy.frame);
  };
  const MethodOutput four = run(traversal::LeafRays::Four, std::nullopt, false);
  const MethodOutput sixtyFour = run(traversal::LeafRays::SixtyFour, std::nullopt, false);
  ASSERT_EQ(sixtyFour.visibility, four.visibility);
  // Leaves at the first step the choice may take them, at the last, and between.
  const traversal::LeafChoiceCosts choices[3] = {{1e30f, 0.0f}, {-1e30f, 0.0f}, {16.0f, 0.0f}};
  const char* names[3] = {"leaves at the first step", "leaves at the last step", "between"};
  for (bool clusters : {false, true}) {
    for (int k = 0; k < 3; ++k) {
      const traversal::LeafChoiceCosts& costs = choices[k];
      const std::string what = std::string(names[k]) + (clusters ? ", clusters" : "");
      const MethodOutput got = run(traversal::LeafRays::Auto, costs, clusters);
      EXPECT_EQ(got.visibility, four.visibility) << what;
      EXPECT_EQ(got.stats["traversal_path"], "one submission") << what;
      EXPECT_EQ(got.stats["submits_per_frame"], 1u) << what;
      EXPECT_EQ(got.stats["host_syncs_per_frame"], 1u) << what;
      const nlohmann::json& t = got.stats["traversal"];
      const uint64_t leafPairs = t["leaf_pairs"].get<uint64_t>();
      const nlohmann::json& by = t["leaf_pairs_by_rays"];
      EXPECT_EQ(by["4"].get<uint64_t>() + by["16"].get<uint64_t>() + by["64"].get<uint64_t>(), leafPairs) << what;
      EXPECT_EQ(t["leaf_rays_choice"].get<std::string>().rfind("per batch from its counts", 0), 0u) << what;
      const MethodOutput& forced = k == 0 ? sixtyFour : four;
      if (k == 2) {
        EXPECT_EQ(by["4"], 0u) << what << ": a step of 16 rays a pair never goes deeper at these costs";
      } else {
        EXPECT_EQ(got.stats["leaf_rays"], forced.stats["leaf_rays"]) << what;
        EXPECT_EQ(by[std::to_string(forced.stats["leaf_rays"].get<uint32_t>())], leafPairs) << what;
        if (!clusters) {
          EXPECT_EQ(t["passes"], forced.stats["traversal"]["passes"]) << what;
          EXPECT_EQ(got.stats["leaf_tests"], forced.stats["leaf_tests"]) << what;
        }
      }
    }
  }
}

// A tree shallower than the leaf levels asked gives what it has: 64 rays a pair over a tree of depth 2
// takes sixteen, of depth 1 four (leafStepOf).
// The leaves' cull (traversal.h, leafCullTestsPerRay): always or never, for each span of leaf rays and in
// one batch or many, the same mask, pairs and leaf tests in one submission; the stats count the leaf pairs
// under each. The device's own rule counts every leaf pair under one or the other.
TEST(ConeMethod, TheLeavesCullKeepsTheMaskPairsAndLeafTestsInOneSubmission) {
  BusyFrame busy;
  auto run = [&](traversal::LeafRays rays, std::optional<float> cull, uint64_t memory) {
    ConeOptions o;
    o.leafRays = rays;
    o.leafCullTestsPerRay = cull;
    o.traversalMemoryBytes = memory;
    return secondFrame(o, busy.frame);
  };
  const float never = std::numeric_limits<float>::infinity();
  // Every span, each batch's leaves from either buffer (the parity of the step that took them), and a
  // frame of many batches.
  const std::pair<traversal::LeafRays, uint64_t> configs[] = {{traversal::LeafRays::Four, uint64_t(256) << 10},
                                                               {traversal::LeafRays::Sixteen, traversal::kDefaultMemoryBytes},
                                                               {traversal::LeafRays::SixtyFour, traversal::kDefaultMemoryBytes}};
  for (const auto& [rays, memory] : configs) {
    {
      const MethodOutput plain = run(rays, never, memory), culled = run(rays, 0.0f, memory);
      const std::string what = std::to_string(plain.stats["leaf_rays"].get<uint32_t>()) + " rays, " +
                               std::to_string(memory) + " bytes";
      ASSERT_EQ(culled.stats["traversal_path"], "one submission") << what;
      ASSERT_EQ(plain.stats["traversal_path"], "one submission") << what;
      EXPECT_EQ(culled.visibility, plain.visibility) << what;
      EXPECT_EQ(culled.stats["pairs_tested"], plain.stats["pairs_tested"]) << what;
      EXPECT_EQ(culled.stats["leaf_tests"], plain.stats["leaf_tests"]) << what;
      const nlohmann::json &a = plain.stats["traversal"], &b = culled.stats["traversal"];
      ASSERT_GT(a["leaf_pairs"].get<uint64_t>(), 0u) << what;
      EXPECT_EQ(a["leaf_pairs_by_cull"]["culled"], 0u) << what;
      EXPECT_EQ(a["leaf_pairs_by_cull"]["not_culled"], a["leaf_pairs"]) << what;
      EXPECT_EQ(b["leaf_pairs_by_cull"]["culled"], b["leaf_pairs"]) << what;
      EXPECT_EQ(b["leaf_pairs_by_cull"]["not_culled"], 0u) << what;
    }
  }
  const MethodOutput automatic = run(traversal::LeafRays::Auto, std::nullopt, traversal::kDefaultMemoryBytes);
  const nlohmann::json& t = automatic.stats["traversal"];
  EXPECT_EQ(t["leaf_pairs_by_cull"]["culled"].get<uint64_t>() + t["leaf_pairs_by_cull"]["not_culled"].get<uint64_t>(),
            t["leaf_pairs"].get<uint64_t>());
  EXPECT_EQ(automatic.visibility, run(traversal::LeafRays::Auto, never, traversal::kDefaultMemoryBytes).visibility);
}

TEST(LeafStep, ATreeGivesTheLevelsItHas) {
  EXPECT_EQ(traversal::leafStepOf(1, 1), 1u);
  EXPECT_EQ(traversal::leafStepOf(1, 3), 1u);
  EXPECT_EQ(traversal::leafStepOf(2, 3), 1u);
  EXPECT_EQ(traversal::leafStepOf(2, 2), 1u);
  EXPECT_EQ(traversal::leafStepOf(3, 3), 1u);
  EXPECT_EQ(traversal::leafStepOf(7, 3), 5u);
  EXPECT_EQ(traversal::leafStepOf(7, 2), 6u);
  EXPECT_EQ(traversal::leafStepOf(7, 1), 7u);
}

// The cone frame as one GPU program: after a warm-up frame, every variant but the two-pass ones costs the
// host one submission, one wait and no allocation (views with and without shadows, a frame with no lit
// sample); what comes back is the mask and the counters; --profile-stages gives the same mask and the
// same counts in one submission per stage.
// The views by name (a camera of the built-in scene, or "nothing"), every one-pass variant or PreciseSorted
// alone.
void expectOneSubmissionFrames(const std::vector<std::string>& views, bool everyVariant) {
  auto& ctx = test::context();
  Scene scene = builtinScene();
  Raster raster(ctx, scene);
  const vec3 light = scene.lights.at(0).position;
  struct View {
    const char* name;
    vec3 light;
  };
  Camera nothing;  // looks away from the scene: no lit sample, no tree
  nothing.eye = {0, 100, 0};
  nothing.target = {0, 200, 0};
  nothing.up = {1, 0, 0};
  for (const View& v : {View{"wall", light}, View{"fur", light}, View{"room", vec3(-6.0f, 0.02f, 3.5f)},
                        View{"nothing", light}}) {
    if (std::find(views.begin(), views.end(), v.name) == views.end()) continue;
    DeviceGBuffer dev;
    GBuffer host;
    const bool empty = std::string(v.name) == "nothing";
    raster.render(empty ? nothing : *scene.findCamera(v.name), v.light, 48, 40, dev, &host);
    if (empty) { ASSERT_EQ(host.litCount(), 0u); }
    FrameInput frame = frameInputOf(scene, host, dev, ctx, v.light, EpsilonPolicy::forScene(scene).eps);
    const uint64_t maskBytes = uint64_t(host.size()) * 4;
    for (const std::string& variant : coneVariantNames()) {
      if (!everyVariant && variant != "PreciseSorted") continue;
      ConeOptions o;
      applyConeVariant(variant, o);
      if (o.twoPass) continue;
      auto method = makeConeMethod(ctx, o);
      const MethodOutput warm = runCounted(*method, frame);
      const MethodOutput out = runCounted(*method, frame);
      const std::string what = std::string(v.name) + " " + variant;
      EXPECT_EQ(out.stats["traversal_path"], "one submission") << what;
      EXPECT_EQ(out.stats["submits_per_frame"], 1u) << what;
      EXPECT_EQ(out.stats["host_syncs_per_frame"], 1u) << what;
      EXPECT_EQ(out.stats["allocations_per_frame"], 0u) << what;
      EXPECT_GT(out.stats["dispatches_per_frame"].get<uint64_t>(), 10u) << what;
      const bool measuredOrder = out.stats.value("ray_order_choice", "").rfind("auto: measured this frame", 0) == 0;
      EXPECT_EQ(out.stats["readback_bytes_per_frame"],
                maskBytes + (STATE_WORDS + SHAPE_WORDS + (measuredOrder ? ORDER_WORDS : 0)) * 4) << what;
      EXPECT_EQ(out.stats["lit_samples"], uint64_t(host.litCount())) << what;
      EXPECT_EQ(out.visibility, warm.visibility) << what;
      // Clusters change which pairs are tested (and, reordering the triangles, which early-accepted node
      // drops which pair), never the mask.
      ConeOptions plain = o;
      plain.clusters = false;
      const MethodOutput without = runCounted(*makeConeMethod(ctx, plain), frame);
      EXPECT_EQ(without.visibility, out.visibility) << what << ": clusters changed the mask";
      if (variant != "PreciseSorted") continue;
      if (!empty) { EXPECT_GT(std::count(out.visibility.begin(), out.visibility.end(), 0.0f), 0) << what; }
      ConeOptions p = o;
      p.profileStages = true;
      auto profiled = makeConeMethod(ctx, p);
      runCounted(*profiled, frame);
      const MethodOutput staged = runCounted(*profiled, frame);
      EXPECT_EQ(staged.visibility, out.visibility) << what;
      EXPECT_EQ(staged.stats["pairs_tested"], out.stats["pairs_tested"]) << what;
      EXPECT_EQ(staged.stats["leaf_tests"], out.stats["leaf_tests"]) << what;
      std::vector<std::string> names;
      for (const StageTime& st : staged.stages) names.push_back(st.name);
      auto has = [&](const char* n) { return std::find(names.begin(), names.end(), n) != names.end(); };
      // Compaction and keys: one fused stage where the sort takes pairs (rays::LitRays::fusedKeys).
      EXPECT_TRUE(has("compact + keys") || (has("compact") && has("keys"))) << what << ": no compaction or keys";
      for (const char* n : {"sort", "build", "traversal", "leaves"}) EXPECT_TRUE(has(n)) << what << ": no stage " << n;
      EXPECT_GE(staged.stats["submits_per_frame"].get<uint64_t>(), 6u) << what;
    }
  }
}
TEST(ConeFrame, OneSubmissionOneHostSyncNoAllocationAfterWarmUp) {
  expectOneSubmissionFrames({"wall", "fur", "room", "nothing"}, /*everyVariant=*/true);
}
// The same for the paper's default variant on a view with shadows and one with no lit sample: the frames
// the sanitizer pass runs (tools/sanitize.sh).
TEST(ConeFrame, OneSubmissionForAViewWithShadowsAndOneWithNoLitSample) {
  expectOneSubmissionFrames({"wall", "nothing"}, /*everyVariant=*/false);
}

// The ray order chosen on the GPU (ConeOptions::adaptiveOrder, order_choice.comp), in the one submission:
// a view whose screen-order tree is as tight as a sorted one keeps screen order (the wall: a plane facing
// the light), one whose deep cones gather rays pointing apart sorts them (the fur); the mask is the very
// mask of both fixed orders. After a loose frame the next ones sort without measuring, and the eighth
// measures again.
TEST(ConeMethod, RayOrderChosenOnTheGpuKeepsTheMaskOfBothOrders) {
  auto& ctx = test::context();
  Scene scene = builtinScene();
  Raster raster(ctx, scene);
  const vec3 light = scene.lights.at(0).position;
  for (const char* view : {"wall", "fur"}) {
    DeviceGBuffer dev;
    GBuffer host;
    raster.render(*scene.findCamera(view), light, 64, 56, dev, &host);
    FrameInput frame = frameInputOf(scene, host, dev, ctx, light, EpsilonPolicy::forScene(scene).eps);
    ConeOptions hilbert, screen, chosen;
    hilbert.adaptiveOrder = false;
    screen.sorted = false;
    const MethodOutput h = runCounted(*makeConeMethod(ctx, hilbert), frame);
    const MethodOutput sc = runCounted(*makeConeMethod(ctx, screen), frame);
    auto method = makeConeMethod(ctx, chosen);
    const MethodOutput first = runCounted(*method, frame);
    EXPECT_EQ(first.visibility, h.visibility) << view;
    EXPECT_EQ(first.visibility, sc.visibility) << view;
    const std::string why = first.stats["ray_order_choice"];
    EXPECT_EQ(why.rfind("auto: measured this frame: ", 0), 0u) << view << ": " << why;
    EXPECT_EQ(first.stats["traversal_path"], "one submission") << view;
    // One submission for the frame; a fresh method's first frame also uploads the scene's triangles,
    // which where device memory is not host visible is one staged copy (this scene is one chunk).
    EXPECT_EQ(first.stats["submits_per_frame"], ctx.hostVisibleDeviceLocal ? 1u : 2u) << view;
    const double looseness = first.stats["screen_tree_looseness"].get<double>();
    const bool wall = std::string(view) == "wall";
    EXPECT_EQ(first.stats["ray_order"], wall ? "screen" : "hilbert") << view << ": looseness " << looseness;
    EXPECT_EQ(looseness > ORDER_LOOSE_RATIO, !wall) << view;
    // The pairs are those of the order it chose. Rays sharing a ray key keep their compaction order, which
    // a measured frame takes in screen order and a sorted frame in rows: the sorted order's pairs up to
    // those ties, and far from the screen order's.
    const double pairs = first.stats["pairs_tested"].get<double>(), sorted = h.stats["pairs_tested"].get<double>(),
                 screened = sc.stats["pairs_tested"].get<double>();
    if (wall) {
      EXPECT_EQ(pairs, screened) << view;
    } else {
      EXPECT_NEAR(pairs, sorted, 0.005 * sorted) << view << ": screen order " << screened;
      EXPECT_GT(std::abs(pairs - screened), 0.05 * sorted) << view << ": screen order " << screened;
    }
    for (uint32_t k = 1; k <= 8; ++k) {
      const MethodOutput next = runCounted(*method, frame);
      EXPECT_EQ(next.visibility, h.visibility) << view << " frame " << k;
      EXPECT_EQ(next.stats["ray_order"], wall ? "screen" : "hilbert") << view << " frame " << k;
      const bool measures = wall || k == 8;
      const std::string said = next.stats["ray_order_choice"];
      EXPECT_EQ(said.rfind("auto: measured this frame", 0) == 0, measures) << view << " frame " << k << ": " << said;
      if (!measures) { EXPECT_EQ(next.stats["allocations_per_frame"], 0u) << view << " frame " << k; }
    }
  }
}

// The order follows its rule (order_choice.comp), as the stats give its inputs: sorted exactly where the
// screen-order tree is loose (looseness > ORDER_LOOSE_RATIO) and triangles x (looseness - 1) >
// ORDER_SORT_PAYS sqrt(lit). Each verdict is reached on one of the views: the wall's tree is tight, the
// fur's loose over many triangles, and family:16's (390 triangles seen whole at 96^2) loose over too few
// for the sort to pay, which keeps screen order with the fixed orders' mask.
TEST(ConeMethod, RayOrderSortsALooseScreenOrderOnlyWhereItsTrianglesMakeTheSortPay) {
  auto& ctx = test::context();
  struct View {
    std::string name;
    Scene scene;
    Camera camera;
    uint32_t w, h;
  };
  std::vector<View> views;
  Scene builtin = builtinScene();
  views.push_back({"wall", builtin, *builtin.findCamera("wall"), 64, 56});
  views.push_back({"fur", builtin, *builtin.findCamera("fur"), 64, 56});
  Scene family = familyScene(parseFamilyArg("family:16"));
  views.push_back({"family:16", family, family.cameras.at(0), 96, 96});
  int tight = 0, sorted = 0, kept = 0;
  for (const View& v : views) {
    Raster raster(ctx, v.scene);
    const vec3 light = v.scene.lights.at(0).position;
    DeviceGBuffer dev;
    GBuffer host;
    raster.render(v.camera, light, v.w, v.h, dev, &host);
    FrameInput frame = frameInputOf(v.scene, host, dev, ctx, light, EpsilonPolicy::forScene(v.scene).eps);
    ConeOptions chosen, hilbert;
    hilbert.adaptiveOrder = false;
    const MethodOutput out = runCounted(*makeConeMethod(ctx, chosen), frame);
    const double looseness = out.stats["screen_tree_looseness"].get<double>();
    const double triangles = out.stats["triangles"].get<double>(), lit = out.stats["lit_samples"].get<double>();
    const double pays = triangles * (looseness - 1.0) / std::sqrt(lit);
    const std::string why = out.stats["ray_order_choice"];
    // Away from the thresholds, where the GPU's float and the host's double could part.
    ASSERT_GT(std::abs(looseness - ORDER_LOOSE_RATIO), 0.05) << v.name;
    ASSERT_GT(std::abs(pays - ORDER_SORT_PAYS), 0.5) << v.name;
    const bool loose = looseness > ORDER_LOOSE_RATIO, sorts = loose && pays > ORDER_SORT_PAYS;
    EXPECT_EQ(out.stats["ray_order"], sorts ? "hilbert" : "screen") << v.name << ": " << why;
    EXPECT_NE(why.find(sorts ? "sorted" : "screen order kept"), std::string::npos) << v.name << ": " << why;
    tight += !loose, sorted += sorts, kept += loose && !sorts;
    EXPECT_EQ(out.visibility, runCounted(*makeConeMethod(ctx, hilbert), frame).visibility) << v.name;
  }
  EXPECT_EQ(tight, 1);
  EXPECT_EQ(sorted, 1);
  EXPECT_EQ(kept, 1) << "a loose screen order over few triangles is kept";
}

// A frame of heightFieldScene(60000) from its automatic camera at size x size (the cluster tests).
struct HeightFieldFrame {
  Scene scene = heightFieldScene(60000);
  Raster raster{test::context(), scene};
  DeviceGBuffer dev;
  GBuffer host;
  FrameInput frame;
  explicit HeightFieldFrame(uint32_t size) {
    const vec3 light = scene.lights.at(0).position;
    raster.render(automaticCamera(scene), light, size, size, dev, &host);
    frame = frameInputOf(scene, host, dev, test::context(), light, EpsilonPolicy::forScene(scene).eps);
  }
};

// Clusters go down the tree while the nodes are wide against them (traverse_advance.comp's expansion
// rule): on a height field of small triangles they are tested below the root's children, expand at the
// first depth with more than 1/EXPAND_NODES_PER_CLUSTER as many nodes as the root kept clusters, and the
// frame tests fewer pairs than without clusters (a tenth less at least; ~22 % here, 40-50 % on the
// million-triangle scenes of bench/scale_bench), with the very same mask.
TEST(ConeMethod, ClustersGoDownTheTreeUntilTheNodesAreAsFineAsThem) {
  auto& ctx = test::context();
  HeightFieldFrame field(96);
  ASSERT_GT(field.host.litCount(), 1000u);
  const Scene& scene = field.scene;
  const FrameInput& frame = field.frame;
  ConeOptions o;
  // The clusters' expansion stops at the 64-ray step whatever span the leaves then take; fixing the span
  // keeps the depths this test counts those of that rule (auto may test some batches' leaves lower).
  o.leafRays = traversal::LeafRays::SixtyFour;
  auto with = makeConeMethod(ctx, o);
  runCounted(*with, frame);  // warm-up: the batch size settles
  const MethodOutput out = runCounted(*with, frame);
  ConeOptions plain = o;
  plain.clusters = false;
  auto without = makeConeMethod(ctx, plain);
  runCounted(*without, frame);
  const MethodOutput ref = runCounted(*without, frame);
  ASSERT_EQ(out.stats["traversal_path"], "one submission");
  EXPECT_EQ(out.visibility, ref.visibility);
  EXPECT_GT(std::count(out.visibility.begin(), out.visibility.end(), 0.0f), 0);

  const nlohmann::json& passes = out.stats["traversal"]["passes"];
  const uint32_t depth = out.stats["tree_depth"].get<uint32_t>();
  const uint32_t tested = testedDepths(out);
  ASSERT_GE(tested, 4u);
  ASSERT_EQ(passes.size(), tested);
  // The depths tested as clusters: a prefix from the root, as deep as the rule says (the root kept every
  // cluster: the field lies wholly within the light's reach).
  uint32_t clusterDepths = 0;
  while (clusterDepths < passes.size() && passes[clusterDepths]["cluster_tests"].get<uint64_t>() > 0) ++clusterDepths;
  const uint64_t clusters = (scene.triangleCount() + CLUSTER_SIZE - 1) / CLUSTER_SIZE;
  const uint32_t lit = out.stats["lit_samples"].get<uint32_t>();
  uint32_t expectDepth = 1;  // the first depth with more than 1/K as many nodes as root clusters
  while (expectDepth + 1 < tested &&
         uint64_t(cone::levelCount(lit, depth, expectDepth)) * EXPAND_NODES_PER_CLUSTER <= clusters)
    ++expectDepth;
  EXPECT_GE(clusterDepths, 3u);
  EXPECT_EQ(clusterDepths, expectDepth);
  for (uint32_t d = clusterDepths; d < passes.size(); ++d) EXPECT_EQ(passes[d]["cluster_tests"], 0u) << d;
  EXPECT_GT(out.stats["traversal"]["expanded_clusters"].get<uint64_t>(), 0u);
  EXPECT_LT(out.stats["pairs_tested"].get<uint64_t>() * 10, ref.stats["pairs_tested"].get<uint64_t>() * 9)
      << out.stats["pairs_tested"] << " pairs with clusters, " << ref.stats["pairs_tested"] << " without";
}

// The leaf choice asked from cluster pairs (traverse_advance.comp, deferLeaves): where clusters reach the
// depth at which they would have to expand for leaves of 64 rays while the expansion rule would keep them
// whole (small triangles against few rays, as on a million-triangle scene seen whole), the choice is made
// from their survival, and "one more depth" keeps them clusters: costs that always go deeper give the
// very passes, expansions and leaf tests of --leaf-rays 4, costs that never do those of --leaf-rays 64,
// the device's own costs a mask bit-identical to both, all in one submission. (Without the choice from
// the clusters, always-deeper costs expand them for 64 rays and test their triangle pairs down to four.)
TEST(ConeMethod, TheLeafChoiceAskedFromClustersKeepsThemClustersWithTheSameMask) {
  auto& ctx = test::context();
  HeightFieldFrame field(96);
  ASSERT_GT(field.host.litCount(), 1000u);
  auto run = [&](traversal::LeafRays rays, std::optional<traversal::LeafChoiceCosts> costs) {
    ConeOptions o;
    o.leafRays = rays;
    o.leafChoiceCosts = costs;
    auto method = makeConeMethod(ctx, o);
    runCounted(*method, field.frame);  // warm-up: the batch size settles
    return runCounted(*method, field.frame);
  };
  const MethodOutput four = run(traversal::LeafRays::Four, std::nullopt);
  const MethodOutput sixtyFour = run(traversal::LeafRays::SixtyFour, std::nullopt);
  ASSERT_EQ(sixtyFour.visibility, four.visibility);
  ASSERT_GT(std::count(four.visibility.begin(), four.visibility.end(), 0.0f), 0);
  // The clusters reach the depth where the leaves of 64 rays expand them, as clusters.
  const uint32_t depth = sixtyFour.stats["tree_depth"].get<uint32_t>();
  ASSERT_GE(depth, 5u);
  const nlohmann::json& at64 = sixtyFour.stats["traversal"]["passes"];
  ASSERT_EQ(at64.size(), depth - 2);
  ASSERT_GT(at64[depth - 4]["cluster_tests"].get<uint64_t>(), 0u);
  // ... and below it with four rays (the rule keeps them whole there).
  const nlohmann::json& at4 = four.stats["traversal"]["passes"];
  ASSERT_EQ(at4.size(), depth);
  ASSERT_GT(at4[depth - 3]["cluster_tests"].get<uint64_t>(), 0u);

  const std::pair<traversal::LeafChoiceCosts, const MethodOutput*> cases[] = {{{-1e30f, 0.0f}, &four},
                                                                            {{1e30f, 0.0f}, &sixtyFour}};
  for (const auto& [costs, forced] : cases) {
    const std::string what = forced == &four ? "always deeper" : "never deeper";
    const MethodOutput got = run(traversal::LeafRays::Auto, costs);
    EXPECT_EQ(got.stats["traversal_path"], "one submission") << what;
    EXPECT_EQ(got.stats["submits_per_frame"], 1u) << what;
    EXPECT_EQ(got.visibility, four.visibility) << what;
    const nlohmann::json &t = got.stats["traversal"], &f = forced->stats["traversal"];
    EXPECT_EQ(t["passes"], f["passes"]) << what;
    EXPECT_EQ(t["expanded_clusters"], f["expanded_clusters"]) << what;
    EXPECT_EQ(got.stats["leaf_tests"], forced->stats["leaf_tests"]) << what;
    EXPECT_EQ(got.stats["leaf_rays"], forced->stats["leaf_rays"]) << what;
    const uint64_t byClusters = t["leaf_choices_by_clusters"].get<uint64_t>();
    if (forced == &four) {
      EXPECT_GT(byClusters, 0u) << what;
      EXPECT_NE(t["leaf_rays_choice"].get<std::string>().find("choices made from cluster pairs' survival"), std::string::npos)
          << t["leaf_rays_choice"];
    } else {
      EXPECT_EQ(byClusters, 0u) << what;
    }
  }
  const MethodOutput automatic = run(traversal::LeafRays::Auto, std::nullopt);
  EXPECT_EQ(automatic.visibility, four.visibility);
  EXPECT_EQ(automatic.stats["submits_per_frame"], 1u);
  // Under a small arena (many batches, each choosing for itself; the deferred clusters' capacity check;
  // an overflow redone chunked) and always-deeper costs: the same mask.
  for (uint64_t memory : {uint64_t(256) << 10, uint64_t(64) << 10}) {
    ConeOptions o;
    o.leafChoiceCosts = traversal::LeafChoiceCosts{-1e30f, 0.0f};
    o.traversalMemoryBytes = memory;
    auto method = makeConeMethod(ctx, o);
    for (int frame = 0; frame < 2; ++frame) {
      const MethodOutput got = runCounted(*method, field.frame);
      EXPECT_EQ(got.visibility, four.visibility) << memory << " bytes, frame " << frame << ": " << got.stats["traversal_path"];
    }
  }
}

// Super clusters (traversal.h, "Clusters"): pass 0 tests every 64 triangles' sphere, not every 16's, and
// the frame tests fewer pairs, with either lanes of the last expansion; the mask is the very mask with
// clusters alone and without clusters.
TEST(ConeMethod, SuperClustersGoDownTheTopOfTheTreeWithTheSameMask) {
  auto& ctx = test::context();
  HeightFieldFrame field(96);
  const FrameInput& frame = field.frame;
  const uint64_t triangles = field.scene.triangleCount();
  auto run = [&](bool clusters, bool supers, traversal::ExpansionLanes lanes) {
    ConeOptions o;
    o.clusters = clusters;
    o.superClusters = supers;
    o.lastExpansionLanes = lanes;
    auto m = makeConeMethod(ctx, o);
    runCounted(*m, frame);
    return runCounted(*m, frame);
  };
  const MethodOutput plain = run(false, false, traversal::ExpansionLanes::Auto);
  EXPECT_GT(std::count(plain.visibility.begin(), plain.visibility.end(), 0.0f), 0);
  for (auto lanes : {traversal::ExpansionLanes::PerCluster, traversal::ExpansionLanes::PerTriangle}) {
    const std::string what = traversal::expansionLanesName(lanes);
    const MethodOutput supers = run(true, true, lanes), clusters = run(true, false, lanes);
    ASSERT_EQ(supers.stats["traversal_path"], "one submission") << what;
    EXPECT_EQ(supers.stats["traversal"]["passes"][0]["pairs_tested"], (triangles + SUPER_SIZE - 1) / SUPER_SIZE) << what;
    EXPECT_EQ(clusters.stats["traversal"]["passes"][0]["pairs_tested"], (triangles + CLUSTER_SIZE - 1) / CLUSTER_SIZE) << what;
    EXPECT_LT(supers.stats["pairs_tested"].get<uint64_t>(), clusters.stats["pairs_tested"].get<uint64_t>()) << what;
    EXPECT_EQ(supers.visibility, plain.visibility) << what;
    EXPECT_EQ(clusters.visibility, plain.visibility) << what;
  }
}

// A scene of more than 16384 super clusters (1.2 M triangles) has its spheres written on several of the
// host's threads where it has them (triangle_layout.cpp, updateClusterSpheres): the mask is the one without
// clusters, for one light and for another (every sphere rewritten), both low over the field.
TEST(ConeMethod, SpheresWrittenOnSeveralThreadsKeepTheMask) {
  auto& ctx = test::context();
  Scene scene = heightFieldScene(1200000);
  Raster raster(ctx, scene);
  // Sixteen rays a leaf pair: at 64 x 64 a tree deep enough above the leaves for clusters (with 64 the
  // traversal stops above the depth clusters start at).
  ConeOptions sixteen;
  sixteen.leafRays = traversal::LeafRays::Sixteen;
  auto method = makeConeMethod(ctx, sixteen);  // one method: the second light rewrites its spheres
  for (const vec3 light : {vec3(0.9f, 0.4f, 0.3f), vec3(-0.7f, 0.3f, -0.5f)}) {  // low: long shadows
    DeviceGBuffer dev;
    GBuffer host;
    raster.render(automaticCamera(scene), light, 64, 64, dev, &host);
    FrameInput frame = frameInputOf(scene, host, dev, ctx, light, EpsilonPolicy::forScene(scene).eps);
    ConeOptions plain;
    plain.clusters = false;
    const MethodOutput want = runCounted(*makeConeMethod(ctx, plain), frame);
    runCounted(*method, frame);  // warm-up: the batch size settles
    const MethodOutput got = runCounted(*method, frame);
    EXPECT_GT(got.stats["traversal"]["passes"][0]["cluster_tests"].get<uint64_t>(), 0u);
    EXPECT_EQ(got.visibility, want.visibility);
    EXPECT_GT(std::count(got.visibility.begin(), got.visibility.end(), 0.0f), 0);
  }
}

// When the clusters stay small against every depth's nodes (few samples over many triangles) they expand
// one depth above the leaves, and that step runs the sphere-test kernel (ConeOptions::sphereLastExpansion):
// the same inputs and tests as with the precise kernel, more leaf pairs (the sphere test is the looser),
// and the very same mask.
TEST(ConeMethod, ALastDepthExpansionTakesTheSphereTestWithTheSameMask) {
  auto& ctx = test::context();
  HeightFieldFrame field(48);
  ASSERT_GT(field.host.litCount(), 300u);
  const FrameInput& frame = field.frame;
  auto run = [&](bool sphere) {
    ConeOptions o;
    o.sphereLastExpansion = sphere;
    // A lane per triangle pair, as the precise kernel's: the same tests (the other lanes' own test follows)
    o.lastExpansionLanes = traversal::ExpansionLanes::PerTriangle;
    o.leafRays = traversal::LeafRays::Sixteen;  // four tested depths at 48 x 48 (64 rays a pair leave three)
    auto m = makeConeMethod(ctx, o);
    runCounted(*m, frame);
    return runCounted(*m, frame);
  };
  const MethodOutput sphere = run(true), precise = run(false);
  ASSERT_EQ(sphere.stats["traversal_path"], "one submission");
  EXPECT_EQ(sphere.stats["last_expansion_test"], "sphere");
  EXPECT_EQ(precise.stats["last_expansion_test"], "precise");
  const nlohmann::json& passes = sphere.stats["traversal"]["passes"];
  const uint32_t depth = testedDepths(sphere);
  ASSERT_GE(depth, 4u);
  ASSERT_EQ(passes.size(), depth);
  // Clusters down to the depth above the leaves' parents: the expansion is the last step.
  for (uint32_t d = 0; d + 1 < depth; ++d) EXPECT_GT(passes[d]["cluster_tests"].get<uint64_t>(), 0u) << d;
  EXPECT_EQ(passes[depth - 1]["cluster_tests"], 0u);
  EXPECT_GT(sphere.stats["traversal"]["expanded_clusters"].get<uint64_t>(), 0u);
  EXPECT_EQ(sphere.stats["pairs_tested"], precise.stats["pairs_tested"]);
  // The sphere kernel ran: it keeps pairs the precise one drops (165 k leaf pairs against 161 k here).
  EXPECT_GT(sphere.stats["traversal"]["leaf_pairs"].get<uint64_t>(), precise.stats["traversal"]["leaf_pairs"].get<uint64_t>());
  EXPECT_EQ(sphere.visibility, precise.visibility);
  EXPECT_GT(std::count(sphere.visibility.begin(), sphere.visibility.end(), 0.0f), 0);
  ConeOptions plain;
  plain.clusters = false;
  auto without = makeConeMethod(ctx, plain);
  runCounted(*without, frame);
  EXPECT_EQ(runCounted(*without, frame).visibility, sphere.visibility);
}

// A pair arena too small for the last depth's expansion: the one-submission frame overflows there and is
// redone chunked, with a lane per cluster pair or per triangle pair alike -- the mask is the roomy
// arena's.
TEST(ConeMethod, ALastExpansionThatOverflowsIsRedoneWithTheSameMask) {
  auto& ctx = test::context();
  HeightFieldFrame field(48);
  const FrameInput& frame = field.frame;
  ConeOptions roomy;
  const MethodOutput want = runCounted(*makeConeMethod(ctx, roomy), frame);
  ASSERT_EQ(want.stats["traversal_path"], "one submission");
  ASSERT_GT(want.stats["traversal"]["expanded_clusters"].get<uint64_t>(), 0u);
  for (auto lanes : {traversal::ExpansionLanes::PerCluster, traversal::ExpansionLanes::PerTriangle}) {
    bool overflowed = false;
    for (uint64_t bytes : {uint64_t(256) << 10, uint64_t(64) << 10}) {
      ConeOptions o;
      o.lastExpansionLanes = lanes;
      o.traversalMemoryBytes = bytes;
      auto method = makeConeMethod(ctx, o);
      // The first frame overflows and is redone chunked; later ones run smaller batches (learnBatch), in
      // one submission where they fit.
      for (int k = 0; k < 3; ++k) {
        const MethodOutput out = runCounted(*method, frame);
        const std::string path = out.stats["traversal_path"];
        std::printf("  %s lanes, %llu bytes, frame %d: %s\n", traversal::expansionLanesName(lanes),
                    (unsigned long long)bytes, k, path.c_str());
        overflowed = overflowed || path != "one submission";
        EXPECT_EQ(out.visibility, want.visibility) << traversal::expansionLanesName(lanes) << ", " << bytes << " bytes";
      }
    }
    EXPECT_TRUE(overflowed) << "no arena overflowed: the test shows nothing";
  }
}

// A frame of several lights (the method's runLights: one submission for all of them) in an arena too
// small for some light's pairs: that light is run again alone, and every light's mask is its one-light
// frame's in a roomy arena -- as it is when the roomy arena holds the three lights in one submission.
// The batches learnt from the overflows, a later frame fits the three lights in one submission again.
TEST(ConeMethod, ALightThatOverflowsAFrameOfSeveralIsRunAgainAloneWithItsOneLightMask) {
  auto& ctx = test::context();
  HeightFieldFrame field(48);
  const std::vector<vec3> lights = {field.frame.light, vec3(0.4f, 1.2f, 0.3f), vec3(-0.5f, 0.9f, -0.2f)};
  std::vector<DeviceGBuffer> dev(lights.size());
  std::vector<GBuffer> host(lights.size());
  std::vector<FrameInput> frames;
  std::vector<std::vector<float>> want;
  for (size_t l = 0; l < lights.size(); ++l) {
    field.raster.render(automaticCamera(field.scene), lights[l], 48, 48, dev[l], &host[l]);
    frames.push_back(frameInputOf(field.scene, host[l], dev[l], ctx, lights[l], field.frame.epsilon));
    want.push_back(runCounted(*makeConeMethod(ctx), frames.back()).visibility);
  }
  const std::vector<MethodOutput> roomy = runCountedLights(*makeConeMethod(ctx), frames);
  for (size_t l = 0; l < lights.size(); ++l) {
    EXPECT_EQ(roomy[l].visibility, want[l]) << "light " << l;
    EXPECT_EQ(roomy[l].stats["submits_per_frame"], 1) << "light " << l;
    EXPECT_FALSE(roomy[l].stats["lights_frame"].contains("alone")) << "light " << l;
  }
  ConeOptions small;
  small.traversalMemoryBytes = uint64_t(256) << 10;
  auto method = makeConeMethod(ctx, small);
  bool alone = false;
  std::vector<MethodOutput> outs;
  for (int k = 0; k < 3; ++k) {
    outs = runCountedLights(*method, frames);
    std::printf("  frame %d: %llu submits\n", k, (unsigned long long)outs[0].stats["submits_per_frame"].get<uint64_t>());
    for (size_t l = 0; l < lights.size(); ++l) {
      const nlohmann::json& lf = outs[l].stats["lights_frame"];
      EXPECT_EQ(lf["lights"], 3) << lf.dump();
      if (!lf["together"].get<bool>()) std::printf("    light %zu: %s\n", l, lf["why"].get<std::string>().c_str());
      if (lf.contains("alone")) {
        alone = true;
        std::printf("    light %zu: %s\n", l, lf["alone"].get<std::string>().c_str());
      }
      EXPECT_EQ(outs[l].visibility, want[l]) << "light " << l << ", frame " << k;
    }
  }
  EXPECT_TRUE(alone) << "no light overflowed: the test shows nothing";
  // The batches learnt from the overflows: the last frame's three lights fit one submission again.
  EXPECT_EQ(outs[0].stats["submits_per_frame"], 1);
  EXPECT_FALSE(outs[0].stats["lights_frame"].contains("alone"));
}

// The engine after a traversal whose pairs passed its arena on the GPU (it never resumes chunked): its lit
// samples that no hit had shadowed by then are 0.5 (sample_light.comp's undecided mode). The lit samples
// are the light's, computed in the kernels (core/shared.h litSampleFor): with the G-buffer's w garbled on
// the device, every pixel the camera pass lit is 0 or 0.5 (0.5 where a roomy frame lights it) and every
// other pixel 1.
TEST(ConeEngine, AnOverflowedFrameMarksTheLightsLitSamplesNotYetShadowedUndecided) {
  auto& ctx = test::context();
  HeightFieldFrame field(48);
  const std::vector<float> want = runCounted(*makeConeMethod(ctx), field.frame).visibility;
  const uint32_t pixels = 48 * 48;
  std::vector<vec4> garbled = field.host.normal;
  for (size_t i = 0; i < garbled.size(); ++i) garbled[i].w = i % 2 ? -1.0f : std::nanf("");
  vk::upload(ctx, field.dev.normal, garbled.data(), garbled.size() * sizeof(vec4));
  ConeOptions small;
  small.traversalMemoryBytes = uint64_t(256) << 10;
  auto engine = makeConeEngine(ctx, small, 1, 1);
  engine->setGeometry(field.scene, geometryRevision(field.scene));
  vk::Buffer out = vk::createBuffer(ctx, uint64_t(pixels) * 4, vk::Memory::HostVisible);
  vk::Commands cmd(ctx);
  const vec3 lights[1] = {field.frame.light};
  engine->record(cmd, field.dev, lights, field.frame.epsilon, 0,
                 [&](uint32_t, const vk::Buffer& mask) { cmd.copy(mask, out, uint64_t(pixels) * 4); });
  cmd.barrier();
  cmd.submit();
  const std::vector<EngineLightStats> st = engine->stats(0);
  ASSERT_EQ(st.size(), 1u);
  ASSERT_FALSE(st[0].complete) << "the arena held the frame's pairs: the test shows nothing";
  EXPECT_EQ(st[0].litSamples, field.host.litCount());
  std::vector<float> mask(pixels);
  std::memcpy(mask.data(), out.mapped, uint64_t(pixels) * 4);
  size_t undecided = 0;
  for (uint32_t i = 0; i < pixels; ++i) {
    if (!field.host.isLit(i)) {
      ASSERT_EQ(mask[i], 1.0f) << "pixel " << i << " is no lit sample";
      continue;
    }
    if (want[i] == 1.0f) ASSERT_EQ(mask[i], 0.5f) << "lit pixel " << i << " nothing shadows";
    else ASSERT_TRUE(mask[i] == 0.0f || mask[i] == 0.5f) << "shadowed pixel " << i << ": " << mask[i];
    undecided += mask[i] == 0.5f;
  }
  EXPECT_GT(undecided, 0u);
}

// That expansion as a lane per super cluster pair (its 64 triangles in one invocation, STEP_EXPAND_SUPER,
// which tests the super cluster's sphere, its clusters', their groups' and their triangles', each only
// against the children the one before kept) or a lane per triangle pair: the same steps above them, fewer
// tests in the first, no more leaf pairs, and the same mask; auto takes what its threshold says on a CPU
// device (one batch here) and the second on a GPU.
TEST(ConeMethod, TheLastExpansionPerClusterOrPerTriangleGivesTheSamePairsAndMask) {
  auto& ctx = test::context();
  HeightFieldFrame field(48);
  const FrameInput& frame = field.frame;
  auto run = [&](traversal::ExpansionLanes lanes) {
    ConeOptions o;
    o.lastExpansionLanes = lanes;
    o.leafRays = traversal::LeafRays::Sixteen;  // four tested depths (64 rays a pair leave three)
    auto m = makeConeMethod(ctx, o);
    runCounted(*m, frame);
    return runCounted(*m, frame);
  };
  const MethodOutput cluster = run(traversal::ExpansionLanes::PerCluster);
  const MethodOutput triangle = run(traversal::ExpansionLanes::PerTriangle);
  const MethodOutput automatic = run(traversal::ExpansionLanes::Auto);
  EXPECT_EQ(cluster.stats["last_expansion_lanes"], "cluster");
  EXPECT_EQ(triangle.stats["last_expansion_lanes"], "triangle");
  const std::optional<uint32_t> minPairs = traversal::expansionLanesMinPairs(ctx);
  const uint64_t pairs = automatic.stats["traversal"]["expansion_pairs_by_lanes"]["cluster"].get<uint64_t>() +
                         automatic.stats["traversal"]["expansion_pairs_by_lanes"]["triangle"].get<uint64_t>();
  EXPECT_EQ(automatic.stats["traversal"]["expansion_lanes_by_batch"]["cluster"].get<uint64_t>() +
                automatic.stats["traversal"]["expansion_lanes_by_batch"]["triangle"].get<uint64_t>(),
            minPairs ? 1u : 0u) << "one batch, one choice (none on a GPU)";
  EXPECT_EQ(automatic.stats["last_expansion_lanes"], minPairs && pairs >= *minPairs ? "cluster" : "triangle");
  ASSERT_GT(cluster.stats["traversal"]["expanded_clusters"].get<uint64_t>(), 0u);
  const uint32_t depth = testedDepths(cluster);
  ASSERT_GE(depth, 4u);
  ASSERT_EQ(cluster.stats["traversal"]["passes"].size(), depth);
  EXPECT_EQ(cluster.stats["traversal"]["passes"][depth - 1]["cluster_tests"], 0u) << "the last step expands";
  // Super clusters down to the depth above the leaves' parents either way; a lane per triangle pair
  // splits them there into clusters (the split's tests are cluster tests), a lane per super cluster
  // pair takes them whole one depth below.
  const nlohmann::json &a = cluster.stats["traversal"]["passes"], &b = triangle.stats["traversal"]["passes"];
  ASSERT_EQ(a.size(), b.size());
  for (uint32_t d = 0; d + 2 < depth; ++d) EXPECT_EQ(a[d], b[d]) << "depth " << d;
  EXPECT_EQ(a[depth - 2]["inputs"].get<uint64_t>() * SUPER_CLUSTERS, b[depth - 2]["inputs"].get<uint64_t>())
      << "the split's inputs are clusters, four a super cluster pair";
  EXPECT_LT(a[depth - 2]["pairs_tested"].get<uint64_t>(), b[depth - 2]["pairs_tested"].get<uint64_t>());
  const uint64_t tested = a[depth - 2]["pairs_tested"].get<uint64_t>() + a[depth - 1]["pairs_tested"].get<uint64_t>();
  const uint64_t testedPerTriangle = b[depth - 2]["pairs_tested"].get<uint64_t>() + b[depth - 1]["pairs_tested"].get<uint64_t>();
  std::printf("last two depths: %llu tests a lane per super cluster pair, %llu per triangle pair\n",
              (unsigned long long)tested, (unsigned long long)testedPerTriangle);
  EXPECT_LT(tested, testedPerTriangle);
  EXPECT_LE(cluster.stats["traversal"]["leaf_pairs"].get<uint64_t>(), triangle.stats["traversal"]["leaf_pairs"].get<uint64_t>());
  EXPECT_EQ(cluster.visibility, triangle.visibility);
  EXPECT_GT(std::count(cluster.visibility.begin(), cluster.visibility.end(), 0.0f), 0);
}

// The last expansion's lanes chosen per batch on the device (ExpansionLanes::Auto, traverse_advance.comp's
// wholeLanes) from the (super) cluster pairs where the two forms part, against a threshold (here given, so
// on any device): from one pair every batch takes a lane per pair, above every batch's pairs a lane per
// triangle pair, and with the threshold at the mean of a many-batch frame's (a small arena) some batches
// take each -- the choice goes both ways within one submission. Each frame's mask is the forced forms'
// and the one without clusters; the stats count every batch's choice and the pairs it saw.
TEST(ConeMethod, TheLastExpansionsLanesAreChosenPerBatchEitherWayWithTheSameMask) {
  auto& ctx = test::context();
  HeightFieldFrame field(48);
  const FrameInput& frame = field.frame;
  ConeOptions plain;
  plain.clusters = false;
  const MethodOutput want = runCounted(*makeConeMethod(ctx, plain), frame);
  ASSERT_GT(std::count(want.visibility.begin(), want.visibility.end(), 0.0f), 0);
  // Frames until one runs in one submission (a small arena's first frames overflow and learn their batch).
  auto run = [&](traversal::ExpansionLanes lanes, std::optional<uint32_t> minPairs, uint64_t memory) {
    ConeOptions o;
    o.lastExpansionLanes = lanes;
    o.expansionLanesMinPairs = minPairs;
    o.leafRays = traversal::LeafRays::Sixteen;  // four tested depths (64 rays a pair leave three)
    if (memory) o.traversalMemoryBytes = memory;
    auto m = makeConeMethod(ctx, o);
    MethodOutput out;
    for (int k = 0; k < 5; ++k) {
      out = runCounted(*m, frame);
      EXPECT_EQ(out.visibility, want.visibility) << traversal::expansionLanesName(lanes) << ", frame " << k;
      if (k > 0 && out.stats["traversal_path"] == "one submission") break;
    }
    EXPECT_EQ(out.stats["traversal_path"], "one submission");
    return out;
  };
  auto batches = [](const MethodOutput& out, const char* form) {
    return out.stats["traversal"]["expansion_lanes_by_batch"][form].get<uint64_t>();
  };
  auto pairs = [](const MethodOutput& out, const char* form) {
    return out.stats["traversal"]["expansion_pairs_by_lanes"][form].get<uint64_t>();
  };
  for (uint64_t memory : {uint64_t(0), uint64_t(256) << 10}) {
    const MethodOutput cluster = run(traversal::ExpansionLanes::Auto, 1u, memory);
    const MethodOutput triangle = run(traversal::ExpansionLanes::Auto, UINT32_MAX, memory);
    EXPECT_EQ(cluster.stats["last_expansion_lanes"], "cluster") << memory;
    EXPECT_EQ(triangle.stats["last_expansion_lanes"], "triangle") << memory;
    EXPECT_GT(batches(cluster, "cluster"), 0u) << memory;
    EXPECT_EQ(batches(cluster, "triangle"), 0u) << memory;
    EXPECT_EQ(batches(triangle, "cluster"), 0u) << memory;
    EXPECT_GT(batches(triangle, "triangle"), 0u) << memory;
    // The choice is the forced form's: the same pairs (a lane per pair tests fewer).
    const MethodOutput forced = run(traversal::ExpansionLanes::PerCluster, std::nullopt, memory);
    EXPECT_EQ(cluster.stats["pairs_tested"], forced.stats["pairs_tested"]) << memory;
    EXPECT_LT(cluster.stats["pairs_tested"].get<uint64_t>(), triangle.stats["pairs_tested"].get<uint64_t>()) << memory;
    if (memory == 0) {
      EXPECT_EQ(batches(cluster, "cluster"), 1u) << "one batch";
      continue;
    }
    // Many batches: a threshold at their mean pairs splits them.
    const uint64_t many = batches(cluster, "cluster");
    ASSERT_GE(many, 3u);
    const uint32_t mean = uint32_t(pairs(cluster, "cluster") / many);
    const MethodOutput mixed = run(traversal::ExpansionLanes::Auto, mean, memory);
    std::printf("  %llu batches; threshold %u pairs: %llu batches a lane a pair (%llu pairs), %llu a lane per triangle pair (%llu pairs)\n",
                (unsigned long long)many, mean, (unsigned long long)batches(mixed, "cluster"),
                (unsigned long long)pairs(mixed, "cluster"), (unsigned long long)batches(mixed, "triangle"),
                (unsigned long long)pairs(mixed, "triangle"));
    EXPECT_GT(batches(mixed, "cluster"), 0u);
    EXPECT_GT(batches(mixed, "triangle"), 0u);
    EXPECT_GE(pairs(mixed, "cluster"), uint64_t(mean) * batches(mixed, "cluster"));
    EXPECT_LT(pairs(mixed, "triangle"), uint64_t(mean) * batches(mixed, "triangle"));
    const uint64_t mixedTests = mixed.stats["pairs_tested"].get<uint64_t>();
    EXPECT_LT(cluster.stats["pairs_tested"].get<uint64_t>(), mixedTests);
    EXPECT_LT(mixedTests, triangle.stats["pairs_tested"].get<uint64_t>());
  }
}

// The whole traversal is conservative end to end: the mask equals the leaf test run on every (triangle,
// lit sample) pair by brute force on the CPU (the same source), for any ray order, down to frames of a
// single ray (a tree of depth 1), with either leaf test (traversal.h LeafTest: the one the method picks for
// the light, and the two ends' it is told to run). On lavapipe the GPU's arithmetic is the CPU's, so equality is exact;
// a GPU may round a division or square root differently and flip a ray grazing an edge.
struct BruteCase {
  Scene scene;
  Camera cam;
  vec3 light;
  uint32_t w, h;
};
// The busy scene's view of the brute-force tests, at w x h.
BruteCase busyBruteCase(uint32_t w, uint32_t h) {
  Camera cam;
  cam.eye = {5, 6, 7};
  cam.target = {0, 0.5f, 0};
  cam.yfov = 0.9f;
  return {busyScene(), cam, vec3(0.5f, 4.0f, 1.0f), w, h};
}
void expectMaskEqualsTheLeafTestOnEveryPair(const std::vector<BruteCase>& cases) {
  auto& ctx = test::context();
  const bool exactDevice = ctx.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
  for (const BruteCase& c : cases) {
    Raster raster(ctx, c.scene);
    DeviceGBuffer dev;
    GBuffer host;
    raster.render(c.cam, c.light, c.w, c.h, dev, &host);
    const float eps = EpsilonPolicy::forScene(c.scene).eps;
    vec3 lo(INFINITY), hi(-INFINITY);
    for (uint32_t i : c.scene.indices) lo = glm::min(lo, c.scene.positions[i]), hi = glm::max(hi, c.scene.positions[i]);
    // The test the method picks for this light (leafTestFor), and the two ends' test it can be told to run.
    const traversal::LeafTest picked = traversal::leafTestFor(cone::chooseFrame(c.light, lo, hi).far, lo, hi, c.light);
    for (bool automatic : {true, false}) {
      const traversal::LeafTest test = automatic ? picked : traversal::LeafTest::TwoEnds;
      // Brute force: every lit sample against every triangle.
      std::vector<float> brute(host.size(), 1.0f);
      for (size_t i = 0; i < host.size(); ++i) {
        if (!host.isLit(i)) continue;
        const vec3 p(host.position[i]);
        vec4 ray = cone::leafRay(p, c.light);
        if (!cone::leafRayUsable(ray, 2.0f * eps)) continue;
        for (size_t t = 0; t + 2 < c.scene.indices.size() && brute[i] != 0.0f; t += 3) {
          vec3 P0 = c.scene.positions[c.scene.indices[t]];
          vec3 P1 = c.scene.positions[c.scene.indices[t + 1]];
          vec3 P2 = c.scene.positions[c.scene.indices[t + 2]];
          const bool hit = test == traversal::LeafTest::FromLight    ? cone::leafHitFromLight(p, c.light, ray, eps, P0, P1, P2)
                           : test == traversal::LeafTest::FromSample ? cone::leafHitFromSample(p, c.light, ray, eps, P0, P1, P2)
                                                                     : cone::leafHit(p, c.light, ray, eps, P0, P1, P2);
          if (hit) brute[i] = 0.0f;
        }
      }
      FrameInput frame;
      frame.scene = &c.scene;
      frame.gbuffer = &host;
      frame.device = &dev;
      frame.vk = &ctx;
      frame.light = c.light;
      frame.epsilon = eps;
      for (bool sorted : {true, false}) {
        ConeOptions o;
        o.sorted = sorted;
        o.leafTestAuto = automatic;
        MethodOutput out = makeConeMethod(ctx, o)->run(frame);
        EXPECT_EQ(out.stats["leaf_test"], traversal::leafTestName(test));
        size_t differ = 0;
        for (size_t i = 0; i < host.size(); ++i) differ += out.visibility[i] != brute[i];
        size_t allowed = exactDevice ? 0 : host.size() / 1000;
        EXPECT_LE(differ, allowed) << c.scene.name << " " << c.w << "x" << c.h << (sorted ? " sorted" : " screen order")
                                   << " " << traversal::leafTestName(test);
      }
    }
  }
}
TEST(ConeMethod, MaskEqualsTheLeafTestOnEveryPairSortedOrNot) {
  Scene builtin = builtinScene();
  expectMaskEqualsTheLeafTestOnEveryPair(
      {busyBruteCase(64, 48), {builtin, *builtin.findCamera("fur"), builtin.lights[0].position, 40, 40},
       {builtin, *builtin.findCamera("room"), vec3(-6.0f, 0.02f, 3.5f), 40, 40}});
}
// The same down to frames of one, four and fifteen samples (trees of depth 1 and 2).
TEST(ConeMethod, MaskEqualsTheLeafTestOnEveryPairInFramesOfOneToFifteenSamples) {
  expectMaskEqualsTheLeafTestOnEveryPair({busyBruteCase(1, 1), busyBruteCase(2, 2), busyBruteCase(3, 5)});
}

}  // namespace
}  // namespace cs
