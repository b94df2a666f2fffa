// shadowmaps/: the maths both languages run — cube-face projection, the LOD of eq. 1 (paper 000 §3.3.2),
// quadtree page keys and page-table addresses, the slope-scaled bias — and the push-constant layouts.
// One source for glslang and C++ (STYLE.md "one layout, two languages"): the C++ side sees these
// functions through glm, so the CPU references of the tests run the very same expressions as the kernels.
// Write it in the common subset: value parameters, `f`-suffixed float literals, `u`-suffixed uints.
#ifndef CONESHADOW_SM_SHARED_H
#define CONESHADOW_SM_SHARED_H

#include "core/shared.h"

#ifdef __cplusplus
#include <cstddef>
namespace cs::sm {
CS_GLSL_TYPES
CS_GLSL_MATH
#endif

// ---- workgroup shapes and constants --------------------------------------------------------------
#define SM_PIXEL_THREADS 256      // per-pixel kernels
#define SM_LIST_THREADS 256       // per-list-entry kernels
#define SM_INVALID_KEY 0xFFFFFFFFu
#define SM_MAX_LEVEL 12u          // page keys hold 12-bit page coordinates: levels 0..12
#define SM_EMPTY_DEPTH 3.0e38f    // stored where no geometry was drawn: every sample is in front of it

// Counters word indices (RMSM's small counter buffer).
#define SM_COUNT_REQUESTS 0u      // valid page requests before pruning
#define SM_COUNT_PRUNED 1u        // after connected-components pruning (= compacted)
#define SM_COUNT_UNIQUE 2u        // after sort + uniquify
#define SM_COUNT_MISSES 3u        // lookups that found no page at any level (0 with full-resolution analysis)
#define SM_COUNT_ISOLATED 4u      // lit samples with no usable neighbour for the derivatives
#define SM_COUNT_FACES 5u         // bit f set: some lit sample lies on cube face f
#define SM_COUNT_UNIQUE_ARGS 8u   // words 8-10: the uniquify dispatch's grid for the pruned count (indirect)
#define SM_COUNT_WORDS 12u

// ---- cube faces ------------------------------------------------------------------------------------
// Face f = 2·axis + (component < 0): the major axis of the direction d from the light (ties go to x,
// then y). Face space of face f: (x_f, y_f, z_f) = (d[axis+1], d[axis+2], ±d[axis]) (indices mod 3), so
// z_f > 0 inside the face; u = x_f / z_f and v = y_f / z_f run over [-1, 1], and the face's shadow-map
// coordinates are s = (u + 1) / 2, t = (v + 1) / 2 — texel column s·R, row t·R at R texels a side.
// (Selects rather than d[axis]: a vector indexed by a per-invocation value becomes a gather through
// memory on SIMD CPUs — lavapipe — and made the request kernel several times slower.)
CS_FN uint cubeFace(vec3 d) {
  vec3 a = abs(d);
  if (a.x >= a.y && a.x >= a.z) return d.x < 0.0f ? 1u : 0u;
  if (a.y >= a.z) return d.y < 0.0f ? 3u : 2u;
  return d.z < 0.0f ? 5u : 4u;
}

CS_FN vec3 faceSpace(uint face, vec3 d) {
  uint axis = face >> 1u;
  vec3 f = axis == 0u ? vec3(d.y, d.z, d.x) : (axis == 1u ? vec3(d.z, d.x, d.y) : d);
  f.z = (face & 1u) != 0u ? -f.z : f.z;
  return f;
}

// (s, t) in [0, 1]² of a face-space point with z_f > 0.
CS_FN vec2 faceST(vec3 f) { return vec2(0.5f + 0.5f * f.x / f.z, 0.5f + 0.5f * f.y / f.z); }

// RMSM's fitted faces: window w = (s0, t0, zoom, 0) maps the part [s0, s0 + 1/zoom] x [t0, t0 + 1/zoom]
// of a face onto the quadtree's [0, 1]² (shadowmaps/README.md, RMSM); (0, 0, 1, 0) is the whole face.
CS_FN vec2 windowST(vec2 st, vec4 w) { return (st - vec2(w.x, w.y)) * w.z; }
// The face coordinate (u, v in [-1, 1]) of window coordinate x (texels of a level with `res` a side).
CS_FN vec2 windowFaceUV(vec2 x, float res, vec4 w) { return 2.0f * (vec2(w.x, w.y) + x / (res * w.z)) - 1.0f; }

// ---- level of detail (paper 000, eq. 1) -----------------------------------------------------------
// dX, dY: the screen-space derivatives of (s, t). ℓ = log2(sqrt(|dX × dY|)): the log2 of the side of a
// texel that matches the pixel's footprint, in units of the face. -inf (here: -1e30) when the footprint
// has no area (a surface seen edge-on from the light needs infinite resolution).
CS_FN float lodFromDerivatives(vec2 dX, vec2 dY) {
  float area = abs(dX.x * dY.y - dX.y * dY.x);
  return area > 0.0f ? 0.5f * log2(area) : -1.0e30f;
}

// The continuous quadtree level λ of an LOD ℓ: level L holds P·2^L texels a side (P = 2^log2Page), so
// the level whose texels match is λ = -ℓ - log2 P, clamped to [0, maxLevel]. The lookup blends the two
// nearest integer levels floor(λ) and floor(λ) + 1 with weight fract(λ) (paper 000 §3.3.1).
CS_FN float quadtreeLevel(float lod, uint log2Page, uint maxLevel) {
  return clamp(-lod - float(log2Page), 0.0f, float(maxLevel));
}

// The level a frame uses for a sample of level λ (in [0, maxLevel]) after the pool fallback lowered the
// finest level to `limit` (rmsm.h coarsenToFit).
CS_FN float frameLevel(float lambda, uint limit) { return min(lambda, float(limit)); }

// ---- texel addressing -------------------------------------------------------------------------------
// The 2x2 bilinear footprint of (s, t) at R texels a side: its lower texel b = floor(s·R - 1/2) (clamped
// to [0, R - 1]) and b + 1, weights from the fraction. A page is requested for, and looked up by, the
// page of b; pages are stored with a one-texel apron on their high sides, so b + 1 is in the same page.
CS_FN vec2 footprintCoord(vec2 st, float res) { return st * res - vec2(0.5f); }
CS_FN vec2 footprintBase(vec2 x, float res) { return clamp(floor(x), vec2(0.0f), vec2(res - 1.0f)); }

// ---- page keys --------------------------------------------------------------------------------------
// key = face << 28 | level << 24 | Morton(px, py): 31 bits, so sorting keys orders pages by face, then
// level, then Z-order — the pages of one superpage are consecutive in the sorted list.
CS_FN uint spreadBits12(uint v) {
  v &= 0xFFFu;
  v = (v | (v << 8u)) & 0x00FF00FFu;
  v = (v | (v << 4u)) & 0x0F0F0F0Fu;
  v = (v | (v << 2u)) & 0x33333333u;
  v = (v | (v << 1u)) & 0x55555555u;
  return v;
}
CS_FN uint pageKey(uint face, uint level, uint px, uint py) {
  return (face << 28u) | (level << 24u) | spreadBits12(px) | (spreadBits12(py) << 1u);
}
CS_FN uint keyFace(uint key) { return key >> 28u; }
CS_FN uint keyLevel(uint key) { return (key >> 24u) & 0xFu; }
CS_FN uint keyPageX(uint key) { return evenBits(key & 0xFFFFFFu); }
CS_FN uint keyPageY(uint key) { return evenBits((key & 0xFFFFFFu) >> 1u); }

// ---- page tables --------------------------------------------------------------------------------------
// Per face a mip hierarchy of tables, level L = 2^L x 2^L entries (one per page), levels 0..maxLevel in
// order, faces one after another. Entry 0 = no page; otherwise pool slot + 1.
CS_FN uint levelOffset(uint level) { return ((1u << (2u * level)) - 1u) / 3u; }
CS_FN uint faceTableEntries(uint maxLevel) { return levelOffset(maxLevel + 1u); }
CS_FN uint tableIndex(uint face, uint level, uint px, uint py, uint maxLevel) {
  return face * faceTableEntries(maxLevel) + levelOffset(level) + (py << level) + px;
}

// ---- bias -------------------------------------------------------------------------------------------
// Slope-scaled depth bias of a sample at distance `dist` from the light whose normal makes angle θ with
// the direction to the light (cosTheta = N·L̂, the G-buffer's light term). A texel of a map with R texels
// per face side spans at most texelAngle = 2/R of face coordinate, i.e. dist·2/R sideways (the most, at
// the face centre). A tap up to `slope` texels sideways sees the receiver's own plane up to
// slope · dist·2/R · tanθ nearer; tanθ is clamped to maxSlope (grazing receivers would need unbounded bias).
CS_FN float slopeScaledBias(float dist, float cosTheta, float texelAngle, float constantBias, float slopeBias,
                            float maxSlope) {
  float c = max(cosTheta, 1.0e-6f);
  float tanTheta = min(sqrt(max(1.0f - c * c, 0.0f)) / c, maxSlope);
  return constantBias + slopeBias * dist * texelAngle * tanTheta;
}

// Receiver-plane bias (an alternative to the slope-scaled one, both methods' `planeBias` option): each
// tap compares against the distance at which ITS texel-centre ray — face-space direction (u, v, 1) —
// meets the sample's tangent plane (dFace = sample - light, nFace = its normal, both in face space),
// minus constantBias and `slack` (curved receivers, rounding). Exact for planar receivers at any angle,
// so grazing surfaces need no large bias (less acne and less light leaking at contacts). Where the ray
// runs within ~0.6° of the plane, or meets it behind the light, the tap falls back to `fallbackReach`.
CS_FN float planeReach(vec3 dFace, vec3 nFace, vec2 uv, float fallbackReach, float constantBias, float slack) {
  vec3 r = vec3(uv.x, uv.y, 1.0f);
  float lenR = length(r);
  float den = dot(nFace, r);
  float t = dot(nFace, dFace) / den;  // light + t·r lies on the plane
  if (!(t > 0.0f) || abs(den) < 0.01f * lenR) return fallbackReach;
  return t * lenR - constantBias - slack;
}

// ---- push constants -----------------------------------------------------------------------------------
// depth.vert / depth.frag: one geometry pass into a window of a face.
struct DepthPush {
  mat4 clip;    // (world - light) -> clip: face space, then the window's scale/offset; z_clip = near
  vec4 light;   // xyz: the point light
};

// cube_lookup.comp
struct CubeLookupPush {
  vec4 light;          // xyz: the point light
  uint width, height;  // G-buffer
  uint resolution;     // texels per face side
  uint pcf;            // 1: bilinear 2x2 percentage-closer filter, 0: nearest texel
  float constantBias;  // world units
  float slopeBias;     // texels (see slopeScaledBias)
  float maxSlope;      // clamp of tanθ
  float minDistance;   // samples this close to the light are lit (the epsilon policy's empty ray)
  uint planeBias;      // 1: receiver-plane bias per tap (planeReach), 0: slope-scaled
  uint pad0, pad1, pad2;
};

// rmsm_requests.comp, rmsm_prune.comp, rmsm_lookup.comp, tests/rmsm_probe.comp
struct RmsmPush {
  vec4 light;          // xyz: the point light
  uint width, height;  // G-buffer
  uint log2Page;       // P = 1 << log2Page texels a page side
  uint maxLevel;       // levels of the page tables: 0..maxLevel (the quadtree's depth)
  uint levelLimit;     // finest level requests and lookups use this frame (<= maxLevel; the fallback lowers it)
  uint cachedFilter;   // 1: drop requests whose page is already resident (cached mode)
  uint count;          // list kernels: entries; probe: queries
  uint first;          // list kernels: first entry
  float constantBias;
  float slopeBias;
  float maxSlope;
  float minDistance;
  float lodBias;       // levels added to λ before clamping (> 0: finer than the pixels ask for)
  uint planeBias;      // 1: receiver-plane bias per tap (planeReach), 0: slope-scaled
  uint analysisStep;   // requests from every analysisStep-th pixel in x and y (1: every pixel; 000 §3.3.5)
  uint pad0;
};

#ifdef __cplusplus
static_assert(sizeof(DepthPush) == 80, "DepthPush layout");
static_assert(sizeof(CubeLookupPush) == 64 && offsetof(CubeLookupPush, constantBias) == 32 &&
                  offsetof(CubeLookupPush, planeBias) == 48,
              "CubeLookupPush layout");
static_assert(sizeof(RmsmPush) == 80 && offsetof(RmsmPush, constantBias) == 48 && offsetof(RmsmPush, lodBias) == 64,
              "RmsmPush layout");
}  // namespace cs::sm
#endif
#endif
