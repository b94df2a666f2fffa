#version 450
#extension GL_GOOGLE_include_directive : require
// Radix sort, step 3 of a pass: rank each key of the tile stably among the tile's keys of its digit and
// write key (and value) to hist[digit * tiles + tile] + rank, the scanned histogram of step 2.
// Ranking: one 16-bit counter per (digit, invocation) in shared memory, two digits per word (digit d low
// half of word d % RADIX_WORDS, high half when d >= RADIX_WORDS). Each invocation counts its own keys into
// its own column (no atomics), one workgroup scan over the words in (word, invocation) order turns the
// counts into stable ranks, and a second walk over the keys hands them out.
// bindings: 0 = keysIn, 1 = valuesIn (uint[], read as uvec4), 2 = keysOut, 3 = valuesOut (uint[]),
//           4 = hist (scanned), 5 = countWords (device count)
#include "sort/sort_layout.h"
layout(std430, binding = 0) readonly buffer KeysIn { uvec4 keys4[]; };
layout(std430, binding = 1) readonly buffer ValuesIn { uvec4 values4[]; };
layout(std430, binding = 2) writeonly buffer KeysOut { uint keysOut[]; };
layout(std430, binding = 3) writeonly buffer ValuesOut { uint valuesOut[]; };
layout(std430, binding = 4) readonly buffer Hist { uint hist[]; };
layout(std430, binding = 5) readonly buffer CountWords { uint countWords[]; };
layout(push_constant) uniform Push { RadixPush pc; };
#include "sort/common.glsl"
#include "sort/radix.glsl"
#define WG_SIZE SORT_THREADS
#define WG_RAKE SORT_RAKE
#include "sort/workgroup_scan.glsl"

const uint kWords = RADIX_WORDS * SORT_THREADS;
shared uint counters[kWords + kWords / 32u];  // padded: one spare word per 32 keeps raking conflict-free
shared uint adjust[RADIX_BINS];               // global position of the tile's first key of each digit, minus its tile rank

uint slot(uint word, uint t) {
  uint i = word * SORT_THREADS + t;
  return i + (i >> 5u);
}
uint unpackRank(uint packed, uint d, uint lowTotal) {
  return d < RADIX_WORDS ? (packed & 0xFFFFu) : (packed >> 16u) + lowTotal;
}
uvec4 loadValues(uint v, uint n) {
  if (4u * v + 3u < n) return values4[v];
  uvec4 r = uvec4(0u);
  for (uint c = 0u; c < 3u; ++c)
    if (4u * v + c < n) r[c] = values4[v][c];
  return r;
}
uint increment(uint d) { return d < RADIX_WORDS ? 1u : 0x10000u; }

void main() {
  uint tile = flatWorkgroup();
  if (tile >= pc.tiles) return;
  uint n = countOf(pc.count, pc.countIndex, pc.flags);
  uint base = tile * SORT_TILE;
  if (base >= n) return;  // uniform: an empty tile has nothing to place
  uint t = gl_LocalInvocationIndex;
  uint first = base + t * SORT_ITEMS;
  uint items = first < n ? min(SORT_ITEMS, n - first) : 0u;

  for (uint i = t; i < kWords + kWords / 32u; i += SORT_THREADS) counters[i] = 0u;
  barrier();
  for (uint k = 0u; k < items; k += 4u) {
    uvec4 key = loadKeys((first + k) / 4u, n);
    for (uint c = 0u; c < 4u; ++c) {
      if (k + c >= items) break;
      uint d = digitOf(key[c]);
      counters[slot(d % RADIX_WORDS, t)] += increment(d);
    }
  }
  barrier();

  // Exclusive scan over all words in (word, invocation) order; invocation t rakes words t*W .. t*W+W-1
  // of that order (W = RADIX_WORDS). Halves never carry: a tile holds fewer than 65536 keys.
  uint sum = 0u;
  for (uint w = 0u; w < RADIX_WORDS; ++w) {
    uint i = t * RADIX_WORDS + w;
    sum += counters[i + (i >> 5u)];
  }
  uint total;
  uint running = workgroupExclusiveSum(sum, total);
  uint lowTotal = total & 0xFFFFu;  // keys with a digit in the low halves come first
  for (uint w = 0u; w < RADIX_WORDS; ++w) {
    uint i = t * RADIX_WORDS + w;
    uint x = counters[i + (i >> 5u)];
    counters[i + (i >> 5u)] = running;
    running += x;
  }
  barrier();
  for (uint d = t; d <= pc.digitMask; d += SORT_THREADS)
    adjust[d] = hist[d * pc.tiles + tile] - unpackRank(counters[slot(d % RADIX_WORDS, 0u)], d, lowTotal);
  barrier();

  bool hasValues = (pc.flags & FLAG_HAS_VALUES) != 0u;
  for (uint k = 0u; k < items; k += 4u) {
    uvec4 key = loadKeys((first + k) / 4u, n);
    uvec4 value = hasValues ? loadValues((first + k) / 4u, n) : uvec4(0u);
    for (uint c = 0u; c < 4u; ++c) {
      if (k + c >= items) break;
      uint d = digitOf(key[c]);
      uint s = slot(d % RADIX_WORDS, t);
      uint packed = counters[s];
      counters[s] = packed + increment(d);
      uint dst = adjust[d] + unpackRank(packed, d, lowTotal);
      keysOut[dst] = key[c];
      if (hasValues) valuesOut[dst] = value[c];
    }
  }
}
