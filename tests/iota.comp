#version 450
#extension GL_GOOGLE_include_directive : require
#include "core/shared.h"
// Test kernel: out[i] = in[i] * scale + i over a 2-D grid of workgroups (vk::gridFor layout).
// bindings: 0 = in (uint[]), 1 = out (uint[])
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer In { uint src[]; };
layout(std430, binding = 1) writeonly buffer Out { uint dst[]; };
layout(push_constant) uniform Push { uint count; uint scale; };

void main() {
  uint i = CS_FLAT_INDEX(64u);
  if (i >= count) return;
  dst[i] = src[i] * scale + i;
}
