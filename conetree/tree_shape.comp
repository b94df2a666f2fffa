#version 450
#extension GL_GOOGLE_include_directive : require
// The implicit tree's shape from the ray count on the GPU (one invocation): depth, per-depth counts and
// offsets (cone_layout.h's index maths, the very functions treeShape() calls on the host) and the
// indirect dispatch of each height's build, so the build and the traversal need no count from the host.
// bindings: 0 = count words (the ray count at p.countIndex), 1 = shape words (SHAPE_*, written)
#include "conetree/cone_layout.h"

layout(local_size_x = 1) in;
layout(std430, binding = 0) readonly buffer CountWords { uint countWords[]; };
layout(std430, binding = 1) writeonly buffer Shape { uint shape[]; };
layout(push_constant) uniform Push { ShapePush p; };

void main() {
  uint n = min(countWords[p.countIndex], p.maxLeaves);
  uint depth = n == 0u ? 0u : treeDepth(n);
  shape[SHAPE_LEAVES] = n;
  shape[SHAPE_DEPTH] = depth;
  shape[SHAPE_NODES] = depth == 0u ? 0u : levelOffset(n, depth, depth);
  shape[3] = 0u;
  for (uint d = 0u; d <= SHAPE_MAX_DEPTH; d++) {
    shape[SHAPE_COUNTS + d] = d <= depth && depth > 0u ? levelCount(n, depth, d) : 0u;
    shape[SHAPE_OFFSETS + d] = d <= depth && depth > 0u ? levelOffset(n, depth, d) : 0u;
  }
  for (uint h = 0u; h <= SHAPE_MAX_DEPTH; h++) {
    uint nodes = h >= 1u && h <= depth ? countAtHeight(n, h) : 0u;
    uint groups = (nodes + CONE_BUILD_THREADS - 1u) / CONE_BUILD_THREADS;
    uint x = min(groups, p.maxPerDim);
    uint y = x == 0u ? 1u : (groups + x - 1u) / x;
    uint at = SHAPE_BUILD_ARGS + 4u * h;
    shape[at] = x;
    shape[at + 1u] = y;
    shape[at + 2u] = 1u;
    shape[at + 3u] = nodes;
  }
}
