// The cone path's claim (issue 4): on every lit sample outside the ambiguity band, its mask equals the
// Embree reference's. Small renders of the built-in scene from every named view, of glTF models on a
// ground plane, of scene-family members no benchmark measures (with every automatic choice against its
// fixed settings), and of the hard cases, each from a few lights; no NaN or inf ever reaches the mask.
// Every case runs every variant of paper 002's Table 1 (issue 7) on the same frame: each one exact, and
// each one's mask equal to the default's (PreciseSorted) bit for bit.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "harness/harness.h"

#include "judge/metrics.h"
#include "raster/raster.h"
#include "rays/hilbert.h"
#include "reference/embree_reference.h"
#include "method/epsilon.h"
#include "sort/sort.h"
#include "tests/cone_test_support.h"
#include "tests/test_context.h"
#include "traversal/cone_method.h"
#include "traversal/traversal.h"

namespace cs {
namespace {

using glm::vec3;

struct CaseResult {
  ErrorStats error;       // the default variant's
  uint64_t shadowed = 0;  // samples the default variant shadowed
  nlohmann::json stats;   // the default variant's
};

// One shared Embree device and one cone method per variant for the whole file: frames of different
// scenes in a row, as an application would send them. cones[0] is the default (PreciseSorted).
struct Harness {
  std::shared_ptr<EmbreeDevice> device = std::make_shared<EmbreeDevice>();
  EmbreeReference embree{device};
  std::vector<std::string> variants;
  std::vector<std::unique_ptr<ShadowMethod>> cones;
  // The default with the two ends' leaf test (traversal.h LeafTest) wherever the default tests from the
  // light: exact too; its mask may differ from the default's within the band only.
  std::unique_ptr<ShadowMethod> twoEnds;

  // Substrings of the labels of frames the running test makes ambiguous on purpose (UndecidedAllowed).
  std::vector<std::string> undecidedLabels;
  // Cone methods the running test adds, each run on every frame after the variants: exact, and the
  // default's mask bit for bit (SameMaskAs).
  std::vector<std::pair<std::string, ShadowMethod*>> sameMask;
  bool undecidedAllowed(const std::string& what) const {
    for (const std::string& l : undecidedLabels)
      if (what.find(l) != std::string::npos) return true;
    return false;
  }

  static Harness& get() {
    static vk::Context& ctx = test::context();  // constructed first, so destroyed after the harness
    (void)ctx;
    static Harness h;
    if (h.cones.empty()) {
      h.variants.push_back(coneVariantName(ConeOptions{}));
      h.cones.push_back(makeConeMethod(test::context()));
      for (const std::string& v : coneVariantNames()) {
        if (v == h.variants.front()) continue;
        ConeOptions o;
        EXPECT_TRUE(applyConeVariant(v, o)) << v;
        h.variants.push_back(v);
        h.cones.push_back(makeConeMethod(test::context(), o));
      }
      ConeOptions o;
      o.leafTestAuto = false;
      h.twoEnds = makeConeMethod(test::context(), o);
    }
    return h;
  }

  // coneScene: what the cone method gets, when not `scene` (raster and reference always get `scene`).
  CaseResult run(const Scene& scene, const Camera& camera, vec3 light, uint32_t w, uint32_t h,
                 const std::string& what, const Scene* coneScene = nullptr) {
    auto& ctx = test::context();
    Raster raster(ctx, scene);
    DeviceGBuffer dev;
    GBuffer host;
    raster.render(camera, light, w, h, dev, &host);
    const EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
    FrameInput frame = frameInputOf(scene, host, dev, ctx, light, policy.eps);
    MethodOutput ref = embree.run(frame);
    if (coneScene) frame.scene = coneScene;
    MethodOutput mine = cones[0]->run(frame);
    std::vector<uint8_t> band = embree.ambiguityBand(scene, host, light, policy);
    CaseResult r = check(host, mine, ref.visibility, band, what);
    // A frame whose band covers over 1 % of its samples proves little about them: only a frame a test
    // names as ambiguous by construction may be undecided (exactness outside its band is checked all the
    // same); any other undecided frame fails.
    if (r.error.undecided && !undecidedAllowed(what))
      ADD_FAILURE() << what << ": undecided, and the test does not expect it: " << r.error.undecidedReason();
    // The other variants on the same frame: exact too, and the default's mask bit for bit.
    std::string pairs = variants[0] + " " + std::to_string(mine.stats["pairs_tested"].get<uint64_t>());
    for (size_t v = 1; v < cones.size(); ++v) {
      MethodOutput other = cones[v]->run(frame);
      const std::string label = what + " [" + variants[v] + "]";
      EXPECT_EQ(other.stats["variant"].get<std::string>(), variants[v]) << label;
      ErrorStats e = compareVisibility(host, other.visibility, ref.visibility, band);
      EXPECT_EQ(e.misclassifiedOutsideBand, 0u) << label << ": " << e.falseShadowOutsideBand << " false shadow, "
                                                << e.falseLightOutsideBand << " false light outside the band";
      EXPECT_TRUE(test::sameBits(other.visibility, mine.visibility)) << label << ": mask differs from " << variants[0];
      pairs += ", " + variants[v] + " " + std::to_string(other.stats["pairs_tested"].get<uint64_t>());
    }
    for (const auto& [name, method] : sameMask) {
      MethodOutput other = method->run(frame);
      const std::string label = what + " [" + name + "]";
      ErrorStats e = compareVisibility(host, other.visibility, ref.visibility, band);
      EXPECT_EQ(e.misclassifiedOutsideBand, 0u) << label << ": " << e.falseShadowOutsideBand << " false shadow, "
                                                << e.falseLightOutsideBand << " false light outside the band";
      EXPECT_TRUE(test::sameBits(other.visibility, mine.visibility)) << label << ": mask differs from " << variants[0];
      pairs += ", " + name + " " + std::to_string(other.stats["pairs_tested"].get<uint64_t>());
    }
    if (mine.stats["leaf_test"] != "two_ends") {  // from the light or the sample: the two ends' test beside it
      MethodOutput other = twoEnds->run(frame);
      const std::string label = what + " [two-ends leaf test]";
      EXPECT_EQ(other.stats["leaf_test"], "two_ends") << label;
      ErrorStats e = compareVisibility(host, other.visibility, ref.visibility, band);
      EXPECT_EQ(e.misclassifiedOutsideBand, 0u) << label << ": " << e.falseShadowOutsideBand << " false shadow, "
                                                << e.falseLightOutsideBand << " false light outside the band";
      size_t differ = 0, differOutsideBand = 0;
      for (size_t i = 0; i < host.size(); ++i) {
        if (other.visibility[i] == mine.visibility[i]) continue;
        differ++;
        differOutsideBand += host.isLit(i) && !band[i];
      }
      EXPECT_EQ(differOutsideBand, 0u) << label << ": the two leaf tests differ outside the band";
      pairs += "; the leaf tests differ on " + std::to_string(differ) + " samples, all in the band";
    }
    std::printf("    pairs tested: %s\n", pairs.c_str());
    return r;
  }

