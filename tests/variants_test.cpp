// Paper 002's variants of the cone path (Table 1) and front-face culling (§3.6): every implemented variant
// is exact against Embree outside the ambiguity band and gives the default's mask bit for bit; the sphere
// test is conservative; front-face culling is exact on closed meshes and tests fewer pairs.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "app/cli.h"
#include "method/registry.h"
#include "judge/metrics.h"
#include "raster/raster.h"
#include "rays/hilbert.h"
#include "reference/embree_reference.h"
#include "sort/sort.h"
#include "method/epsilon.h"
#include "tests/cone_test_support.h"
#include "tests/test_context.h"
#include "traversal/cone_method.h"
#include "traversal/sphere_test.h"

namespace cs {
namespace {

using glm::dvec3;
using glm::vec3;
using glm::vec4;

const char* kVariants[] = {"PreciseSorted", "Precise", "Spheres", "SpheresSorted", "PreciseSEA", "PreciseEATP", "PreciseSEATP"};

ConeOptions variant(const std::string& name, bool frontFaceCulling = false) {
  ConeOptions o;
  EXPECT_TRUE(applyConeVariant(name, o)) << name;
  o.frontFaceCulling = frontFaceCulling;
  return o;
}

using test::lookAt;

using Frame = test::ReferenceFrame;

using VariantResult = test::ConeRun;
using test::sameBits;

// One configuration on the frame, exact; its stats name its test and front-face culling.
VariantResult runExact(Frame& f, const ConeOptions& o, const std::string& what) {
  VariantResult r = test::runExactCone(f, o, what);
  EXPECT_EQ(r.stats["test"].get<std::string>(), o.test == ConeTest::Sphere ? "sphere" : "precise") << what;
  EXPECT_EQ(r.stats["front_face_culling"].get<bool>(), o.frontFaceCulling) << what;
  return r;
}

// Every variant on one frame: exact, and the default's mask bit for bit. Returns pairs tested per variant,
// the first four (PreciseSorted, Precise, Spheres, SpheresSorted) without clusters.
// The precise test has the bounding-sphere test ANDed in, so on the same tree it never keeps a pair the
// sphere test drops: Precise visits at most Spheres' nodes, PreciseSorted at most SpheresSorted's. With
// clusters the two expand them into triangles at different depths (traversal.h, "Clusters"), which can
// move the count either way (the fur at 96² with 64 rays a leaf pair: Precise 583 k, Spheres 576 k); so
// the comparison runs the four without them too.
std::vector<uint64_t> allVariants(Frame& f, const std::string& what) {
  std::vector<uint64_t> pairs;
  std::vector<float> first;
  for (const char* v : kVariants) {
    VariantResult r = runExact(f, variant(v), what + " " + v);
    if (first.empty()) first = r.mask;
    else EXPECT_TRUE(sameBits(first, r.mask)) << what << ": " << v << "'s mask differs from PreciseSorted's";
    pairs.push_back(r.pairs);
  }
  for (size_t k = 0; k < 4; ++k) {
    ConeOptions o = variant(kVariants[k]);
    o.clusters = false;
    VariantResult r = runExact(f, o, what + " " + kVariants[k] + " without clusters");
    EXPECT_TRUE(sameBits(first, r.mask)) << what << ": " << kVariants[k] << " without clusters";
    pairs[k] = r.pairs;
  }
  EXPECT_LE(pairs[1], pairs[2]) << what << ": Precise vs Spheres";
  EXPECT_LE(pairs[0], pairs[3]) << what << ": PreciseSorted vs SpheresSorted";
  return pairs;
}

TEST(VariantNames, MapToTheirOptionsAndTheSwitchesCombine) {
  ASSERT_EQ(coneVariantNames().size(), std::size(kVariants));
  for (const std::string& v : coneVariantNames()) EXPECT_EQ(coneVariantName(variant(v)), v);
  EXPECT_EQ(coneVariantName(ConeOptions{}), "PreciseSorted");
  ConeOptions o;
  EXPECT_FALSE(applyConeVariant("Nope", o));
  ConeOptions seatp = variant("PreciseSEATP"), eatp = variant("PreciseEATP");
  EXPECT_TRUE(seatp.earlyAccept && seatp.sorted && seatp.twoPass && seatp.test == ConeTest::Precise);
  EXPECT_TRUE(eatp.earlyAccept && !eatp.sorted && eatp.twoPass);
  EXPECT_FALSE(variant("PreciseSEA").twoPass);
  EXPECT_FALSE(variant("PreciseSorted").earlyAccept);

  // The registry's cone settings: a variant, amended by switches in any order; values matched without
  // regard to case; bad values are usage errors naming the method.
  registerBuiltinMethods();
  const MethodInfo& cone = methodOrUsageError("Cone");
  auto settingsOf = [](std::vector<std::pair<std::string, std::string>> kv) {
    Settings s("cone");
    for (auto& [k, v] : kv) s.set(k, v);
    return s;
  };
  EXPECT_NO_THROW(cone.check(settingsOf({{"two-pass", "on"}, {"variant", "PreciseSorted"}})));
  EXPECT_NO_THROW(cone.check(settingsOf({{"variant", "preciseseatp"}, {"test", "PRECISE"}})));
  EXPECT_NO_THROW(cone.check(settingsOf({{"leaf-rays", "16"}, {"variant", "PreciseSorted"}})));
  EXPECT_NO_THROW(cone.check(settingsOf({{"leaf-test", "two-ends"}})));
  EXPECT_NO_THROW(cone.check(settingsOf({{"leaf-test", "Auto"}})));
  for (std::vector<std::pair<std::string, std::string>> bad :
       std::vector<std::vector<std::pair<std::string, std::string>>>{{{"variant", "Bogus"}},
                                                                     {{"front-face-culling", "maybe"}},
                                                                     {{"leaf-rays", "8"}},
                                                                     {{"leaf-test", "from-light"}},
                                                                     {{"two-pass", "perhaps"}},
                                                                     {{"test", "cube"}},
                                                                     {{"test", "sphere"}, {"early-accept", "on"}},
                                                                     {{"variant", "PreciseSEA"}, {"test", "sphere"}},
                                                                     {{"blocker-max-fraction", "2"}},
                                                                     {{"blocker-solid-angle", "x"}},
                                                                     {{"variant", "PreciseSEATP"}, {"ray-order", "screen"}}}) {
    try {
      cone.check(settingsOf(bad));
      ADD_FAILURE() << bad.front().first << "=" << bad.front().second << " was accepted";
    } catch (const UsageError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("cone: ", 0), 0u) << e.what();
    }
  }
  EXPECT_NO_THROW(cone.check(settingsOf({{"variant", "PreciseEATP"}, {"ray-order", "screen"}})));
  // The ray order: chosen per frame by default; a Table 1 variant named alone sorts as the paper does,
  // and its leaves take four rays a pair as the paper's do (unless --leaf-rays says otherwise).
  Scene scene = builtinScene();
  Raster raster(test::context(), scene);
  const glm::vec3 light = scene.lights.at(0).position;
  DeviceGBuffer dev;
  GBuffer host;
  raster.render(*scene.findCamera("wall"), light, 24, 20, dev, &host);
  const FrameInput tiny = frameInputOf(scene, host, dev, test::context(), light, EpsilonPolicy::forScene(scene).eps);
  auto tinyFrame = [&]() -> const FrameInput& { return tiny; };
  for (auto [settings, sorted, adaptive] :
       std::vector<std::tuple<std::vector<std::pair<std::string, std::string>>, bool, bool>>{
           {{}, true, true},
           {{{"ray-order", "hilbert"}}, true, false},
           {{{"ray-order", "screen"}}, false, true},
           {{{"variant", "PreciseSorted"}}, true, false},
           {{{"variant", "PreciseSorted"}, {"ray-order", "auto"}}, true, true},
           {{{"variant", "Precise"}}, false, false},
           {{{"variant", "PreciseSorted"}, {"leaf-rays", "16"}}, true, false}}) {
    std::unique_ptr<ShadowMethod> m = cone.make(&test::context(), settingsOf(settings));
    const MethodOutput out = runCounted(*m, tinyFrame());
    const std::string what = settings.empty() ? "defaults" : settings.front().second;
    EXPECT_EQ(out.stats["sorted"], sorted) << what;
    EXPECT_EQ(out.stats.contains("ray_order_choice"), sorted && adaptive) << what;
    auto named = [&](const char* key) {
      return std::any_of(settings.begin(), settings.end(), [&](const auto& kv) { return kv.first == key; });
    };
    const bool cpu = test::context().properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
    // Given (16; four for a variant), or chosen from the frame's counts on a CPU device (the stats say why).
    const bool chosen = cpu && !named("leaf-rays") && !named("variant");
    const uint32_t leafRays = named("leaf-rays") ? 16u : named("variant") ? 4u : 4u;
    const std::string choice = out.stats["traversal"]["leaf_rays_choice"].get<std::string>();
    if (chosen) {
      const uint32_t got = out.stats["leaf_rays"].get<uint32_t>();
      EXPECT_TRUE(got == 4u || got == 16u || got == 64u) << what << ": " << got;
      EXPECT_EQ(choice.rfind("per batch from its counts", 0), 0u) << what << ": " << choice;
    } else {
      EXPECT_EQ(out.stats["leaf_rays"], leafRays) << what;
      EXPECT_EQ(choice, "given") << what;
    }
    // The stats name the sort this device gets (sort::sortSchemeFor, sortShapeFor).
    const sort::SortShape shape = sort::sortShapeFor(test::context());
    EXPECT_EQ(out.stats.value("ray_sort", ""), std::string(sort::sortSchemeName(sort::sortSchemeFor(test::context()))) +
                                                   ", tiles of " + std::to_string(shape.threads) + " x " +
                                                   std::to_string(shape.items) + " keys")
        << what;
    // The key the sorted variants sort by: 18 bits (two radix passes) in the world frame; none unsorted.
    if (sorted) {
      EXPECT_EQ(out.stats.value("ray_key_bits", 0u), rays::kRayKeyBits) << what;
    } else {
      EXPECT_FALSE(out.stats.contains("ray_key_bits")) << what;
    }
  }
  try {
    cone.check(settingsOf({{"variant", "Precise"}, {"ray-order", "auto"}}));
    ADD_FAILURE() << "an unsorted variant with --ray-order auto was accepted";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("unsorted"), std::string::npos) << e.what();
  }
  auto m = cone.make(&test::context(), settingsOf({{"variant", "Spheres"}, {"front-face-culling", "on"}, {"two-pass", "on"}}));
  EXPECT_EQ(m->name(), "cone");
  ConeOptions stp = variant("SpheresSorted");
  stp.twoPass = true;
  EXPECT_EQ(coneVariantName(stp), "SpheresSTP");
  ConeOptions ea = variant("Precise");
  ea.earlyAccept = true;
  EXPECT_EQ(coneVariantName(ea), "PreciseEA");
}

