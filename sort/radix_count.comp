#version 450
#extension GL_GOOGLE_include_directive : require
// Radix sort, step 1 of a pass: each tile's digit histogram, written digit-major
// (hist[digit * tiles + tile]) so one exclusive scan of the table gives every (digit, tile) its first
// output position. `tiles`, the table's row stride, is the tiles the count fills (at least one), not the
// host's bound: with a device count the dispatch is indirect (sort::IndirectGroups: only those tiles,
// at least one), the table has no rows of tiles that did not run, and tile 0 writes its size,
// (digitMask + 1) * tiles (0 for no keys), to binding 5 for the scan of the table, which then covers
// those entries only, and after it the indirect arguments of the scan's level-0 grid (sort::Count::
// withGroups): max(1, ceil(size / SCAN_BLOCK)) workgroups, where a grid for the capacity's table
// launched them all (a far view's few runs fill a few tiles of a table sized for every pixel).
// It also leaves the tile's ranking counters scanned in binding 4 (radix.glsl, kRankWords), which the
// scatter then loads instead of counting the tile's keys a second time.
// bindings: 0 = keys (uint[], read as uvec4), 1 = hist (uint[], (digitMask + 1) * tiles),
//           2 = countWords (device count), 3 = pairs (PAIRS_IN: read instead of binding 0, as a uniform
//           texel buffer, RGBA32UI), 4 = ranks (uint[kRankWords * tiles], written as uvec4), 5 = the
//           table's entry count, then its scan's grid x, y, 1 (four uint, written by tile 0)
#include "sort/sort_layout.h"
layout(std430, binding = 0) readonly buffer Keys { uvec4 keys4[]; };
layout(std430, binding = 1) writeonly buffer Hist { uint hist[]; };
layout(std430, binding = 2) readonly buffer CountWords { uint countWords[]; };
layout(std430, binding = 4) writeonly buffer Ranks { uvec4 ranks4[]; };
layout(std430, binding = 5) writeonly buffer TableCount { uint tableCount[4]; };
layout(push_constant) uniform Push { RadixPush pc; };
#include "sort/common.glsl"
#define PAIR_TEXELS 3
#include "sort/radix.glsl"
#define WG_SIZE SORT_THREADS
#define WG_RAKE SORT_RAKE
#include "sort/workgroup_scan.glsl"

// Counting as the scatter ranks (radix_scatter.comp): one 16-bit counter per (digit, invocation), two
// digits a word, each invocation adding to its own column with a plain load and store. A shared atomic
// costs lavapipe more than the two (sort_bench, 1 M pairs), and the columns' sum below is half a read a key.
shared uint counters[kWords + kWords / 32u];  // radix.glsl, slot()

void main() {
  uint tile = CS_FLAT_WORKGROUP;
  if (tile >= pc.tiles) return;
  uint n = countOf(pc.count, pc.countIndex, pc.flags);
  uint tiles = tableTiles(n);
  if (tile >= tiles) return;
  uint t = gl_LocalInvocationIndex;
  // No keys (a device count of 0: the cone path's sort on a frame that keeps screen order): an empty
  // table, nothing to count or rank. The sort launches no tile then (sort.cpp clears binding 5 before);
  // a tile launched all the same (the look-back scheme's one) only says so.
  if (tile == 0u && t == 0u) {
    uint entries = n == 0u ? 0u : (pc.digitMask + 1u) * tiles;
    // The grid as vk::gridFor makes it, rows past 65535 workgroups (every device's least limit a side).
    uint groups = max(ceilDiv(entries, uint(SCAN_BLOCK)), 1u), y = ceilDiv(groups, 65535u);
    tableCount[0] = entries;
    tableCount[1] = ceilDiv(groups, y);
    tableCount[2] = y;
    tableCount[3] = 1u;
  }
  if (n == 0u) return;
  for (uint i = t; i < kWords + kWords / 32u; i += SORT_THREADS) counters[i] = 0u;
  barrier();
  uint first = tile * SORT_TILE + t * SORT_ITEMS;
  uint items = first < n ? min(SORT_ITEMS, n - first) : 0u;
  for (uint k = 0u; k < items; k += 4u) {
    uvec4 key = loadKeys((first + k) / 4u, n);
    for (uint c = 0u; c < 4u; ++c) {
      if (k + c >= items) break;
      uint d = digitOf(key[c]);
      counters[slot(d % RADIX_WORDS, t)] += d < RADIX_WORDS ? 1u : 0x10000u;
    }
  }
  barrier();
  // Word w holds digits w (low halves) and w + RADIX_WORDS (high halves): a tile holds fewer than 65536
  // keys, so neither half carries.
  for (uint w = t; w < RADIX_WORDS; w += SORT_THREADS) {
    uint sum = 0u;
    for (uint u = 0u; u < SORT_THREADS; ++u) sum += counters[slot(w, u)];
    if (w <= pc.digitMask) hist[w * tiles + tile] = sum & 0xFFFFu;
    if (w + RADIX_WORDS <= pc.digitMask) hist[(w + RADIX_WORDS) * tiles + tile] = sum >> 16u;
  }
  // The ranks: an exclusive scan over all words in (word, invocation) order, invocation t raking words
  // t*W .. t*W+W-1 of that order (W = RADIX_WORDS) and storing its scanned words four at a time.
  uint sum = 0u;
  for (uint w = 0u; w < RADIX_WORDS; ++w) {
    uint i = t * RADIX_WORDS + w;
    sum += counters[i + (i >> 5u)];
  }
  uint total;
  uint running = workgroupExclusiveSum(sum, total);  // (its barriers also end the column sums' reads)
  uint at = tile * kRankWords;
  for (uint w = 0u; w < RADIX_WORDS; w += 4u) {
    uint i = t * RADIX_WORDS + w, j = i + (i >> 5u);  // four words in a row: i is a multiple of 4
    uvec4 r;
    r.x = running;
    r.y = r.x + counters[j];
    r.z = r.y + counters[j + 1u];
    r.w = r.z + counters[j + 2u];
    running = r.w + counters[j + 3u];
    ranks4[(at + i) / 4u] = r;
  }
  if (t == 0u) ranks4[(at + kWords) / 4u] = uvec4(total & 0xFFFFu, 0u, 0u, 0u);
}