  // The default variant's result against the reference: only 0 and 1, samples that are not lit stay 1,
  // nothing misclassified outside the band (the first few misclassified samples named).
  static CaseResult check(const GBuffer& host, const MethodOutput& mine, const std::vector<float>& reference,
                          const std::vector<uint8_t>& band, const std::string& what) {
    const uint32_t w = host.width;
    CaseResult r;
    r.stats = mine.stats;
    EXPECT_EQ(mine.visibility.size(), host.size()) << what;
    for (size_t i = 0; i < mine.visibility.size(); ++i) {
      const float v = mine.visibility[i];
      if (!(v == 0.0f || v == 1.0f)) {
        ADD_FAILURE() << what << ": visibility " << v << " at pixel " << i << " (only 0 and 1 may appear)";
        break;
      }
      if (!host.isLit(i)) {
        EXPECT_EQ(v, 1.0f) << what << ": a sample that is not lit must stay 1, pixel " << i;
      }
      r.shadowed += host.isLit(i) && v == 0.0f;
    }
    r.error = compareVisibility(host, mine.visibility, reference, band);
    std::ostringstream detail;
    int shown = 0;
    for (size_t i = 0; i < host.size() && shown < 5; ++i) {
      if (!host.isLit(i) || band[i] || (mine.visibility[i] >= 0.5f) == (reference[i] >= 0.5f)) continue;
      glm::vec4 p = host.position[i];
      detail << "\n  pixel (" << i % w << ", " << i / w << ") at (" << p.x << ", " << p.y << ", " << p.z
             << "): cone " << mine.visibility[i] << ", embree " << reference[i];
      shown++;
    }
    EXPECT_EQ(r.error.misclassifiedOutsideBand, 0u)
        << what << ": " << r.error.falseShadowOutsideBand << " false shadow, " << r.error.falseLightOutsideBand
        << " false light outside the band (of " << r.error.litSamples << " lit, " << r.error.bandSamples
        << " in the band)" << detail.str();
    std::printf("  %-58s lit %6llu shadowed %6llu band %5llu%s | in band: %llu fs %llu fl | pairs %llu leaf tests %llu\n",
                what.c_str(), (unsigned long long)r.error.litSamples, (unsigned long long)r.shadowed,
                (unsigned long long)r.error.bandSamples, r.error.undecided ? " (undecided)" : "",
                (unsigned long long)r.error.falseShadow, (unsigned long long)r.error.falseLight,
                (unsigned long long)mine.stats["pairs_tested"].get<uint64_t>(),
                (unsigned long long)mine.stats["leaf_tests"].get<uint64_t>());
    return r;
  }
};

using test::lookAt;

// Within a test: the frames whose labels hold one of `labels` may be undecided (judge/metrics.h), each
// for the reason the test gives where it makes one.
struct UndecidedAllowed {
  explicit UndecidedAllowed(std::vector<std::string> labels) { Harness::get().undecidedLabels = std::move(labels); }
  ~UndecidedAllowed() { Harness::get().undecidedLabels.clear(); }
  UndecidedAllowed(const UndecidedAllowed&) = delete;
  UndecidedAllowed& operator=(const UndecidedAllowed&) = delete;
};

// Within a test: these cone methods run on every frame too (Harness::sameMask).
struct SameMaskAs {
  explicit SameMaskAs(std::vector<std::pair<std::string, ShadowMethod*>> methods) {
    Harness::get().sameMask = std::move(methods);
  }
  ~SameMaskAs() { Harness::get().sameMask.clear(); }
  SameMaskAs(const SameMaskAs&) = delete;
  SameMaskAs& operator=(const SameMaskAs&) = delete;
};

// ---- the built-in scene -------------------------------------------------------------------------------

TEST(ConeExactness, BuiltinSceneFromEveryViewAndTwoLights) {
  // Undecided here: hairs thinner than the band's 1e-3 diagonal offsets (fur), the grazing
  // light 2 cm above the floor, and close-ups of shadow edges (edge, room, wall), whose band spans many pixels.
  UndecidedAllowed ambiguous({"builtin/fur", "builtin/room", "builtin/edge", "builtin/wall light (1.3"});
  Scene scene = builtinScene();
  ASSERT_FALSE(scene.lights.empty());
  const vec3 lights[] = {
      scene.lights[0].position,
      vec3(-6.0f, 0.02f, 3.5f),  // 2 cm above the floor, under the table's side: grazing, wide cones
  };
  for (const std::string& view : builtinViewNames()) {
    const Camera* cam = scene.findCamera(view);
    ASSERT_NE(cam, nullptr) << view;
    for (vec3 light : lights) {
      std::string what = "builtin/" + view + " light (" + std::to_string(light.x) + ", " + std::to_string(light.y) +
                         ", " + std::to_string(light.z) + ")";
      CaseResult r = Harness::get().run(scene, *cam, light, 128, 128, what);
      EXPECT_GT(r.error.litSamples, 1000u) << what;
    }
  }
}

// ---- the scene family: members no benchmark measures ---------------------------------------------------

// Members drawn from a fixed seed among those past the 40 the benchmarks and their rules were measured on
// (core/scene.h familyMember: camera distance, light elevation and distance, triangle size, ground, open
// meshes all drawn), each from its own light and from one drawn in or around its bounds. Every variant
// exact and equal bit for bit (the harness), and so is every choice `auto` makes against its fixed
// settings: 4, 16 and 64 rays a leaf pair, screen and Hilbert order, clusters off, each lane form of the
// last expansion, a small arena (batches, an overflow redone chunked).
TEST(ConeExactness, UnseenFamilyMembersEveryChoiceTheSameMask) {
  // Undecided: a drawn light may graze a surface or stand among the objects, where the band spans many pixels.
  UndecidedAllowed ambiguous({"family:"});
  std::vector<std::pair<std::string, ConeOptions>> fixed;
  for (auto [name, rays] : {std::pair{"leaf rays 4", traversal::LeafRays::Four}, {"leaf rays 16", traversal::LeafRays::Sixteen},
                            {"leaf rays 64", traversal::LeafRays::SixtyFour}}) {
    ConeOptions o;
    o.leafRays = rays;
    fixed.push_back({name, o});
  }
  {
    ConeOptions screen, hilbert, noClusters, perCluster, perTriangle, small;
    screen.sorted = false;
    hilbert.adaptiveOrder = false;
    noClusters.clusters = false;
    perCluster.lastExpansionLanes = traversal::ExpansionLanes::PerCluster;
    perTriangle.lastExpansionLanes = traversal::ExpansionLanes::PerTriangle;
    small.traversalMemoryBytes = uint64_t(64) << 10;
    fixed.insert(fixed.end(), {{"screen order", screen}, {"hilbert order", hilbert}, {"clusters off", noClusters},
                               {"a lane a cluster pair", perCluster}, {"a lane a triangle pair", perTriangle},
                               {"a 64 KiB arena", small}});
  }
  std::vector<std::unique_ptr<ShadowMethod>> methods;
  std::vector<std::pair<std::string, ShadowMethod*>> named;
  for (const auto& [name, o] : fixed) {
    methods.push_back(makeConeMethod(test::context(), o));
    named.push_back({name, methods.back().get()});
  }
  SameMaskAs choices(named);
  std::mt19937_64 rng(20261207);
  std::uniform_real_distribution<float> u(-0.1f, 1.1f);
  uint64_t lit = 0;
  for (int k = 0; k < 5; ++k) {
    const std::string member = "family:" + std::to_string(41 + rng() % 1000000);
    const Scene scene = familyScene(parseFamilyArg(member));
    ASSERT_FALSE(scene.cameras.empty() || scene.lights.empty()) << member;
    const vec3 lo = scene.boundsMin, hi = scene.boundsMax;
    const vec3 drawn = lo + vec3(u(rng), u(rng), u(rng)) * (hi - lo);
    for (vec3 light : {scene.lights[0].position, drawn}) {
      const std::string what = member + " (" + std::to_string(scene.triangleCount()) + " triangles) light (" +
                               std::to_string(light.x) + ", " + std::to_string(light.y) + ", " + std::to_string(light.z) + ")";
      lit += Harness::get().run(scene, scene.cameras[0], light, 72, 56, what).error.litSamples;
    }
  }
  EXPECT_GT(lit, 5000u);  // the draws see geometry
}

// ---- glTF models ----------------------------------------------------------------------------------------

// The model on a ground plane a little below its bounds, so it casts shadows on something.
Scene onGround(Scene s) {
  s.computeBounds();
  const vec3 lo = s.boundsMin, hi = s.boundsMax, c = 0.5f * (lo + hi);
  const float r = 2.0f * glm::length(hi - lo);
  const float y = lo.y - 0.01f * (hi.y - lo.y);
  const uint32_t b = uint32_t(s.positions.size());
  s.positions.insert(s.positions.end(), {{c.x - r, y, c.z - r}, {c.x + r, y, c.z - r}, {c.x + r, y, c.z + r}, {c.x - r, y, c.z + r}});
  s.normals.insert(s.normals.end(), 4, vec3(0, 1, 0));
  s.indices.insert(s.indices.end(), {b, b + 2, b + 1, b, b + 3, b + 2});
  s.computeBounds();
  return s;
}

struct ModelCase {
  const char* file;
  uint32_t size;
};

TEST(ConeExactness, GltfModelsOnAGroundPlaneFromTwoLightsOneCloseToASurface) {
  // Undecided here: thin parts and touching surfaces within the band's offsets, and the light
  // 1e-3 of the diagonal above the ground, which grazes it.
  UndecidedAllowed ambiguous({"2CylinderEngine", "ClearCoat", "textureTransform"});
  const ModelCase models[] = {
      {"2CylinderEngine-glTF-Binary/2CylinderEngine.glb", 128},
      {"ClearCoat-glTF/ClearCoatTest.gltf", 128},
      {"textureTransform/TextureTransformTest.gltf", 96},
      {"glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube.gltf", 96},
  };
  for (const ModelCase& m : models) {
    std::ostringstream warn;
    Scene model = loadGltf(std::string(CONESHADOW_ASSIMP_MODELS) + "/" + m.file, warn);
    model.computeBounds();
    const vec3 lo = model.boundsMin, hi = model.boundsMax, c = 0.5f * (lo + hi), ext = hi - lo;
    Scene scene = onGround(model);
    const float diag = glm::length(ext);
    Camera cam = lookAt(c + vec3(0.55f, 0.45f, 0.7f) * diag, c, 0.8f);
    // Above the model; and just above the ground plane, beside the model (1e-3 of the diagonal).
    const vec3 lights[] = {c + vec3(0.2f * ext.x, 0.9f * diag, 0.3f * ext.z),
                           vec3(c.x + 0.3f * ext.x, lo.y + 1e-3f * diag, c.z + 0.45f * ext.z)};
    for (vec3 light : lights) {
      std::string what = std::string(m.file) + " light y=" + std::to_string(light.y);
      CaseResult r = Harness::get().run(scene, cam, light, m.size, m.size, what);
      EXPECT_GT(r.error.litSamples, 500u) << what;
    }
  }
}

// ---- the BART scenes paper 002 measured on --------------------------------------------------------------

TEST(ConeExactness, BartMuseumKitchenAndRobotsFromTheirViewsAndLights) {
  // Undecided here: the kitchen's touching furniture, within the band's offsets of each other.
  UndecidedAllowed ambiguous({"kitchen"});
  const std::string bart = CONESHADOW_BART_SCENES;
  if (!std::filesystem::exists(bart + "/museum/museum5.aff")) GTEST_SKIP() << "no BART scenes at " << bart;
  struct BartCase {
    const char* file;
    double time;
    uint32_t size;
  };
  for (const BartCase& c : {BartCase{"museum/museum5.aff", 2.0, 128}, BartCase{"kitchen/kitchen.aff", 0.0, 96},
                            BartCase{"robot/Robot.aff", 0.0, 64}}) {
    std::ostringstream warn;
    Scene scene = loadAff(bart + "/" + c.file, warn, c.time);
    for (const Camera& cam : scene.cameras)
      for (size_t l = 0; l < std::min<size_t>(scene.lights.size(), 2); ++l) {
        const std::string what = std::string(c.file) + " " + cam.name + " " + scene.lights[l].name;
        Harness::get().run(scene, cam, scene.lights[l].position, c.size, c.size, what);
      }
  }
}

// ---- hard cases -----------------------------------------------------------------------------------------

Scene soup(const std::vector<vec3>& positions, const char* name) {
  Scene s;
  s.name = name;
  s.positions = positions;
  for (uint32_t i = 0; i < positions.size(); ++i) s.indices.push_back(i);
  // Flat normals (every triangle has its own three vertices); degenerate triangles get +y.
  s.normals.assign(positions.size(), vec3(0, 1, 0));
  for (size_t t = 0; t + 2 < positions.size(); t += 3) {
    vec3 n = glm::cross(positions[t + 1] - positions[t], positions[t + 2] - positions[t]);
    float l = glm::length(n);
    if (l > 0 && std::isfinite(l)) s.normals[t] = s.normals[t + 1] = s.normals[t + 2] = n / l;
  }
  s.computeBounds();
  return s;
}

void addQuad(std::vector<vec3>& p, vec3 o, vec3 u, vec3 v) {
  p.insert(p.end(), {o, o + u, o + u + v, o, o + u + v, o + v});
}

// A floor with a few casters above it: boxes, a pyramid, a sloped card.
std::vector<vec3> floorAndCasters(float size = 10) {
  std::vector<vec3> p;
  addQuad(p, {-size, 0, -size}, {2 * size, 0, 0}, {0, 0, 2 * size});
  auto box = [&](vec3 lo, vec3 hi) {
    vec3 d = hi - lo;
    addQuad(p, lo, {d.x, 0, 0}, {0, d.y, 0});
    addQuad(p, lo + vec3(0, 0, d.z), {d.x, 0, 0}, {0, d.y, 0});
    addQuad(p, lo, {0, 0, d.z}, {0, d.y, 0});
    addQuad(p, lo + vec3(d.x, 0, 0), {0, 0, d.z}, {0, d.y, 0});
    addQuad(p, lo + vec3(0, d.y, 0), {d.x, 0, 0}, {0, 0, d.z});
    addQuad(p, lo, {d.x, 0, 0}, {0, 0, d.z});
  };
  box({-3, 0.5f, -2}, {-1, 1.5f, 0});
  box({1, 0, 1}, {2.5f, 3, 2});
  addQuad(p, {0, 1, -3}, {2, 0.5f, 0}, {0, 1.5f, 1});
  return p;
}

TEST(ConeHardCases, LightAHairAwayFromALargeWall) {
  // A light 1e-4 from the wall: most rays graze it.
  UndecidedAllowed ambiguous({"hair-wall"});
  // Light 1e-4 from a huge wall (z = 0), the camera looking at the wall and the floor: the cones of the
  // wall's own samples are nearly hemispheres (past pi/2 - eps: the complementary-cone path).
  std::vector<vec3> p = floorAndCasters();
  addQuad(p, {-10, 0, -4}, {20, 0, 0}, {0, 8, 0});  // the wall z = -4
  Scene scene = soup(p, "hair-wall");
  const vec3 light(0.4f, 2.0f, -4.0f + 1e-4f);
  for (vec3 eye : {vec3(0.5f, 3, 6), vec3(6, 1, -2)}) Harness::get().run(scene, lookAt(eye, {0, 1.5f, -4}), light, 128, 128, "hair-wall");
}

TEST(ConeHardCases, LightExactlyInATrianglesPlane) {
  // The light at y = 1 exactly, in the plane of a horizontal card at y = 1 and of the floor's extension;
  // the card's own samples see rays that lie in its plane.
  std::vector<vec3> p = floorAndCasters();
  addQuad(p, {-4, 1, 2}, {3, 0, 0}, {0, 0, 2});      // horizontal card at y = 1
  addQuad(p, {2, 0, -6}, {0, 5, 0}, {3, 0, 0});      // vertical card in the plane x = 2 ...
  Scene scene = soup(p, "light-in-plane");
  for (vec3 light : {vec3(0.3f, 1.0f, 2.7f), vec3(2.0f, 2.2f, -1.0f)})  // ... whose plane holds the second light
    Harness::get().run(scene, lookAt({5, 6, 8}, {0, 0.5f, 0}), light, 128, 128, "light-in-plane");
}

TEST(ConeHardCases, SampleAtTheLight) {
  // Samples at the light: their rays are shorter than the band's offsets.
  UndecidedAllowed ambiguous({"sample-at-light"});
  // The light sits exactly on the floor (y = 0) and on a box corner: samples at (or within eps of) the
  // light have empty rays and must stay lit, with no NaN anywhere.
  std::vector<vec3> p = floorAndCasters();
  Scene scene = soup(p, "sample-at-light");
  // On the floor (the camera sees the box faces turned to the light), and on a box corner.
  const vec3 onFloor(0.25f, 0.0f, 0.25f), onCorner(-1.0f, 1.5f, 0.0f);
  for (auto [light, eye] : {std::pair{onFloor, vec3(-3, 2.5f, -5)}, std::pair{onCorner, vec3(0.3f, 3, 3)},
                            std::pair{onCorner, vec3(-0.5f, 2.5f, 1.5f)}}) {
    CaseResult r = Harness::get().run(scene, lookAt(eye, light), light, 128, 128, "sample-at-light");
    EXPECT_GT(r.error.litSamples, 300u);
  }
}

TEST(ConeHardCases, SliversAndZeroAreaTriangles) {
  std::vector<vec3> p = floorAndCasters();
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1, 1);
  for (int i = 0; i < 400; ++i) {
    vec3 a(u(rng) * 4, 1.5f + u(rng), u(rng) * 4), d(u(rng), u(rng) * 0.2f, u(rng));
    switch (i % 4) {
      case 0: p.insert(p.end(), {a, a + d, a + d * 0.5f}); break;                           // collinear
      case 1: p.insert(p.end(), {a, a, a + d}); break;                                       // repeated vertex
      case 2: p.insert(p.end(), {a, a, a}); break;                                           // a point
      default: p.insert(p.end(), {a, a + d, a + 0.5f * d + vec3(0, 1e-4f, 0)}); break;     // sliver
    }
  }
  Scene scene = soup(p, "slivers");
  Harness::get().run(scene, lookAt({5, 6, 8}, {0, 0.5f, 0}), vec3(0.3f, 4.0f, 0.5f), 128, 128, "slivers");
}

TEST(ConeHardCases, SceneTranslatedFarFromTheOrigin) {
  // At 1e5 from the origin the epsilon floor (32 ulp) widens the band.
  UndecidedAllowed ambiguous({"translated 1e5"});
  const vec3 offset(1e5f, -1e5f, 1e5f);
  std::vector<vec3> p = floorAndCasters();
  for (vec3& v : p) v += offset;
  Scene scene = soup(p, "translated");
  Camera cam = lookAt(offset + vec3(5, 6, 8), offset + vec3(0, 0.5f, 0));
  Harness::get().run(scene, cam, offset + vec3(0.3f, 4.0f, 0.5f), 128, 128, "translated 1e5");
}

TEST(ConeHardCases, CoplanarAndTouchingOccluders) {
  std::vector<vec3> p = floorAndCasters();
  // Two coplanar cards sharing an edge, a third overlapping them in the same plane, and a box resting
  // on the floor (touching it along its bottom face).
  addQuad(p, {-2, 2, -1}, {2, 0, 0}, {0, 0, 2});
  addQuad(p, {0, 2, -1}, {2, 0, 0}, {0, 0, 2});
  addQuad(p, {-1, 2, 0}, {2, 0, 0}, {0, 0, 2});
  addQuad(p, {-4, 0, 3}, {1, 0, 0}, {0, 1, 0});
  addQuad(p, {-4, 0, 3}, {0, 0, 1}, {0, 1, 0});
  Scene scene = soup(p, "coplanar");
  Harness::get().run(scene, lookAt({5, 6, 8}, {0, 0.5f, 0}), vec3(0.1f, 4.0f, 0.2f), 128, 128, "coplanar");
}

TEST(ConeHardCases, LightInsideAClosedMesh) {
  // A closed box around the light, the camera inside it too: every sample is shadowed by nothing but
  // itself, except that the casters inside the box shadow the walls.
  std::vector<vec3> p;
  auto box = [&](vec3 lo, vec3 hi) {
    vec3 d = hi - lo;
    addQuad(p, lo, {d.x, 0, 0}, {0, d.y, 0});
    addQuad(p, lo + vec3(0, 0, d.z), {d.x, 0, 0}, {0, d.y, 0});
    addQuad(p, lo, {0, 0, d.z}, {0, d.y, 0});
    addQuad(p, lo + vec3(d.x, 0, 0), {0, 0, d.z}, {0, d.y, 0});
    addQuad(p, lo + vec3(0, d.y, 0), {d.x, 0, 0}, {0, 0, d.z});
    addQuad(p, lo, {d.x, 0, 0}, {0, 0, d.z});
  };
  box({-5, 0, -5}, {5, 5, 5});
  box({1, 1, 1}, {2, 2, 2});
  box({-2, 3, -1}, {-1, 3.5f, 1});
  Scene scene = soup(p, "closed");
  Harness::get().run(scene, lookAt({-4, 4, 4}, {0, 1.5f, 0}, 1.3f), vec3(0.2f, 2.5f, 0.3f), 128, 128, "light inside");
  // And the light inside a closed box seen from outside: everything outside is shadowed.
  Harness::get().run(scene, lookAt({3, 3.8f, 3}, {0, 0, 0}, 1.3f), vec3(1.5f, 1.5f, 1.5f), 96, 96, "light in the small box");
}

TEST(ConeHardCases, OneHugeTriangleCoveringTheView) {
  // A light a hair above the triangle grazes all of it.
  UndecidedAllowed ambiguous({"huge, light a hair above"});
  // One triangle (z = 0) far larger than the view, a second one between it and the light, far enough
  // from both that the epsilon (1e-4 of the 5.6e3 diagonal) does not swallow it.
  std::vector<vec3> p = {{-2e3f, -2e3f, 0}, {2e3f, -2e3f, 0}, {0, 2e3f, 0}, {-20, -15, 40}, {25, -10, 40}, {0, 20, 40}};
  Scene scene = soup(p, "huge");
  const Camera cam = lookAt({10, 5, 300}, {0, 0, 0});
  CaseResult r = Harness::get().run(scene, cam, vec3(3, 2, 80), 128, 128, "huge");
  EXPECT_GT(r.shadowed, 200u);  // the occluder's shadow: ~3 % of the view
  // Only the huge triangle: nothing can shadow it; and a light a hair above it.
  Scene alone = soup({p[0], p[1], p[2]}, "huge alone");
  r = Harness::get().run(alone, cam, vec3(3, 2, 80), 64, 64, "huge alone");
  EXPECT_EQ(r.shadowed, 0u);
  Harness::get().run(scene, cam, vec3(3, 2, 1e-2f), 128, 128, "huge, light a hair above");
}

TEST(ConeHardCases, NonFiniteTrianglesAreDroppedAsEmbreeDropsThem) {
  // The loader refuses non-finite files; a scene built in code may still carry such triangles. The cone
  // method drops them (Embree's builder skips them too); raster and reference see the finite scene.
  std::vector<vec3> p = floorAndCasters();
  Scene scene = soup(p, "finite");
  p.insert(p.end(), {{NAN, 1, 1}, {1, 2, 1}, {1, 1, 2}, {INFINITY, 1, 1}, {1, 2, 1}, {1, 1, 2}});
  Scene withNonFinite = soup(p, "non-finite");
  CaseResult r = Harness::get().run(scene, lookAt({5, 6, 8}, {0, 0.5f, 0}), vec3(0.3f, 4.0f, 0.5f), 96, 96,
                                    "non-finite", &withNonFinite);
  EXPECT_EQ(r.stats["triangles_dropped"].get<uint64_t>(), 2u);
}

// ---- far lights (issue 14) ---------------------------------------------------------------------------------
// A point light standing in for the sun: 10 to 10^5 scene diagonals away, from above, along a coordinate
// axis and in the plane of the floor. Relative to the light, the vertices and the hit distance of a
// triangle next to a sample round to an ulp of L, which passes eps from ~10^2 diagonals on: the leaf test
// must measure from the sample's end there (precise_test.h, leafHit).

vec3 farLight(vec3 centre, float diagonal, float k, vec3 dir) { return centre + (k * diagonal) * glm::normalize(dir); }

TEST(ConeHardCases, FarLightsFromTenToATenThousandThousandDiagonals) {
  Scene scene = soup(floorAndCasters(), "far-light");
  const vec3 c = 0.5f * (scene.boundsMin + scene.boundsMax);
  const float diag = glm::length(scene.boundsMax - scene.boundsMin);
  const Camera cam = lookAt({5, 6, 8}, {0, 0.5f, 0});
  // The same view with a light of its own, above the casters: the pairs a far light may cost at most 2x of
  // (issue 14), in the far-light frame (traversal.h) from 4 diagonals on.
  const uint64_t ownPairs =
      Harness::get().run(scene, cam, vec3(0.3f, 4.0f, 0.5f), 96, 96, "own light").stats["pairs_tested"].get<uint64_t>();
  for (float k : {10.0f, 1e2f, 1e3f, 1e4f, 1e5f}) {
    const vec3 lights[] = {
        farLight(c, diag, k, {0.3f, 1.0f, 0.2f}),                      // from above, off every axis
        vec3(0.25f, k * diag, -0.5f),                                  // along the y axis
        vec3(k * diag * 0.94f, 0.0f, k * diag * 0.34f),                // in the floor's plane (y = 0)
        farLight(c, diag, k, {-0.7f, 0.35f, 0.6f}),                    // low, from the other side
    };
    for (vec3 light : lights) {
      std::ostringstream what;
      what << "far light " << k << " diagonals at (" << light.x << ", " << light.y << ", " << light.z << ")";
      CaseResult r = Harness::get().run(scene, cam, light, 96, 96, what.str());
      EXPECT_EQ(r.stats["frame"].get<std::string>(), "far") << what.str();
      EXPECT_LE(r.stats["pairs_tested"].get<uint64_t>(), 2 * ownPairs) << what.str() << " (own light: " << ownPairs << ")";
      // The far frame's key is the world's width (a grid fitted to the rays, rays/hilbert.h frameKeyGrid):
      // its sort takes two radix passes, not the four of a grid over the whole scene's projection.
      const uint32_t keyBits = r.stats["ray_key_bits"].get<uint32_t>();
      EXPECT_EQ(keyBits, rays::kRayKeyBits) << what.str();
      EXPECT_EQ(sort::radixPasses(keyBits), 2u) << what.str();
    }
  }
}

TEST(ConeHardCases, FarLightsUpToTheDocumentedLimitAndAClearErrorPastIt) {
  // At 2^62 the light nudge's floor (4 ulp of the light) is a visible angle.
  UndecidedAllowed ambiguous({"4.5e18"});
  // Up to 2^62 from the scene (method/epsilon.h, kMaxLightDistance): exact outside the band, however
  // wide the band grows; past it, the cone path refuses the frame instead of a silently lit mask.
  Scene scene = soup(floorAndCasters(), "far-light limit");
  const vec3 c = 0.5f * (scene.boundsMin + scene.boundsMax);
  const float diag = glm::length(scene.boundsMax - scene.boundsMin);
  const Camera cam = lookAt({5, 6, 8}, {0, 0.5f, 0});
  for (float k : {1e8f, 1e12f, 1e16f})
    Harness::get().run(scene, cam, farLight(c, diag, k, {0.3f, 1.0f, 0.2f}), 64, 64,
                       "far light 1e" + std::to_string(int(std::log10(k))) + " diagonals");
  Harness::get().run(scene, cam, vec3(0.3f, 4.5e18f, 0.2f), 64, 64, "far light 4.5e18 (just inside 2^62)");

  const vec3 tooFar(0.3f, 4.7e18f, 0.2f);
  EXPECT_FALSE(lightRangeProblem(vec3(0.3f, 4.5e18f, 0.2f), scene.boundsMin, scene.boundsMax).size());
  EXPECT_NE(lightRangeProblem(tooFar, scene.boundsMin, scene.boundsMax).find("move it closer"), std::string::npos);
  EXPECT_NE(lightRangeProblem(vec3(0, INFINITY, 0), scene.boundsMin, scene.boundsMax), "");
  test::ReferenceFrame near(scene, cam, c + vec3(0, 5, 0), 16);
  near.input.light = tooFar;
  try {
    Harness::get().cones[0]->run(near.input);
    ADD_FAILURE() << "a light past the limit was not refused";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cone path: the light at"), std::string::npos) << e.what();
  }
}

TEST(ConeHardCases, FarLightOnTheBuiltinSceneAndAGltfModel) {
  // The engine's touching parts, as in the glTF test above.
  UndecidedAllowed ambiguous({"2CylinderEngine, far light"});
  // The closed built-in room from outside (every sample behind a wall) and open: its casters alone.
  Scene builtin = builtinScene();
  const float bdiag = glm::length(builtin.boundsMax - builtin.boundsMin);
  const vec3 bc = 0.5f * (builtin.boundsMin + builtin.boundsMax);
  for (float k : {10.0f, 1e3f, 1e5f})
    Harness::get().run(builtin, *builtin.findCamera("wall"), farLight(bc, bdiag, k, {0.2f, 1.0f, 0.4f}), 64, 64,
                       "builtin/wall, far light " + std::to_string(int(k)) + " diagonals");
  std::ostringstream warn;
  Scene engine = onGround(loadGltf(std::string(CONESHADOW_ASSIMP_MODELS) + "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb", warn));
  const vec3 lo = engine.boundsMin, hi = engine.boundsMax, ec = 0.5f * (lo + hi);
  const float ediag = glm::length(hi - lo);
  const Camera cam = lookAt(ec + vec3(0.2f, 0.25f, 0.3f) * ediag, ec, 0.8f);
  for (float k : {10.0f, 1e3f})
    Harness::get().run(engine, cam, farLight(ec, ediag, k, {0.3f, 1.0f, 0.2f}), 64, 64,
                       "2CylinderEngine, far light " + std::to_string(int(k)) + " diagonals");
}

TEST(ConeHardCases, FarLightsGrazingTheWallsOfTheClosedRoom) {
  // Grazing the back wall: which side of its edge with the ceiling a ray passes is rounding's choice.
  UndecidedAllowed ambiguous({"builtin/room, light ("});
  // The built-in room is closed: a light outside shadows every sample, through its walls. In the plane
  // z = 0 and far, the light grazes the back wall (z = -7, N.L down to 10^-13): the rays run along it and
  // meet the ceiling a hair from the edge the two share. From 10^6 on, the precise test in the far frame
  // rejected such pairs while the frame's rotation left the light D 2^-24 off its axis (coordinates
  // relative to it rounded to 0.004 at 10^13; ConeFrame's shear); a sample the raster left an ulp
  // behind the back wall threads the crack at the edge, which only a start behind the surface shows to
  // be rounding's choice (method/epsilon.h). The work stays that of the nearest of these lights: at 10^9 and
  // 10^11 the triangles' bounding spheres had grown to an ulp of the distance (sphere_test.h) and the
  // pairs eightfold.
  Scene scene = builtinScene();
  const Camera cam = *scene.findCamera("room");
  uint64_t nearest = 0;
  for (float d : {1e6f, 1e9f, 1e11f, 1e13f, 1e17f}) {
    const vec3 light(d, 0.3f * d, 0.0f);
    const std::string what = "builtin/room, light (" + std::to_string(d) + ", 0.3 of it, 0)";
    CaseResult r = Harness::get().run(scene, cam, light, 96, 96, what);
    EXPECT_EQ(r.stats["frame"].get<std::string>(), "far");
    const uint64_t pairs = r.stats["pairs_tested"].get<uint64_t>();
    if (!nearest) nearest = pairs;
    EXPECT_LE(2 * pairs, 3 * nearest) << what << ": " << pairs << " pairs, " << nearest << " at 10^6";
  }
}

// The leaf test from the light (traversal.h LeafTest) runs up to the far frame's threshold (8
// half-diagonals from the centre of the bounds), where its rays are longest: just inside it, exact and
// within the band of the two ends' test (Harness::run runs both); just outside, the far frame and the
// test from the sample (within the band of the two ends' test too).
TEST(ConeHardCases, LightsEitherSideOfTheFarFramesThreshold) {
  Scene scene = soup(floorAndCasters(), "threshold");
  const vec3 c = 0.5f * (scene.boundsMin + scene.boundsMax);
  const float diag = glm::length(scene.boundsMax - scene.boundsMin);
  const Camera cam = lookAt({5, 6, 8}, {0, 0.5f, 0});
  for (const vec3 dir : {vec3(0.3f, 1.0f, 0.2f), vec3(-0.7f, 0.35f, 0.6f)}) {
    for (float k : {3.9f, 4.1f}) {  // diagonals: 7.8 and 8.2 half-diagonals
      const std::string what = "floor and casters, light " + std::to_string(k) + " diagonals";
      const CaseResult r = Harness::get().run(scene, cam, farLight(c, diag, k, dir), 96, 96, what);
      EXPECT_EQ(r.stats["frame"], k < 4.0f ? "world" : "far") << what;
      EXPECT_EQ(r.stats["leaf_test"], k < 4.0f ? "from_light" : "from_sample") << what;
      EXPECT_GT(r.shadowed, 0u) << what;
      EXPECT_LT(r.shadowed, r.error.litSamples) << what;
    }
  }
}

TEST(ConeHardCases, FarLightMaskIsBitIdenticalAtEveryArenaSize) {
  // The far-light frame under bounded memory: the minimal arena (one node's children per depth, chunks of
  // one pair) and a small one give the default's mask bit for bit, for the default and two-pass variants.
  Scene scene = soup(floorAndCasters(), "far-light arena");
  const vec3 c = 0.5f * (scene.boundsMin + scene.boundsMax);
  const float diag = glm::length(scene.boundsMax - scene.boundsMin);
  test::ReferenceFrame f(scene, lookAt({5, 6, 8}, {0, 0.5f, 0}), farLight(c, diag, 1e3f, {0.3f, 1.0f, 0.2f}), 64);
  for (const char* variant : {"PreciseSorted", "PreciseSEATP", "Spheres"}) {
    ConeOptions base;
    ASSERT_TRUE(applyConeVariant(variant, base));
    test::ConeRun plain = test::runExactCone(f, base, std::string("far light 1e3 ") + variant);
    EXPECT_EQ(plain.stats["frame"].get<std::string>(), "far");
    const uint32_t depth = cone::treeDepth(uint32_t(f.host.litCount()));
    ConeOptions small = base, least = base;
    small.traversalMemoryBytes = 9000;
    test::useLeastArena(least, depth);
    for (const ConeOptions& o : {small, least}) {
      test::ConeRun r = test::runExactCone(f, o, std::string("far light 1e3 ") + variant + " " +
                                                     std::to_string(o.traversalMemoryBytes) + " B");
      EXPECT_TRUE(test::sameBits(plain.mask, r.mask)) << variant << " at " << o.traversalMemoryBytes << " bytes (" << r.stats["traversal_path"] << ")";
    }
  }
}

TEST(ConeHardCases, FarLightOnTheBartMuseum) {
  const std::string bart = CONESHADOW_BART_SCENES;
  if (!std::filesystem::exists(bart + "/museum/museum5.aff")) GTEST_SKIP() << "no BART scenes at " << bart;
  std::ostringstream warn;
  Scene scene = loadAff(bart + "/museum/museum5.aff", warn, 2.0);
  scene.computeBounds();
  const vec3 c = 0.5f * (scene.boundsMin + scene.boundsMax);
  const float diag = glm::length(scene.boundsMax - scene.boundsMin);
  ASSERT_FALSE(scene.cameras.empty());
  for (float k : {10.0f, 1e3f, 1e5f})
    Harness::get().run(scene, scene.cameras.front(), farLight(c, diag, k, {0.2f, 1.0f, 0.35f}), 64, 64,
                       "museum5, far light " + std::to_string(int(k)) + " diagonals");
}

TEST(ConeHardCases, SceneFarFromTheOriginLitFromFarAway) {
  // As SceneTranslatedFarFromTheOrigin.
  UndecidedAllowed ambiguous({"translated 1e5"});
  const vec3 offset(1e5f, -1e5f, 1e5f);
  std::vector<vec3> p = floorAndCasters();
  for (vec3& v : p) v += offset;
  Scene scene = soup(p, "translated, far light");
  const float diag = glm::length(scene.boundsMax - scene.boundsMin);
  Camera cam = lookAt(offset + vec3(5, 6, 8), offset + vec3(0, 0.5f, 0));
  for (float k : {1e2f, 1e4f})
    Harness::get().run(scene, cam, farLight(offset, diag, k, {0.3f, 1.0f, 0.2f}), 96, 96,
                       "translated 1e5, light " + std::to_string(int(k)) + " diagonals away");
}

TEST(ConeHardCases, LightExactlyOnAVertexAndOnAnEdge) {
  // A light on an edge: rays from the edge's neighbours graze both its triangles.
  UndecidedAllowed ambiguous({"light on a vertex / edge"});
  // Box 2 of floorAndCasters spans (1, 0, 1)-(2.5, 3, 2): its top corner (1, 3, 1) and the midpoint of
  // its top edge along x, (1.75, 3, 1), both exact in fp32.
  Scene scene = soup(floorAndCasters(), "light-on-vertex");
  for (vec3 light : {vec3(1.0f, 3.0f, 1.0f), vec3(1.75f, 3.0f, 1.0f), vec3(2.5f, 3.0f, 1.5f)})
    for (vec3 eye : {vec3(5, 6, 8), vec3(-4, 5, -5)})
      Harness::get().run(scene, lookAt(eye, {0, 0.5f, 0}), light, 96, 96, "light on a vertex / edge");
}

TEST(ConeHardCases, LightInsideAThinSlab) {
  // Two parallel plates 10x10, 0.05 apart (4 times the band's largest normal offset, 1e-3 of the
  // diagonal), the light between them, and cards standing between the plates: every lit sample's ray runs
  // nearly in the plates' plane, the cones near hemispheres.
  std::vector<vec3> p;
  addQuad(p, {-5, 1.0f, -5}, {0, 0, 10}, {10, 0, 0});      // lower plate, facing up
  addQuad(p, {-5, 1.05f, -5}, {10, 0, 0}, {0, 0, 10});     // upper plate, facing down
  for (int i = 0; i < 6; ++i) {
    float x = -3.0f + float(i), z = 0.5f * float(i % 3) - 0.5f;
    addQuad(p, {x, 1.0f, z}, {0.9f, 0, 0.6f}, {0, 0.05f, 0});
    addQuad(p, {x, 1.0f, z}, {0, 0.05f, 0}, {0.9f, 0, 0.6f});  // both sides
  }
  Scene scene = soup(p, "thin slab");
  const vec3 light(0.1f, 1.025f, 0.2f);
  Harness::get().run(scene, lookAt({4.0f, 1.025f, 4.0f}, {0, 1.025f, 0}, 1.2f), light, 96, 96, "light in a thin slab");
  Harness::get().run(scene, lookAt({0.3f, 1.04f, 0.4f}, {-3, 1.01f, -1}, 1.2f), light, 96, 96, "light in a thin slab, near");
}

// Lights 1 to 10^16 scene diagonals outside closed and nearly closed scenes (issue 48): the built-in room
// seen from inside (every sample behind a wall from the light), a closed box over a plane, a plane under
// a slab a thousandth of the diagonal thick. From above, off every axis and straight along one; every
// frame decided (its band under 1 % of the lit samples) and exact, most samples in shadow.
TEST(ConeHardCases, FarLightsOutsideClosedScenesAreExactAndDecided) {
  std::vector<vec3> boxOverPlane, slab;
  auto box = [](std::vector<vec3>& p, vec3 lo, vec3 hi) {  // closed, faces outward
    vec3 d = hi - lo;
    addQuad(p, lo, {0, d.y, 0}, {d.x, 0, 0});
    addQuad(p, lo + vec3(0, 0, d.z), {d.x, 0, 0}, {0, d.y, 0});
    addQuad(p, lo, {0, 0, d.z}, {0, d.y, 0});
    addQuad(p, lo + vec3(d.x, 0, 0), {0, d.y, 0}, {0, 0, d.z});
    addQuad(p, lo + vec3(0, d.y, 0), {0, 0, d.z}, {d.x, 0, 0});
    addQuad(p, lo, {d.x, 0, 0}, {0, 0, d.z});
  };
  addQuad(boxOverPlane, {-6, 0, -6}, {0, 0, 12}, {12, 0, 0});
  box(boxOverPlane, {-2, 1, -2}, {2, 3, 2});
  addQuad(slab, {-6, 0, -6}, {0, 0, 12}, {12, 0, 0});
  box(slab, {-3, 1, -3}, {3, 1.017f, 3});  // 1/1000 of the diagonal
  struct Case {
    Scene scene;
    Camera camera;
  };
  Scene room = builtinScene();
  std::vector<Case> cases = {{room, *room.findCamera("room")},
                             {soup(boxOverPlane, "box over a plane"), lookAt({0.3f, 0.6f, 0.2f}, {-5, 0, -4}, 1.3f)},
                             {soup(slab, "plane under a thin slab"), lookAt({0.2f, 0.5f, 0.3f}, {-4, 0, -5}, 1.3f)}};
  for (Case& c : cases) {
    const vec3 centre = 0.5f * (c.scene.boundsMin + c.scene.boundsMax);
    const float diag = glm::length(c.scene.boundsMax - c.scene.boundsMin);
    for (float k : {1.0f, 1e2f, 1e4f, 1e8f, 1e12f, 1e16f})
      for (vec3 dir : {vec3(0.3f, 1.0f, 0.2f), vec3(0.0f, 1.0f, 0.0f), vec3(-0.6f, 0.8f, 0.45f)}) {
        if (dir.x == 0 && c.scene.name == room.name) continue;  // straight up grazes the room's walls: below
        std::ostringstream what;
        what << c.scene.name << ", light " << k << " diagonals toward (" << dir.x << ", " << dir.y << ", " << dir.z << ")";
        const vec3 light = farLight(centre, diag, k + 0.5f, dir);
        CaseResult r = Harness::get().run(c.scene, c.camera, light, 64, 64, what.str());
        EXPECT_GT(r.error.litSamples, 1000u) << what.str();
        EXPECT_GT(r.shadowed, r.error.litSamples / 2) << what.str();
      }
  }
}

// The example of issue 48: the light straight above the closed room, a hair off the axis, so every wall
// faces it at a grazing 10^-8 rad and every ray from a wall runs along it to the edge where it meets the
// ceiling. Which side of that edge a ray passes is fp32 rounding's choice (a sample an ulp behind its
// wall escapes the room), so the band holds nearly every wall sample: the frame is undecided, and says so.
TEST(ConeHardCases, AFrameWhoseBandCoversItsSamplesIsUndecided) {
  Scene scene = builtinScene();
  test::ReferenceFrame f(scene, *scene.findCamera("wall"), vec3(1.3f, 1e8f, -0.7f), 64);
  auto cone = makeConeMethod(test::context());
  const MethodOutput out = cone->run(f.input);
  const ErrorStats e = compareVisibility(f.host, out.visibility, f.reference, f.band);
  EXPECT_TRUE(e.undecided) << e.bandSamples << " of " << e.litSamples << " in the band";
  EXPECT_GT(e.bandFraction, 0.5);
  EXPECT_NE(e.undecidedReason().find("no count outside the band judges this frame"), std::string::npos);
  const nlohmann::json j = toJson(e);
  EXPECT_EQ(j["undecided"], true);
  EXPECT_DOUBLE_EQ(j["band_fraction"].get<double>(), e.bandFraction);
}

}  // namespace
}  // namespace cs