TEST(VariantExactness, EveryVariantIsExactAndBitIdenticalOnTheBuiltinScene) {
  Scene scene = builtinScene();
  for (const char* view : {"wall", "fur"}) {
    const Camera* cam = scene.findCamera(view);
    ASSERT_NE(cam, nullptr) << view;
    Frame f(scene, *cam, scene.lights[0].position, 96);
    std::vector<uint64_t> pairs = allVariants(f, std::string("builtin/") + view);
    if (std::string(view) == "wall") {
      // 002 §3.2: the precise test culls large grazing triangles the sphere cannot.
      EXPECT_GE(pairs[2], pairs[1]) << "Spheres vs Precise";
      EXPECT_GE(pairs[3], pairs[0]) << "SpheresSorted vs PreciseSorted";
    }
  }
}

TEST(VariantExactness, EveryVariantIsExactOnAGltfModel) {
  std::ostringstream warn;
  Scene model = loadGltf(std::string(CONESHADOW_ASSIMP_MODELS) + "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb", warn);
  model.computeBounds();
  const vec3 lo = model.boundsMin, hi = model.boundsMax, c = 0.5f * (lo + hi), ext = hi - lo;
  const float diag = glm::length(ext);
  // A ground plane under the model.
  const float r = 2.0f * diag, y = lo.y - 0.01f * ext.y;
  const uint32_t b = uint32_t(model.positions.size());
  model.positions.insert(model.positions.end(),
                         {{c.x - r, y, c.z - r}, {c.x + r, y, c.z - r}, {c.x + r, y, c.z + r}, {c.x - r, y, c.z + r}});
  model.normals.insert(model.normals.end(), 4, vec3(0, 1, 0));
  model.indices.insert(model.indices.end(), {b, b + 2, b + 1, b, b + 3, b + 2});
  model.computeBounds();
  Frame f(model, lookAt(c + vec3(0.55f, 0.45f, 0.7f) * diag, c, 0.8f), c + vec3(0.2f * ext.x, 0.9f * diag, 0.3f * ext.z),
          96);
  allVariants(f, "2CylinderEngine");
}

