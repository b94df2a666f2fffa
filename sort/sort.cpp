// GPU scan, compaction and radix sort: see sort.h. The host loop of each reads like the algorithm.
#include "sort/sort.h"

#include <algorithm>
#include <string>
#include <utility>

#include "sort/compact_scatter.comp.h"
#include "sort/groups_for.comp.h"
#include "sort/radix_count.comp.h"
#include "sort/radix_histogram.comp.h"
#include "sort/radix_scatter.comp.h"
#include "sort/scan_block.comp.h"
#include "sort/scan_reduce.comp.h"

namespace cs::sort {

// ---- sizing -------------------------------------------------------------------------------------

uint32_t ceilDiv(uint64_t a, uint32_t b) { return uint32_t((a + b - 1) / b); }

ScanLevels scanLevelCounts(uint32_t n, size_t minLevels) {
  CS_CHECK(minLevels <= kMaxScanLevels, "scan of at least " << minLevels << " levels (at most " << kMaxScanLevels << ")");
  ScanLevels l;
  l.counts[l.levels++] = n;
  while (l.counts[l.levels - 1] > SCAN_BLOCK || l.levels < minLevels) {
    CS_CHECK(l.levels < kMaxScanLevels, "scan of " << n << " elements: more than " << kMaxScanLevels << " levels");
    l.counts[l.levels] = ceilDiv(l.counts[l.levels - 1], SCAN_BLOCK);
    ++l.levels;
  }
  return l;
}

uint64_t scanScratchElements(uint32_t capacity) {
  auto levels = scanLevelCounts(capacity, 2);
  uint64_t total = 0;
  for (size_t l = 1; l < levels.size(); ++l) total += 2 * uint64_t(std::max(levels[l], 1u));
  return total;
}

uint32_t radixPasses(uint32_t keyBits) { return ceilDiv(keyBits, RADIX_BITS); }
uint32_t sortTiles(uint32_t count, SortShape shape) { return ceilDiv(count, shape.tile()); }
uint64_t histogramEntries(uint32_t count, SortShape shape) { return uint64_t(RADIX_BINS) * sortTiles(count, shape); }

uint64_t lookBackWords(uint32_t count, SortShape shape) {
  return LOOKBACK_STATUS + uint64_t(LOOKBACK_MAX_PASSES) * RADIX_BINS * std::max(sortTiles(count, shape), 1u);
}

uint32_t radixScatterSharedBytes(SortShape shape) {
  const uint32_t words = RADIX_WORDS * shape.threads;
  return 4 * (words + words / 32 + RADIX_BINS + 1 + shape.threads + shape.threads / SORT_RAKE + 1);
}

namespace {
bool shapeFits(const vk::Context& ctx, SortShape shape) {
  const auto& l = ctx.properties.limits;
  return radixScatterSharedBytes(shape) <= l.maxComputeSharedMemorySize &&
         shape.threads <= l.maxComputeWorkGroupInvocations && shape.threads <= l.maxComputeWorkGroupSize[0];
}
}  // namespace

SortShape sortShapeFor(const vk::Context& ctx) {
  if (ctx.properties.deviceType != VK_PHYSICAL_DEVICE_TYPE_CPU && shapeFits(ctx, kGpuSortShape)) return kGpuSortShape;
  return kCpuSortShape;
}

const char* sortSchemeName(SortScheme scheme) {
  return scheme == SortScheme::LookBack ? "look-back" : "reduce-then-scan";
}

SortScheme sortSchemeFor(const vk::Context& ctx) {
  constexpr uint32_t kNvidia = 0x10DE, kAmd = 0x1002;
  const auto& p = ctx.properties;
  if (p.deviceType != VK_PHYSICAL_DEVICE_TYPE_CPU && (p.vendorID == kNvidia || p.vendorID == kAmd)) return SortScheme::LookBack;
  return SortScheme::ReduceThenScan;
}

void checkBinding(const vk::Context& ctx, uint64_t elements, uint32_t bytesPerElement, const char* what) {
  uint64_t bytes = elements * bytesPerElement, limit = ctx.maxStorageBufferRange();
  if (bytes > limit)
    throw Error(std::string(what) + ": " + std::to_string(elements) + " elements of " +
                    std::to_string(bytesPerElement) + " bytes need " + std::to_string(bytes) +
                    " bytes in one storage binding, above the device's limit of " + std::to_string(limit) +
                    " bytes (maxStorageBufferRange, " + std::to_string(limit / bytesPerElement) + " elements)",
                "sort on " + ctx.deviceName(), "lower the resolution or the element bound");
}

namespace {
uint32_t gridLimitForTesting = 0;
}  // namespace

vk::Grid workgroupGrid(const vk::Context& ctx, uint64_t workgroups) {
  uint32_t limit = std::min(ctx.properties.limits.maxComputeWorkGroupCount[0], ctx.properties.limits.maxComputeWorkGroupCount[1]);
  if (gridLimitForTesting) limit = std::min(limit, gridLimitForTesting);
  return vk::gridFor(workgroups, 1, limit);
}

void setGridLimitForTesting(uint32_t maxPerDimension) { gridLimitForTesting = maxPerDimension; }

namespace {
int32_t lookBackSpins = -1;
}  // namespace

void setLookBackSpinsForTesting(int32_t spins) { lookBackSpins = spins; }

namespace {
int32_t pairScratch = -1;
}  // namespace

void setPairScratchForTesting(int32_t allowed) { pairScratch = allowed; }

namespace {

VkDeviceSize alignUp(VkDeviceSize v, VkDeviceSize a) { return (v + a - 1) / a * a; }

vk::BufferRange range(const vk::Buffer& b, VkDeviceSize offset, VkDeviceSize bytes) {
  return vk::BufferRange(b, offset, std::max<VkDeviceSize>(bytes, 4));
}

// A GpuWord bound as words [0, index] of its buffer (offset 0 needs no alignment), else the dummy.
vk::BufferRange bindWord(GpuWord w, const vk::Buffer& dummy) {
  if (!w.valid()) return dummy;
  vk::BufferRange r;
  r.buffer = w.buffer;
  r.offset = 0;
  r.range = (VkDeviceSize(w.index) + 1) * 4;
  return r;
}

uint32_t countFlags(const Count& c) { return c.onDevice() ? FLAG_COUNT_FROM_BUFFER : 0u; }

vk::Grid groups(const vk::Context& ctx, uint64_t workgroups) { return workgroupGrid(ctx, workgroups); }

// Kernels read and write four elements at a time: an array must start on a 16-byte boundary.
void checkRange(const vk::BufferRange& r, const char* what) {
  CS_CHECK(r.offset % 16 == 0, what << ": a range must start at a multiple of 16 bytes, not at " << r.offset);
}

vk::Buffer dummyBuffer(vk::Context& ctx) { return vk::createBuffer(ctx, 16); }

}  // namespace

// ---- scan ---------------------------------------------------------------------------------------

Scan::Scan(vk::Context& ctx, uint32_t capacity) : ctx_(ctx), capacity_(capacity) {
  checkBinding(ctx, capacity, 4, "scan");
  levels_ = scanLevelCounts(capacity, 2);
  VkDeviceSize align = std::max<VkDeviceSize>(ctx.properties.limits.minStorageBufferOffsetAlignment, 16);
  sumsOffset_.assign(levels_.size(), 0);
  scannedOffset_.assign(levels_.size(), 0);
  VkDeviceSize bytes = 0;
  for (size_t l = 1; l < levels_.size(); ++l) {
    sumsOffset_[l] = bytes;
    bytes = alignUp(bytes + VkDeviceSize(std::max(levels_[l], 1u)) * 4, align);
    scannedOffset_[l] = bytes;
    bytes = alignUp(bytes + VkDeviceSize(std::max(levels_[l], 1u)) * 4, align);
  }
  scratch_ = vk::createBuffer(ctx, bytes);
  dummy_ = dummyBuffer(ctx);
  reduce_ = vk::createKernel(ctx, "scan_reduce", spv_scan_reduce_comp, 3, sizeof(ScanPush));
  block_ = vk::createKernel(ctx, "scan_block", spv_scan_block_comp, 5, sizeof(ScanPush));
}

vk::BufferRange Scan::sums(uint32_t level) const {
  return range(scratch_, sumsOffset_.at(level), VkDeviceSize(levels_[level]) * 4);
}
vk::BufferRange Scan::scanned(uint32_t level) const {
  return range(scratch_, scannedOffset_.at(level), VkDeviceSize(levels_[level]) * 4);
}
vk::BufferRange Scan::countBinding(const Count& count) const { return bindWord(count.word, dummy_); }
vk::BufferRange Scan::wordBinding(GpuWord w) const { return bindWord(w, dummy_); }

void Scan::record(vk::Commands& cmd, const vk::BufferRange& in, const vk::BufferRange& out, Count count,
                  GpuWord total, int fieldShift) {
  CS_CHECK(fieldShift < 32, "scan: a field from bit " << fieldShift);
  CS_CHECK(count.max <= capacity_, "scan of " << count.max << " elements, capacity " << capacity_);
  checkRange(in, "scan input");
  checkRange(out, "scan output");
  bool inPlace = in.buffer == out.buffer && in.offset == out.offset;
  if (in.buffer == out.buffer && !inPlace) {
    VkDeviceSize gap = in.offset > out.offset ? in.offset - out.offset : out.offset - in.offset;
    CS_CHECK(gap >= VkDeviceSize(count.max) * 4, "scan: input and output ranges partly overlap");
  }
  recordLevel(cmd, in, out, count, 0, total, inPlace, fieldShift);
  cmd.barrier();
}

void Scan::recordLevel(vk::Commands& cmd, const vk::BufferRange& in, const vk::BufferRange& out,
                       const Count& count, uint32_t level, GpuWord total, bool inPlace, int fieldShift) {
  const ScanLevels counts = scanLevelCounts(count.max, level + 1);  // host bounds per level
  ScanPush push{count.max, count.word.index, countFlags(count), level, total.index, 0, 0, 0};
  if (inPlace) push.flags |= FLAG_IN_PLACE;
  if (fieldShift >= 0) {
    push.flags |= FLAG_FIELD;
    push.fieldShift = uint32_t(fieldShift);
  }
  if (level + 1 == counts.size()) {  // fits one block: scan it, no offsets, and report the total
    if (total.valid()) push.flags |= FLAG_WRITE_TOTAL;
    // With the device's grid for the first level and no total to write, the device's grid launches it:
    // none for a count of 0 (lavapipe hands every dispatch with a workgroup to its threads).
    if (level == 0 && count.groupsBuffer != VK_NULL_HANDLE && count.onDevice() && !total.valid())
      cmd.dispatchIndirect(block_, {in, out, dummy_, countBinding(count), wordBinding(total)}, &push, sizeof(push),
                           count.groupsBuffer, count.groupsOffset);
    else
      cmd.dispatch(block_, {in, out, dummy_, countBinding(count), wordBinding(total)}, push, 1);
    return;
  }
  // Block sums -> scan them one level up -> scan each block from its offset.
  vk::Grid g = groups(ctx_, counts[level + 1]);
  const bool indirect = level == 0 && count.groupsBuffer != VK_NULL_HANDLE && count.onDevice();
  if (indirect)
    cmd.dispatchIndirect(reduce_, {in, sums(level + 1), countBinding(count)}, &push, sizeof(push), count.groupsBuffer,
                         count.groupsOffset);
  else
    cmd.dispatch(reduce_, {in, sums(level + 1), countBinding(count)}, push, g.x, g.y);
  cmd.barrier();
  recordLevel(cmd, sums(level + 1), scanned(level + 1), count, level + 1, total, false, -1);
  cmd.barrier();
  push.flags |= FLAG_ADD_OFFSETS;
  if (indirect)
    cmd.dispatchIndirect(block_, {in, out, scanned(level + 1), countBinding(count), dummy_}, &push, sizeof(push),
                         count.groupsBuffer, count.groupsOffset);
  else
    cmd.dispatch(block_, {in, out, scanned(level + 1), countBinding(count), dummy_}, push, g.x, g.y);
}

// ---- compaction ---------------------------------------------------------------------------------

Compact::Compact(vk::Context& ctx, uint32_t capacity) : scan_(ctx, capacity) {
  scatter_ = vk::createKernel(ctx, "compact_scatter", spv_compact_scatter_comp, 5, sizeof(ScanPush));
}

void Compact::record(vk::Commands& cmd, const vk::BufferRange& flags, Count count, const vk::BufferRange& out,
                     GpuWord kept, const vk::BufferRange& values) {
  CS_CHECK(count.max <= scan_.capacity_, "compaction of " << count.max << " elements, capacity " << scan_.capacity_);
  checkRange(flags, "compaction flags");
  const uint32_t blocks = scanLevelCounts(count.max, 2)[1];
  vk::Grid g = groups(scan_.ctx_, blocks);
  ScanPush push{count.max, count.word.index, countFlags(count) | FLAG_NONZERO_AS_ONE, 0, 0, 0, 0, 0};
  // Kept per block -> their exclusive scan (its total is the kept count) -> scatter from the offsets.
  cmd.dispatch(scan_.reduce_, {flags, scan_.sums(1), scan_.countBinding(count)}, push, g.x, g.y);
  cmd.barrier();
  scan_.recordLevel(cmd, scan_.sums(1), scan_.scanned(1), count, 1, kept, false, -1);
  cmd.barrier();
  push.flags = countFlags(count) | (values.buffer ? FLAG_HAS_VALUES : 0u);
  const vk::BufferRange valuesOrDummy = values.buffer ? values : vk::BufferRange(scan_.dummy_);
  cmd.dispatch(scatter_, {flags, valuesOrDummy, out, scan_.scanned(1), scan_.countBinding(count)}, push, g.x, g.y);
  cmd.barrier();
}

void Compact::recordBlockScan(vk::Commands& cmd, Count count, GpuWord kept) {
  CS_CHECK(count.max <= scan_.capacity_, "compaction of " << count.max << " elements, capacity " << scan_.capacity_);
  scan_.recordLevel(cmd, scan_.sums(1), scan_.scanned(1), count, 1, kept, false, -1);
  cmd.barrier();
}

// ---- indirect dispatch arguments ----------------------------------------------------------------

IndirectGroups::IndirectGroups(vk::Context& ctx)
    : ctx_(ctx), kernel_(vk::createKernel(ctx, "groups_for", spv_groups_for_comp, 2, sizeof(GroupsPush))) {}

void IndirectGroups::record(vk::Commands& cmd, const Count& count, uint32_t perGroup, const vk::Buffer& args,
                            uint32_t index, uint32_t minGroups) {
  CS_CHECK(count.onDevice() && perGroup > 0, "indirect groups need a device count and a group size");
  CS_CHECK((uint64_t(index) + 3) * 4 <= args.size, "indirect groups: arguments at " << index << " past the buffer");
  const uint32_t maxPerDim = std::min(ctx_.properties.limits.maxComputeWorkGroupCount[0],
                                      ctx_.properties.limits.maxComputeWorkGroupCount[1]);
  CS_CHECK(uint64_t(ceilDiv(count.max, perGroup)) <= uint64_t(maxPerDim) * maxPerDim,
           "indirect groups: " << count.max << " elements need more workgroups than a 2-D grid holds");
  GroupsPush push{count.max, count.word.index, perGroup, index, maxPerDim, minGroups, 0, 0};
  if (count.gateBuffer != VK_NULL_HANDLE) {  // 0 workgroups unless the gate opens and the kernel writes them
    cmd.fill(args, 0, VkDeviceSize(index) * 4, 12);
    cmd.barrier();
    cmd.dispatchIndirect(kernel_, {bindWord(count.word, args), args}, &push, sizeof(push), count.gateBuffer,
                         count.gateOffset);
  } else {
    cmd.dispatch(kernel_, {bindWord(count.word, args), args}, push, 1);
  }
}

// ---- radix sort ---------------------------------------------------------------------------------

namespace {
// The histogram table's size (in words: the table, or the look-back workspace), after checking that
// the pairs and the table fit one binding each.
uint64_t checkedHistogram(const vk::Context& ctx, uint32_t capacity, SortShape shape, SortScheme scheme) {
  checkBinding(ctx, capacity, 4, "radix sort");
  const uint64_t words = scheme == SortScheme::LookBack ? lookBackWords(capacity, shape) : histogramEntries(capacity, shape);
  checkBinding(ctx, words, 4, "radix sort histogram");
  CS_CHECK(shape.threads % SORT_RAKE == 0 && shape.items % 4 == 0 && shape.items > 0 && shape.tile() < 65536 &&
               RADIX_BINS % shape.threads == 0,
           "radix sort tile of " << shape.threads << " x " << shape.items << " keys");
  const uint32_t shared = ctx.properties.limits.maxComputeSharedMemorySize;
  if (!shapeFits(ctx, shape))
    throw Error("radix sort needs " + std::to_string(radixScatterSharedBytes(shape)) +
                    " bytes of workgroup shared memory and " + std::to_string(shape.threads) +
                    " invocations a workgroup, the device offers " + std::to_string(shared) + " bytes and " +
                    std::to_string(ctx.properties.limits.maxComputeWorkGroupInvocations),
                "sort on " + ctx.deviceName(), "lower SORT_THREADS_CPU or RADIX_BITS in sort/sort_layout.h");
  return words;
}
}  // namespace

RadixSort::RadixSort(vk::Context& ctx, uint32_t capacity) : RadixSort(ctx, capacity, sortShapeFor(ctx)) {}

RadixSort::RadixSort(vk::Context& ctx, uint32_t capacity, SortShape shape)
    : RadixSort(ctx, capacity, shape, sortSchemeFor(ctx)) {}

RadixSort::RadixSort(vk::Context& ctx, uint32_t capacity, SortShape shape, SortScheme scheme)
    : ctx_(ctx), capacity_(capacity), shape_(shape), scheme_(scheme), groups_(ctx) {
  const uint64_t histWords = checkedHistogram(ctx, capacity, shape, scheme);
  const bool lookBack = scheme == SortScheme::LookBack;
  if (!lookBack) scan_.emplace(ctx, uint32_t(histWords));
  // Pair scratch: whole uvec4s (kernels read pairs four at a time) and, for a single pass, room for the
  // keys then the values at an offset any device's storage alignment (at most 256 bytes) accepts.
  const VkDeviceSize padded = alignUp(std::max<VkDeviceSize>(capacity, 1), 64);
  // (and within one uniform texel buffer: the kernels read pairs as RGBA32UI texels, two a texel).
  pairs_ = pairScratch != 0 && padded * 8 <= ctx.properties.limits.maxStorageBufferRange &&
           padded / 2 <= ctx.properties.limits.maxTexelBufferElements;
  scratchA_ = vk::createBuffer(ctx, pairs_ ? padded * 8 : VkDeviceSize(capacity) * 4);
  scratchB_ = vk::createBuffer(ctx, pairs_ ? padded * 8 : VkDeviceSize(capacity) * 4);
  hist_ = vk::createBuffer(ctx, histWords * 4);
  // Reduce-then-scan: each tile's scanned ranking counters, from the count pass to the scatter.
  const uint64_t rankWords = uint64_t(RADIX_WORDS * shape.threads + 4) * std::max(sortTiles(capacity, shape), 1u);
  if (!lookBack) checkBinding(ctx, rankWords, 4, "radix sort ranks");
  ranks_ = lookBack ? dummyBuffer(ctx) : vk::createBuffer(ctx, rankWords * 4);
  tableCount_ = vk::createBuffer(ctx, 16, vk::Memory::Device, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
  dummy_ = dummyBuffer(ctx);
  args_ = vk::createBuffer(ctx, 16, vk::Memory::Device, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
  const uint32_t spins = lookBackSpins >= 0 ? uint32_t(lookBackSpins) : LOOKBACK_SPINS;
  spins_ = spins;
  for (uint32_t in = 0; in < 2; ++in) {
    if (lookBack && in == 1 && !pairs_) break;  // the look-back histogram reads the first pass's input only
    const std::initializer_list<vk::SpecConstant> spec = {{0, shape.threads}, {1, shape.items}, {2, lookBack ? 1u : 0u},
                                                          {3, spins}, {4, in}, {5, 0u}};
    if (lookBack)
      count_[in] = vk::createKernel(ctx, "radix_histogram", spv_radix_histogram_comp, 4, sizeof(RadixPush), spec);
    else
      count_[in] = vk::createKernel(ctx, "radix_count", spv_radix_count_comp, 6, sizeof(RadixPush), spec);
  }
  for (uint32_t in = 0; in < 2; ++in)
    for (uint32_t out = 0; out < 2; ++out) {
      if (!pairs_ && (in || out)) continue;
      const std::initializer_list<vk::SpecConstant> spec = {{0, shape.threads}, {1, shape.items}, {2, lookBack ? 1u : 0u},
                                                            {3, spins}, {4, in}, {5, out}};
      scatter_[in][out] = vk::createKernel(ctx, "radix_scatter", spv_radix_scatter_comp, 9, sizeof(RadixPush), spec);
    }
}

uint64_t RadixSort::bytesAllocated() const {
  return scratchA_.size + scratchB_.size + hist_.size + ranks_.size + tableCount_.size + dummy_.size + args_.size +
         (scan_ ? scan_->bytesAllocated() : 0);
}

vk::BufferRange RadixSort::pairInput() const {
  CS_CHECK(pairs_, "radix sort of " << capacity_ << " pairs: no pair scratch on this device (RadixSort::pairInputs)");
  return range(scratchA_, 0, alignUp(std::max<VkDeviceSize>(capacity_, 1), 4) * 8);
}

void RadixSort::record(vk::Commands& cmd, const vk::BufferRange& keys, const vk::BufferRange& values, Count count,
                       uint32_t keyBits) {
  recordPasses(cmd, keys, values, count, keyBits, false, true);
}

void RadixSort::recordFromPairs(vk::Commands& cmd, const vk::BufferRange& keys, const vk::BufferRange& values,
                                Count count, uint32_t keyBits, bool keysOut) {
  CS_CHECK(pairs_, "radix sort from pairs: no pair scratch on this device (RadixSort::pairInputs)");
  CS_CHECK(radixPasses(keyBits) >= 2 && values.buffer != VK_NULL_HANDLE,
           "radix sort from pairs: " << keyBits << " key bits (two passes or more, with values)");
  recordPasses(cmd, keys, values, count, keyBits, true, keysOut);
}

void RadixSort::recordPasses(vk::Commands& cmd, const vk::BufferRange& keys, const vk::BufferRange& values,
                             Count count, uint32_t keyBits, bool fromPairs, bool keysOut) {
  CS_CHECK(count.max <= capacity_, "radix sort of " << count.max << " pairs, capacity " << capacity_);
  CS_CHECK(keyBits <= 32, "radix sort: " << keyBits << " key bits");
  checkRange(keys, "radix sort keys");
  checkRange(values, "radix sort values");
  const uint32_t passes = radixPasses(keyBits), tiles = sortTiles(count.max, shape_);
  if (passes == 0 || tiles == 0) return;
  const bool hasValues = values.buffer != VK_NULL_HANDLE;
  const VkDeviceSize bytes = VkDeviceSize(count.max) * 4;
  // Where a pass reads or writes: separate arrays, or interleaved pairs (`pairs`, in `keys`).
  // A side of pairs is read through `texels` (the whole scratch buffer as RGBA32UI texels); a kernel
  // reading separate arrays gets a one-texel view there, never read.
  struct Side {
    vk::BufferRange keys, values;
    bool pairs = false;
    vk::BufferRange texels;
  };
  const vk::BufferRange noTexels = vk::texels(dummy_, VK_FORMAT_R32G32B32A32_UINT);
  const Side user{keys, hasValues ? values : vk::BufferRange(dummy_), false, noTexels};
  const bool interleave = pairs_ && hasValues && passes >= 2;
  // Separate scratch: keys alone in A, keys and values in A and B, or (pair scratch, one pass) both in A.
  const VkDeviceSize valuesAt = pairs_ ? scratchA_.size / 2 : 0;
  const Side alt{range(scratchA_, 0, bytes),
                 !hasValues ? vk::BufferRange(dummy_) : pairs_ ? range(scratchA_, valuesAt, bytes) : range(scratchB_, 0, bytes),
                 false, noTexels};
  const VkDeviceSize pairBytes = alignUp(count.max, 4) * 8;  // whole uvec4s
  const Side pairSide[2] = {{range(scratchA_, 0, pairBytes), vk::BufferRange(dummy_), true,
                             interleave ? vk::texels(scratchA_, VK_FORMAT_R32G32B32A32_UINT) : noTexels},
                            {range(scratchB_, 0, pairBytes), vk::BufferRange(dummy_), true,
                             interleave ? vk::texels(scratchB_, VK_FORMAT_R32G32B32A32_UINT) : noTexels}};
  // Pass p reads sides[p] and writes sides[p + 1]; the last lands in the caller's arrays. A fixed array (32
  // key bits at most: LOOKBACK_MAX_PASSES passes), so recording a sort allocates nothing.
  std::array<Side, LOOKBACK_MAX_PASSES + 1> sides;
  size_t sideCount = 0;
  auto add = [&](const Side& s) { sides[sideCount++] = s; };
  if (fromPairs) {  // the producer's pairs in scratch A, then B, A, ... and the caller's arrays last
    for (uint32_t p = 0; p < passes; ++p) add(pairSide[p % 2]);
    add(user);
  } else if (interleave) {
    add(user);
    for (uint32_t p = 1; p < passes; ++p) add(pairSide[(p - 1) % 2]);
    add(user);
  } else {
    Side a = user, b = alt;
    if (passes % 2 == 1) {  // an odd number of passes starts from a copy, so the last one lands in `keys`
      VkBufferCopy k{keys.offset, alt.keys.offset, bytes}, v{values.offset, alt.values.offset, bytes};
      vkCmdCopyBuffer(cmd.handle(), keys.buffer, alt.keys.buffer, 1, &k);
      if (hasValues) vkCmdCopyBuffer(cmd.handle(), values.buffer, alt.values.buffer, 1, &v);
      cmd.barrier();
      std::swap(a, b);
    }
    for (uint32_t p = 0; p <= passes; ++p) add(p % 2 == 0 ? a : b);
  }
  const vk::BufferRange countBinding = bindWord(count.word, dummy_);
  const vk::Grid g = groups(ctx_, tiles);
  const bool indirect = count.onDevice();
  if (indirect) {
    // The tiles the device count fills. Reduce-then-scan: none for a count of 0, so nothing of the sort
    // launches (the cone path's sort on a frame that keeps screen order): the table's size and its scan's
    // grid (tableCount_, which a count pass writes) cleared first, so the scan launches none either.
    // Look-back: at least one (radix_count.comp's table rows).
    const bool rows = scheme_ == SortScheme::LookBack;
    if (!rows) cmd.fill(tableCount_, 0);
    groups_.record(cmd, count, shape_.tile(), args_, 0, rows ? 1 : 0);
    cmd.barrier();
  }
  const uint32_t flags = countFlags(count) | (hasValues ? FLAG_HAS_VALUES : 0u);
  // One kernel over the tiles (those the device count fills, or all of count.max's), then a barrier.
  auto overTiles = [&](const vk::Kernel& kernel, std::initializer_list<vk::BufferRange> buffers, const RadixPush& push) {
    if (indirect)
      cmd.dispatchIndirect(kernel, buffers, &push, sizeof(push), args_);
    else
      cmd.dispatch(kernel, buffers, push, g.x, g.y);
    cmd.barrier();
  };
  const bool lookBack = scheme_ == SortScheme::LookBack;
  if (lookBack) {  // every pass's digit totals, from one read of the keys, into a zeroed workspace
    const VkDeviceSize words = LOOKBACK_STATUS + VkDeviceSize(passes) * RADIX_BINS * tiles;
    cmd.fill(hist_, 0, 0, words * 4);
    cmd.barrier();
    overTiles(count_[sides[0].pairs],
              {sides[0].pairs ? vk::BufferRange(dummy_) : sides[0].keys, range(hist_, 0, words * 4), countBinding,
               sides[0].texels},
              RadixPush{count.max, count.word.index, flags, 0, 0, tiles, 0, keyBits});
  }
  for (uint32_t p = 0; p < passes; ++p) {
    const Side& src = sides[p];
    const Side& dst = sides[p + 1];
    const uint32_t shift = p * RADIX_BITS, bits = std::min<uint32_t>(RADIX_BITS, keyBits - shift);
    const RadixPush push{count.max, count.word.index, flags, shift, (1u << bits) - 1u, tiles, p, keyBits};
    // The scatter's table: the look-back workspace (the tiles add up the ones before them while they run),
    // or this pass's (digit, tile) table, counted and scanned first so every (digit, tile) knows its start.
    vk::BufferRange table = range(hist_, 0, hist_.size);
    if (!lookBack) {
      // With a device count the table has a row entry for each tile the count fills, and the scan reads
      // how many entries that makes from the count pass (tableCount_): a sort bounded by a large capacity
      // scans the table of the keys it has.
      const uint32_t entries = (1u << bits) * tiles;
      table = range(hist_, 0, VkDeviceSize(entries) * 4);
      overTiles(count_[src.pairs],
                {src.pairs ? vk::BufferRange(dummy_) : src.keys, table, countBinding, src.texels, ranks_, tableCount_},
                push);
      // (and its level-0 grid from the count pass's arguments after the count: the workgroups it needs)
      scan_->record(cmd, table, table,
                    indirect ? Count::device(GpuWord(tableCount_, 0), entries).withGroups(tableCount_.buffer, 4)
                             : Count(entries));
    }
    // Scatter: stable rank inside the tile, written from the tile's start of each digit.
    const vk::BufferRange none(dummy_);
    const bool valuesOnly = !keysOut && p + 1 == passes;  // (fromPairs: src.pairs, dst the caller's arrays)
    if (valuesOnly && scatterValues_.pipeline == VK_NULL_HANDLE) {  // compiled for the callers that ask
      scatterValues_ = vk::createKernel(ctx_, "radix_scatter (values)", spv_radix_scatter_comp, 9, sizeof(RadixPush),
                                        {{0, shape_.threads}, {1, shape_.items}, {2, lookBack ? 1u : 0u}, {3, spins_},
                                         {4, 1u}, {5, 0u}, {6, 0u}});
    }
    overTiles(valuesOnly ? scatterValues_ : scatter_[src.pairs][dst.pairs],
              {src.pairs ? none : src.keys, src.values, dst.pairs ? none : dst.keys, dst.pairs ? none : dst.values, table,
               countBinding, dst.pairs ? dst.keys : none, src.texels, ranks_},
              push);
  }
}

}  // namespace cs::sort
