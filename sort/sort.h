// sort/: general-purpose GPU primitives on uint32 arrays — exclusive scan, stream compaction and a stable
// LSD radix sort of (key, value) pairs — used by the cone path (002 §3.5: compact the lit samples, sort
// their rays by Hilbert key; rays/rays.h), by traversal's pair compaction and by RMSM's page requests.
// Knows no cones and no pages.
//
// Contract shared by all three:
//  - record*() only records into the caller's vk::Commands (no submit, no host round trip between
//    passes); it ends with a barrier, so later commands see the results. Scratch is owned by the object,
//    sized at construction for `capacity` elements by the pure functions below; a count above the
//    capacity is a cs::Error. One object serves one recording at a time: record, submit, then reuse.
//  - Counts come from the host (Count{n}) or from the GPU (Count::device(word, bound)): a uint32 that an
//    earlier command wrote, read by every kernel and clamped to the host bound, which sizes the dispatch.
//    Traversal and RMSM can chain compaction -> sort without reading a count back.
//  - Arrays are vk::BufferRange of uint32: a whole buffer, or an offset that is a multiple of 16 bytes
//    (kernels move four elements at a time) and of minStorageBufferOffsetAlignment. Every array must fit
//    one storage binding: capacity * 4 bytes <= maxStorageBufferRange (128 MiB = 32M elements on
//    lavapipe), otherwise construction throws a cs::Error naming the count and the limit. No chunking:
//    one binding per array keeps kernels simple, and the G-buffer itself is bound the same way (so it
//    hits the same limit first). Counts must stay below 2^30.
//  - Wide dispatches use 2-D grids (workgroupGrid), so counts beyond 65,535 workgroups are fine.
//  - No subgroup operations anywhere: workgroup scans go through shared memory (workgroup_scan.glsl), so
//    the same SPIR-V is correct for subgroups of 8 (lavapipe), 32 or 64. Results are bit-identical across
//    runs and devices (integer sums; the sort is stable).
//
// Algorithms (sizes in sort_layout.h, with the measurements behind them). Scan: reduce-then-scan over
// blocks of SCAN_BLOCK = 2048 (64 invocations x 32 consecutive elements, moved as uvec4), recursing on
// the block sums, so n elements cost two reads and one write plus ~n/2048 extra; the array and two levels
// of sums cover any 32-bit count. Compaction: the same reduce (counting nonzero flags), a scan of the
// block counts, and a scatter that re-derives each element's rank inside its block. Radix sort: per pass
// (RADIX_BITS = 9, so ceil(keyBits / 9) passes), each tile (8192 keys on lavapipe, SortShape) counts its
// keys in per-invocation 16-bit counters in shared memory, writes its digit histogram and leaves the
// counters scanned (its keys' stable ranks inside the tile, radix_count.comp), one scan of the
// digit-major histogram table gives every (digit, tile) its output offset, and a scatter places each key
// from the two (radix_scatter.comp); or, by look-back (SortScheme), one histogram of every pass's digits up front and
// no count or scan per pass. Passes ping-pong between the caller's arrays and the object's; an odd pass
// count starts with a copy so the result always lands in the caller's arrays.
#pragma once
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "sort/sort_layout.h"
#include "vk/context.h"

namespace cs::sort {

// A uint32 living on the GPU: element `index` of `buffer` (counts read by kernels, totals they write).
struct GpuWord {
  VkBuffer buffer = VK_NULL_HANDLE;
  uint32_t index = 0;
  GpuWord() = default;
  GpuWord(const vk::Buffer& b, uint32_t i = 0) : buffer(b.buffer), index(i) {}  // NOLINT: implicit on purpose
  bool valid() const { return buffer != VK_NULL_HANDLE; }
};

// How many elements a primitive works on.
struct Count {
  uint32_t max = 0;  // host count; with `word` set, an upper bound on the device count
  GpuWord word;      // when valid, kernels read the count from here (clamped to max)
  Count(uint32_t n = 0) : max(n) {}  // NOLINT: a host count converts implicitly
  static Count device(GpuWord w, uint32_t upperBound) {
    Count c(upperBound);
    c.word = w;
    return c;
  }
  bool onDevice() const { return word.valid(); }
  // Scan only: the level-0 grid on the GPU too -- indirect dispatch arguments (x, y, 1) at `offset` of
  // `args` for max(1, ceil(count / SCAN_BLOCK)) workgroups, written by whoever wrote the count -- so a
  // scan bounded by a large capacity launches only the workgroups the device count needs.
  VkBuffer groupsBuffer = VK_NULL_HANDLE;
  VkDeviceSize groupsOffset = 0;
  Count withGroups(VkBuffer args, VkDeviceSize offset) const { return with(&Count::groupsBuffer, &Count::groupsOffset, args, offset); }
  // A device count's gate: indirect dispatch arguments (1, 1, 1) or (0, 1, 1) at `offset` of `buffer`,
  // written before the count's work is recorded, that say whether any of it runs. IndirectGroups launches
  // through it (its arguments cleared first), so a count the gate closes launches nothing that sizes its
  // work, and the work's own dispatches none: on lavapipe every dispatch with a workgroup is handed to its
  // threads, tens of microseconds whatever it does (the cone path's keys and sort on a frame that keeps
  // screen order).
  VkBuffer gateBuffer = VK_NULL_HANDLE;
  VkDeviceSize gateOffset = 0;
  Count withGate(VkBuffer args, VkDeviceSize offset) const { return with(&Count::gateBuffer, &Count::gateOffset, args, offset); }

