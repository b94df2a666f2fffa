#version 450
#extension GL_GOOGLE_include_directive : require
// Test kernel (tests/sort_test.cpp): the GPU half of rays/hilbert.h's two-language contract.
// out[y * 2^order + x] = hilbertIndex(x, y, order) for every cell; rayOut[i] = rayKey(dirs[i].xyz).
// bindings: 0 = out (uint[] per cell), 1 = dirs (vec4[]), 2 = rayOut (uint[] per direction)
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = PIXEL_THREADS) in;
layout(std430, binding = 0) writeonly buffer Out { uint outIndex[]; };
layout(std430, binding = 1) readonly buffer Dirs { vec4 dirs[]; };
layout(std430, binding = 2) writeonly buffer RayOut { uint rayOut[]; };
layout(push_constant) uniform Push { HilbertGridPush pc; };

void main() {
  uint i = CS_FLAT_INDEX(PIXEL_THREADS);
  uint side = 1u << pc.order;
  if (i < side * side) outIndex[i] = hilbertIndex(i % side, i / side, pc.order);
  if (i < pc.directions) rayOut[i] = rayKey(dirs[i].xyz);
}