TEST(VariantExactness, AScenePastOneTriangleBufferIsTraversedBufferByBufferWithTheSameMask) {
  // 7,540 triangles in buffers of 1,000 (as a scene past the device's storage binding would be split).
  Scene scene = builtinScene();
  Frame f(scene, *scene.findCamera("room"), scene.lights[0].position, 80);
  for (const char* v : {"PreciseSorted", "PreciseSEATP", "Spheres"}) {
    VariantResult whole = runExact(f, variant(v), std::string("builtin/room ") + v);
    ConeOptions split = variant(v);
    split.trianglesPerBinding = 1000;
    VariantResult parts = runExact(f, split, std::string("builtin/room ") + v + " in 1000-triangle buffers");
    EXPECT_EQ(parts.stats["triangle_buffers"].get<uint64_t>(), 8u);
    EXPECT_EQ(whole.stats["triangle_buffers"].get<uint64_t>(), 1u);
    EXPECT_TRUE(sameBits(whole.mask, parts.mask)) << v << ": splitting the triangles changed the mask";
  }
}

// ---- front-face culling on closed meshes ------------------------------------------------------------------

// A box's 12 triangles, wound so that N = (v1 - v0) x (v2 - v0) points out of it (or into it: a room).
void addBox(std::vector<vec3>& p, vec3 lo, vec3 hi, bool inward) {
  const vec3 ctr = 0.5f * (lo + hi), d = hi - lo;
  auto quad = [&](vec3 o, vec3 u, vec3 v) {
    vec3 q[6] = {o, o + u, o + u + v, o, o + u + v, o + v};
    for (int t = 0; t < 6; t += 3) {
      vec3 n = glm::cross(q[t + 1] - q[t], q[t + 2] - q[t]);
      bool out = glm::dot(n, (q[t] + q[t + 1] + q[t + 2]) / 3.0f - ctr) > 0;
      if (out == inward) std::swap(q[t + 1], q[t + 2]);
      p.insert(p.end(), {q[t], q[t + 1], q[t + 2]});
    }
  };
  quad(lo, {d.x, 0, 0}, {0, d.y, 0});
  quad(lo + vec3(0, 0, d.z), {d.x, 0, 0}, {0, d.y, 0});
  quad(lo, {0, 0, d.z}, {0, d.y, 0});
  quad(lo + vec3(d.x, 0, 0), {0, 0, d.z}, {0, d.y, 0});
  quad(lo + vec3(0, d.y, 0), {d.x, 0, 0}, {0, 0, d.z});
  quad(lo, {d.x, 0, 0}, {0, 0, d.z});
}

