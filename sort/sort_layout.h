// sort/: workgroup shapes, flags and push constants, shared by the GLSL kernels and sort.cpp
// (one layout, two languages). The sizing maths in sort.h reads the same numbers.
#ifndef CONESHADOW_SORT_LAYOUT_H
#define CONESHADOW_SORT_LAYOUT_H

#include "core/shared.h"

// ---- workgroup shapes ---------------------------------------------------------------------------
// Chosen for lavapipe, where the primitives run in CI and in the benchmark, and kept legal and correct
// everywhere. There (2 threads) a barrier costs one coroutine switch per 8-wide subgroup, so few
// invocations per workgroup with many elements each beat wide workgroups (docs/ARCHITECTURE.md, "sort/",
// has the measurements); a uvec4 buffer access costs about what a scalar one does, so kernels read and
// write four consecutive elements at a time; and indexed shared-memory access is the dominant cost of
// the sort's ranking, so tiles are long (fewer counters to clear and scan per key). A discrete GPU
// would prefer wider workgroups and shorter tiles; the numbers are all here.
//
// Scan and compaction: a block of SCAN_THREADS x SCAN_ITEMS elements per workgroup, each invocation
// owning SCAN_ITEMS consecutive ones ("blocked" arrangement), so a level of the multi-level scan
// shrinks the problem 2048-fold: the array and two levels of block sums cover any 32-bit count.
#define SCAN_THREADS 64
#define SCAN_ITEMS 32  // a multiple of 4 (uvec4 access) and at most 32 (one bit each in a uint mask)
#define SCAN_BLOCK (SCAN_THREADS * SCAN_ITEMS)
#define SCAN_RAKE 8  // the workgroup-wide scan rakes SCAN_THREADS/SCAN_RAKE segments of SCAN_RAKE values

// Radix sort: RADIX_BITS per pass, a tile of SORT_THREADS x SORT_ITEMS keys per workgroup. Ranking
// keeps one 16-bit counter per (digit, invocation) in shared memory, two digits packed per uint
// (digit d in the low half of word d, digit d + RADIX_BINS/2 in the high half): RADIX_BINS/2 words per
// invocation, 16 KiB at 16 invocations. A tile must stay below 65536 keys so the packed halves never
// carry into each other. The tile's shape is chosen per device (sort::SortShape, sort::sortShapeFor) and
// reaches the kernels as specialisation constants: the workgroup size (local_size_x_id 0, SORT_THREADS
// in the kernels) and SORT_ITEMS (constant_id 1). The defaults below are the CPU device's (lavapipe):
// few invocations, each with a long run of keys, because every invocation pays for its own counters.
// Nine bits a digit, not eight: the ray key's 18 bits (rays/hilbert.h) take two passes instead of three
// (and the 27 bits it had three instead of four), for the same counters per key (16 invocations x 256
// words where eight bits took 32 x 128); faster on lavapipe for 32-bit keys too (docs/ARCHITECTURE.md,
// "sort/").
#define RADIX_BITS 9
#define RADIX_BINS (1 << RADIX_BITS)
#define RADIX_WORDS (RADIX_BINS / 2)
#define SORT_THREADS_CPU 16
#define SORT_ITEMS_CPU 512  // a multiple of 4 (uvec4 access)
// On other devices (sortShapeFor): the same 16 invocations (their counters fit lavapipe's 32 KiB, so
// the shape is tested here too), each with a quarter of the run: four times the workgroups, so a 1 M-key
// pass launches 512 workgroups, not 128. Half a warp a workgroup on NVIDIA: the counters of 32
// invocations of 9-bit digits would not fit lavapipe's shared memory, where every shape is tested.
#define SORT_THREADS_GPU 16
#define SORT_ITEMS_GPU 128
#define SORT_RAKE 8  // workgroup scan segments of the ranking step (SORT_THREADS / SORT_RAKE of them)

// Radix sort by look-back (sort::SortScheme::LookBack, radix_histogram.comp + radix_scatter.comp with
// LOOKBACK set): one workspace of uint32 words, zeroed before every sort --
//   [LOOKBACK_PARTITIONS + p]            pass p's tile counter: a workgroup takes its tile in launch order
//   [LOOKBACK_DIGITS + p * RADIX_BINS + d] keys whose pass-p digit is d, over the whole input (one fused
//                                        histogram pass writes all of them)
//   [LOOKBACK_STATUS + (p * tiles + t) * RADIX_BINS + d]  tile t's word for digit d in pass p: 0 (not yet),
//                                        LOOKBACK_AGGREGATE | the tile's own count, or LOOKBACK_PREFIX | the
//                                        count of tiles 0..t together (counts stay below 2^30)
#define LOOKBACK_MAX_PASSES 4  // 32 key bits / RADIX_BITS
#define LOOKBACK_PARTITIONS 0
#define LOOKBACK_DIGITS 16  // past the counters, 64-byte aligned
#define LOOKBACK_STATUS (LOOKBACK_DIGITS + LOOKBACK_MAX_PASSES * RADIX_BINS)
#define LOOKBACK_AGGREGATE 0x40000000u
#define LOOKBACK_PREFIX 0x80000000u
#define LOOKBACK_VALUE 0x3FFFFFFFu
#define LOOKBACK_SPINS 2048u  // reads of an unpublished tile's word before the waiting tile counts its keys
                              // itself (radix_scatter.comp's constant_id 3; sort::setLookBackSpinsForTesting)