 private:
  Count with(VkBuffer Count::*buffer, VkDeviceSize Count::*at, VkBuffer args, VkDeviceSize offset) const {
    Count c = *this;
    c.*buffer = args;
    c.*at = offset;
    return c;
  }
};

// ---- sizing and dispatch maths (pure, unit-tested) ----------------------------------------------
uint32_t ceilDiv(uint64_t a, uint32_t b);
// Element counts of the scan's levels: {n, ceil(n/B), ceil(n/B^2), ...} down to the first that fits one
// block (B = SCAN_BLOCK), and at least `minLevels` entries (at most kMaxScanLevels). In a fixed array, so
// recording a scan allocates nothing: two levels of block sums cover any 32-bit count.
inline constexpr size_t kMaxScanLevels = 4;
struct ScanLevels {
  std::array<uint32_t, kMaxScanLevels> counts{};
  size_t levels = 0;
  size_t size() const { return levels; }
  uint32_t operator[](size_t level) const { return counts[level]; }
  const uint32_t* begin() const { return counts.data(); }
  const uint32_t* end() const { return counts.data() + levels; }
};
ScanLevels scanLevelCounts(uint32_t n, size_t minLevels = 1);
// uint32 elements of scratch a Scan of `capacity` needs (block sums and their scans, every level >= 1).
uint64_t scanScratchElements(uint32_t capacity);
uint32_t radixPasses(uint32_t keyBits);     // ceil(keyBits / RADIX_BITS): 18-bit ray keys in 2, 32 bits in 4
// The radix sort's tile, chosen per device (sort_layout.h): `threads` invocations a workgroup, each
// owning `items` consecutive keys; the kernels get both as specialisation constants.
struct SortShape {
  uint32_t threads = SORT_THREADS_CPU, items = SORT_ITEMS_CPU;
  uint32_t tile() const { return threads * items; }
};
inline constexpr SortShape kCpuSortShape{SORT_THREADS_CPU, SORT_ITEMS_CPU};
inline constexpr SortShape kGpuSortShape{SORT_THREADS_GPU, SORT_ITEMS_GPU};
// A CPU device (lavapipe) gets kCpuSortShape, as measured there (docs/RESULTS.md, "GPU sort primitives"); any
// other device kGpuSortShape when its shared memory and workgroup limits hold it, else kCpuSortShape.
SortShape sortShapeFor(const vk::Context& ctx);
// How the sort learns where a tile's keys of a digit start (radix_scatter.comp): ReduceThenScan, a count
// pass and a scan of the (digit, tile) table every pass, is correct on any device; LookBack counts every
// pass's digits in one pass over the keys up front and lets each tile add up the tiles before it while
// they run (decoupled look-back): no count pass and no scan per pass. A tile waits on another for a
// bounded number of reads, then counts that tile's keys itself, so both are correct on any device; a
// wait is short only where a running workgroup keeps running while another spins.
enum class SortScheme { ReduceThenScan, LookBack };
const char* sortSchemeName(SortScheme scheme);
// LookBack on NVIDIA and AMD GPUs (which keep resident workgroups running; GPU sorts rely on it there);
// ReduceThenScan elsewhere, lavapipe included: there a tile often waits on the one running on the other
// core until its reads run out and counts that tile itself, and lavapipe ends all of an invocation's loops
// after 65535 iterations in total, which a long walk of counted tiles would pass (a wrong sort, silently);
// and reduce-then-scan is the faster there (docs/ARCHITECTURE.md, "sort/").
SortScheme sortSchemeFor(const vk::Context& ctx);
// uint32 words of the look-back workspace (sort_layout.h) for `count` keys.
uint64_t lookBackWords(uint32_t count, SortShape shape = {});
uint32_t sortTiles(uint32_t count, SortShape shape = {});         // ceil(count / tile)
uint64_t histogramEntries(uint32_t count, SortShape shape = {});  // RADIX_BINS * sortTiles(count)
// Shared memory radix_scatter.comp declares (counters + padding, per-digit offsets, workgroup scan):
// ~18 KiB for either shape; Vulkan guarantees 16 KiB, lavapipe has 32 KiB and desktop GPUs 48 KiB or more.
uint32_t radixScatterSharedBytes(SortShape shape = {});
// Throws a cs::Error naming `what`, the element count and the binding limit when `elements` of
// `bytesPerElement` do not fit one storage-buffer binding of this device.
void checkBinding(const vk::Context& ctx, uint64_t elements, uint32_t bytesPerElement, const char* what);
// The 2-D grid (vk::gridFor) for `workgroups` workgroups within the device's per-dimension limit.
vk::Grid workgroupGrid(const vk::Context& ctx, uint64_t workgroups);
// Tests only: cap the workgroups per grid dimension (0 = the device's limit), so small inputs exercise
// the 2-D grids that only counts beyond 65,535 workgroups need otherwise.
void setGridLimitForTesting(uint32_t maxPerDimension);
// Tests only: the look-back's reads of a tile's word before counting its keys itself, for sorts made
// afterwards (-1 = the default, LOOKBACK_SPINS; 0 = never read: every tile before is counted).
void setLookBackSpinsForTesting(int32_t spins);
// Tests only: whether sorts made afterwards may keep interleaved pair scratch (RadixSort::record) or must
// use separate arrays, as they do when pairs would not fit one binding (-1 = the default: when they fit).
void setPairScratchForTesting(int32_t allowed);

// ---- exclusive scan -----------------------------------------------------------------------------
class Scan {
 public:
  Scan(vk::Context& ctx, uint32_t capacity);
  // out[i] = in[0] + ... + in[i-1] (mod 2^32) for i < count; `total`, when valid, gets the sum of all.
  // `in` and `out` may be the very same range (in-place); partly overlapping ranges are an error.
  // With fieldShift >= 0 each element counts as (in[i] >> fieldShift) + 1: a length less one kept in
  // the high bits of a packed word (rays/: a run's pixels).
  void record(vk::Commands& cmd, const vk::BufferRange& in, const vk::BufferRange& out, Count count,
              GpuWord total = {}, int fieldShift = -1);
  uint32_t capacity() const { return capacity_; }
  uint64_t bytesAllocated() const { return scratch_.size + dummy_.size; }

