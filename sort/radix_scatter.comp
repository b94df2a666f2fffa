#version 450
#extension GL_GOOGLE_include_directive : require
// Radix sort, step 3 of a pass: rank each key of the tile stably among the tile's keys of its digit and
// write key (and value) to hist[digit * tiles + tile] + rank, the scanned histogram of step 2 (tiles:
// the tiles the count fills, radix.glsl's tableTiles).
// Ranking: one 16-bit counter per (digit, invocation) in shared memory, two digits per word (digit d low
// half of word d % RADIX_WORDS, high half when d >= RADIX_WORDS). Each invocation counts its own keys into
// its own column (no atomics), one workgroup scan over the words in (word, invocation) order turns the
// counts into stable ranks, and a second walk over the keys hands them out.
// Where a tile's keys of a digit start in the output comes from one of two schemes (sort::SortScheme):
//  - reduce-then-scan (LOOKBACK false): a count pass and a scan of the digit-major histogram table before
//    this kernel (radix_count.comp, sort::Scan); binding 4 is that scanned table.
//  - look-back (LOOKBACK true): binding 4 is the look-back workspace (sort_layout.h). Tiles are taken in
//    launch order from the pass's counter; a tile publishes its own count of each digit, then walks back
//    over the tiles before it, adding their counts until one has published its inclusive prefix, and
//    publishes its own. The digit's start over all keys comes from radix_histogram.comp's totals. No count
//    pass, no table scan. It waits on earlier tiles only, which already run (or ran) on the device, and
//    only for SPINS reads: a tile still unpublished by then is counted from its keys here, so the
//    result never depends on scheduling (sort::sortSchemeFor says where waiting is expected to be short).
// Layouts (sort.h): the input is separate keys and values, or (PAIRS_IN) interleaved pairs in binding 7;
// the output separate keys and values, or (PAIRS_OUT) interleaved pairs in binding 6, one uvec2 store a key,
// or (KEYS_OUT false, separate) the values alone.
// bindings: 0 = keysIn (or pairsIn), 1 = valuesIn (uint[], read as uvec4), 2 = keysOut, 3 = valuesOut
//           (uint[]), 4 = hist (scanned) or the look-back workspace, 5 = countWords (device count),
//           6 = pairsOut (uvec2[]), 7 = pairsIn (PAIRS_IN: the pairs as a uniform texel buffer, RGBA32UI),
//           8 = ranks (reduce-then-scan: the tile's scanned counters from radix_count.comp, radix.glsl)
#include "sort/sort_layout.h"
layout(std430, binding = 0) readonly buffer KeysIn { uvec4 keys4[]; };
layout(std430, binding = 1) readonly buffer ValuesIn { uvec4 values4[]; };
layout(std430, binding = 2) writeonly buffer KeysOut { uint keysOut[]; };
layout(std430, binding = 3) writeonly buffer ValuesOut { uint valuesOut[]; };
layout(std430, binding = 4) buffer Hist { uint hist[]; };
layout(std430, binding = 5) readonly buffer CountWords { uint countWords[]; };
layout(std430, binding = 6) writeonly buffer PairsOut { uvec2 pairsOut[]; };
layout(std430, binding = 8) readonly buffer Ranks { uvec4 ranks4[]; };
layout(push_constant) uniform Push { RadixPush pc; };
#include "sort/common.glsl"
#define PAIR_TEXELS 7
#include "sort/radix.glsl"
layout(constant_id = 2) const bool LOOKBACK = false;
layout(constant_id = 3) const uint SPINS = LOOKBACK_SPINS;
layout(constant_id = 5) const bool PAIRS_OUT = false;
layout(constant_id = 6) const bool KEYS_OUT = true;  // false: the last pass of a sort whose caller needs the order only
#define WG_SIZE SORT_THREADS
#define WG_RAKE SORT_RAKE
#include "sort/workgroup_scan.glsl"

shared uint counters[kWords + kWords / 32u];  // radix.glsl, slot()
shared uint adjust[RADIX_BINS];               // global position of the tile's first key of each digit, minus its tile rank
shared uint lookbackTile;                     // look-back: the tile this workgroup took

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