// ---- flags (ScanPush.flags, CompactPush.flags, RadixPush.flags, rays/'s KeysPush.flags) ------------------
#define FLAG_COUNT_FROM_BUFFER 1u  // the element count is min(countBuffer[countIndex], push.count)
#define FLAG_NONZERO_AS_ONE 2u     // reduce: count nonzero elements instead of summing them
#define FLAG_ADD_OFFSETS 4u        // scan: add the scanned block sums of the next level
#define FLAG_WRITE_TOTAL 8u        // scan: the single-block top level writes the grand total
#define FLAG_IN_PLACE 16u          // scan: read the input through the output binding (in == out)
#define FLAG_HAS_VALUES 32u        // compaction / sort: a value array travels with the keys
#define FLAG_FIELD 64u             // scan, level 0: each element counts as (x >> fieldShift) + 1

// ---- push constants -----------------------------------------------------------------------------
#ifdef __cplusplus
#include <cstddef>
namespace cs::sort {
CS_GLSL_TYPES
#endif

// scan_reduce.comp, scan_block.comp, compact_scatter.comp. The count a kernel works on is the base
// count (push or buffer) divided, rounded up, by SCAN_BLOCK `level` times (see levelCount()).
struct ScanPush {
  uint count;       // base element count, or its upper bound when FLAG_COUNT_FROM_BUFFER is set
  uint countIndex;  // element of the count binding that holds the device count
  uint flags;
  uint level;       // 0 = the caller's array, 1 = its block sums, ...
  uint totalIndex;  // element of the total binding that receives the grand total
  uint fieldShift;  // FLAG_FIELD: the element's field (a length less one in its high bits) starts here
  uint pad1, pad2;
};

// groups_for.comp: indirect dispatch arguments for a device count.
struct GroupsPush {
  uint count;       // upper bound on the device count
  uint countIndex;  // element of the count binding that holds the device count
  uint perGroup;    // elements a workgroup of the dispatch takes
  uint argsIndex;   // element of the args binding where (x, y, z) go
  uint maxPerDim;   // the device's workgroups per grid dimension
  uint minGroups;   // at least this many workgroups, even for a count of 0
  uint pad1, pad2;
};

// radix_count.comp, radix_scatter.comp
struct RadixPush {
  uint count;       // element count, or its upper bound when FLAG_COUNT_FROM_BUFFER is set
  uint countIndex;
  uint flags;
  uint shift;       // lowest key bit of this pass's digit
  uint digitMask;   // (1 << bits of this pass) - 1
  uint tiles;       // tiles the histogram table is laid out for (its row stride)
  uint pass;        // look-back: this pass's index (its tile counter and status rows)
  uint keyBits;     // look-back histogram: key bits sorted (every pass's digit is counted at once)
};

#ifdef __cplusplus
static_assert(sizeof(GroupsPush) == 32, "GroupsPush layout");
static_assert(sizeof(ScanPush) == 32 && offsetof(ScanPush, totalIndex) == 16, "ScanPush layout");
static_assert(sizeof(RadixPush) == 32 && offsetof(RadixPush, tiles) == 20, "RadixPush layout");
static_assert(SORT_THREADS_CPU * SORT_ITEMS_CPU < 65536 && SORT_THREADS_GPU * SORT_ITEMS_GPU < 65536,
              "packed 16-bit rank counters would carry");
static_assert(SORT_THREADS_CPU % SORT_RAKE == 0 && SORT_THREADS_GPU % SORT_RAKE == 0 && SCAN_THREADS % SCAN_RAKE == 0,
              "rake segments");
static_assert(RADIX_BITS >= 1 && RADIX_BITS <= 9, "radix digit width: the ranking counters (RADIX_WORDS a invocation) must fit shared memory");
static_assert(LOOKBACK_MAX_PASSES * RADIX_BITS >= 32, "look-back workspace holds every pass of a 32-bit key");
static_assert(SCAN_ITEMS % 4 == 0 && SCAN_ITEMS <= 32 && SORT_ITEMS_CPU % 4 == 0 && SORT_ITEMS_GPU % 4 == 0,
              "uvec4 access, kept-bit masks");
}  // namespace cs::sort
#endif
#endif