Scene soup(const std::vector<vec3>& positions) {
  Scene s;
  s.name = "closed room";
  s.positions = positions;
  for (uint32_t i = 0; i < positions.size(); ++i) s.indices.push_back(i);
  s.normals.resize(positions.size());
  for (size_t t = 0; t + 2 < positions.size(); t += 3) {
    vec3 n = glm::normalize(glm::cross(positions[t + 1] - positions[t], positions[t + 2] - positions[t]));
    s.normals[t] = s.normals[t + 1] = s.normals[t + 2] = n;
  }
  s.computeBounds();
  return s;
}

TEST(VariantFrontFaceCulling, IsExactOnClosedMeshesAndTestsFewerPairs) {
  std::vector<vec3> p;
  addBox(p, {-6, 0, -6}, {6, 6, 6}, /*inward=*/true);  // the room, seen from inside
  addBox(p, {1, 0, 1}, {2.5f, 1.5f, 2.5f}, false);
  addBox(p, {-3, 1, -1}, {-1.5f, 2.2f, 1}, false);
  addBox(p, {-1, 0, 2}, {0, 3, 3}, false);
  for (int i = 0; i < 6; ++i) addBox(p, {-4.0f + 1.3f * i, 0.5f, -3}, {-3.5f + 1.3f * i, 1.0f, -2.5f}, false);
  Scene scene = soup(p);
  Frame f(scene, lookAt({-5, 5, 5}, {0, 1, 0}, 1.2f), vec3(0.3f, 4.5f, 0.2f), 96);
  for (const char* v : kVariants) {
    VariantResult off = runExact(f, variant(v), std::string("closed room ") + v);
    VariantResult on = runExact(f, variant(v, true), std::string("closed room ") + v + " ffc");
    EXPECT_TRUE(sameBits(off.mask, on.mask)) << v << ": front-face culling changed the mask";
    EXPECT_LT(on.pairs, off.pairs) << v;
  }
}

// ---- the sphere test is conservative ----------------------------------------------------------------------

