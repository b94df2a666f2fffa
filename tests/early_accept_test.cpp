// Early accept (002 §3.3; ConeOptions::earlyAccept, variant "PreciseSEA"): the covered test never accepts
// a cone with a ray that misses (a property test against brute force through the very leaf test), and
// the traversal with early accept gives the plain PreciseSorted mask bit for bit -- on the built-in
// scene, on a large wall in front of the light (where it fires and tests fewer pairs) and at a tiny
// traversal memory -- with zero misclassified samples outside the band against Embree.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/cone_property_support.h"

#include "judge/metrics.h"
#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "method/epsilon.h"
#include "tests/cone_test_support.h"
#include "tests/test_context.h"
#include "traversal/cone_method.h"
#include "traversal/precise_test.h"
#include "traversal/traversal.h"

namespace cs {
namespace {

using cone::ConeNode;
using glm::dvec3;
using glm::vec3;
using glm::vec4;

// ---- the covered test: never true for a cone with a ray that misses ----------------------------------

ConeNode makeCone(dvec3 a, double alpha, double lmin, double lmax) {
  ConeNode c;
  c.axisCos = vec4(vec3(a), float(std::cos(alpha)));
  c.sinLen = vec4(float(std::sin(alpha)), float(lmin), float(lmax), float(alpha));
  return c;
}

TEST(EarlyAcceptCovered, NeverAcceptsAConeWithARayThatMissesTheTriangleInItsInterval) {
  // CONE_PROPERTY_PAIRS / CONE_PROPERTY_SEED run a longer sweep by hand.
  const char* pairsEnv = std::getenv("CONE_PROPERTY_PAIRS");
  const char* seedEnv = std::getenv("CONE_PROPERTY_SEED");
  std::mt19937_64 rng(seedEnv ? std::strtoull(seedEnv, nullptr, 10) : 20261122);
  auto uni = [&](double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); };
  auto logUni = [&](double a, double b) { return std::exp(uni(std::log(a), std::log(b))); };
  auto unit = [&] {
    for (;;) {
      dvec3 v(uni(-1, 1), uni(-1, 1), uni(-1, 1));
      double l = glm::length(v);
      if (l > 1e-3 && l <= 1) return v / l;
    }
  };
  const int n = pairsEnv ? std::atoi(pairsEnv) : 20000;
  int accepted = 0, nearMissAccepted = 0;
  for (int i = 0; i < n; ++i) {
    const dvec3 a = unit();
    const double alpha = logUni(1e-5, 1.2);
    const double lmax = logUni(1e-2, 1e3);
    const double lmin = lmax * uni(0.05, 1.0);
    const double eps = (i % 4 == 0) ? 0.0 : lmin * logUni(1e-6, 0.3);
    const ConeNode c = makeCone(a, alpha, lmin, lmax);
    // A triangle around the axis: its plane crosses the axis at distance t0, tilted by up to ~80 degrees;
    // the vertices at a radius of `scale` times the cone's footprint. Near misses: scale near 1, t0 near
    // Lmin - eps or near eps, the light near the plane.
    const int kind = i % 6;
    double t0 = lmin * uni(0.05, 1.0);
    if (kind == 1) t0 = (lmin - eps) * uni(0.97, 1.03);
    if (kind == 2) t0 = eps * uni(0.9, 1.5) + 1e-7 * lmin;
    const dvec3 nrm = glm::normalize(a + uni(0, kind == 3 ? 6.0 : 1.5) * unit());
    const dvec3 p0 = t0 * a;
    dvec3 u = glm::normalize(glm::cross(nrm, std::abs(nrm.x) < 0.5 ? dvec3(1, 0, 0) : dvec3(0, 1, 0)));
    dvec3 w = glm::cross(nrm, u);
    const double foot = t0 * std::tan(std::min(alpha, 1.5)) / std::max(0.05, std::abs(glm::dot(nrm, a)));
    const double scale = kind == 4 ? uni(0.98, 1.3) : logUni(0.5, 20.0);
    const double phase = uni(0, 2 * M_PI);
    vec3 v[3];
    for (int k = 0; k < 3; ++k) {
      // An equilateral triangle circumscribing a disc of radius R has circumradius 2R.
      double ang = phase + k * 2 * M_PI / 3 + (kind == 5 ? uni(-0.3, 0.3) : 0.0);
      double r = 2.0 * scale * foot * (kind == 5 ? uni(0.7, 1.3) : 1.0);
      v[k] = vec3(p0 + r * (std::cos(ang) * u + std::sin(ang) * w) + (kind == 5 ? uni(-0.1, 0.1) * t0 * nrm : dvec3(0)));
    }
    if (i % 2) std::swap(v[1], v[2]);
    if (!cone::preciseConeCovered(c, cone::preciseTriangle(v[0], v[1], v[2]), float(eps))) continue;
    accepted++;
    if (kind == 1 || kind == 2 || kind == 4) nearMissAccepted++;
    // Every ray of the cone -- on its boundary, inside, along the axis -- of length Lmin, Lmax or between
    // hits the triangle within (eps, L - eps), through the leaf test itself.
    for (int k = 0; k < 200; ++k) {
      const test::ProbeRay probe = test::probeRay(k, a, alpha, lmin, lmax, uni, [](vec3 x, vec3 l) { return cone::leafRay(x, l); });
      const dvec3 r = probe.r;
      const double L = probe.L, th = probe.theta;
      ASSERT_TRUE(cone::leafHit(probe.w, vec3(0), probe.ray, float(eps), v[0], v[1], v[2]))
          << "pair " << i << " (kind " << kind << ") accepted but the ray at theta " << th << " of alpha " << alpha
          << ", length " << L << " (Lmin " << lmin << ", Lmax " << lmax << ", eps " << eps << ") misses";
      // The other leaf test (traversal.h LeafTest) too: early accept shadows what either would.
      ASSERT_TRUE(cone::leafHitFromLight(probe.w, vec3(0), probe.ray, float(eps), v[0], v[1], v[2]))
          << "pair " << i << " (kind " << kind << ") accepted but the ray at theta " << th << " of alpha " << alpha
          << ", length " << L << " (Lmin " << lmin << ", Lmax " << lmax << ", eps " << eps
          << ") misses the test from the light";
      // And in double: the plane crossing lies within (eps, L - eps).
      dvec3 e1 = dvec3(v[1]) - dvec3(v[0]), e2 = dvec3(v[2]) - dvec3(v[0]), pv = glm::cross(r, e2);
      double det = glm::dot(e1, pv);
      ASSERT_NE(det, 0.0);
      dvec3 tv = -dvec3(v[0]), qv = glm::cross(tv, e1);
      double bu = glm::dot(tv, pv) / det, bv = glm::dot(r, qv) / det, tt = glm::dot(e2, qv) / det;
      ASSERT_TRUE(bu > 0 && bv > 0 && bu + bv < 1 && tt > eps && tt < L - eps)
          << "pair " << i << " (kind " << kind << "): double check fails at theta " << th;
    }
  }
  std::printf("  covered: %d of %d pairs accepted (%d near misses)\n", accepted, n, nearMissAccepted);
  EXPECT_GT(accepted, n / 10) << "the covered test must not be trivially false";
  EXPECT_GT(nearMissAccepted, 100);
}

TEST(EarlyAcceptCovered, RejectsTheClearMisses) {
  const dvec3 a(0, 0, -1);
  const ConeNode c = makeCone(a, 0.1, 4.0, 5.0);
  auto covered = [&](float z, float r, float eps) {
    vec3 v0(0, 2 * r, z), v1(-1.8f * r, -r, z), v2(1.8f * r, -r, z);
    return cone::preciseConeCovered(c, cone::preciseTriangle(v0, v1, v2), eps);
  };
  EXPECT_TRUE(covered(-1.0f, 1.0f, 0.01f));
  EXPECT_FALSE(covered(-1.0f, 0.05f, 0.01f)) << "too small to cover the cone";
  EXPECT_FALSE(covered(-3.995f, 10.0f, 0.01f)) << "beyond Lmin - eps";
  EXPECT_FALSE(covered(-4.5f, 10.0f, 0.01f)) << "beyond Lmin: some rays end before the plane";
  EXPECT_FALSE(covered(-0.005f, 1.0f, 0.01f)) << "within eps of the light";
  EXPECT_FALSE(covered(1.0f, 1.0f, 0.01f)) << "behind the light";
  ConeNode wide = makeCone(a, 1.56, 4.0, 5.0);
  EXPECT_FALSE(cone::preciseConeCovered(wide, cone::preciseTriangle(vec3(0, 1e4f, -1), vec3(-1e4f, -1e4f, -1),
                                                                    vec3(1e4f, -1e4f, -1)), 0.01f));
  ConeNode empty = c;
  empty.sinLen.z = -1;
  EXPECT_FALSE(cone::preciseConeCovered(empty, cone::preciseTriangle(vec3(0, 2, -1), vec3(-2, -1, -1), vec3(2, -1, -1)),
                                        0.01f));
}

// ---- the traversal with early accept: the same mask, fewer pairs --------------------------------------

using test::lookAt;

using Frame = test::ReferenceFrame;

using Result = test::ConeRun;
using test::sameBits;

Result runExact(Frame& f, const ConeOptions& o, const std::string& what) { return test::runExactCone(f, o, what); }
uint64_t accepted(const Result& r) { return r.stats["early_accepted_nodes"].get<uint64_t>(); }

ConeOptions sea() {
  ConeOptions o;
  EXPECT_TRUE(applyConeVariant("PreciseSEA", o));
  EXPECT_TRUE(o.earlyAccept);
  return o;
}

// A receiving wall (z = -6) and a large quad (z = -0.4) right in front of the light at the origin, plus
// a small caster, seen from the side so both the wall's shadowed and lit parts are in view.
Scene largeWallScene() {
  Scene s;
  s.name = "large wall";
  auto quad = [&](vec3 o, vec3 du, vec3 dv) { test::addQuad(s, o, du, dv); };
  quad({-12, -12, -6}, {24, 0, 0}, {0, 24, 0});       // the receiving wall, facing +z (the light)
  quad({-1.5f, -1.2f, -0.4f}, {3, 0, 0}, {0, 2.4f, 0}); // the large occluder close to the light
  quad({4, 2, -3}, {1, 0, 0}, {0, 1, 0});              // a small caster off to the side
  s.computeBounds();
  return s;
}

TEST(EarlyAccept, MaskEqualsPreciseSortedOnTheBuiltinScene) {
  Scene scene = builtinScene();
  for (const char* view : {"wall", "room"}) {
    const Camera* cam = scene.findCamera(view);
    ASSERT_NE(cam, nullptr) << view;
    Frame f(scene, *cam, scene.lights[0].position, 96);
    Result plain = runExact(f, ConeOptions{}, std::string("builtin/") + view + " PreciseSorted");
    Result early = runExact(f, sea(), std::string("builtin/") + view + " PreciseSEA");
    EXPECT_TRUE(sameBits(plain.mask, early.mask)) << view << ": early accept changed the mask";
    EXPECT_LE(early.pairs, plain.pairs) << view;
  }
}

TEST(EarlyAccept, FiresOnALargeWallInFrontOfTheLightWithTheSameMaskAndFewerPairs) {
  Scene scene = largeWallScene();
  Frame f(scene, lookAt({7, 3, 2}, {0, 0, -6}, 1.1f), vec3(0, 0, 0), 128);
  Result plain = runExact(f, ConeOptions{}, "large wall PreciseSorted");
  Result early = runExact(f, sea(), "large wall PreciseSEA");
  size_t shadowed = 0;
  for (float v : plain.mask) shadowed += v == 0.0f;
  EXPECT_GT(shadowed, 1000u) << "the large wall must shadow much of the view";
  EXPECT_TRUE(sameBits(plain.mask, early.mask)) << "early accept changed the mask";
  EXPECT_EQ(accepted(plain), 0u);
  EXPECT_GT(accepted(early), 0u) << "early accept must fire on a large occluder in front of the light";
  EXPECT_LT(early.pairs, plain.pairs);
}

// The frame sorted without measuring the screen order first (the fused compaction, whose sort writes the
// sorted rays' records for the tree): early accept reads a covered node's rays from those records, and
// the mask is the one-frame reference's, bit for bit, in one submission.
TEST(EarlyAccept, SortedWithoutMeasuringReadsTheRaysFromTheSortsRecords) {
  Scene scene = largeWallScene();
  Frame f(scene, lookAt({7, 3, 2}, {0, 0, -6}, 1.1f), vec3(0, 0, 0), 128);
  Result plain = runExact(f, ConeOptions{}, "large wall PreciseSorted");
  ConeOptions o = sea();
  o.adaptiveOrder = false;
  Result early = runExact(f, o, "large wall PreciseSEA, sorted without measuring");
  EXPECT_EQ(early.stats["ray_order"], "hilbert");
  EXPECT_EQ(early.stats["traversal_path"], "one submission");
  EXPECT_TRUE(sameBits(plain.mask, early.mask)) << "early accept on the sort's records changed the mask";
  EXPECT_GT(accepted(early), 0u) << "early accept must fire on a large occluder in front of the light";
}

TEST(EarlyAccept, BitIdenticalAtATinyTraversalMemory) {
  Scene scene = largeWallScene();
  Frame f(scene, lookAt({7, 3, 2}, {0, 0, -6}, 1.1f), vec3(0, 0, 0), 96);
  Result plain = runExact(f, ConeOptions{}, "large wall PreciseSorted");
  const uint32_t depth = cone::treeDepth(uint32_t(f.host.litCount()));
  ConeOptions small = sea();
  small.traversalMemoryBytes = 9000;
  ConeOptions least = sea();
  test::useLeastArena(least, depth);
  for (const ConeOptions& o : {small, least}) {
    Result r = runExact(f, o, "large wall PreciseSEA " + std::to_string(o.traversalMemoryBytes) + " B");
    EXPECT_TRUE(sameBits(plain.mask, r.mask)) << o.traversalMemoryBytes << " bytes: mask differs";
    EXPECT_GT(accepted(r), 0u);
  }
}

}  // namespace
}  // namespace cs
