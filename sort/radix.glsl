// LSD radix sort, one pass = count -> scan -> scatter over tiles of SORT_TILE keys (002 §3.5 sorts the ray
// keys "using a fast radix sort"). Invocation t of a tile owns its SORT_ITEMS consecutive keys, so a
// tile's keys in (invocation, item) order are its keys in input order: ranking them by (digit,
// invocation, item) is stable without any subgroup operation, for any subgroup size. Keys are read four
// at a time (uvec4): on lavapipe a vector access costs about what a scalar one does.
// Expects `pc` (RadixPush) and the key binding `keys4` (uvec4[]).

// The tile's shape, specialised per device (sort_layout.h, sort::SortShape): the workgroup size and the
// keys each invocation owns.
layout(local_size_x = SORT_THREADS_CPU, local_size_x_id = 0) in;
layout(constant_id = 1) const uint SORT_ITEMS = SORT_ITEMS_CPU;
#define SORT_THREADS gl_WorkGroupSize.x
#define SORT_TILE (SORT_THREADS * SORT_ITEMS)

uint digitOf(uint key) { return (key >> pc.shift) & pc.digitMask; }

// Reduce-then-scan: the (digit, tile) table's row stride for n keys, the tiles n fills (at least one,
// so an empty sort still has a table to scan), whatever bound sized the dispatch (radix_count.comp).
uint tableTiles(uint n) { return max(ceilDiv(n, SORT_TILE), 1u); }

// The keys come from the key binding (uint[]), or with PAIRS_IN as interleaved (key, value) pairs
// (uvec2[], two to a RGBA32UI texel) from binding PAIR_TEXELS, a uniform texel buffer over the sort's own
// scratch between passes: a pass stores one uvec2 per key where separate arrays take two scattered
// stores (sort.h), and reads them as texels, the cheap gather on lavapipe (docs/ARCHITECTURE.md, "Memory
// access"). Pair scratch is padded to whole uvec4s, and its view starts at the buffer's start.
layout(constant_id = 4) const bool PAIRS_IN = false;
layout(binding = PAIR_TEXELS) uniform usamplerBuffer pairTexels;
uvec4 loadPairs(uint v) { return texelFetch(pairTexels, int(v)); }  // pairs 2v and 2v + 1

// Keys 4v .. 4v+3 (those below n; the rest are never used by callers). Component loads at the tail, so
// nothing past key n - 1 is read (pairs: the padding is read and ignored).
uvec4 loadKeys(uint v, uint n) {
  if (PAIRS_IN) {
    uvec4 a = loadPairs(2u * v), b = loadPairs(2u * v + 1u);
    return uvec4(a.x, a.z, b.x, b.z);
  }
  if (4u * v + 3u < n) return keys4[v];
  uvec4 r = uvec4(0u);
  for (uint c = 0u; c < 3u; ++c)
    if (4u * v + c < n) r[c] = keys4[v][c];
  return r;
}

// The ranking counters (radix_count.comp, radix_scatter.comp): one 16-bit counter per (digit, invocation),
// two digits a word (digit d in the low half of word d % RADIX_WORDS, d + RADIX_WORDS in the high half),
// laid out word by word, the invocations' columns side by side, one spare word per 32 so a rake of
// consecutive words is free of bank conflicts. A tile holds fewer than 65536 keys: the halves never carry.
const uint kWords = RADIX_WORDS * SORT_THREADS;
// Reduce-then-scan: the count pass leaves each tile's counters scanned (the tile-local ranks, unpadded, in
// (word, invocation) order) in the ranks buffer, kRankWords a tile: kWords, then the tile's count of keys
// with a low-half digit (unpackRank's lowTotal) and three words of padding. The scatter loads them instead
// of counting the tile's keys again and scanning.
const uint kRankWords = kWords + 4u;
uint slot(uint word, uint t) {
  uint i = word * SORT_THREADS + t;
  return i + (i >> 5u);
}
