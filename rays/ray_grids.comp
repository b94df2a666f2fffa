#version 450
#extension GL_GOOGLE_include_directive : require
// Each face's key grid (faceKeyGrid, rays/hilbert.h: its run of keys from the subset's counts, its fitted
// grid of that size from its box) from what ray_bounds.comp left, once a frame, so the keys kernels read
// one vec4 a ray instead of zooming per ray; in the far-light frame (pc.framed) the frame's one grid
// (frameKeyGrid) in grids[0].
// bindings: 0 = boxes and counts (RAY_BOUNDS_WORDS uint), 1 = grids (vec4 per face)
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = 8) in;
layout(std430, binding = 0) readonly buffer Boxes { uvec4 boxes[]; };
layout(std430, binding = 1) writeonly buffer Grids { vec4 grids[]; };
layout(push_constant) uniform Push { KeysPush pc; };

void main() {
  uint face = gl_LocalInvocationIndex;
  if (face >= 6u) return;
  if (pc.framed != 0u) {  // one grid over the frame's coordinates, fitted to face 0's box
    if (face == 0u) grids[0] = frameKeyGrid(boxes[0], pc.rect, uint(RAY_KEY_MAX_ORDER));
    return;
  }
  uint counts[6];
  for (uint f = 0u; f < 6u; ++f) counts[f] = boxes[RAY_BOUNDS_COUNTS / 4u + f / 4u][f % 4u];
  grids[face] = faceKeyGrid(boxes[face], faceKeySlot(face, counts));
}
