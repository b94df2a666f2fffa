#version 450
#extension GL_GOOGLE_include_directive : require
// The fitted box of each face for the ray keys (rays/hilbert.h, RAY_BOUNDS_SAMPLES): the face
// coordinates of RAY_BOUNDS_SAMPLES lit samples spread evenly over the compacted ones (boundsSample),
// each invocation taking RAY_BOUNDS_ITEMS of them. An invocation keeps its own minima per face, the
// workgroup merges them in shared memory and adds them to the buffer with one atomicMin a word.
// bindings: 0 = position (vec4[] per pixel), 1 = samples (uint[] pixel indices), 2 = bounds
//           (RAY_BOUNDS_WORDS uint, all ones before the dispatch), 3 = countWords (device count)
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = RAY_BOUNDS_THREADS) in;
layout(std430, binding = 0) readonly buffer Position { vec4 position[]; };
layout(std430, binding = 1) readonly buffer Samples { uint samples[]; };
layout(std430, binding = 2) buffer Bounds { uint bounds[]; };
layout(std430, binding = 3) readonly buffer CountWords { uint countWords[]; };
layout(push_constant) uniform Push { KeysPush pc; };
#include "sort/common.glsl"

shared uint box[24];

void main() {
  uint t = gl_LocalInvocationIndex;
  if (t < 24u) box[t] = RAY_BOUNDS_EMPTY;
  uint n = countOf(pc.count, pc.countIndex, pc.flags);
  // Per face: the least orderedBits of u, v, -u, -v among this invocation's samples.
  uvec4 least[6];
  for (uint f = 0u; f < 6u; ++f) least[f] = uvec4(RAY_BOUNDS_EMPTY);
  uint first = (gl_WorkGroupID.x * RAY_BOUNDS_THREADS + t) * RAY_BOUNDS_ITEMS;
  for (uint k = 0u; k < RAY_BOUNDS_ITEMS && n > 0u; ++k) {
    vec3 d = position[samples[boundsSample(first + k, n)]].xyz - pc.light.xyz;
    uint face = rayFace(d);
    if (face == 7u) continue;
    vec2 uv = rayFaceUV(d, face);
    least[face] = min(least[face], uvec4(orderedBits(uv.x), orderedBits(uv.y), orderedBits(-uv.x), orderedBits(-uv.y)));
  }
  barrier();
  for (uint f = 0u; f < 6u; ++f)
    if (least[f].x != RAY_BOUNDS_EMPTY)
      for (uint c = 0u; c < 4u; ++c) atomicMin(box[4u * f + c], least[f][c]);
  barrier();
  if (t < 24u && box[t] != RAY_BOUNDS_EMPTY) atomicMin(bounds[t], box[t]);
}
