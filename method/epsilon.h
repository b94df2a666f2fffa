// The shared epsilon policy: how far from its ends a shadow ray starts and stops counting hits, and the
// family of perturbed rays whose disagreement defines the ambiguity band (docs/ARCHITECTURE.md, "Error metric and ambiguity band").
//
// Every method and every checker uses these numbers; they are, with s = the diagonal of the scene's
// bounding box (computed from the positions) and M = the largest |coordinate| of any scene position:
//
//   floor = 32 · FLT_EPSILON · M          32 fp32 ulps of the largest coordinate (FLT_EPSILON = 2^-23 is
//                                          one ulp at 1.0). Positions are fp32, and so are the raster's
//                                          interpolated sample positions and Embree's intersection maths;
//                                          their rounding is a few ulps of M, so a surface can appear up
//                                          to that far from where the sample sits. 32 ulps leaves an 8x
//                                          margin. Never below FLT_MIN (only an empty scene reaches it).
//   eps   = max(1e-4 · s, floor)          the along-ray epsilon. For a scene of diagonal s near the origin
//                                          1e-4·s dominates; for a scene translated 1e5 from the origin
//                                          the floor dominates (M = 1e5 -> floor = 0.381).
//
// Base answer (the reference, and what every method is judged against): the ray from the sample p toward
// the light l, origin = p, unit direction d = (l - p) / L with L = |l - p|, counting hits with
// t in (eps, L - eps). A ray that reaches the light is unoccluded: the light is a point, not a surface.
// Geometry within eps of the sample does not count (the sample's own surface, rounding), nor geometry
// within eps of the light (a surface through the light cannot be resolved in fp32 either; those samples
// land in the band through the ray-end members below). When L <= 2·eps the ray is empty: lit.
//
// The band family. Each member is a perturbed ray; a sample is in the ambiguity band when ANY member's
// answer (occluded or not) differs from the base answer. Every along-ray / along-normal distance below
// is floored (max(x, floor)).
//   start along the ray : origin p, t in (a, L - eps),                  a ∈ {1e-5, 1e-4, 1e-3} · s
//   start along normal  : origin p' = p + a·n, t in (0, L' - eps),      a ∈ {1e-5, 1e-4, 1e-3} · s,
//                         n = the sample's normal (faces the light for lit samples), L' = |l - p'|
//                         (the normal offset replaces the along-ray epsilon, as a normal-offset bias does)
//   light nudged aside  : light l' = l ± δ·u or l ± δ·v, (u, v) an orthonormal pair perpendicular to d;
//                         origin p, t in (eps, L' - eps), L' = |l' - p|;
//                         δ = max(1e-4 · s, 4 · FLT_EPSILON · max(M, largest |coordinate| of l)):
//                         its own, smaller floor of 4 ulps, only so that the nudge survives fp32 rounding
//                         of l' (the 32-ulp floor would move the shadow of a far-translated scene by a
//                         visible amount: 0.19 at 1e5)
//   end along the ray   : origin p, t in (eps, L - e),                  e ∈ {0, 1e-5, 1e-3} · s
//                         (e = 0 floors to `floor`: catches geometry between floor and eps of the light)
//   start behind        : origin p - b·n, t in (eps, L' - eps),         b = 4 · FLT_EPSILON · M
//                         (the raster's rounding can leave a sample a few ulps behind its surface: at a
//                         grazing light the base ray then threads the crack where its surface meets the
//                         next one, and which side of the edge it passes is the rounding's choice; at
//                         other angles the ray meets its own surface within eps and nothing changes)
// Members identical to the base ray (e.g. a = 1e-4·s when it equals eps) are skipped: same answer.
// Up to 13 members per sample (14 rays with the base).
#pragma once
#include <algorithm>
#include <array>
#include <cfloat>
#include <cstdint>
#include <string>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

