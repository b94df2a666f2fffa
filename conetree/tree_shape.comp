#version 450
#extension GL_GOOGLE_include_directive : require
// The implicit tree's shape from the ray count on the GPU (one invocation): depth, per-depth counts and
// offsets (cone_layout.h's index maths, the very functions treeShape() calls on the host) and the
// indirect dispatch of each height's build below topHeight and of the top's (tree_top.comp), so the
// build and the traversal need no count from the host.
// With keepWhenZero, a count of 0 leaves the shape as it was and dispatches no build: the tree built
// before stands (a rebuild the GPU decided against).
// bindings: 0 = count words (the ray count at p.countIndex), 1 = shape words (SHAPE_*, written)
#include "conetree/cone_layout.h"

layout(local_size_x = 1) in;
layout(std430, binding = 0) readonly buffer CountWords { uint countWords[]; };
layout(std430, binding = 1) writeonly buffer Shape { uint shape[]; };
layout(push_constant) uniform Push { ShapePush p; };

void writeArgs(uint at, uint items, uint groupSize) {
  uvec2 grid = indirectGrid(items, groupSize, p.maxPerDim);
  shape[at] = grid.x;
  shape[at + 1u] = grid.y;
  shape[at + 2u] = 1u;
  shape[at + 3u] = items;
}

void main() {
  uint n = min(countWords[p.countIndex], p.maxLeaves);
  if (n == 0u && p.keepWhenZero != 0u) {  // keep the tree there is: build nothing
    for (uint h = 0u; h <= SHAPE_MAX_DEPTH; h++) writeArgs(SHAPE_BUILD_ARGS + 4u * h, 0u, CONE_BUILD_THREADS);
    return;
  }
  uint depth = n == 0u ? 0u : treeDepth(n);
  shape[SHAPE_LEAVES] = n;
  shape[SHAPE_DEPTH] = depth;
  shape[SHAPE_NODES] = depth == 0u ? 0u : levelOffset(n, depth, depth);
  shape[3] = 0u;
  for (uint d = 0u; d <= SHAPE_MAX_DEPTH; d++) {
    shape[SHAPE_COUNTS + d] = d <= depth && depth > 0u ? levelCount(n, depth, d) : 0u;
    shape[SHAPE_OFFSETS + d] = d <= depth && depth > 0u ? levelOffset(n, depth, d) : 0u;
  }
  // Heights 1 .. topHeight - 1 a dispatch each, the rest in tree_top.comp's one workgroup (slot 0).
  uint top = topHeight(n);
  for (uint h = 1u; h <= SHAPE_MAX_DEPTH; h++)
    writeArgs(SHAPE_BUILD_ARGS + 4u * h, h < top && h <= depth ? countAtHeight(n, h) : 0u, CONE_BUILD_THREADS);
  writeArgs(SHAPE_BUILD_ARGS, depth >= top ? 1u : 0u, 1u);
}