uint statusWord(uint tile, uint d) { return LOOKBACK_STATUS + (pc.pass * pc.tiles + tile) * RADIX_BINS + d; }

// Look-back: adjust[] for the digits of this invocation's contiguous share (RADIX_BINS / SORT_THREADS
// of them), from the tile-local starts in counters[] (scanned) and the tiles before this one. Called by
// every invocation.
uint tileStart(uint d, uint lowTotal) { return unpackRank(counters[slot(d % RADIX_WORDS, 0u)], d, lowTotal); }
uint tileCount(uint d, uint tileKeys, uint lowTotal) {
  return (d == pc.digitMask ? tileKeys : tileStart(d + 1u, lowTotal)) - tileStart(d, lowTotal);
}
// Digits an invocation walks back for, at most (SORT_THREADS is a multiple of SORT_RAKE, sort.cpp checks).
const uint kMaxShare = RADIX_BINS / SORT_RAKE;

// Keys of each digit d0 .. d0 + nd - 1 in tile j, counted from the keys themselves: what a tile that has
// not published yet would publish, so the walk never depends on how long another workgroup takes. One pass
// over the tile for all the invocation's digits: a CPU driver may end a shader's loops after a fixed
// number of iterations (lavapipe: 65535, all loops of an invocation together), so the walk keeps its loops
// short (docs/ARCHITECTURE.md, "Sort").
void countTile(uint j, uint d0, uint nd, inout uint counts[kMaxShare]) {
  for (uint k = 0u; k < nd; ++k) counts[k] = 0u;
  uint n = countOf(pc.count, pc.countIndex, pc.flags), first = j * SORT_TILE, last = min(first + SORT_TILE, n);
  for (uint i = first; i < last; i += 4u) {
    uvec4 key = loadKeys(i / 4u, n);
    for (uint c = 0u; c < 4u; ++c) {
      uint k = digitOf(key[c]) - d0;  // wraps past nd for digits below d0
      if (i + c < last && k < nd) ++counts[k];
    }
  }
}

void lookBack(uint tile, uint tileKeys, uint lowTotal) {
  uint d0 = gl_LocalInvocationIndex * (RADIX_BINS / SORT_THREADS), d1 = min(d0 + RADIX_BINS / SORT_THREADS, pc.digitMask + 1u);
  uint nd = d1 > d0 ? d1 - d0 : 0u;
  uint totals = 0u;
  for (uint d = d0; d < d1; ++d) {
    totals += hist[LOOKBACK_DIGITS + pc.pass * RADIX_BINS + d];
    atomicExchange(hist[statusWord(tile, d)], (tile == 0u ? LOOKBACK_PREFIX : LOOKBACK_AGGREGATE) | tileCount(d, tileKeys, lowTotal));
  }
  uint allTotals;
  uint digitStart = workgroupExclusiveSum(totals, allTotals);  // keys of the digits below d0, all tiles
  // Tile by tile back from this one, each digit until a tile has published its inclusive prefix.
  uint before[kMaxShare], counts[kMaxShare];  // keys of digit d0 + k in the tiles walked; a counted tile's
  bool open[kMaxShare];
  for (uint k = 0u; k < nd; ++k) {
    before[k] = 0u;
    open[k] = true;
  }
  uint stillOpen = tile > 0u ? nd : 0u;
  for (uint j = tile; j > 0u && stillOpen > 0u; --j) {
    bool counted = false;
    for (uint k = 0u; k < nd; ++k) {
      if (!open[k]) continue;
      uint word = 0u;  // once the tile is counted, its counts serve the rest without waiting again
      for (uint tries = 0u; !counted && tries < SPINS && (word & (LOOKBACK_AGGREGATE | LOOKBACK_PREFIX)) == 0u; ++tries)
        word = atomicAdd(hist[statusWord(j - 1u, d0 + k)], 0u);
      if ((word & (LOOKBACK_AGGREGATE | LOOKBACK_PREFIX)) == 0u) {  // not published yet: count it here
        if (!counted) countTile(j - 1u, d0, nd, counts);
        counted = true;
        word = LOOKBACK_AGGREGATE | counts[k];
      }
      before[k] += word & LOOKBACK_VALUE;
      if ((word & LOOKBACK_PREFIX) != 0u) {
        open[k] = false;
        --stillOpen;
      }
    }
  }
  for (uint k = 0u; k < nd; ++k) {
    uint d = d0 + k;
    if (tile != 0u) atomicExchange(hist[statusWord(tile, d)], LOOKBACK_PREFIX | (before[k] + tileCount(d, tileKeys, lowTotal)));
    adjust[d] = digitStart + before[k] - tileStart(d, lowTotal);
    digitStart += hist[LOOKBACK_DIGITS + pc.pass * RADIX_BINS + d];
  }
}

