#version 450
#extension GL_GOOGLE_include_directive : require
// Radix sort by look-back, before the first pass: how many keys carry each digit, for every pass at
// once (one read of the keys instead of one count pass per digit). Each tile counts into shared bins and
// adds its non-zero bins to the workspace's totals (sort_layout.h, LOOKBACK_DIGITS). An invocation's keys
// are consecutive, and keys made in screen order share their high digits with their neighbours: a
// digit is added once per run of equal digits, not once per key.
// bindings: 0 = keys (uint[], read as uvec4), 1 = workspace (uint[], zeroed), 2 = countWords (device count),
//           3 = a uniform texel buffer radix.glsl declares (pairs; never read here)
#include "sort/sort_layout.h"
layout(std430, binding = 0) readonly buffer Keys { uvec4 keys4[]; };
layout(std430, binding = 1) buffer Workspace { uint work[]; };
layout(std430, binding = 2) readonly buffer CountWords { uint countWords[]; };
layout(push_constant) uniform Push { RadixPush pc; };
#include "sort/common.glsl"
#define PAIR_TEXELS 3
#include "sort/radix.glsl"

shared uint bins[LOOKBACK_MAX_PASSES * RADIX_BINS];

void main() {
  uint tile = CS_FLAT_WORKGROUP;
  if (tile >= pc.tiles) return;
  uint n = countOf(pc.count, pc.countIndex, pc.flags);
  if (tile * SORT_TILE >= n) return;  // uniform
  uint passes = ceilDiv(pc.keyBits, RADIX_BITS);
  uint t = gl_LocalInvocationIndex;
  for (uint i = t; i < passes * RADIX_BINS; i += SORT_THREADS) bins[i] = 0u;
  barrier();

  uvec4 mask = uvec4(0u);  // pass p's digit mask (0 past the last pass)
  for (uint p = 0u; p < passes; ++p) mask[p] = (1u << min(RADIX_BITS, pc.keyBits - p * RADIX_BITS)) - 1u;
  uvec4 last = uvec4(0u), run = uvec4(0u);  // per pass: the digit of the current run and its length
  uint first = tile * SORT_TILE + t * SORT_ITEMS;
  uint items = first < n ? min(SORT_ITEMS, n - first) : 0u;
  for (uint k = 0u; k < items; k += 4u) {
    uvec4 key = loadKeys((first + k) / 4u, n);
    for (uint c = 0u; c < 4u; ++c) {
      if (k + c >= items) break;
      for (uint p = 0u; p < passes; ++p) {
        uint d = (key[c] >> (p * RADIX_BITS)) & mask[p];
        if (d != last[p] && run[p] != 0u) {
          atomicAdd(bins[p * RADIX_BINS + last[p]], run[p]);
          run[p] = 0u;
        }
        last[p] = d;
        run[p] += 1u;
      }
    }
  }
  for (uint p = 0u; p < passes; ++p)
    if (run[p] != 0u) atomicAdd(bins[p * RADIX_BINS + last[p]], run[p]);
  barrier();
  for (uint i = t; i < passes * RADIX_BINS; i += SORT_THREADS)
    if (bins[i] != 0u) atomicAdd(work[LOOKBACK_DIGITS + i], bins[i]);
}
