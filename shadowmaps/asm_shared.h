// shadowmaps/: adaptive shadow maps (ASM, paper 001) — what GLSL and C++ share (one source, compiled by
// both, like sm_shared.h): the node hash the lookup walks, the texel footprint comparison of the
// analysis, the pool layout and the push constants of asm_frame.comp.
// Write it in the common subset: value parameters, `f`-suffixed float literals, `u`-suffixed uints.
#ifndef CONESHADOW_ASM_SHARED_H
#define CONESHADOW_ASM_SHARED_H

#include "shadowmaps/sm_shared.h"

#ifdef __cplusplus
namespace cs::sm {
#endif

#define ASM_THREADS 256       // asm_frame.comp: one invocation per pixel
#define ASM_EMPTY_SLOT 0xFFFFFFFFu
#define ASM_MODE_ANALYSE 0u   // benefit per (node, cell) and the nodes each analysed sample walked through
#define ASM_MODE_LOOKUP 1u    // visibility per pixel from the finest resident node
#define ASM_MAX_DEPTH 12u     // node keys (sm_shared.h pageKey) hold 12-bit coordinates per level

// ---- the tree as the GPU sees it --------------------------------------------------------------------
// A node at depth L of face f is a window of N x N texels of the face at N·C^L texels a side (N the node
// resolution, C the cells per axis): node (x, y) of depth L holds face texels [x·N, x·N + N] x [y·N, y·N
// + N] (one texel of apron right and below, so a 2x2 footprint whose base lies in the node stays in it)
// in pool slot s at s·(N + 1)² (row-major); with the ID + depth test a second pool of the same layout
// holds each texel's nearest triangle. Its cell (i, j) is the region the child node (x·C + i,
// y·C + j) at depth L + 1 covers. The resident nodes are found through an open-addressing hash of their
// keys, pageKey(face, L, x, y): `capacity` (a power of two) pairs (key, slot), empty keys
// SM_INVALID_KEY, linear probing, built by the host every frame.
CS_FN uint asmHash(uint key, uint capacity) {
  uint h = key * 0x9E3779B1u;
  h ^= h >> 15u;
  return h & (capacity - 1u);
}
CS_FN uint asmSlotStride(uint nodeRes) { return (nodeRes + 1u) * (nodeRes + 1u); }

// The analysis's resolution test (paper 001 §3.1: the shadow map's texel is larger than the eye's
// pixel). Both as areas on the receiving surface, from the raster pass's own geometry rather than the
// paper's mip-map trick: a pixel of angular size `pixelAngle` at distance `eyeDistance` covers
// (pixelAngle·eyeDistance)² / cosView; a texel of a face at `res` texels a side, at distance `lightDistance`
// in direction d (|d| / z_f = `stretch` >= 1, the cube map's off-axis factor), covers
// (2·lightDistance / (res·stretch))² / cosLight. The cosines are clamped at 0.05 (grazing surfaces
// count as 20× stretched, not infinitely).
CS_FN float asmPixelArea(float pixelAngle, float eyeDistance, float cosView) {
  float side = pixelAngle * eyeDistance;
  return side * side / max(cosView, 0.05f);
}
CS_FN float asmTexelArea(float res, float lightDistance, float stretch, float cosLight) {
  float side = 2.0f * lightDistance / (res * stretch);
  return side * side / max(cosLight, 0.05f);
}

// ---- push constants -----------------------------------------------------------------------------------
struct AsmPush {
  vec4 light;          // xyz: the point light
  vec4 eye;            // xyz: the camera; w: the angle one pixel spans (2·tan(yfov / 2) / height)
  uint width, height;  // G-buffer
  uint mode;           // ASM_MODE_*
  uint nodeRes;        // N: texels a side of every node
  uint cells;          // C: cells a side of every node
  uint maxDepth;       // deepest level a node may have
  uint capacity;       // hash entries (a power of two)
  uint analysisStep;   // analyse pixels whose x and y are multiples of this
  float constantBias;  // world units
  float slopeBias;     // texels
  float maxSlope;
  float minDistance;   // samples this close to the light are lit (the epsilon policy's empty ray)
  uint pcf;            // 1: 2x2 percentage-closer filter, 0: nearest texel
  uint planeBias;      // 1: receiver-plane bias per tap
  uint idTest;         // 1: paper 001 §4.2's ID + depth test: a tap whose triangle is the sample's is lit
  uint pad0;
};

#ifdef __cplusplus
static_assert(sizeof(AsmPush) == 96 && offsetof(AsmPush, width) == 32 && offsetof(AsmPush, constantBias) == 64,
              "AsmPush layout");
}  // namespace cs::sm
#endif
#endif
