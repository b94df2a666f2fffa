#version 450
#extension GL_GOOGLE_include_directive : require
// The leaves' hits into the visibility, once a traversal's leaves have all run: sorted ray r's bit in
// `shadowed` set (traverse_leaves.comp: a leaf test hit it) puts 0 in its pixel's visibility word.
// LEAF_HITS_RAYS rays an invocation (traversal_layout.h), as many invocations as the sorted rays need:
// on the device path from the indirect arguments pass 0's advance wrote from the tree's shape
// (STATE_HITS_ARGS), on the chunked path from the host's count. The leaves gather the hits of a pair as
// bits and OR them in with one atomic; writing each hit's visibility there instead was a loop of a
// storage load and an atomic per hit that ran, on lavapipe, as often as the lane with the most hits
// needed (a third of the fur's leaves at 1024²). Here each shadowed ray is one store, whatever the number of triangles that hit
// it; a plain store, since every writer writes 0 and nothing else writes the word in this pass.
// bindings: 0 = rays (uniform texel buffer, RGBA32UI, one texel a sorted ray: .w its pixel index),
//           1 = shadowed (uniform texel buffer, R32UI: a bit a sorted ray), 2 = visibility (uint per pixel),
//           3 = the tree's shape words (uniform texel buffer, RGBA32UI; read when p.fromShape)
#include "conetree/cone_layout.h"
#include "traversal/traversal_layout.h"

layout(local_size_x = CONE_BUILD_THREADS) in;
layout(binding = 0) uniform usamplerBuffer rays;
layout(binding = 1) uniform usamplerBuffer shadowed;
layout(std430, binding = 2) buffer Visibility { uint visibility[]; };
layout(binding = 3) uniform usamplerBuffer shapeTexels;
layout(push_constant) uniform Push { LeafHitsPush p; };

void main() {
  uint j = CS_FLAT_INDEX(CONE_BUILD_THREADS);
  uint n = p.fromShape != 0u ? texelWord(shapeTexels, SHAPE_LEAVES) : p.count;
  uint first = j << LEAF_HITS_SHIFT;
  if (first >= n) return;
  uint bits = (texelFetch(shadowed, int(first >> 5u)).x >> (first & 31u)) & LEAF_HITS_MASK;
  if (n - first < LEAF_HITS_RAYS) bits &= (1u << (n - first)) - 1u;
  for (uint todo = bits; todo != 0u; todo &= todo - 1u)
    visibility[texelFetch(rays, int(first + uint(findLSB(todo)))).w] = 0u;
}
