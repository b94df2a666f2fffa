#version 450
#extension GL_GOOGLE_include_directive : require
// Each face's key grid (fittedFaceGrid, rays/hilbert.h) from the box ray_bounds.comp left, once a frame,
// so the keys kernel reads one vec4 a ray instead of zooming per ray.
// bindings: 0 = boxes (RAY_BOUNDS_WORDS uint), 1 = grids (vec4 per face)
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = 8) in;
layout(std430, binding = 0) readonly buffer Boxes { uvec4 boxes[]; };
layout(std430, binding = 1) writeonly buffer Grids { vec4 grids[]; };
layout(push_constant) uniform Push { KeysPush pc; };

void main() {
  uint face = gl_LocalInvocationIndex;
  if (face < 6u) grids[face] = fittedFaceGrid(boxes[face], uint(RAY_KEY_HILBERT_ORDER));
}