TEST(VariantSphereTest, NeverRejectsAPairWithAPointOrALeafHitInsideTheCone) {
  std::mt19937_64 rng(20261122);
  auto uni = [&](double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); };
  auto unit = [&] {
    for (;;) {
      dvec3 q(uni(-1, 1), uni(-1, 1), uni(-1, 1));
      double l = glm::length(q);
      if (l > 1e-3 && l <= 1) return q / l;
    }
  };
  const double angles[] = {0, 1e-6, 1e-3, 0.05, 0.3, 1.0, M_PI / 2 - 1e-4, M_PI / 2, 2.0, M_PI};
  int hits = 0, misses = 0, rejected = 0;
  for (int i = 0; i < 20000; ++i) {
    dvec3 a = unit();
    double alpha = i % 3 == 0 ? angles[rng() % std::size(angles)] : uni(0, 1.2);
    double lmax = std::exp(uni(std::log(0.1), std::log(100.0)));
    float eps = i % 4 == 0 ? 0.0f : float(lmax * 1e-3);
    cone::ConeNode node;
    node.axisCos = vec4(vec3(a), float(std::cos(alpha)));
    node.sinLen = vec4(float(std::sin(alpha)), 0.0f, float(lmax), float(alpha));
    // Triangles around the cone's boundary, of every size, some containing the apex.
    dvec3 centre = unit() * (lmax * uni(0, 1.5));
    if (i % 2 == 0) {  // near the boundary: a point at angle alpha +- a bit
      dvec3 t = std::abs(a.x) < 0.5 ? dvec3(1, 0, 0) : dvec3(0, 1, 0);
      dvec3 u = glm::normalize(glm::cross(a, t));
      double th = std::min(M_PI, std::max(0.0, alpha + uni(-0.2, 0.2)));
      centre = (std::cos(th) * a + std::sin(th) * u) * (lmax * uni(0.01, 1.3));
    }
    double size = lmax * std::exp(uni(std::log(1e-4), std::log(2.0)));
    vec3 v[3];
    for (auto& x : v) x = vec3(centre + unit() * size);
    if (i % 10 == 0) v[0] = vec3(0);  // a vertex at the apex
    bool keep = cone::sphereConeTriangle(node, v[0], v[1], v[2], eps);
    // Brute force: points of the triangle inside the cone at distances in (eps, lmax - eps), and leaf rays.
    auto inCone = [&](dvec3 x) {
      double l = glm::length(x);
      if (!(l > eps) || !(l < lmax - eps)) return false;
      return std::atan2(glm::length(glm::cross(x, a)), glm::dot(x, a)) <= alpha;
    };
    bool hit = false;
    const int G = 24;
    for (int s = 0; s <= G && !hit; ++s)
      for (int t = 0; s + t <= G && !hit; ++t)
        hit = inCone(dvec3(v[0]) + (double(s) / G) * dvec3(v[1] - v[0]) + (double(t) / G) * dvec3(v[2] - v[0]));
    for (int k = 0; k < 100 && !hit; ++k) {
      double b1 = uni(0, 1), b2 = uni(0, 1);
      if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
      dvec3 x = dvec3(v[0]) + b1 * dvec3(v[1] - v[0]) + b2 * dvec3(v[2] - v[0]);
      if (!(glm::length(x) > 0)) continue;
      // The leaf ray through that point, past it to a length inside the cone.
      vec3 w = vec3(glm::normalize(x) * std::min(lmax, glm::length(x) * uni(1.0, 1.5)));
      vec4 ray = cone::leafRay(w, vec3(0));
      if (ray.w <= lmax && std::atan2(glm::length(glm::cross(dvec3(w), a)), glm::dot(dvec3(w), a)) <= alpha &&
          cone::leafHit(w, vec3(0), ray, eps, v[0], v[1], v[2]))
        hit = true;
    }
    if (hit) {
      hits++;
      ASSERT_TRUE(keep) << "pair " << i << " intersects but the sphere test rejected it: alpha " << alpha << " Lmax "
                        << lmax << " eps " << eps;
    } else {
      misses++;
      rejected += !keep;
    }
  }
  EXPECT_GT(hits, 1000);
  EXPECT_GT(rejected, misses / 4) << rejected << " of " << misses;  // conservative, not trivially so
}

TEST(VariantSphereTest, FrontFacingFollowsTheCounterClockwiseConvention) {
  // Light at the origin; a triangle in the plane y = 1, CCW seen from below (N = -y points at the light).
  vec3 a(0, 1, 0), b(1, 1, 0), c(0, 1, 1);
  EXPECT_TRUE(glm::dot(glm::cross(b - a, c - a), a) < 0);
  EXPECT_TRUE(cone::facesLight(a, b, c));
  EXPECT_FALSE(cone::facesLight(a, c, b));
  EXPECT_FALSE(cone::facesLight(vec3(1, 0, 0), vec3(2, 0, 0), vec3(1, 0, 1)));  // edge-on: kept
}

}  // namespace
}  // namespace cs
