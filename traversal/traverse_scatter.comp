#version 450
#extension GL_GOOGLE_include_directive : require
// Compaction of one pass's survivors: input i writes its surviving children, in child order, at arena
// slots outFirst + offsets[i] + 0, 1, ... (offsets: sort/'s exclusive scan of the counts). When the
// survivors (the scan's total) would pass outLimit, nothing is written: the host retries a smaller chunk.
// bindings: 0 = arena (uvec2 pairs, written), 1 = chunk (uvec2 input pairs, a copy: outputs may overwrite
//           the inputs' arena slots), 2 = masks (uint per input), 3 = offsets (uint per input),
//           4 = stats (STAT_TOTAL: the survivors; on the device path the state words, the count at p.countWord)
#include "traversal/traverse.glsl"

layout(local_size_x = TRAVERSE_THREADS) in;
layout(std430, binding = 0) writeonly buffer Arena { uvec2 pairs[]; };
layout(std430, binding = 1) readonly buffer Chunk { uvec2 inputs[]; };
layout(std430, binding = 2) readonly buffer Masks { uint masks[]; };
layout(std430, binding = 3) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = 4) readonly buffer Stats { uint stats[]; };
layout(push_constant) uniform Push { TraversePush p; };

void main() {
  uint i = flatIndex();
  if (i >= (p.countWord != 0u ? stats[p.countWord] : p.count)) return;
  uint mask = masks[i];
  if (mask == 0u || stats[STAT_TOTAL] > p.outLimit - p.outFirst) return;
  // The input pair: a triangle or cluster of pass 0, an arena pair, or (an expansion, device path) the
  // triangle i % 64 of cluster pair i / 64.
  uint mode = p.deviceParams != 0u ? stats[STATE_MODE] : STEP_TRIANGLES;
  bool expand = mode == STEP_EXPAND;
  uint first = mode == STEP_CLUSTERS ? p.first >> CLUSTER_SHIFT : p.first;
  uvec2 in_ = expand ? inputs[i >> CLUSTER_SHIFT] : (p.fromTriangles != 0u ? uvec2(first + i, 0u) : inputs[i]);
  uint tri = expand ? (in_.x << CLUSTER_SHIFT) + (i & (CLUSTER_SIZE - 1u)) : in_.x;
  uint firstChild = p.fromTriangles != 0u ? 0u : 4u * in_.y;
  uint out_ = p.outFirst + offsets[i];
  for (uint k = 0u; k < 4u; k++)
    if ((mask & (1u << k)) != 0u) pairs[out_++] = uvec2(tri, firstChild + k);
}
