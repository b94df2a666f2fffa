// Shared setup of the cone-path tests: a camera from two points, quads for hand-built scenes, one frame
// rendered once with its Embree reference and ambiguity band, which every configuration under test is
// judged against, and the run of one cone configuration on it, checked exact.
#pragma once
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "judge/metrics.h"
#include "harness/harness.h"
#include "harness/run.h"
#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "method/epsilon.h"
#include "tests/test_context.h"
#include "traversal/cone_method.h"

namespace cs::test {

inline Camera lookAt(glm::vec3 eye, glm::vec3 target, float yfov = 0.9f) {
  Camera c;
  c.eye = eye;
  c.target = target;
  c.yfov = yfov;
  c.znear = 0.01f;
  c.zfar = 1e4f;
  return c;
}

// The least arena a traversal of a tree of `depth` runs in (traversal::minimumPairs pairs, one node's
// children per depth, in chunks of a single pair), set on `o` as its arena and its memory bound.
inline void useLeastArena(ConeOptions& o, uint32_t depth) {
  o.arena = {traversal::minimumPairs(depth), 1, traversal::minimumPairs(depth) * 8 + traversal::chunkScratchBytes(1)};
  o.traversalMemoryBytes = o.arena.bytes;
}

// Appends the quad o, o + du, o + du + dv, o + dv (two triangles, normal du x dv) to a hand-built scene.
inline void addQuad(Scene& s, glm::vec3 o, glm::vec3 du, glm::vec3 dv) {
  const uint32_t b = uint32_t(s.positions.size());
  s.positions.insert(s.positions.end(), {o, o + du, o + du + dv, o + dv});
  s.normals.insert(s.normals.end(), 4, glm::normalize(glm::cross(du, dv)));
  s.indices.insert(s.indices.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
}

// One frame prepared by the run entry (harness/run.h: samples, epsilon, the Embree reference, the band),
// untimed and with no method judged; the names the cone tests read it by.
struct ReferenceFrame {
  std::unique_ptr<PreparedFrame> prepared;
  GBuffer& host;
  DeviceGBuffer& dev;
  EpsilonPolicy& policy;
  FrameInput& input;
  std::vector<float>& reference;
  std::vector<uint8_t>& band;
  ReferenceFrame(const Scene& scene, const Camera& camera, glm::vec3 light, uint32_t size)
      : prepared(prepare(scene, camera, light, size)),
        host(prepared->gbuffer),
        dev(prepared->device),
        policy(prepared->policy),
        input(prepared->input),
        reference(prepared->reference.output.visibility),
        band(prepared->band) {}

 private:
  static std::unique_ptr<PreparedFrame> prepare(const Scene& scene, const Camera& camera, glm::vec3 light, uint32_t size) {
    harness::RunSpec s;
    s.scene = &scene;
    s.views = {{camera, camera.name}};
    s.lights = {light};
    s.width = s.height = size;
    s.frames = 0;  // one run each, untimed
    s.keepFrames = true;
    return std::move(harness::run(context(), s).frames.front().prepared);
  }
};

inline bool sameBits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

struct ConeRun {
  std::vector<float> mask;
  uint64_t pairs = 0;  // stats.pairs_tested
  nlohmann::json stats;
};

// Past this share of the lit samples in the band, a frame's exactness check is vacuous.
inline constexpr double kSwallowedBandFraction = 0.5;

// Runs one cone configuration on the frame and expects zero misclassified samples outside the band and
// the stats to name its variant; prints a line of its counts (and two-pass's, when on).
inline ConeRun runExactCone(ReferenceFrame& f, const ConeOptions& o, const std::string& what) {
  auto method = makeConeMethod(context(), o);
  MethodOutput out = method->run(f.input);
  ErrorStats e = compareVisibility(f.host, out.visibility, f.reference, f.band);
  // These runs compare configurations on the built-in views, several of them undecided by the 1 % rule
  // (ConeExactness names which); a band that swallowed most of the frame would prove nothing at all.
  EXPECT_LE(e.bandFraction, kSwallowedBandFraction) << what << ": the band holds " << e.bandSamples << " of "
                                                    << e.litSamples << " lit samples";
  EXPECT_EQ(e.misclassifiedOutsideBand, 0u) << what << ": " << e.falseShadowOutsideBand << " false shadow, "
                                            << e.falseLightOutsideBand << " false light (of " << e.litSamples << " lit)";
  EXPECT_EQ(out.stats["variant"].get<std::string>(), coneVariantName(o)) << what;
  ConeRun r;
  r.mask = std::move(out.visibility);
  r.pairs = out.stats["pairs_tested"].get<uint64_t>();
  r.stats = std::move(out.stats);
  std::printf("  %-44s lit %6llu pairs tested %10llu early accepted %7llu leaf tests %10llu",
              what.c_str(), (unsigned long long)e.litSamples, (unsigned long long)r.pairs,
              (unsigned long long)r.stats["early_accepted_nodes"].get<uint64_t>(),
              (unsigned long long)r.stats["leaf_tests"].get<uint64_t>());
  const nlohmann::json& tp = r.stats["two_pass"];
  if (tp.is_object())
    std::printf("  blockers %u finished in pass one %u update: %s", tp["blockers"].get<unsigned>(),
                tp["rays_finished_pass_one"].get<unsigned>(), tp["update"].get<std::string>().c_str());
  std::printf("\n");
  return r;
}

}  // namespace cs::test