namespace cs {

struct Scene;

// One shadow ray: hits count when t is in the open interval (tnear, tfar); dir is unit length.
struct ShadowRay {
  glm::vec3 org{0};
  glm::vec3 dir{0, 0, 1};
  float tnear = 0;
  float tfar = 0;
  bool operator==(const ShadowRay&) const = default;
};

// Which member groups of the band family to trace (all by default; the contract (docs/ARCHITECTURE.md, "Contracts") asks for at least the
// start offsets and the sideways nudge).
struct BandOptions {
  bool startAlongRay = true;
  bool startAlongNormal = true;
  bool lightNudge = true;
  bool endAlongRay = true;
  bool startBehind = true;
};

struct EpsilonPolicy {
  static constexpr float kRelativeEps = 1e-4f;                 // eps = kRelativeEps · s
  static constexpr float kFloorUlps = 32.0f;                   // floor = kFloorUlps · FLT_EPSILON · M
  static constexpr std::array<float, 3> kStartOffsets = {1e-5f, 1e-4f, 1e-3f};  // · s, along ray / normal
  static constexpr float kLightNudge = 1e-4f;                  // · s, sideways, 4 directions
  static constexpr float kNudgeFloorUlps = 4.0f;               // the nudge's own floor, in ulps
  static constexpr std::array<float, 3> kEndOffsets = {0.0f, 1e-5f, 1e-3f};     // · s, before the light
  static constexpr float kBehindUlps = 4.0f;                   // b = kBehindUlps · FLT_EPSILON · M, start behind
  static constexpr int kMaxBandMembers =
      int(kStartOffsets.size()) * 2 + 4 + int(kEndOffsets.size()) + 1;

  float scale = 0;        // s: bounding-box diagonal
  float maxAbsCoord = 0;  // M: largest |coordinate| of any position
  float floor = FLT_MIN;  // 32 · FLT_EPSILON · M
  float eps = FLT_MIN;    // max(1e-4 · s, floor)

  float floored(float x) const { return x > floor ? x : floor; }
  // b, how far behind its surface the start-behind member puts a sample (never below FLT_MIN).
  float behindOffset() const { return std::max(kBehindUlps * FLT_EPSILON * maxAbsCoord, FLT_MIN); }
  float relative(float fractionOfScale) const { return floored(fractionOfScale * scale); }
  // δ, the sideways nudge of the light (floored at 4 ulps of M and of the light's coordinates).
  float lightNudge(glm::vec3 light) const;

  // From the scene's positions (not its stored bounds, which a caller may not have computed).
  static EpsilonPolicy forScene(const Scene& scene);
  // From a bounding box; M is taken from the box corners.
  static EpsilonPolicy forBounds(glm::vec3 lo, glm::vec3 hi);

  // The base ray of sample p toward light l (see the top of this file).
  ShadowRay baseRay(glm::vec3 p, glm::vec3 light) const;
  // The band family of a sample at p with normal n; writes up to kMaxBandMembers rays to `out`, skips
  // members equal to the base ray, returns how many it wrote.
  int bandFamily(glm::vec3 p, glm::vec3 n, glm::vec3 light, const BandOptions& options,
                 ShadowRay* out) const;
};

// How far a light may be from the scene. Every shadow ray's length L = |light - p| is an fp32 length
// computed as sqrt(x^2 + y^2 + z^2): past sqrt(FLT_MAX / 3) ~ 1.06e19 the squares overflow and the ray
// (Embree's and the cone path's alike) would silently count as lit. 2^62 ~ 4.6e18 leaves a factor 4 in L
// (16 in the squares) for the leaf test's products of coordinates. Below it, the cone path's leaf test
// measures from the end of the ray nearer the triangle (traversal/precise_test.h, leafHit) and stays exact
// outside the band at any distance; the band itself widens with the distance (the light nudge's floor is
// 4 ulp of the light's coordinates), which the reports show.
constexpr double kMaxLightDistance = 4611686018427387904.0;  // 2^62

// Empty when the light is finite and every point of the box [lo, hi] lies within kMaxLightDistance of
// it; otherwise what is wrong and what to do, for an error message.
std::string lightRangeProblem(glm::vec3 light, glm::vec3 lo, glm::vec3 hi);

// A ray from `org` toward `target` counting hits in (tnear, |target - org| - endOffset).
ShadowRay rayToward(glm::vec3 org, glm::vec3 target, float tnear, float endOffset);

// Two unit vectors u, v with (u, v, d) orthonormal, d unit (Duff et al. 2017, "Building an Orthonormal
// Basis, Revisited": branchless, no singularity but the sign switch at d.z = 0).
void orthonormalBasis(glm::vec3 d, glm::vec3& u, glm::vec3& v);

inline nlohmann::json toJson(const EpsilonPolicy& p) {
  return {{"scale", p.scale},
          {"max_abs_coord", p.maxAbsCoord},
          {"floor", p.floor},
          {"eps", p.eps},
          {"relative_eps", EpsilonPolicy::kRelativeEps},
          {"floor_ulps", EpsilonPolicy::kFloorUlps},
          {"band_start_offsets", EpsilonPolicy::kStartOffsets},
          {"band_light_nudge", EpsilonPolicy::kLightNudge},
          {"band_light_nudge_floor_ulps", EpsilonPolicy::kNudgeFloorUlps},
          {"band_end_offsets", EpsilonPolicy::kEndOffsets}};
}

}  // namespace cs