void main() {
  uint tile;
  if (LOOKBACK) {
    if (gl_LocalInvocationIndex == 0u) lookbackTile = atomicAdd(hist[LOOKBACK_PARTITIONS + pc.pass], 1u);
    barrier();
    tile = lookbackTile;
  } else {
    tile = CS_FLAT_WORKGROUP;
  }
  if (tile >= pc.tiles) return;
  uint n = countOf(pc.count, pc.countIndex, pc.flags);
  uint base = tile * SORT_TILE;
  if (base >= n) return;  // uniform: an empty tile has nothing to place
  uint t = gl_LocalInvocationIndex;
  uint first = base + t * SORT_ITEMS;
  uint items = first < n ? min(SORT_ITEMS, n - first) : 0u;

  uint lowTotal;  // keys with a digit in the low halves come first
  if (LOOKBACK) {
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
    lowTotal = total & 0xFFFFu;
    for (uint w = 0u; w < RADIX_WORDS; ++w) {
      uint i = t * RADIX_WORDS + w;
      uint x = counters[i + (i >> 5u)];
      counters[i + (i >> 5u)] = running;
      running += x;
    }
    barrier();
  } else {
    // Reduce-then-scan: the count pass scanned this tile's counters already (radix_count.comp).
    uint at = tile * kRankWords;
    for (uint w = 0u; w < RADIX_WORDS; w += 4u) {
      uint i = t * RADIX_WORDS + w, j = i + (i >> 5u);  // four words in a row: i is a multiple of 4
      uvec4 r = ranks4[(at + i) / 4u];
      counters[j] = r.x;
      counters[j + 1u] = r.y;
      counters[j + 2u] = r.z;
      counters[j + 3u] = r.w;
    }
    lowTotal = ranks4[(at + kWords) / 4u].x;
    barrier();
  }
  if (LOOKBACK) {
    lookBack(tile, min(SORT_TILE, n - base), lowTotal);
  } else {
    uint tiles = tableTiles(n);
    for (uint d = t; d <= pc.digitMask; d += SORT_THREADS)
      adjust[d] = hist[d * tiles + tile] - unpackRank(counters[slot(d % RADIX_WORDS, 0u)], d, lowTotal);
  }
  barrier();

  bool hasValues = (pc.flags & FLAG_HAS_VALUES) != 0u;
  for (uint k = 0u; k < items; k += 4u) {
    uvec4 key, value;
    if (PAIRS_IN) {
      uvec4 a = loadPairs((first + k) / 2u), b = loadPairs((first + k) / 2u + 1u);
      key = uvec4(a.x, a.z, b.x, b.z);
      value = uvec4(a.y, a.w, b.y, b.w);
    } else {
      key = loadKeys((first + k) / 4u, n);
      value = hasValues ? loadValues((first + k) / 4u, n) : uvec4(0u);
    }
    for (uint c = 0u; c < 4u; ++c) {
      if (k + c >= items) break;
      uint d = digitOf(key[c]);
      uint s = slot(d % RADIX_WORDS, t);
      uint packed = counters[s];
      counters[s] = packed + increment(d);
      uint dst = adjust[d] + unpackRank(packed, d, lowTotal);
      if (PAIRS_OUT) {
        pairsOut[dst] = uvec2(key[c], value[c]);
      } else {
        if (KEYS_OUT) keysOut[dst] = key[c];
        if (hasValues) valuesOut[dst] = value[c];
      }
    }
  }
}
