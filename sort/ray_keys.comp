#version 450
#extension GL_GOOGLE_include_directive : require
// The Hilbert ray key (sort/hilbert.h) of every compacted sample: ray = light -> position[sample].
// bindings: 0 = position (vec4[] per pixel), 1 = samples (uint[] pixel indices), 2 = keys (uint[]),
//           3 = countWords (device count)
#include "sort/sort_layout.h"
#include "sort/hilbert.h"
layout(local_size_x = PIXEL_THREADS) in;
layout(std430, binding = 0) readonly buffer Position { vec4 position[]; };
layout(std430, binding = 1) readonly buffer Samples { uint samples[]; };
layout(std430, binding = 2) writeonly buffer Keys { uint keys[]; };
layout(std430, binding = 3) readonly buffer CountWords { uint countWords[]; };
layout(push_constant) uniform Push { KeysPush pc; };
#include "sort/common.glsl"

void main() {
  uint i = flatWorkgroup() * PIXEL_THREADS + gl_LocalInvocationIndex;
  if (i >= countOf(pc.count, pc.countIndex, pc.flags)) return;
  keys[i] = rayKey(position[samples[i]].xyz - pc.light.xyz);
}
