#version 450
#extension GL_GOOGLE_include_directive : require
// Two-pass traversal (002 §3.4), the update step: flags[i] = 1 when sorted ray i (sample samples[i]) is
// still lit after the blockers' pass, 0 when a blocker shadowed it. sort/'s Compact then keeps the
// unfinished rays' samples in their order (still Hilbert-sorted) for the tree of the second pass.
// bindings: 0 = samples (uint pixel per sorted ray), 1 = visibility (uint per pixel; 0 = shadowed),
//           2 = flags (uint per ray)
#include "traversal/traverse.glsl"

layout(local_size_x = TRAVERSE_THREADS) in;
layout(std430, binding = 0) readonly buffer Samples { uint samples[]; };
layout(std430, binding = 1) readonly buffer Visibility { uint visibility[]; };
layout(std430, binding = 2) writeonly buffer Flags { uint flags[]; };
layout(push_constant) uniform Push { TraversePush p; };

void main() {
  uint i = flatIndex();
  if (i >= p.count) return;
  flags[i] = visibility[samples[i]] != 0u ? 1u : 0u;
}