 private:
  friend class Compact;
  // Scans level `level` of a base count: reads `in` (the caller's array at level 0, the block sums
  // above), writes `out`. Levels above it use the scratch arrays.
  void recordLevel(vk::Commands& cmd, const vk::BufferRange& in, const vk::BufferRange& out, const Count& count,
                   uint32_t level, GpuWord total, bool inPlace, int fieldShift);
  vk::BufferRange sums(uint32_t level) const;     // block sums of level - 1, one per block
  vk::BufferRange scanned(uint32_t level) const;  // their exclusive scan
  vk::BufferRange countBinding(const Count& count) const;
  vk::BufferRange wordBinding(GpuWord w) const;

  vk::Context& ctx_;
  uint32_t capacity_;
  ScanLevels levels_;                                   // scanLevelCounts(capacity, 2)
  std::vector<VkDeviceSize> sumsOffset_, scannedOffset_;  // bytes into scratch_, per level (0 unused)
  vk::Kernel reduce_, block_;
  vk::Buffer scratch_, dummy_;
};

// ---- stream compaction --------------------------------------------------------------------------
class Compact {
 public:
  Compact(vk::Context& ctx, uint32_t capacity);
  // For every i < count with flags[i] != 0, in order of i: out[k++] = i, or values[i] when `values` is
  // given (buffer != VK_NULL_HANDLE). k, the number kept, goes to `kept` on the GPU.
  void record(vk::Commands& cmd, const vk::BufferRange& flags, Count count, const vk::BufferRange& out,
              GpuWord kept, const vk::BufferRange& values = {});
  uint32_t capacity() const { return scan_.capacity(); }
  uint64_t bytesAllocated() const { return scan_.bytesAllocated(); }

  // For callers whose own kernels count and scatter (a compaction fused with what it feeds, as the
  // cone path's lit samples and their ray keys, rays.h): one uint per block of SCAN_BLOCK elements for
  // their kept counts, and recordBlockScan, which turns them into the blocks' exclusive offsets and their
  // total into `kept`. `count` is the element count the blocks cover (ceil(count / SCAN_BLOCK) blocks).
  vk::BufferRange blockCounts() const { return scan_.sums(1); }
  vk::BufferRange blockOffsets() const { return scan_.scanned(1); }
  void recordBlockScan(vk::Commands& cmd, Count count, GpuWord kept);

