// The Embree reference and the epsilon policy against an analytic shadow: a square occluder above a
// ground plane, whose shadow outline follows from similar triangles. The G-buffers are built on the CPU
// (no raster), so these tests need no GPU.
#include <cfloat>
#include <atomic>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <xmmintrin.h>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/scene.h"
#include "raster/gbuffer.h"
#include "reference/embree_reference.h"
#include "method/epsilon.h"
#include "reference/parallel.h"

namespace cs {
namespace {

const glm::vec3 kLight(0.1f, 3.0f, 0.2f);  // off-centre, so the shadow is not symmetric

// Two triangles (a, b, c) and (a, c, d): they share the diagonal a-c.
void addQuad(Scene& s, glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d) {
  uint32_t base = uint32_t(s.positions.size());
  for (glm::vec3 v : {a, b, c, d}) {
    s.positions.push_back(v);
    s.normals.push_back(glm::normalize(glm::cross(b - a, c - a)));
  }
  for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) s.indices.push_back(base + i);
}

void setBounds(Scene& s) {
  s.boundsMin = s.boundsMax = s.positions.at(0);
  for (glm::vec3 v : s.positions) {
    s.boundsMin = glm::min(s.boundsMin, v);
    s.boundsMax = glm::max(s.boundsMax, v);
  }
}

// Ground y = 0 over [-3,3]^2 (shared diagonal x = z) and a square occluder at y = 1 over [-0.5,0.5]^2
// (shared diagonal x = z as well), everything moved by `offset`.
Scene analyticScene(glm::vec3 offset = glm::vec3(0)) {
  Scene s;
  s.name = "analytic";
  const glm::vec3 o = offset;
  addQuad(s, o + glm::vec3(-3, 0, -3), o + glm::vec3(-3, 0, 3), o + glm::vec3(3, 0, 3), o + glm::vec3(3, 0, -3));
  addQuad(s, o + glm::vec3(-0.5f, 1, -0.5f), o + glm::vec3(-0.5f, 1, 0.5f), o + glm::vec3(0.5f, 1, 0.5f),
          o + glm::vec3(0.5f, 1, -0.5f));
  setBounds(s);
  return s;
}

// One G-buffer sample on a surface with normal n, lit by `light` the way the raster pass fills it.
void setSample(GBuffer& g, size_t i, glm::vec3 p, glm::vec3 n, glm::vec3 light) {
  g.position[i] = glm::vec4(p, 1.0f);
  g.normal[i] = glm::vec4(n, std::max(0.0f, glm::dot(n, glm::normalize(light - p))));
}

GBuffer emptyGBuffer(uint32_t w, uint32_t h) {
  GBuffer g;
  g.width = w;
  g.height = h;
  g.position.assign(g.size(), glm::vec4(0));
  g.normal.assign(g.size(), glm::vec4(0));
  return g;
}

// size x size samples at pixel centres over [-2,2]^2 on the ground (+ offset); row 0 at z = -2.
GBuffer groundGrid(uint32_t size, glm::vec3 light, glm::vec3 offset = glm::vec3(0)) {
  GBuffer g = emptyGBuffer(size, size);
  const float step = 4.0f / float(size);
  for (uint32_t row = 0; row < size; ++row)
    for (uint32_t col = 0; col < size; ++col)
      setSample(g, size_t(row) * size + col,
                offset + glm::vec3(-2.0f + (float(col) + 0.5f) * step, 0.0f, -2.0f + (float(row) + 0.5f) * step),
                glm::vec3(0, 1, 0), light);
  return g;
}

// The exact shadow of the occluder on the ground: the square scaled by ly / (ly - 1) about the light's
// foot (similar triangles). signedDistance < 0 inside; max-norm, so |d| > tol means Euclidean > tol too.
struct ShadowRect {
  double cx, cz, hx, hz;
  ShadowRect(glm::dvec3 light, double occluderHeight, double half, glm::dvec3 offset = glm::dvec3(0)) {
    glm::dvec3 l = light - offset;  // work in the untranslated frame
    double k = l.y / (l.y - occluderHeight);
    double x0 = l.x + k * (-half - l.x), x1 = l.x + k * (half - l.x);
    double z0 = l.z + k * (-half - l.z), z1 = l.z + k * (half - l.z);
    cx = 0.5 * (x0 + x1) + offset.x;
    cz = 0.5 * (z0 + z1) + offset.z;
    hx = 0.5 * (x1 - x0);
    hz = 0.5 * (z1 - z0);
  }
  double signedDistance(glm::dvec3 p) const { return std::max(std::abs(p.x - cx) - hx, std::abs(p.z - cz) - hz); }
};

MethodOutput runReference(EmbreeReference& ref, const Scene& scene, const GBuffer& g, glm::vec3 light,
                          const EpsilonPolicy& policy) {
  FrameInput frame;
  frame.scene = &scene;
  frame.gbuffer = &g;
  frame.light = light;
  frame.epsilon = policy.eps;
  return ref.run(frame);
}

TEST(EpsilonPolicy, RelativeEpsilonForASceneAtTheOrigin) {
  Scene s = analyticScene();
  EpsilonPolicy p = EpsilonPolicy::forScene(s);
  EXPECT_FLOAT_EQ(p.scale, std::sqrt(6.0f * 6.0f + 1.0f + 6.0f * 6.0f));
  EXPECT_FLOAT_EQ(p.maxAbsCoord, 3.0f);
  EXPECT_FLOAT_EQ(p.floor, 32.0f * FLT_EPSILON * 3.0f);
  EXPECT_FLOAT_EQ(p.eps, 1e-4f * p.scale);  // 1e-4·s dominates the floor
  EXPECT_GT(p.eps, p.floor);
}

TEST(EpsilonPolicy, FloorDominatesForASceneTranslatedBy1e5) {
  Scene s = analyticScene(glm::vec3(1e5f));
  EpsilonPolicy p = EpsilonPolicy::forScene(s);
  EXPECT_NEAR(p.scale, std::sqrt(73.0f), 1e-2f);   // fp32 rounding of the translated corners
  EXPECT_FLOAT_EQ(p.maxAbsCoord, 1e5f + 3.0f);
  EXPECT_FLOAT_EQ(p.floor, 32.0f * FLT_EPSILON * (1e5f + 3.0f));  // ~0.381
  EXPECT_FLOAT_EQ(p.eps, p.floor);
  EXPECT_GT(p.floor, 100.0f * 1e-4f * p.scale);
  // The floor is 32 ulps of the coordinates: an fp32 step at 1e5 is 2^-7.
  EXPECT_GE(p.floor, 32.0f * (std::nextafter(1e5f, 2e5f) - 1e5f));
  // The sideways nudge keeps its own 4-ulp floor (~0.048), not the 32-ulp one.
  EXPECT_FLOAT_EQ(p.lightNudge(glm::vec3(1e5f) + kLight), 4.0f * FLT_EPSILON * (1e5f + 3.0f));
  EXPECT_FLOAT_EQ(EpsilonPolicy::forScene(analyticScene()).lightNudge(kLight), 1e-4f * std::sqrt(73.0f));
}

TEST(EpsilonPolicy, BaseRayStopsEpsilonShortOfBothEnds) {
  EpsilonPolicy p = EpsilonPolicy::forScene(analyticScene());
  glm::vec3 sample(1, 0, 1);
  ShadowRay r = p.baseRay(sample, kLight);
  float L = glm::length(kLight - sample);
  EXPECT_EQ(r.org, sample);
  EXPECT_NEAR(glm::length(r.dir), 1.0f, 1e-6f);
  EXPECT_FLOAT_EQ(r.tnear, p.eps);
  EXPECT_FLOAT_EQ(r.tfar, L - p.eps);
  // A sample at the light: an empty interval, nothing can count.
  ShadowRay at = p.baseRay(kLight, kLight);
  EXPECT_LT(at.tfar, at.tnear);
}

TEST(EpsilonPolicy, BandFamilyHasEveryMemberThatDiffersFromTheBase) {
  EpsilonPolicy p = EpsilonPolicy::forScene(analyticScene());
  ShadowRay rays[EpsilonPolicy::kMaxBandMembers];
  // Start along ray: 1e-4·s equals eps and is skipped (2); along normal (3); nudges (4); ends (3); behind (1).
  EXPECT_EQ(p.bandFamily(glm::vec3(1, 0, 1), glm::vec3(0, 1, 0), kLight, {}, rays), 13);
  ShadowRay base = p.baseRay(glm::vec3(1, 0, 1), kLight);
  for (int i = 0; i < 13; ++i) EXPECT_FALSE(rays[i] == base) << "member " << i;
  // The last starts 4 ulps of M behind the surface, with the base's epsilon.
  EXPECT_EQ(rays[12].org, glm::vec3(1, 0, 1) - p.behindOffset() * glm::vec3(0, 1, 0));
  EXPECT_FLOAT_EQ(p.behindOffset(), EpsilonPolicy::kBehindUlps * FLT_EPSILON * p.maxAbsCoord);
  EXPECT_FLOAT_EQ(rays[12].tnear, p.eps);
  // Nudged lights sit 1e-4·s off the ray, perpendicular to it.
  for (int i = 5; i < 9; ++i) {
    glm::vec3 nudgedLight = rays[i].org + rays[i].dir * (rays[i].tfar + p.eps);
    glm::vec3 offset = nudgedLight - kLight;
    EXPECT_NEAR(glm::length(offset), EpsilonPolicy::kLightNudge * p.scale, 1e-5f);
    EXPECT_NEAR(glm::dot(offset, base.dir), 0.0f, 1e-5f);
  }
  // Translated by 1e5 every along-ray distance floors to eps: only the normal offsets, the nudges and the
  // start behind remain.
  EpsilonPolicy far = EpsilonPolicy::forScene(analyticScene(glm::vec3(1e5f)));
  EXPECT_EQ(far.bandFamily(glm::vec3(1e5f), glm::vec3(0, 1, 0), glm::vec3(1e5f) + kLight, {}, rays), 8);
}

TEST(EpsilonPolicy, OrthonormalBasisIsOrthonormal) {
  for (glm::vec3 d : {glm::vec3(0, 0, 1), glm::vec3(0, 0, -1), glm::vec3(1, 0, 0), glm::normalize(glm::vec3(1, -2, 3)),
                      glm::normalize(glm::vec3(-1e-3f, 1, -1e-4f))}) {
    glm::vec3 u, v;
    orthonormalBasis(d, u, v);
    EXPECT_NEAR(glm::length(u), 1.0f, 1e-5f);
    EXPECT_NEAR(glm::length(v), 1.0f, 1e-5f);
    EXPECT_NEAR(glm::dot(u, v), 0.0f, 1e-5f);
    EXPECT_NEAR(glm::dot(u, d), 0.0f, 1e-5f);
    EXPECT_NEAR(glm::dot(v, d), 0.0f, 1e-5f);
  }
}

TEST(EmbreeReference, SquareOccluderShadowMatchesSimilarTriangles) {
  Scene scene = analyticScene();
  GBuffer g = groundGrid(256, kLight);
  EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  EmbreeReference ref;
  MethodOutput out = runReference(ref, scene, g, kLight, policy);
  std::vector<uint8_t> band = ref.ambiguityBand(scene, g, kLight, policy);
  ShadowRect rect(glm::dvec3(kLight), 1.0, 0.5);
  // The rectangle the test expects: [-0.8, 0.7] x [-0.85, 0.65].
  EXPECT_NEAR(rect.cx - rect.hx, -0.8, 1e-6);
  EXPECT_NEAR(rect.cx + rect.hx, 0.7, 1e-6);
  EXPECT_NEAR(rect.cz - rect.hz, -0.85, 1e-6);
  EXPECT_NEAR(rect.cz + rect.hz, 0.65, 1e-6);

  const double tol = 1e-3;      // fp noise is ~1e-6; the band's members move the outline ~1e-3
  const double bandReach = 1e-2;
  size_t inside = 0, outside = 0, near = 0, inBand = 0;
  for (size_t i = 0; i < g.size(); ++i) {
    ASSERT_TRUE(g.isLit(i));
    double d = rect.signedDistance(glm::dvec3(glm::vec3(g.position[i])));
    float exact = d < 0 ? 0.0f : 1.0f;
    if (d < -tol) {
      EXPECT_EQ(out.visibility[i], 0.0f) << "sample " << i << " is inside the shadow by " << -d;
      ++inside;
    } else if (d > tol) {
      EXPECT_EQ(out.visibility[i], 1.0f) << "sample " << i << " is outside the shadow by " << d;
      ++outside;
    } else {
      EXPECT_TRUE(band[i] || out.visibility[i] == exact) << "sample " << i << " at " << d << " from the outline";
      ++near;
    }
    if (band[i]) {
      ++inBand;
      EXPECT_LE(std::abs(d), bandReach) << "band sample " << i << " is " << d << " from the outline";
    }
  }
  EXPECT_GT(inside, 5000u);
  EXPECT_GT(outside, 50000u);
  EXPECT_LT(inBand, 200u);  // at most a thin line along the outline
}

TEST(EmbreeReference, SamplesExactlyOnTheShadowOutlineAreInTheBand) {
  Scene scene = analyticScene();
  EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  // Along the x = -0.8 and x = 0.7 edges of the shadow, on the outline and 0.02 to either side.
  const float zs[] = {-0.6f, -0.3f, 0.0f, 0.25f, 0.5f};
  const float xs[] = {-0.8f, -0.82f, -0.78f, 0.7f, 0.72f, 0.68f};
  GBuffer g = emptyGBuffer(6, 5);
  for (int r = 0; r < 5; ++r)
    for (int c = 0; c < 6; ++c) setSample(g, size_t(r) * 6 + c, glm::vec3(xs[c], 0, zs[r]), glm::vec3(0, 1, 0), kLight);
  EmbreeReference ref;
  MethodOutput out = runReference(ref, scene, g, kLight, policy);
  std::vector<uint8_t> band = ref.ambiguityBand(scene, g, kLight, policy);
  for (int r = 0; r < 5; ++r) {
    size_t row = size_t(r) * 6;
    EXPECT_EQ(band[row + 0], 1) << "on the outline x = -0.8, z = " << zs[r];
    EXPECT_EQ(band[row + 3], 1) << "on the outline x = 0.7, z = " << zs[r];
    EXPECT_EQ(band[row + 1], 0);
    EXPECT_EQ(band[row + 2], 0);
    EXPECT_EQ(band[row + 4], 0);
    EXPECT_EQ(band[row + 5], 0);
    EXPECT_EQ(out.visibility[row + 1], 1.0f);  // outside
    EXPECT_EQ(out.visibility[row + 2], 0.0f);  // inside
    EXPECT_EQ(out.visibility[row + 4], 1.0f);
    EXPECT_EQ(out.visibility[row + 5], 0.0f);
  }
}

TEST(EmbreeReference, NotLitSamplesGetVisibilityOneAndNoBand) {
  Scene scene = analyticScene();
  EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  GBuffer g = emptyGBuffer(4, 1);
  setSample(g, 0, glm::vec3(0, 0, 0), glm::vec3(0, 1, 0), kLight);  // lit, in the shadow
  // 1: no geometry (position.w = 0); 2: geometry facing away (light term 0); 3: no geometry either.
  g.position[2] = glm::vec4(0.1f, 0, 0.1f, 1);
  g.normal[2] = glm::vec4(0, -1, 0, 0);
  EmbreeReference ref;
  MethodOutput out = runReference(ref, scene, g, kLight, policy);
  std::vector<uint8_t> band = ref.ambiguityBand(scene, g, kLight, policy);
  EXPECT_EQ(out.visibility, (std::vector<float>{0, 1, 1, 1}));
  EXPECT_EQ(band, (std::vector<uint8_t>{0, 0, 0, 0}));
  EXPECT_EQ(out.stats.at("rays").get<uint64_t>(), 1u);
}

TEST(EmbreeReference, LightBelowThePlaneLeavesItsSamplesUnlit) {
  Scene scene = analyticScene();
  const glm::vec3 below(0.1f, -2.0f, 0.2f);
  GBuffer g = groundGrid(16, below);
  EXPECT_EQ(g.litCount(), 0u);  // N·L < 0 everywhere: the raster's light term is 0
  EmbreeReference ref;
  MethodOutput out = runReference(ref, scene, g, below, EpsilonPolicy::forScene(scene));
  for (float v : out.visibility) EXPECT_EQ(v, 1.0f);
  EXPECT_EQ(out.stats.at("rays").get<uint64_t>(), 0u);
}

TEST(EmbreeReference, SceneTranslatedBy1e5DoesNotShadowItself) {
  const glm::vec3 offset(1e5f);
  Scene scene = analyticScene(offset);
  const glm::vec3 light = offset + kLight;  // rounded to fp32 steps of 2^-7
  GBuffer g = groundGrid(128, light, offset);
  EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  EmbreeReference ref;
  MethodOutput out = runReference(ref, scene, g, light, policy);
  std::vector<uint8_t> band = ref.ambiguityBand(scene, g, light, policy);
  ShadowRect rect(glm::dvec3(light), 1.0, 0.5, glm::dvec3(offset));
  const double tol = 0.05;  // positions are quantised to 2^-7 ~ 0.008 here
  size_t inside = 0, outside = 0;
  for (size_t i = 0; i < g.size(); ++i) {
    double d = rect.signedDistance(glm::dvec3(glm::vec3(g.position[i])));
    if (d > tol) {
      EXPECT_EQ(out.visibility[i], 1.0f) << "self-shadowing at sample " << i;
      EXPECT_EQ(band[i], 0) << "sample " << i;
      ++outside;
    } else if (d < -tol) {
      EXPECT_EQ(out.visibility[i], 0.0f) << "sample " << i;
      ++inside;
    }
  }
  EXPECT_GT(inside, 1000u);
  EXPECT_GT(outside, 10000u);
}

TEST(EmbreeReference, GrazingRaysAlongTheSharedGroundEdgeAreLitOrInTheBand) {
  Scene scene = analyticScene();
  EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  // Samples on the ground's shared diagonal x = z, lights low over the ground (rays at ~0.3 to 6 degrees).
  const glm::vec3 lights[] = {{2.9f, 0.01f, 2.9f}, {-2.5f, 0.02f, 2.5f}, {2.0f, 0.3f, -1.0f}, {2.8f, 0.05f, 1.0f}};
  for (glm::vec3 light : lights) {
    GBuffer g = emptyGBuffer(64, 1);
    for (uint32_t i = 0; i < 64; ++i) {
      float t = -2.9f + 5.8f * (float(i) + 0.5f) / 64.0f;
      setSample(g, i, glm::vec3(t, 0, t), glm::vec3(0, 1, 0), light);
    }
    EmbreeReference ref;
    MethodOutput out = runReference(ref, scene, g, light, policy);
    std::vector<uint8_t> band = ref.ambiguityBand(scene, g, light, policy);
    for (uint32_t i = 0; i < 64; ++i) {
      if (!g.isLit(i)) continue;
      glm::vec3 p(g.position[i]);
      // Rays that pass under the occluder can still be shadowed by it; judge the others.
      glm::vec3 atOccluder = p + (light - p) * ((1.0f - p.y) / (light.y - p.y));
      if (light.y > 1.0f && std::abs(atOccluder.x) < 0.6f && std::abs(atOccluder.z) < 0.6f) continue;
      EXPECT_TRUE(out.visibility[i] == 1.0f || band[i]) << "sample " << i << " light " << light.x << "," << light.y;
    }
  }
}

TEST(EmbreeReference, RayInThePlaneOfTwoCoplanarTrianglesAcrossTheirSharedEdgeIsLitOrInTheBand) {
  Scene scene = analyticScene();
  // A vertical wall z = 1.5 of two triangles sharing the diagonal (-1,0)-(1,2); light in its plane.
  addQuad(scene, glm::vec3(-1, 0, 1.5f), glm::vec3(-1, 2, 1.5f), glm::vec3(1, 2, 1.5f), glm::vec3(1, 0, 1.5f));
  const glm::vec3 light(0.3f, 3.0f, 1.5f);
  EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  GBuffer g = emptyGBuffer(3, 1);
  setSample(g, 0, glm::vec3(-0.5f, 0, 1.5f), glm::vec3(0, 1, 0), light);
  setSample(g, 1, glm::vec3(0.7f, 0, 1.5f), glm::vec3(0, 1, 0), light);
  setSample(g, 2, glm::vec3(0.0f, 0, 1.5f), glm::vec3(0, 1, 0), light);
  EmbreeReference ref;
  MethodOutput out = runReference(ref, scene, g, light, policy);
  std::vector<uint8_t> band = ref.ambiguityBand(scene, g, light, policy);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(out.visibility[i] == 1.0f || band[i]) << "sample " << i;
}

TEST(EmbreeReference, RaysThroughTheOccludersSharedEdgeAreShadowed) {
  // Watertightness (RTC_SCENE_FLAG_ROBUST): rays aimed exactly at the occluder's diagonal x = z, far from
  // its outline, must hit one of the two triangles, and no hair's move changes that.
  Scene scene = analyticScene();
  EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  GBuffer g = emptyGBuffer(41, 1);
  for (uint32_t i = 0; i < 41; ++i) {
    float t = -0.4f + 0.8f * float(i) / 40.0f;
    glm::vec3 q(t, 1, t);
    glm::vec3 p = kLight + (q - kLight) * (kLight.y / (kLight.y - 1.0f));
    p.y = 0.0f;
    setSample(g, i, p, glm::vec3(0, 1, 0), kLight);
  }
  EmbreeReference ref;
  MethodOutput out = runReference(ref, scene, g, kLight, policy);
  std::vector<uint8_t> band = ref.ambiguityBand(scene, g, kLight, policy);
  for (uint32_t i = 0; i < 41; ++i) {
    EXPECT_EQ(out.visibility[i], 0.0f) << "ray " << i << " slipped through the shared edge";
    EXPECT_EQ(band[i], 0) << "ray " << i;
  }
}

TEST(EmbreeReference, GeometryWithinEpsilonOfTheLightDoesNotCountButIsInTheBand) {
  Scene scene = analyticScene();
  EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  const glm::vec3 light(0.0f, 2.5f, 2.0f);
  // A wall in the plane x = eps/4, just beside the light: the ray from (1, 0, 2) crosses it at
  // (eps/4) / |d.x| = 0.67·eps before the light.
  const float x = 0.25f * policy.eps;
  addQuad(scene, glm::vec3(x, 1.5f, 1.5f), glm::vec3(x, 3.5f, 1.5f), glm::vec3(x, 3.5f, 2.5f), glm::vec3(x, 1.5f, 2.5f));
  GBuffer g = emptyGBuffer(2, 1);
  setSample(g, 0, glm::vec3(1.0f, 0, 2.0f), glm::vec3(0, 1, 0), light);
  setSample(g, 1, glm::vec3(-1.0f, 0, 2.0f), glm::vec3(0, 1, 0), light);
  EmbreeReference ref;
  MethodOutput out = runReference(ref, scene, g, light, policy);
  std::vector<uint8_t> band = ref.ambiguityBand(scene, g, light, policy);
  EXPECT_EQ(out.visibility[0], 1.0f);  // the crossing is within eps of the light: does not count
  EXPECT_EQ(band[0], 1);               // the end members (stopping at floor, 1e-5·s) see the wall
  // From x < 0 the ray never meets the wall; band[1] is not asserted: the light nudged 1e-4·s sideways
  // lands beyond the wall, so that sample is legitimately ambiguous too.
  EXPECT_EQ(out.visibility[1], 1.0f);
}

TEST(EmbreeReference, ReportsStagesBytesAndStats) {
  Scene scene = analyticScene();
  GBuffer g = groundGrid(64, kLight);
  EmbreeReference ref;
  MethodOutput out = runReference(ref, scene, g, kLight, EpsilonPolicy::forScene(scene));
  ASSERT_EQ(out.stages.size(), 2u);
  EXPECT_EQ(out.stages[0].name, "bvh_build");
  EXPECT_EQ(out.stages[1].name, "rays");
  EXPECT_DOUBLE_EQ(out.totalMs, out.stages[0].ms + out.stages[1].ms);
  const uint64_t buffers = scene.positions.size() * 12 + scene.indices.size() * 4 + g.size() * 4;
  EXPECT_GE(out.bytesAllocated, buffers);
  EXPECT_GE(out.peakBytes, g.size() * 4);
  EXPECT_LE(out.peakBytes, out.bytesAllocated);
  EXPECT_EQ(out.stats.at("triangles").get<uint64_t>(), 4u);
  EXPECT_EQ(out.stats.at("rays").get<uint64_t>(), g.litCount());
  EXPECT_EQ(out.stats.at("build_quality").get<std::string>(), "medium");
  StageTime band;
  ref.ambiguityBand(scene, g, kLight, EpsilonPolicy::forScene(scene), {}, &band);
  EXPECT_EQ(band.name, "band");
  EXPECT_GT(band.ms, 0.0);
}

TEST(EmbreeReference, SharedDeviceServesManyFramesWithoutLeaking) {
  auto device = std::make_shared<EmbreeDevice>();
  const int64_t before = device->liveBytes();
  Scene scene = analyticScene();
  GBuffer g = groundGrid(64, kLight);
  EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  std::vector<float> first;
  {
    EmbreeReference ref(device);
    for (int frame = 0; frame < 3; ++frame) {
      MethodOutput out = runReference(ref, scene, g, kLight, policy);
      if (frame == 0) first = out.visibility;
      EXPECT_EQ(out.visibility, first) << "frame " << frame;
    }
    EmbreeReference other(device);  // a second user of the same device
    EXPECT_EQ(runReference(other, scene, g, kLight, policy).visibility, first);
  }
  EXPECT_EQ(device->liveBytes(), before);
}

TEST(EmbreeReference, BandReusesTheFramesBvhOnlyForTheSameGeometry) {
  Scene scene = analyticScene();
  GBuffer g = groundGrid(32, kLight);
  EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  EmbreeReference ref;
  EXPECT_FALSE(ref.builtFrom(scene));
  runReference(ref, scene, g, kLight, policy);
  EXPECT_TRUE(ref.builtFrom(scene));
  Scene copy = scene;
  EXPECT_TRUE(ref.builtFrom(copy));  // same numbers, another object: still reusable
  copy.positions[5].y += 0.25f;      // raise a corner of the occluder
  EXPECT_FALSE(ref.builtFrom(copy));
  ref.ambiguityBand(copy, g, kLight, policy);  // rebuilds for the changed scene
  EXPECT_TRUE(ref.builtFrom(copy));
}

TEST(EmbreeReference, IndexPastTheVerticesIsAnError) {
  Scene scene = analyticScene();
  scene.indices[4] = uint32_t(scene.positions.size());
  GBuffer g = groundGrid(4, kLight);
  EmbreeReference ref;
  EXPECT_THROW(runReference(ref, scene, g, kLight, EpsilonPolicy::forScene(scene)), Error);
}

TEST(EmbreeReference, EmptySceneLeavesEverySampleLit) {
  Scene scene;
  scene.name = "empty";
  GBuffer g = groundGrid(8, kLight);
  EmbreeReference ref;
  MethodOutput out = runReference(ref, scene, g, kLight, EpsilonPolicy::forScene(scene));
  for (float v : out.visibility) EXPECT_EQ(v, 1.0f);
}

TEST(EmbreeReference, ZeroFrameEpsilonFallsBackToThePolicy) {
  Scene scene = analyticScene();
  GBuffer g = groundGrid(8, kLight);
  EmbreeReference ref;
  FrameInput frame;
  frame.scene = &scene;
  frame.gbuffer = &g;
  frame.light = kLight;
  MethodOutput out = ref.run(frame);
  EXPECT_FLOAT_EQ(out.stats.at("epsilon").get<float>(), EpsilonPolicy::forScene(scene).eps);
}

TEST(EmbreeDevice, EmbreeErrorsBecomeCsErrors) {
  EmbreeDevice device;
  EXPECT_EQ(rtcNewGeometry(device.handle(), RTCGeometryType(999)), nullptr);
  try {
    device.check("rtcNewGeometry");
    ADD_FAILURE() << "expected cs::Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.where, "rtcNewGeometry");
    EXPECT_NE(std::string(e.what()).find("invalid geometry type"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(device.check("after"));  // reported once, then cleared
  EXPECT_THROW(EmbreeDevice("threads=notanumber"), Error);
}

TEST(ThreadPool, RunsEveryIndexOnceAndRethrowsTheFirstError) {
  ThreadPool pool(4);
  EXPECT_EQ(pool.threadCount(), 4u);
  for (size_t count : {size_t(0), size_t(1), size_t(12), size_t(13), size_t(10007)}) {
    std::vector<std::atomic<int>> hits(count);
    pool.parallelFor(count, 13, [&](size_t b, size_t e) {
      for (size_t i = b; i < e; ++i) hits[i]++;
    });
    for (size_t i = 0; i < count; ++i) ASSERT_EQ(hits[i].load(), 1) << "count " << count << " index " << i;
  }
  EXPECT_THROW(pool.parallelFor(100, 1, [](size_t b, size_t) {
    if (b == 50) throw std::runtime_error("chunk 50");
  }), std::runtime_error);
  std::atomic<size_t> after{0};
  pool.parallelFor(100, 7, [&](size_t b, size_t e) { after += e - b; });  // still usable
  EXPECT_EQ(after.load(), 100u);
  // Every chunk runs with flush-to-zero and denormals-are-zero; the caller gets its own mode back.
  const unsigned before = _mm_getcsr();
  std::atomic<int> withoutFtz{0};
  pool.parallelFor(1000, 1, [&](size_t, size_t) {
    if ((_mm_getcsr() & 0x8040u) != 0x8040u) withoutFtz++;
  });
  EXPECT_EQ(withoutFtz.load(), 0);
  EXPECT_EQ(_mm_getcsr(), before);
}

}  // namespace
}  // namespace cs
