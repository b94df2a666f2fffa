// Lit samples in ray order: see rays.h.
#include "rays/rays.h"

#include <algorithm>
#include <array>
#include <numeric>

#include "rays/hilbert.h"
#include "rays/lit_count.comp.h"
#include "rays/lit_samples.comp.h"
#include "rays/lit_runs.comp.h"
#include "rays/ray_bounds.comp.h"
#include "rays/ray_grids.comp.h"
#include "rays/ray_keys.comp.h"
#include "rays/run_expand.comp.h"
#include "rays/run_items.comp.h"

namespace cs::rays {

// The G-buffer read as texels (vk::texels): position and normal are one vec4 a pixel.
constexpr VkFormat kPixelTexels = VK_FORMAT_R32G32B32A32_SFLOAT;
// The faces' key grids (ray_grids.comp writes them): a vec4 texel per face, read as texels by every kernel
// that keys (a storage load is a bounds-checked load per lane on a SIMD CPU driver).
constexpr VkFormat kGridTexels = VK_FORMAT_R32G32B32A32_SFLOAT;
// The runs' words (run_items.comp and after): uint arrays read as R32UI texels.
constexpr VkFormat kWordTexels = VK_FORMAT_R32_UINT;
// lit_runs' uvec2 per invocation (lit bits, leaders) as run_items reads them: two a texel.
constexpr VkFormat kPairTexels = VK_FORMAT_R32G32B32A32_UINT;
// count_'s words: the lit count, the runs' count.
constexpr uint32_t kLitWord = 0, kRunsWord = 1;
// runArgs_: indirect arguments (x, y, z) for the run kernels (a workgroup per PIXEL_THREADS runs) and
// for the scan of the runs' lengths (a workgroup per SCAN_BLOCK runs).
constexpr uint32_t kRunGroupsArgs = 0, kRunScanArgs = 4;

static_assert(RAY_BOUNDS_SAMPLES <= 65536u, "boundsSample: j * (n % RAY_BOUNDS_SAMPLES) in 32 bits");
static_assert((RAY_BOUNDS_SAMPLES & (RAY_BOUNDS_SAMPLES - 1u)) == 0u, "firstBoundsSampleFrom: a power of two");
static_assert(RAY_BOUNDS_COUNTS >= 24 && RAY_BOUNDS_COUNTS % 4 == 0 && RAY_BOUNDS_WORDS >= RAY_BOUNDS_COUNTS + 6,
              "four words for each of six faces, then a count each");

const char* rayOrderName(RayOrder order) {
  switch (order) {
    case RayOrder::Hilbert: return "hilbert";
    case RayOrder::ScreenMorton: return "screen-morton";
    case RayOrder::ScreenRows: return "screen-rows";
  }
  return "?";
}

ScreenDomain screenDomain(uint32_t width, uint32_t height, RayOrder order) {
  ScreenDomain d;
  if (order != RayOrder::ScreenMorton) {
    d.size = uint64_t(width) * height;
    return d;
  }
  const uint32_t tile = 1u << MORTON_TILE_BITS;
  d.tilesX = sort::ceilDiv(width, tile);
  d.tilesY = sort::ceilDiv(height, tile);
  d.size = uint64_t(d.tilesX) * d.tilesY * tile * tile;
  return d;
}

RectDomain rectDomain(const PixelRect& r) {
  RectDomain d;
  if (r.x0 >= r.x1 || r.y0 >= r.y1) return d;  // one row of padding: no position is read
  d.x0 = r.x0, d.y0 = r.y0, d.x1 = r.x1, d.y1 = r.y1;
  d.span = sort::ceilDiv(r.x1 - r.x0, SCAN_ITEMS) * SCAN_ITEMS;
  d.size = uint64_t(r.y1 - r.y0) * d.span;
  return d;
}

uint64_t maxRectDomain(uint32_t width, uint32_t height) {
  return std::max<uint64_t>(uint64_t(height) * (sort::ceilDiv(width, SCAN_ITEMS) * SCAN_ITEMS), SCAN_ITEMS);
}

namespace {
// Invocations of lit_count.comp (and lit_runs.comp) over `positions` row-major positions: whole blocks.
uint32_t blockInvocations(uint64_t positions) { return sort::ceilDiv(positions, SCAN_BLOCK) * SCAN_THREADS; }

uint32_t checkedPixels(const vk::Context& ctx, uint32_t width, uint32_t height) {
  uint64_t domain = std::max({screenDomain(width, height, RayOrder::ScreenMorton).size, uint64_t(width) * height,
                              maxRectDomain(width, height)});
  sort::checkBinding(ctx, domain, 4, "lit samples");
  return uint32_t(uint64_t(width) * height);
}
}  // namespace

ScreenDomain screenDomain(uint32_t width, uint32_t height, RayOrder order, const PixelRect& r) {
  ScreenDomain d = screenDomain(width, height, order);
  if (order != RayOrder::ScreenMorton) return d;
  const uint32_t tile = 1u << MORTON_TILE_BITS;
  if (r.x0 >= r.x1 || r.y0 >= r.y1) {  // no pixel can be lit: one tile, whose positions the rect test drops
    d.tilesX = d.tilesY = 1;
  } else {
    d.tileX0 = r.x0 / tile, d.tileY0 = r.y0 / tile;
    d.tilesX = sort::ceilDiv(r.x1, tile) - d.tileX0;
    d.tilesY = sort::ceilDiv(r.y1, tile) - d.tileY0;
  }
  d.size = uint64_t(d.tilesX) * d.tilesY * tile * tile;
  return d;
}

namespace {
// g.geometryRect within the image (the default rect is the whole image, whatever its size).
PixelRect clampedRect(const DeviceGBuffer& g) {
  const PixelRect& r = g.geometryRect;
  return {std::min(r.x0, g.width), std::min(r.y0, g.height), std::min(r.x1, g.width), std::min(r.y1, g.height)};
}
}  // namespace

LitRays::LitRays(vk::Context& ctx, uint32_t width, uint32_t height)
    : ctx_(ctx),
      maxPixels_(checkedPixels(ctx, width, height)),
      maxDomain_(std::max({screenDomain(width, height, RayOrder::ScreenMorton).size, uint64_t(maxPixels_),
                           maxRectDomain(width, height)})),
      compact_(ctx, uint32_t(maxDomain_)),
      sort_(ctx, maxPixels_),
      groups_(ctx),
      runScan_(ctx, blockInvocations(maxRectDomain(width, height))),
      itemScan_(ctx, std::max(maxPixels_, 1u)) {
  rayBounds_ = vk::createKernel(ctx, "ray_bounds", spv_ray_bounds_comp, 4, sizeof(KeysPush), {{0, 0u}});
  frameRayBounds_ = vk::createKernel(ctx, "ray_bounds (frame)", spv_ray_bounds_comp, 4, sizeof(KeysPush), {{0, 1u}});
  rayGrids_ = vk::createKernel(ctx, "ray_grids", spv_ray_grids_comp, 2, sizeof(KeysPush));
  rayKeys_ = vk::createKernel(ctx, "ray_keys", spv_ray_keys_comp, 5, sizeof(KeysPush), {{0, 0u}});
  frameRayKeys_ = vk::createKernel(ctx, "ray_keys (frame)", spv_ray_keys_comp, 5, sizeof(KeysPush), {{0, 1u}});
  litCount_ = vk::createKernel(ctx, "lit_count", spv_lit_count_comp, 4, sizeof(LitPush), {{0, 0u}});
  mortonLitCount_ = vk::createKernel(ctx, "lit_count (Morton)", spv_lit_count_comp, 4, sizeof(LitPush), {{0, 1u}});
  litSamples_ = vk::createKernel(ctx, "lit_samples", spv_lit_samples_comp, 3, sizeof(LitPush), {{0, 0u}});
  mortonLitSamples_ = vk::createKernel(ctx, "lit_samples (Morton)", spv_lit_samples_comp, 3, sizeof(LitPush), {{0, 1u}});
  litRuns_ = vk::createKernel(ctx, "lit_runs", spv_lit_runs_comp, 8, sizeof(KeysPush), {{0, 0u}});
  frameLitRuns_ = vk::createKernel(ctx, "lit_runs (frame)", spv_lit_runs_comp, 8, sizeof(KeysPush), {{0, 1u}});
  runItems_ = vk::createKernel(ctx, "run_items", spv_run_items_comp, 7, sizeof(KeysPush), {{0, 0u}});
  frameRunItems_ = vk::createKernel(ctx, "run_items (frame)", spv_run_items_comp, 7, sizeof(KeysPush), {{0, 1u}});
  for (uint32_t keys = 0; keys < 2; ++keys)
    for (uint32_t records = 0; records < 2; ++records)
      runExpand_[keys][records] =
          vk::createKernel(ctx, keys ? (records ? "run_expand (keys, records)" : "run_expand (keys)")
                                     : (records ? "run_expand (records)" : "run_expand"),
                           spv_run_expand_comp, 8, sizeof(RunsPush), {{0, keys}, {1, records}});
  samples_ = vk::createBuffer(ctx, uint64_t(maxPixels_) * 4);
  keys_ = vk::createBuffer(ctx, uint64_t(maxPixels_) * 4);
  count_ = vk::createBuffer(ctx, 16);
  bounds_ = vk::createBuffer(ctx, RAY_BOUNDS_WORDS * 4);
  grids_ = vk::createBuffer(ctx, 8 * 16);
  keyArgs_ = vk::createBuffer(ctx, 32, vk::Memory::Device, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
  keptBits_ = vk::createBuffer(ctx, uint64_t(sort::ceilDiv(maxDomain_, SCAN_BLOCK)) * SCAN_THREADS * 8);
  const uint64_t words = std::max(maxPixels_, 1u);
  runOrder_ = vk::createBuffer(ctx, words * 4);
  const uint32_t runInvocations = blockInvocations(maxRectDomain(width, height));
  runCells_ = vk::createBuffer(ctx, uint64_t(runInvocations) * SCAN_ITEMS * 4);  // whole blocks
  runStarts_ = vk::createBuffer(ctx, words * 4);
  runCounts_ = vk::createBuffer(ctx, uint64_t(runInvocations) * 4);
  runArgs_ = vk::createBuffer(ctx, 32, vk::Memory::Device, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
  geometryRect_ = vk::createBuffer(ctx, kGeometryRectBytes);
}

uint64_t LitRays::bytesAllocated() const {
  return compact_.bytesAllocated() + sort_.bytesAllocated() + runScan_.bytesAllocated() +
         itemScan_.bytesAllocated() + samples_.size + keys_.size + count_.size + bounds_.size + grids_.size +
         keyArgs_.size + keptBits_.size + runKeys_.size + runCells_.size + runOrder_.size + runStarts_.size +
         runCounts_.size + runArgs_.size + geometryRect_.size;
}

void LitRays::recordCompaction(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light, RayOrder order) {
  const uint64_t pixels = uint64_t(g.width) * g.height;
  const PixelRect r = clampedRect(g);
  const ScreenDomain d = screenDomain(g.width, g.height, order, r);  // Morton: the rect's tiles
  CS_CHECK(pixels <= maxPixels_ && d.size <= maxDomain_,
           "G-buffer of " << g.width << "x" << g.height << " exceeds the " << maxPixels_ << " pixels LitRays was made for");
  const bool morton = order == RayOrder::ScreenMorton;
  CS_CHECK(g.width < 65536 && g.height < 65536,
           "G-buffer of " << g.width << "x" << g.height << ": a side of at most 65535 pixels (LitPush's rect)");
  const LitPush push{g.width,           g.height,           morton ? 1u : 0u,
                     d.tilesX,          uint32_t(d.size),   r.x0 | r.x1 << 16,
                     r.y0 | r.y1 << 16, d.tileX0 | d.tileY0 << 16, glm::vec4(light, 1.0f)};
  recordLitCount(cmd, g, push);
  const vk::Grid grid = sort::workgroupGrid(ctx_, sort::ceilDiv(d.size, SCAN_BLOCK));
  cmd.dispatch(morton ? mortonLitSamples_ : litSamples_, {keptBits_, compact_.blockOffsets(), samples_}, push, grid.x,
               grid.y);
  cmd.barrier();
  runsPending_ = false;
}

void LitRays::recordLitCount(vk::Commands& cmd, const DeviceGBuffer& g, const LitPush& push) {
  const vk::Grid grid = sort::workgroupGrid(ctx_, sort::ceilDiv(push.domain, SCAN_BLOCK));
  cmd.dispatch(push.order ? mortonLitCount_ : litCount_,
               {vk::texels(g.position, kPixelTexels), vk::texels(g.normal, kPixelTexels), keptBits_, compact_.blockCounts()},
               push, grid.x, grid.y);
  cmd.barrier();
  compact_.recordBlockScan(cmd, push.domain, sort::GpuWord(count_, 0));
}

void LitRays::recordCompactionWithKeys(vk::Commands& cmd, const DeviceGBuffer& g, const KeysPush& frame) {
  const uint64_t pixels = uint64_t(g.width) * g.height;
  CS_CHECK(pixels <= maxPixels_,
           "G-buffer of " << g.width << "x" << g.height << " exceeds the " << maxPixels_ << " pixels LitRays was made for");
  CS_CHECK(fusedKeys(), "compaction with keys: the sort takes no pairs on this device (LitRays::fusedKeys)");
  KeysPush push = frame;
  push.count = uint32_t(pixels);  // lit_runs (its fetches' clamp) and ray_bounds (recordBounds): the pixels
  const bool framed = frame.framed != 0u;
  keyBits_ = kRayKeyBits;
  // The positions: the rows of the pixels that may hold geometry (rectDomain), not the image.
  const RectDomain d = rectDomain(clampedRect(g));
  CS_CHECK(d.size <= maxRectDomain(g.width, g.height), "rect domain of " << d.size << " positions");
  const vk::Grid grid = sort::workgroupGrid(ctx_, sort::ceilDiv(d.size, SCAN_BLOCK));
  const vk::BufferRange position = vk::texels(g.position, kPixelTexels), grids = vk::texels(grids_, kGridTexels);
  cmd.fill(count_, 0, kLitWord * 4, 4);  // lit_runs adds its subgroups' lit counts (recordBounds' barrier)
  recordBounds(cmd, g, push);  // the key grids first, from the pixels alone, and the enumeration's words
  // One pass over the positions (lit_runs.comp): which are lit (their count to the lit word), and the runs
  // of equal keys among them (every pixel's key cell, four at a time, kept per position); each invocation's
  // first run (the scan of its runs' counts, their total the runs' count), then one item a run as the
  // sort's input (run_items.comp: the leader's key from its cell).
  const uint32_t invocations = blockInvocations(d.size);
  cmd.dispatch(framed ? frameLitRuns_ : litRuns_,
               {position, vk::texels(g.normal, kPixelTexels), keptBits_, vk::BufferRange(count_, 0, (kLitWord + 1) * 4),
                grids, runCounts_, runCells_, vk::uniforms(geometryRect_, kGeometryRectBytes)},
               push, grid.x, grid.y);
  cmd.barrier();
  runScan_.record(cmd, vk::BufferRange(runCounts_, 0, uint64_t(invocations) * 4),
                  vk::BufferRange(runCounts_, 0, uint64_t(invocations) * 4), sort::Count(invocations),
                  sort::GpuWord(count_, kRunsWord));
  const vk::Grid spans = sort::workgroupGrid(ctx_, sort::ceilDiv(invocations, RUN_ITEMS_SPAN * SCAN_THREADS));
  cmd.dispatch(framed ? frameRunItems_ : runItems_,
               {position, vk::texels(keptBits_, kPairTexels), vk::texels(runCounts_, kWordTexels), sort_.pairInput(),
                grids, vk::texels(runCells_, kWordTexels), vk::uniforms(geometryRect_, kGeometryRectBytes)},
               push, spans.x, spans.y);
  cmd.barrier();
  runsPending_ = true;
}

void LitRays::recordBounds(vk::Commands& cmd, const DeviceGBuffer& g, const KeysPush& keys, const sort::Count* sortCount) {
  cmd.fill(bounds_, RAY_BOUNDS_EMPTY, 0, RAY_BOUNDS_COUNTS * 4);  // the boxes empty, the counts zero
  cmd.fill(bounds_, 0, RAY_BOUNDS_COUNTS * 4, bounds_.size - RAY_BOUNDS_COUNTS * 4);
  // The pixels that may hold geometry (ray_bounds reads the subset's members in them) and the fused
  // compaction's enumeration of them (lit_runs, run_items: rectDomain).
  const RectDomain d = rectDomain(clampedRect(g));
  const uint32_t words[7] = {d.x0, d.y0, d.x1, d.y1, g.width, d.span, uint32_t(d.size)};
  for (uint32_t k = 0; k < 7; ++k) cmd.fill(geometryRect_, words[k], k * 4, 4);
  // With the keys' count on the device: min(count, RAY_BOUNDS_GROUPS) workgroups (ray_bounds.comp strides
  // by the workgroups launched; the boxes do not depend on how many), none where nothing will be sorted.
  const bool indirect = sortCount && sortCount->onDevice();
  if (indirect)
    groups_.record(cmd, sort::Count::device(sortCount->word, RAY_BOUNDS_GROUPS).withGate(sortCount->gateBuffer, sortCount->gateOffset),
                   1, keyArgs_, kBoundsArgs);
  cmd.barrier();
  KeysPush push = keys;
  push.count = g.width * g.height;  // the subset is spread over the pixels
  const vk::Kernel& bounds = keys.framed ? frameRayBounds_ : rayBounds_;
  const std::initializer_list<vk::BufferRange> bindings = {vk::texels(g.position, kPixelTexels), vk::texels(g.normal, kPixelTexels),
                                                           bounds_, vk::uniforms(geometryRect_, kGeometryRectBytes)};
  if (indirect)
    cmd.dispatchIndirect(bounds, bindings, &push, sizeof(push), keyArgs_, kBoundsArgs * 4);
  else
    cmd.dispatch(bounds, bindings, push, RAY_BOUNDS_GROUPS);
  cmd.barrier();
  if (indirect && sortCount->gateBuffer != VK_NULL_HANDLE)  // no grid where nothing will be keyed
    cmd.dispatchIndirect(rayGrids_, {bounds_, grids_}, &push, sizeof(push), sortCount->gateBuffer, sortCount->gateOffset);
  else
    cmd.dispatch(rayGrids_, {bounds_, grids_}, push, 1);
  cmd.barrier();
}

void LitRays::recordKeys(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light, sort::Count count) {
  KeysPush push{};
  push.light = glm::vec4(light, 1.0f);
  recordKeys(cmd, g, push, count);
}

void LitRays::recordKeys(vk::Commands& cmd, const DeviceGBuffer& g, const KeysPush& frame, sort::Count count) {
  CS_CHECK(count.max <= maxPixels_, "ray keys for " << count.max << " samples, capacity " << maxPixels_);
  KeysPush push = frame;
  push.count = count.max;
  push.countIndex = count.word.index;
  push.flags = count.onDevice() ? FLAG_COUNT_FROM_BUFFER : 0u;
  const bool framed = frame.framed != 0u;
  keyBits_ = kRayKeyBits;
  runsPending_ = false;
  vk::BufferRange countBinding = count.onDevice() ? vk::BufferRange() : vk::BufferRange(count_);
  if (count.onDevice()) {
    countBinding.buffer = count.word.buffer;
    countBinding.offset = 0;
    countBinding.range = (VkDeviceSize(count.word.index) + 1) * 4;
  }
  recordBounds(cmd, g, push, &count);  // each face's (or the frame's) box over the subset, for its fitted grid
  const vk::Kernel& keys = framed ? frameRayKeys_ : rayKeys_;
  const vk::BufferRange grids = vk::texels(grids_, kGridTexels);
  if (count.onDevice()) {  // as many workgroups as the device count needs (none for a count of 0)
    groups_.record(cmd, count, PIXEL_THREADS, keyArgs_, 0);
    cmd.barrier();
    cmd.dispatchIndirect(keys, {vk::texels(g.position, kPixelTexels), samples_, keys_, countBinding, grids}, &push,
                         sizeof(push), keyArgs_);
  } else {
    vk::Grid grid = sort::workgroupGrid(ctx_, sort::ceilDiv(count.max, PIXEL_THREADS));
    cmd.dispatch(keys, {vk::texels(g.position, kPixelTexels), samples_, keys_, countBinding, grids}, push, grid.x, grid.y);
  }
  cmd.barrier();
}

bool LitRays::recordSort(vk::Commands& cmd, sort::Count count, const vk::Buffer* records, const vk::Buffer* positions) {
  CS_CHECK((records == nullptr) == (positions == nullptr), "LitRays::recordSort: the records need the positions");
  const bool writeRecords = records != nullptr;
  if (writeRecords)
    CS_CHECK(records->size >= uint64_t(maxPixels_) * 16 && positions->size >= uint64_t(maxPixels_) * 16,
             "LitRays::recordSort: records of " << records->size << " bytes, positions of " << positions->size
                                                << " for up to " << maxPixels_ << " rays");
  if (!runsPending_) {
    sort_.record(cmd, keys_, samples_, count, keyBits_);
    return false;
  }
  runsPending_ = false;
  CS_CHECK(count.word.buffer == count_.buffer && count.word.index == kLitWord,
           "LitRays::recordSort after recordCompactionWithKeys sorts the lit samples: pass count()");
  // The runs' items by key (their keys too, for keepSortedKeys), where each run starts in the order (the
  // scan of their lengths), then each run's pixels (and key) from there.
  const sort::Count items = sort::Count::device(sort::GpuWord(count_, kRunsWord), maxPixels_);
  if (keepSortedKeys_ && !runKeys_.buffer) runKeys_ = vk::createBuffer(ctx_, uint64_t(std::max(maxPixels_, 1u)) * 4);
  const vk::Buffer& sortedKeys = keepSortedKeys_ ? runKeys_ : runOrder_;  // (read by run_expand with the keys)
  sort_.recordFromPairs(cmd, sortedKeys, runOrder_, items, keyBits_, keepSortedKeys_);
  groups_.record(cmd, items, PIXEL_THREADS, runArgs_, kRunGroupsArgs);
  groups_.record(cmd, items, SCAN_BLOCK, runArgs_, kRunScanArgs);
  cmd.barrier();
  itemScan_.record(cmd, runOrder_, runStarts_, items.withGroups(runArgs_.buffer, kRunScanArgs * 4), {},
                   RUN_PIXEL_BITS);
  const RunsPush runs{0, maxPixels_, kRunsWord, kLitWord};
  // Without the records, bindings 6 and 7 are not read or written: any valid buffers.
  cmd.dispatchIndirect(runExpand_[keepSortedKeys_ ? 1 : 0][writeRecords ? 1 : 0],
                       {vk::texels(runOrder_, kWordTexels), vk::texels(runStarts_, kWordTexels), samples_, keys_,
                        vk::texels(sortedKeys, kWordTexels), vk::texels(count_, kWordTexels),
                        vk::texels(writeRecords ? *positions : samples_, kPixelTexels),
                        writeRecords ? *records : samples_},
                       &runs, sizeof(runs), runArgs_, kRunGroupsArgs * 4);
  cmd.barrier();
  return writeRecords;
}

void LitRays::record(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light, RayOrder order) {
  if (order == RayOrder::Hilbert && fusedKeys()) {
    KeysPush push{};
    push.light = glm::vec4(light, 1.0f);
    recordCompactionWithKeys(cmd, g, push);
    cmd.mark("lit compaction + ray keys");
    recordSort(cmd, count());
    cmd.mark("ray sort");
    return;
  }
  recordCompaction(cmd, g, light, order);
  cmd.mark("lit compaction");
  if (order != RayOrder::Hilbert) return;
  const sort::Count lit = sort::Count::device(sort::GpuWord(count_, 0), g.width * g.height);
  recordKeys(cmd, g, light, lit);
  cmd.mark("ray keys");
  recordSort(cmd, lit);
  cmd.mark("ray sort");
}

uint32_t LitRays::readCount() const { return vk::download<uint32_t>(ctx_, count_, 1)[0]; }

namespace {
// The ray to position x under `keys`: from the light in the world, or in the rotated frame (frameRay).
glm::vec3 keyedRay(glm::vec3 x, const KeysPush& keys) {
  return keys.framed ? frameRay(x, keys.rowX, keys.rowY, keys.rowZ, keys.origin, keys.lightFrame)
                     : x - glm::vec3(keys.light);
}
}  // namespace

FaceBounds referenceBounds(const GBuffer& g, glm::vec3 light) {
  KeysPush keys{};
  keys.light = glm::vec4(light, 1.0f);
  return referenceBounds(g, keys);
}

FaceBounds referenceBounds(const GBuffer& g, const KeysPush& keys) {
  FaceBounds b;
  b.boxes.fill(glm::uvec4(RAY_BOUNDS_EMPTY));
  b.counts.fill(0);
  const uint32_t n = uint32_t(g.size());
  for (uint32_t j = 0; j < RAY_BOUNDS_SAMPLES && n > 0; ++j) {
    const uint32_t pixel = boundsSample(j, n);
    if (!g.isLit(pixel)) continue;
    const glm::vec3 d = keyedRay(glm::vec3(g.position[pixel]), keys);
    const uint32_t face = keys.framed ? (frameRayKeyed(d) ? 0u : 7u) : rayFace(d);
    if (face == 7) continue;
    const glm::vec2 uv = keys.framed ? frameUV(d) : rayFaceUV(d, face);
    b.boxes[face] =
        glm::min(b.boxes[face], glm::uvec4(orderedBits(uv.x), orderedBits(uv.y), orderedBits(-uv.x), orderedBits(-uv.y)));
    ++b.counts[face];
  }
  return b;
}

FaceBounds FaceBounds::fromWords(const std::vector<uint32_t>& words) {
  CS_CHECK(words.size() >= RAY_BOUNDS_COUNTS + 6,
           "FaceBounds::fromWords: " << words.size() << " words, want " << RAY_BOUNDS_COUNTS + 6);
  FaceBounds b;
  for (uint32_t face = 0; face < 6; ++face) {
    b.boxes[face] = glm::uvec4(words[4 * face], words[4 * face + 1], words[4 * face + 2], words[4 * face + 3]);
    b.counts[face] = words[RAY_BOUNDS_COUNTS + face];
  }
  return b;
}

glm::vec4 FaceBounds::keyGrid(uint32_t face) const {
  uint32_t c[6];
  std::copy(counts.begin(), counts.end(), c);
  return faceKeyGrid(boxes.at(face), faceKeySlot(face, c));
}

glm::vec4 FaceBounds::frameGrid(glm::vec4 rect) const { return frameKeyGrid(boxes[0], rect, RAY_KEY_MAX_ORDER); }

std::vector<uint32_t> referenceRayOrder(const GBuffer& g, glm::vec3 light, RayOrder order) {
  if (order == RayOrder::Hilbert) {
    KeysPush keys{};
    keys.light = glm::vec4(light, 1.0f);
    return referenceRayOrder(g, keys);
  }
  std::vector<uint32_t> samples;
  if (order == RayOrder::ScreenMorton) {
    const ScreenDomain d = screenDomain(g.width, g.height, order);
    for (uint64_t i = 0; i < d.size; ++i) {
      glm::uvec2 p = screenOrderPixel(uint32_t(i), d.tilesX);
      if (p.x < g.width && p.y < g.height && g.isLit(size_t(p.y) * g.width + p.x)) samples.push_back(p.y * g.width + p.x);
    }
    return samples;
  }
  for (uint32_t i = 0; i < g.size(); ++i)
    if (g.isLit(i)) samples.push_back(i);
  return samples;
}

std::vector<uint32_t> referenceRayOrder(const GBuffer& g, const KeysPush& keys) {
  std::vector<uint32_t> samples = referenceRayOrder(g, glm::vec3(keys.light), RayOrder::ScreenRows);
  const FaceBounds bounds = referenceBounds(g, keys);
  std::array<glm::vec4, 6> grids;
  for (uint32_t face = 0; face < 6; ++face) grids[face] = bounds.keyGrid(face);
  const glm::vec4 frame = bounds.frameGrid(keys.rect);
  std::vector<uint32_t> key(g.size());
  for (uint32_t s : samples) {
    const glm::vec3 d = keyedRay(glm::vec3(g.position[s]), keys);
    const uint32_t face = rayFace(d);
    key[s] = keys.framed ? frameRayKey(d, frame) : face == 7 ? kRayKeyDegenerate : faceKey(d, face, grids[face]);
  }
  std::stable_sort(samples.begin(), samples.end(), [&](uint32_t a, uint32_t b) { return key[a] < key[b]; });
  return samples;
}

}  // namespace cs::rays