 private:
  Scan scan_;
  vk::Kernel scatter_;
};

// ---- indirect dispatch arguments ----------------------------------------------------------------
// Writes, as a VkDispatchIndirectCommand at element `index` of `args` (a buffer made with
// VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT), the 2-D grid vk::gridFor would make for ceil(min(device count,
// count.max) / perGroup) workgroups: a dispatch sized by an earlier kernel's output without a readback.
// The launched kernel must still check its index against the device count. No barrier: the caller adds
// one before the indirect dispatch.
class IndirectGroups {
 public:
  explicit IndirectGroups(vk::Context& ctx);
  // minGroups: launch at least that many workgroups, even for a count of 0. With the count's gate closed,
  // the arguments are 0 workgroups and no kernel runs (Count::withGate).
  void record(vk::Commands& cmd, const Count& count, uint32_t perGroup, const vk::Buffer& args, uint32_t index,
              uint32_t minGroups = 0);

 private:
  vk::Context& ctx_;
  vk::Kernel kernel_;
};

// ---- radix sort ---------------------------------------------------------------------------------
class RadixSort {
 public:
  RadixSort(vk::Context& ctx, uint32_t capacity);  // the device's shape and scheme (sortShapeFor, sortSchemeFor)
  RadixSort(vk::Context& ctx, uint32_t capacity, SortShape shape);  // the device's scheme
  RadixSort(vk::Context& ctx, uint32_t capacity, SortShape shape, SortScheme scheme);
  // Sorts the first `count` (key, value) pairs by the low `keyBits` bits of the key (higher bits are
  // ignored and travel with the key), stably, in place: the results are back in `keys` and `values`.
  // `values` may be empty (buffer == VK_NULL_HANDLE) to sort keys alone. ceil(keyBits / RADIX_BITS) passes. With
  // a device count the passes are dispatched indirectly for the tiles it fills, not for count.max.
  // Between passes the pairs travel interleaved in the object's scratch (one uvec2 store a key where two
  // arrays take two scattered stores; the scatter's stores are its dearest accesses on lavapipe), so two
  // or more passes with values go: caller's arrays -> pairs -> ... -> pairs -> caller's arrays.
  void record(vk::Commands& cmd, const vk::BufferRange& keys, const vk::BufferRange& values, Count count,
              uint32_t keyBits = 32);
  // The same sort for a producer that writes its (key, value) pairs, interleaved (uvec2), straight into
  // the sort's own scratch (pairInput()) instead of two arrays: the first pass reads them there, so the
  // pairs are stored once and never split. Results land in `keys` and `values` as with record(). Only
  // where pairInputs() (the pair scratch fits one storage binding and one texel buffer) and for keys of
  // two or more passes (keyBits > RADIX_BITS); a cs::Error otherwise. With keysOut false the last pass
  // writes the values alone and `keys` is left as it was: for a caller that needs only the order (one
  // scattered store a key fewer).
  void recordFromPairs(vk::Commands& cmd, const vk::BufferRange& keys, const vk::BufferRange& values, Count count,
                       uint32_t keyBits, bool keysOut = true);
  bool pairInputs() const { return pairs_; }
  vk::BufferRange pairInput() const;  // uvec2[capacity]: where recordFromPairs reads its pairs
  uint32_t capacity() const { return capacity_; }
  SortShape shape() const { return shape_; }
  SortScheme scheme() const { return scheme_; }
  uint64_t bytesAllocated() const;

 private:
  void recordPasses(vk::Commands& cmd, const vk::BufferRange& keys, const vk::BufferRange& values, Count count,
                    uint32_t keyBits, bool fromPairs, bool keysOut);

  vk::Context& ctx_;
  uint32_t capacity_;
  SortShape shape_;
  SortScheme scheme_;
  std::optional<Scan> scan_;  // of the histogram table (ReduceThenScan)
  IndirectGroups groups_;  // a device count: the count and scatter passes launch only the tiles it fills
  // Scratch between passes. pairs_: scratchA_ and scratchB_ each hold interleaved (key, value) pairs (or
  // scratchA_ keys alone, or keys then values for a single pass); otherwise (pairs would not fit one
  // binding) scratchA_ holds keys and scratchB_ values.
  bool pairs_ = false;
  // count_: radix_count (ReduceThenScan, [1] reading pairs) or radix_histogram (LookBack);
  // scatter_[pairs in][pairs out]; scatterValues_: pairs in, the values alone out (KEYS_OUT false),
  // compiled at its first use. spins_: the look-back's reads before counting a tile itself.
  vk::Kernel count_[2], scatter_[2][2], scatterValues_;
  uint32_t spins_ = LOOKBACK_SPINS;
  vk::Buffer scratchA_, scratchB_, hist_, dummy_, args_;  // hist_: the table, or the look-back workspace
  vk::Buffer ranks_;  // reduce-then-scan: each tile's scanned counters, count pass to scatter (radix.glsl)
  vk::Buffer tableCount_;  // reduce-then-scan: a pass's table entries, the device count of its scan, and
                           // its scan's level-0 grid (x, y, 1: indirect arguments at byte 4)
};

}  // namespace cs::sort
