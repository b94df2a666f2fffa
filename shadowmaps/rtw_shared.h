// shadowmaps/: rectilinear texture warping (RTW, paper 004) — the maths GLSL and C++ share (one source,
// compiled by both, like sm_shared.h): the importance functions, the 1-D warp of one axis, the buffer
// layout of the warp maps and the push constants of the RTW kernels and the warped geometry pass.
// Write it in the common subset: value parameters, `f`-suffixed float literals, `u`-suffixed uints.
#ifndef CONESHADOW_RTW_SHARED_H
#define CONESHADOW_RTW_SHARED_H

#include "shadowmaps/sm_shared.h"

#ifdef __cplusplus
namespace cs::sm {
#endif

#define RTW_THREADS 256          // per-pixel and per-texel kernels
#define RTW_WARP_THREADS 256     // rtw_warp.comp: one workgroup per face and axis
#define RTW_MAX_CELLS 2048u      // super-cells per axis (shared memory of rtw_warp.comp: 2 floats a cell)
// The warped pass's geometry shader: at most 72 vertices of 14 components, as the limit counts them
// (gl_Position, gl_PointSize, and two 4-component locations): 1008 of the 1024 Vulkan guarantees.
#define RTW_GS_MAX_VERTICES 72
#define RTW_GS_COMPONENTS 14u

// Importance functions (RtwImportancePush::functions), multiplied (paper 004 §5).
#define RTW_VIEW 1u      // I_DV: 1 inside the desired view, 0 outside (forward: the view frustum test)
#define RTW_DISTANCE 2u  // I_D: 1 / the sample's view depth
#define RTW_EDGE 4u      // I_E: 1 at a depth discontinuity of the light's depth image, alpha elsewhere
#define RTW_NORMAL 8u    // I_SN: 1 + beta · clamp(-N·v, 0, 1)
#define RTW_UNIFORM 16u  // every cell 1: the identity warp (a plain cube map through the RTW path)

// Analyses (RtwImportancePush::mode of rtw_forward.comp).
#define RTW_FORWARD_IMPORTANCE 0u  // forward analysis: the light's depth image writes the importance map
#define RTW_FORWARD_EDGES 1u       // hybrid analysis: the light's depth image writes I_E per texel
// rtw_importance.comp after the forward analysis: every lit sample raises its cell to alpha times its
// own importance (no I_E), so no sample in view lies in a culled cell (a view narrower than a texel of
// the light's depth image would otherwise see its cells culled: the forward view test reads texel
// centres).
#define RTW_SAMPLE_COVERAGE 2u

// ---- the warp buffer ------------------------------------------------------------------------------------
// For face f and axis a (0 = s, the face's x; 1 = t), n + 1 knots K[0..n], K[0] = 0, K[n] = 1,
// non-decreasing: super-cell k, the unwarped [k/n, (k+1)/n], goes to the warped [K[k], K[k+1]] linearly.
// A culled cell (no importance) has K[k] = K[k+1]: zero width. After the 12 knot arrays, one word per
// face: 1 when the face holds any importance (it is rendered), 0 when not (8 words); then per face and
// axis the live range [lo, hi] of unwarped coordinates, from the first live cell's start to the last
// one's end: the warped pass clips every triangle to it, so no vertex lies in the culled cells beyond
// the live ones (there the warp is flat, and a straight warped edge to such a vertex would stand for
// none of the true edge's path through the live cells).
CS_FN uint rtwKnotBase(uint face, uint axis, uint cells) { return (face * 2u + axis) * (cells + 1u); }
CS_FN uint rtwActiveIndex(uint face, uint cells) { return 12u * (cells + 1u) + face; }
CS_FN uint rtwRangeIndex(uint face, uint axis, uint cells) { return 12u * (cells + 1u) + 8u + (face * 2u + axis) * 2u; }
// Then per face and axis the inverse at the texel centres: R values, texel j's centre (j + 1/2) / R
// unwarped (what the warped pass's fragments and the receiver-plane taps need; a table, not a search).
CS_FN uint rtwInverseBase(uint face, uint axis, uint cells, uint resolution) {
  return 12u * (cells + 1u) + 32u + (face * 2u + axis) * resolution;
}
CS_FN uint rtwWarpWords(uint cells, uint resolution) { return 12u * (cells + 1u) + 32u + 12u * resolution; }

// The cell of unwarped coordinate s in [0, 1] (clamped: the end cells extend the map linearly).
CS_FN uint rtwCell(float s, uint cells) {
  return uint(clamp(floor(s * float(cells)), 0.0f, float(cells - 1u)));
}
// Warped coordinate of s, from the two knots of its cell (k0 = K[k], k1 = K[k + 1], k = rtwCell(s)).
CS_FN float rtwWarpIn(float s, uint cell, uint cells, float k0, float k1) {
  return k0 + (s * float(cells) - float(cell)) * (k1 - k0);
}
// Unwarped coordinate of warped s' inside cell `cell` (k0 <= s' <= k1); a culled cell maps to its start.
CS_FN float rtwUnwarpIn(float sw, uint cell, uint cells, float k0, float k1) {
  float f = k1 > k0 ? clamp((sw - k0) / (k1 - k0), 0.0f, 1.0f) : 0.0f;
  return (float(cell) + f) / float(cells);
}

// ---- importance functions (paper 004 §5) --------------------------------------------------------------
// I_D: the desired view's projected size of a sample falls as 1/q with its view depth q (§5.2; the paper
// uses 1 - depth, which is 1/q up to the projection's constants: the warp is scale-free). Depths below
// qMin (the camera's near plane) count as qMin.
CS_FN float rtwDistanceImportance(float q, float qMin) { return 1.0f / max(q, qMin); }
// I_SN: a bonus beta for surfaces facing the view direction (§5.4). `facing` = -N·v̂ with v̂ the unit
// direction from the eye to the sample.
CS_FN float rtwNormalImportance(float facing, float beta) { return 1.0f + beta * clamp(facing, 0.0f, 1.0f); }
// I_E: a texel of the light's depth image whose distance d differs from a neighbour's dn by more than the
// threshold is a shadow edge (§5.3). Empty neighbours (no geometry, dn >= SM_EMPTY_DEPTH / 2) receive no
// shadow and make no edge. The threshold: the constant bias plus the depth a surface `slope` (tanθ)
// steep changes over one texel of the depth image (2/m of face coordinate at m texels a side).
CS_FN bool rtwDepthEdge(float d, float dn, float constantBias, float texelAngle, float slope) {
  if (!(dn < 0.5f * SM_EMPTY_DEPTH)) return false;
  return abs(d - dn) > constantBias + slope * max(d, dn) * texelAngle;
}
#define RTW_EDGE_SLOPE 4.0f  // tanθ above which a smooth surface reads as an edge (~76°)

// ---- push constants -----------------------------------------------------------------------------------
// rtw_importance.comp (backward and hybrid, per pixel) and rtw_forward.comp (forward, per texel).
// The desired view, in a small buffer (push constants stop at 128 bytes on some devices).
struct RtwView {
  mat4 viewProj;       // world -> the desired view's clip space (forward: I_DV)
  vec4 eye;            // xyz: the desired view's eye; w: qMin (its near plane)
  vec4 forward;        // xyz: the view's unit forward direction (view depth q = (p - eye)·forward)
};

struct RtwImportancePush {
  vec4 light;          // xyz: the point light
  uint width, height;  // G-buffer (per pixel); forward: unused
  uint cells;          // super-cells per axis (n)
  uint forwardRes;     // texels a side of the light's depth image per face (m)
  uint functions;      // RTW_* bits
  uint mode;           // rtw_forward.comp: RTW_FORWARD_*; rtw_importance.comp: RTW_SAMPLE_COVERAGE or 0
  float alpha;         // I_E's importance away from edges
  float beta;          // I_SN's bonus
  float constantBias;  // world units: the edge test's constant term and the lit-sample minimum distance
  float minDistance;   // samples this close to the light are lit (not analysed)
  uint pad0, pad1;
};

// rtw_warp.comp: one workgroup per (face, axis).
struct RtwWarpPush {
  uint cells;
  uint radius;      // the blur's half width in cells (ceil(3 sigma)); 0: no blur
  float sigma;      // the Gaussian's standard deviation in cells
  uint resolution;  // R: the inverse table's texels
};

// depth_warp.vert / depth_warp.geom: the warped geometry pass of one face.
struct RtwDepthPush {
  vec4 light;        // xyz: the point light
  uint face;
  uint cells;
  uint resolution;   // texels a side of the RTW map (R)
  uint tessellate;   // 1: subdivide triangles whose warped edges exceed tessTexels
  float tessTexels;  // longest warped edge a sub-triangle may keep, in texels
  float nearPlane;   // face-space z below which geometry is clipped
  float margin;      // the clip reaches this far past the face's edges (face coordinates, >= 0)
  uint pad0;
};

// rtw_lookup.comp
struct RtwLookupPush {
  vec4 light;          // xyz: the point light
  uint width, height;  // G-buffer
  uint resolution;     // R
  uint cells;          // n
  float constantBias;  // world units
  float slopeBias;     // texels
  float maxSlope;
  float minDistance;
  uint pcf;
  uint planeBias;
  float warpBias;      // scale on the texel the slope term uses (covers the warp's non-linearity)
  uint pad0;
};

#ifdef __cplusplus
static_assert(sizeof(RtwView) == 96, "RtwView layout");
static_assert(sizeof(RtwImportancePush) == 64, "RtwImportancePush layout");
static_assert(sizeof(RtwWarpPush) == 16, "RtwWarpPush layout");
static_assert(sizeof(RtwDepthPush) == 48, "RtwDepthPush layout");
static_assert(sizeof(RtwLookupPush) == 64, "RtwLookupPush layout");
}  // namespace cs::sm
#endif
#endif
