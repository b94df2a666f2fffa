// The ray key of 002 §3.5 and the screen order of its unsorted variant, as plain functions that glslang
// and C++ both compile: the kernels use them, and so do the tests as their CPU reference.
//
// Ray key (32 bits, ray = light -> sample, direction d = sample - light):
//   bits 28..30  face = 2 * axis + (d[axis] < 0): the major axis of d (x, y, z = 0, 1, 2) and its sign.
//                Ties (|d.x| == |d.y| >= |d.z|, ...) go to the lowest axis, so boundary directions have
//                exactly one face.
//   bits  0..27  Hilbert index of the cell that (d[axis+1], d[axis+2]) / |d[axis]| (both in [-1, 1])
//                falls in, on a 2^14 x 2^14 grid over the face. 28 bits and not 29: a Hilbert curve
//                needs a square 2^k x 2^k grid (2k bits); the 29th bit would only buy a 2:1 anisotropic
//                grid, halving the cells' width on one axis. A cell spans ~1.2e-4 rad, far below the
//                angle between neighbouring pixels' rays at any useful resolution, so rays sharing a
//                cell are rare and keep their compaction order (the sort is stable).
//   bit  31      always 0: sort 31 key bits (RAY_KEY_BITS).
// Degenerate rays (zero length: a sample at the light; or a non-finite direction) get
// RAY_KEY_DEGENERATE, which no real direction produces (face field 7), so they sort after all others.
//
// GPU and CPU agree exactly on the face and on the integer Hilbert index; the cell coordinates come
// from one float division, which Vulkan allows to be 2.5 ulp off, so a direction within ~1e-7 of a cell
// boundary may land in the neighbouring cell on a GPU. Lavapipe's division is exact.
#ifndef CONESHADOW_RAYS_HILBERT_H
#define CONESHADOW_RAYS_HILBERT_H

#include "rays/rays_layout.h"

#define RAY_KEY_HILBERT_ORDER 14
#define RAY_KEY_FACE_SHIFT 28
#define RAY_KEY_BITS 31
#define RAY_KEY_DEGENERATE 0x7FFFFFFFu

