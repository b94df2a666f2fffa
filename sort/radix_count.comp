#version 450
#extension GL_GOOGLE_include_directive : require
// Radix sort, step 1 of a pass: each tile's digit histogram, written digit-major
// (hist[digit * tiles + tile]) so one exclusive scan of the table gives every (digit, tile) its first
// output position. Tiles past the device count write zeros; with a device count the dispatch is indirect
// (sort::IndirectGroups: only the tiles the count fills), and tile 0 also zeroes the entries of the
// tiles [used, tiles) that were not launched.
// bindings: 0 = keys (uint[], read as uvec4), 1 = hist (uint[], (digitMask + 1) * tiles),
//           2 = countWords (device count), 3 = pairs (PAIRS_IN: read instead of binding 0, as a uniform
//           texel buffer, RGBA32UI)
#include "sort/sort_layout.h"
layout(std430, binding = 0) readonly buffer Keys { uvec4 keys4[]; };
layout(std430, binding = 1) writeonly buffer Hist { uint hist[]; };
layout(std430, binding = 2) readonly buffer CountWords { uint countWords[]; };
layout(push_constant) uniform Push { RadixPush pc; };
#include "sort/common.glsl"
#define PAIR_TEXELS 3
#include "sort/radix.glsl"

shared uint bins[RADIX_BINS];

void main() {
  uint tile = flatWorkgroup();
  if (tile >= pc.tiles) return;
  uint n = countOf(pc.count, pc.countIndex, pc.flags);
  uint t = gl_LocalInvocationIndex;
  for (uint d = t; d < RADIX_BINS; d += SORT_THREADS) bins[d] = 0u;
  barrier();
  uint first = tile * SORT_TILE + t * SORT_ITEMS;
  uint items = first < n ? min(SORT_ITEMS, n - first) : 0u;
  for (uint k = 0u; k < items; k += 4u) {
    uvec4 key = loadKeys((first + k) / 4u, n);
    for (uint c = 0u; c < 4u; ++c)
      if (k + c < items) atomicAdd(bins[digitOf(key[c])], 1u);
  }
  barrier();
  for (uint d = t; d <= pc.digitMask; d += SORT_THREADS) hist[d * pc.tiles + tile] = bins[d];
  if (tile == 0u) {
    uint used = max(ceilDiv(n, SORT_TILE), 1u);
    uint rest = pc.tiles - min(used, pc.tiles);
    for (uint e = t; e < rest * (pc.digitMask + 1u); e += SORT_THREADS) hist[(e / rest) * pc.tiles + used + e % rest] = 0u;
  }
}
