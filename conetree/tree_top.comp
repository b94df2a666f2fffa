#version 450
#extension GL_GOOGLE_include_directive : require
// The top of the cone tree in one workgroup (docs/ARCHITECTURE.md, "conetree/"): every height from
// topHeight(n) (cone_layout.h: the lowest with at most CONE_TOP_NODES nodes, at least 2) up to the root,
// after build_level.comp built the heights below. Each level's nodes go to the node array and to shared
// memory, where the next level reads them: a barrier between levels instead of a dispatch and a barrier a
// height over a handful of nodes. The same merges as build_level.comp over the same children, so the
// nodes are those a dispatch a height writes, bit for bit. Launched indirectly from the shape words
// (SHAPE_BUILD_ARGS + 0: one workgroup, or none when the tree is not that deep or a rebuild was kept).
// bindings: 0 = nodes (ConeNode, the whole tree; the top heights written), 1 = shape words (uniform
//           texel buffer, RGBA32UI), 2 = nodes again (uniform texel buffer, RGBA32F: two texels a
//           ConeNode; the level below the top read), 3 = boxes (cone_layout.h, boxOffset: the top's
//           heights written, from the boxes of the height below -- a level's writes made visible to the
//           next by a barrier -- or at height 2 from the rays), 4 = the sorted rays' records (uniform
//           texel buffer, RGBA32UI: the sample's position as float bits, ConeTree::rays)
#include "conetree/cone_math.h"

layout(local_size_x = CONE_BUILD_THREADS) in;
layout(std430, binding = 0) writeonly buffer Nodes { ConeNode nodes[]; };
layout(binding = 1) uniform usamplerBuffer shapeTexels;
layout(binding = 2) uniform samplerBuffer nodeTexels;
layout(std430, binding = 3) coherent buffer Boxes { vec4 boxes[]; };
layout(binding = 4) uniform usamplerBuffer rayTexels;
uint shapeWord(uint w) { return texelWord(shapeTexels, w); }
layout(push_constant) uniform Push { BuildPush p; };
layout(constant_id = 0) const uint SPEC_FAR = 0u;  // 1: the far-light frame (= p.frame.rowX.w != 0)

const uint kPerThread = CONE_TOP_NODES / CONE_BUILD_THREADS;
shared vec4 levelAxisCos[CONE_TOP_NODES], levelSinLen[CONE_TOP_NODES];  // the level built last

void main() {
  uint t = gl_LocalInvocationIndex;
  uint leaves = shapeWord(SHAPE_LEAVES);
  uint depth = shapeWord(SHAPE_DEPTH), first = topHeight(leaves);
  for (uint h = first; h <= depth; ++h) {
    uint d = depth - h;
    uint count = shapeWord(SHAPE_COUNTS + d), nodeOffset = shapeWord(SHAPE_OFFSETS + d);
    uint childCount = shapeWord(SHAPE_COUNTS + d + 1u), childOffset = shapeWord(SHAPE_OFFSETS + d + 1u);
    ConeNode made[kPerThread];
    for (uint k = 0u; k < kPerThread; ++k) {
      uint j = t + k * CONE_BUILD_THREADS;
      if (j >= count) break;
      uvec2 r = childRange(j, childCount);
      ConeNode c[4];
      for (uint i = 0u; i < 4u; ++i) {
        uint at = r.x + i;
        if (at >= r.y) {
          c[i] = emptyCone();
        } else if (h == first) {
          c[i].axisCos = texelFetch(nodeTexels, int(2u * (childOffset + at)));
          c[i].sinLen = texelFetch(nodeTexels, int(2u * (childOffset + at) + 1u));
        } else {
          c[i].axisCos = levelAxisCos[at];
          c[i].sinLen = levelSinLen[at];
        }
      }
      // build_level.comp's merge of interior nodes (four children, the missing ones empty).
      made[k] = SPEC_FAR != 0u ? coneParentFar(c[0], c[1], c[2], c[3], 4u, CONE_PAD * p.frame.centre.w)
                               : coneParent(c[0], c[1], c[2], c[3], 4u, CONE_PAD);
      nodes[nodeOffset + j] = made[k];
      // build_level.comp's box: of the children's boxes, or at height 2 of the node's rays
      vec3 lo = vec3(3.0e38), hi = vec3(-3.0e38);
      if (h == 2u) {
        for (uint at = 16u * j; at < min(16u * j + 16u, leaves); ++at) {
          vec3 position = uintBitsToFloat(texelFetch(rayTexels, int(at)).xyz);
          lo = min(lo, position);
          hi = max(hi, position);
        }
      } else {
        uint below = boxOffset(leaves, h - 1u);
        for (uint at = r.x; at < r.y; ++at) {
          lo = min(lo, boxes[2u * (below + at)].xyz);
          hi = max(hi, boxes[2u * (below + at) + 1u].xyz);
        }
      }
      uint b = boxOffset(leaves, h) + j;
      boxes[2u * b] = vec4(lo, 0.0f);
      boxes[2u * b + 1u] = vec4(hi, 0.0f);
    }
    memoryBarrierBuffer();  // this level's boxes, for the next level's invocations
    barrier();  // every child of this level read before the level overwrites them
    for (uint k = 0u; k < kPerThread; ++k) {
      uint j = t + k * CONE_BUILD_THREADS;
      if (j >= count) break;
      levelAxisCos[j] = made[k].axisCos;
      levelSinLen[j] = made[k].sinLen;
    }
    barrier();
  }
}