#ifdef __cplusplus
namespace cs::rays {
namespace glsl {  // the functions below are GLSL; these names let C++ read them as written
CS_GLSL_TYPES
CS_GLSL_MATH
#endif

// Index of cell (x, y) along the Hilbert curve over a 2^order x 2^order grid (order 1..16). The curve
// starts at (0, 0) and ends at (2^order - 1, 0); consecutive indices are edge-neighbouring cells.
CS_FN uint hilbertIndex(uint x, uint y, uint order) {
  uint d = 0u;
  for (uint s = 1u << (order - 1u); s > 0u; s >>= 1u) {
    uint rx = (x & s) != 0u ? 1u : 0u;
    uint ry = (y & s) != 0u ? 1u : 0u;
    d += s * s * ((3u * rx) ^ ry);
    // Turn the quadrant into the curve's base orientation for the next, finer level.
    x &= s - 1u;
    y &= s - 1u;
    if (ry == 0u) {
      if (rx == 1u) {
        x = s - 1u - x;
        y = s - 1u - y;
      }
      uint t = x;
      x = y;
      y = t;
    }
  }
  return d;
}

// Which of the six direction faces d belongs to (2 * axis + negative), or 7 for a degenerate d.
CS_FN uint rayFace(vec3 d) {
  vec3 a = abs(d);
  // NaN fails every comparison and +-inf exceeds FLT_MAX: both are degenerate, as is d == 0.
  if (!(a.x <= CS_FLT_MAX && a.y <= CS_FLT_MAX && a.z <= CS_FLT_MAX)) return 7u;
  uint axis = 2u;
  if (a.x >= a.y && a.x >= a.z)
    axis = 0u;
  else if (a.y >= a.z)
    axis = 1u;
  float m = a[axis];
  if (!(m > 0.0f)) return 7u;
  return 2u * axis + (d[axis] < 0.0f ? 1u : 0u);
}

// The face-local cell of d on the 2^order grid: (d[axis+1], d[axis+2]) / |d[axis]| mapped from
// [-1, 1] to cells 0 .. 2^order - 1 (the value 1 itself goes to the last cell). d must not be degenerate.
CS_FN uvec2 rayCell(vec3 d, uint face, uint order) {
  uint axis = face >> 1u;
  float m = abs(d[axis]);
  float u = d[(axis + 1u) % 3u] / m;
  float v = d[(axis + 2u) % 3u] / m;
  float half_ = float(1u << (order - 1u));  // scaling by a power of two and adding it are exact
  float last = float((1u << order) - 1u);
  return uvec2(uint(clamp(floor(u * half_ + half_), 0.0f, last)), uint(clamp(floor(v * half_ + half_), 0.0f, last)));
}

// The 32-bit sort key of the ray with direction d (see the header comment).
CS_FN uint rayKey(vec3 d) {
  uint face = rayFace(d);
  if (face == 7u) return RAY_KEY_DEGENERATE;
  uvec2 c = rayCell(d, face, uint(RAY_KEY_HILBERT_ORDER));
  return (face << uint(RAY_KEY_FACE_SHIFT)) | hilbertIndex(c.x, c.y, uint(RAY_KEY_HILBERT_ORDER));
}

// The ray key in a rotated frame (the cone path's far-light frame, traversal/traversal.h): d_f = the ray
// in frame coordinates, all rays within a few degrees of +z. Hilbert index (order 15, 30 bits) of the
// cell of (d_f.x / d_f.z, d_f.y / d_f.z) mapped by rect = (u0, v0, 1 / (u1 - u0), 1 / (v1 - v0)) onto
// [0, 1]^2 (values outside clamped to the edge cells): the whole grid spans the scene's projection, where
// the face grid of rayKey would give a far light's rays a handful of cells. Degenerate (d_f.z <= 0 or not
// finite): RAY_KEY_DEGENERATE.
CS_FN uint frameRayKey(vec3 d, vec4 rect) {
  if (!(d.z > 0.0f) || !(abs(d.x) <= CS_FLT_MAX && abs(d.y) <= CS_FLT_MAX && d.z <= CS_FLT_MAX))
    return RAY_KEY_DEGENERATE;
  float u = (d.x / d.z - rect.x) * rect.z;
  float v = (d.y / d.z - rect.y) * rect.w;
  float n = 32768.0f;  // 2^15
  uint x = uint(clamp(floor(u * n), 0.0f, n - 1.0f));
  uint y = uint(clamp(floor(v * n), 0.0f, n - 1.0f));
  return hilbertIndex(x, y, 15u);
}


// The pixel (x, y) at position i of the unsorted screen order over tiles of 2^MORTON_TILE_BITS pixels
// a side, tilesX tiles per row. May lie outside the image when its size is not a multiple of the tile.
CS_FN uvec2 screenOrderPixel(uint i, uint tilesX) {
  uint tile = i >> (2u * uint(MORTON_TILE_BITS));
  uint local = i & ((1u << (2u * uint(MORTON_TILE_BITS))) - 1u);
  uint tx = tile % tilesX, ty = tile / tilesX;
  return uvec2((tx << uint(MORTON_TILE_BITS)) + evenBits(local),
               (ty << uint(MORTON_TILE_BITS)) + evenBits(local >> 1u));
}

#ifdef __cplusplus
}  // namespace glsl
using glsl::hilbertIndex;
using glsl::rayCell;
using glsl::rayFace;
using glsl::rayKey;
using glsl::frameRayKey;
using glsl::screenOrderPixel;
constexpr uint32_t kRayKeyDegenerate = RAY_KEY_DEGENERATE;
constexpr uint32_t kRayKeyBits = RAY_KEY_BITS;
constexpr uint32_t kRayKeyHilbertOrder = RAY_KEY_HILBERT_ORDER;
}  // namespace cs::rays
#endif
#endif
