// Step one of the cone path (002 §3.5): the lit samples of the G-buffer as pixel indices in ray order.
// Rays go from the light to each lit sample (geometry present and N·L > 0, as GBuffer::isLit). Either
// sorted by the Hilbert ray key of rays/hilbert.h (face of the direction + Hilbert index on that face),
// so that neighbours in the array have close directions, or — the paper's unsorted variant — left in
// screen order: tiled Morton order, where four consecutive samples come from one 2x2 pixel block (before
// compaction drops the unlit ones), as a mip-map over the 2-D grid would group them.
//
// What the cone tree builder reads: samples() (uint32 pixel index y * width + x per ray, in order) and the
// count (countBuffer()[0] on the GPU, or readCount() on the host: one 4-byte readback). Nothing else per
// ray. Equal keys keep row-major order (the sort is stable), so the order is deterministic.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "raster/gbuffer.h"
#include "raster/raster.h"
#include "rays/hilbert.h"
#include "rays/rays_layout.h"
#include "sort/sort.h"

namespace cs::rays {

enum class RayOrder {
  Hilbert,       // sorted by Hilbert ray key (002 §3.5)
  ScreenMorton,  // unsorted: screen order, Morton inside 64x64 tiles, tiles row-major
  ScreenRows,    // unsorted: plain row-major screen order
};
const char* rayOrderName(RayOrder order);

// The positions the lit-flag pass enumerates: row-major pixels, or whole Morton tiles covering the image
// (positions outside it are never lit).
struct ScreenDomain {
  uint32_t tilesX = 0, tilesY = 0;  // Morton tiles per row / column (0 for row-major)
  uint32_t tileX0 = 0, tileY0 = 0;  // the first tile's column and row (a window of the image's tiles)
  uint64_t size = 0;                // positions enumerated
};
ScreenDomain screenDomain(uint32_t width, uint32_t height, RayOrder order);
// In Morton order, only the window of tiles that meet `clamped` (the pixels that may hold geometry, within
// the image; an empty rect: the first tile), in the same order: the same lit samples in the same order
// from the positions of the rect's tiles instead of the image's (a far view's scene covers a tenth of it).
// Row-major: the image, as above.
ScreenDomain screenDomain(uint32_t width, uint32_t height, RayOrder order, const PixelRect& clamped);

// What the fused compaction (recordCompactionWithKeys) enumerates: the rows of `rect` (the pixels that may
// hold geometry, clamped to the image), each padded to `span` positions, a whole SCAN_ITEMS
// (rectDomainPixel); an empty rect as one row of padding. Its kernels, its scan and its workgroups scale
// with the rect, not the image: a far view's scene covers a tenth of the image, and the per-invocation
// work over the rest was most of the pass (docs/ARCHITECTURE.md, "rays/").
struct RectDomain {
  uint32_t x0 = 0, y0 = 0, x1 = 0, y1 = 1;  // the rect (x1 - x0 pixels of a row are real, the rest padding)
  uint32_t span = SCAN_ITEMS;               // positions a row
  uint64_t size = SCAN_ITEMS;               // positions enumerated: rows * span
};
RectDomain rectDomain(const PixelRect& clamped);
// The most positions rectDomain gives for an image of width x height.
uint64_t maxRectDomain(uint32_t width, uint32_t height);

class LitRays {
 public:
  // Scratch for G-buffers of up to width x height pixels in any order.
  LitRays(vk::Context& ctx, uint32_t width, uint32_t height);

  // Everything, with no host round trip: lit bits -> compaction -> (Hilbert) ray keys -> stable radix sort
  // of (key, pixel). Marks "lit compaction", then for Hilbert "ray keys" and "ray sort", on cmd's timer;
  // Hilbert where fusedKeys(): "lit compaction + ray keys" (recordCompactionWithKeys), then "ray sort".
  void record(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light, RayOrder order);

  // The steps, for callers that want to time them or read the count in between.
  // The lit samples of g for `light` (core/shared.h litSampleFor: the term computed here, g.normal.w not
  // read) -> samples(), count. Here and in recordCompactionWithKeys no position outside g.geometryRect
  // counts or is read where a whole invocation's positions lie outside it (raster.h, DeviceGBuffer).
  void recordCompaction(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light, RayOrder order);
  void recordKeys(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light, sort::Count count);  // -> keys()
  // The keys in a rotated frame (frameRayKey on the grid fitted to the subset, as the faces'): `frame`
  // holds KeysPush's rowX .. rect (framed = 1).
  void recordKeys(vk::Commands& cmd, const DeviceGBuffer& g, const KeysPush& frame, sort::Count count);
  // Compaction and keys in one (row-major order; the sorted path): the faces' (or the rotated frame's)
  // boxes and grids first (from the subset of the pixels recordKeys takes too, which needs no compaction), then one pass
  // over the pixels (lit_runs.comp) marks the lit ones, counts them (atomically, to the lit count), keys
  // every pixel with geometry and finds the runs of equal keys (consecutive lit pixels of
  // one invocation's SCAN_ITEMS whose keys agree: 65-80 % of the lit pixels of a render follow a
  // neighbour that way), and run_items.comp writes one (key, leader pixel and length) item a run straight
  // into the sort's input. recordSort sorts the items and writes each run's pixels where the run starts
  // (run_expand.comp after a scan of the lengths): a stable sort puts a run's pixels next to each other
  // in row order anyway, so samples() and keys() (unless keepSortedKeys(false)) are those of
  // recordCompaction(ScreenRows) + recordKeys + recordSort, bit for bit, from a sort of a quarter to a
  // third of the keys. Only where fusedKeys(): the sort takes pairs (sort::RadixSort::pairInputs) and a
  // pixel index fits RUN_PIXEL_BITS.
  bool fusedKeys() const { return sort_.pairInputs() && maxPixels_ <= (1u << RUN_PIXEL_BITS); }
  void recordCompactionWithKeys(vk::Commands& cmd, const DeviceGBuffer& g, const KeysPush& keys);
  // Sorts (keys(), samples()) by key -- or, after recordCompactionWithKeys, its runs into them (`count`
  // then is count()): the key bits of the last recording (RAY_KEY_BITS in either frame). Given `records`
  // (16 bytes a pixel of the G-buffer's capacity) and the G-buffer's `positions`, a sort of runs also writes each sorted ray's record, uvec4(float bits of its position,
  // its pixel), as conetree::ConeTree::rays() holds them (read in pixel order here, where the tree's build
  // would gather them in the sorted order), in place of samples(), which it leaves as it was (the records
  // hold the pixels). Returns whether it wrote them (a sort of runs only; otherwise samples() as always).
  bool recordSort(vk::Commands& cmd, sort::Count count, const vk::Buffer* records = nullptr,
                  const vk::Buffer* positions = nullptr);
  // Whether keys() holds the sorted keys after a sort from recordCompactionWithKeys' pairs (default yes);
  // a caller that needs only the order (samples()) spares the sort's last pass its key stores.
  void keepSortedKeys(bool keep) { keepSortedKeys_ = keep; }

  const vk::Buffer& samples() const { return samples_; }
  const vk::Buffer& keys() const { return keys_; }
  const vk::Buffer& bounds() const { return bounds_; }  // the fitted boxes and counts (RAY_BOUNDS_WORDS uint)
  // The bits of the keys the last recordKeys or recordCompactionWithKeys made (RAY_KEY_BITS, in the world
  // and in a rotated frame): the sort takes sort::radixPasses of them.
  uint32_t keyBits() const { return keyBits_; }
  const sort::RadixSort& sorter() const { return sort_; }
  const vk::Buffer& countBuffer() const { return count_; }
  // The lit count, on the GPU.
  sort::Count count() const { return sort::Count::device(sort::GpuWord(count_, 0), maxPixels_); }
  uint32_t readCount() const;  // the lit count on the host; after the recording was submitted
  uint64_t bytesAllocated() const;

 private:
  vk::Context& ctx_;
  uint32_t maxPixels_;
  uint64_t maxDomain_;
  sort::Compact compact_;
  sort::RadixSort sort_;
  sort::IndirectGroups groups_;  // a device count: the keys launch only the workgroups it needs
  vk::Kernel rayBounds_, frameRayBounds_, rayGrids_;  // the fitted boxes and grids (ray_bounds, ray_grids.comp)
  vk::Kernel rayKeys_, frameRayKeys_;          // the world's keys, a rotated frame's (ray_keys.comp SPEC_FRAMED)
  // Compaction: lit_count.comp and lit_samples.comp, row-major or Morton (SPEC_MORTON).
  vk::Kernel litCount_, mortonLitCount_, litSamples_, mortonLitSamples_;
  // Fused: lit_runs.comp (world or rotated-frame keys), run_items.comp; after the sort run_expand.comp,
  // [with the keys: keepSortedKeys][with the rays' records].
  vk::Kernel litRuns_, frameLitRuns_, runItems_, frameRunItems_, runExpand_[2][2];
  sort::Scan runScan_;   // each lit_runs invocation's first run, from their counts
  sort::Scan itemScan_;  // where each sorted run starts, from their lengths
  vk::Buffer samples_, keys_, count_, bounds_, grids_, keyArgs_;
  // The runs: runKeys_ (the sorted runs' keys, made on the first sort that keeps them: keepSortedKeys),
  // runCounts_ (per lit_runs invocation: its leaders' count, then its first run),
  // runOrder_ (the sorted runs: leader pixel | (length - 1) << RUN_PIXEL_BITS), runStarts_ (where each
  // starts in the order), runArgs_ (indirect arguments).
  vk::Buffer runKeys_, runCells_, runOrder_, runStarts_, runCounts_, runArgs_;
  // lit_runs' binding 7, run_items' 6, ray_bounds' 3: the enumeration (rectDomain) as two uvec4 (std140):
  // the rect (x0, y0, x1, y1), then the image's width, the span and the positions (recordBounds fills it).
  static constexpr VkDeviceSize kGeometryRectBytes = 32;
  vk::Buffer geometryRect_;
  bool keepSortedKeys_ = true;
  // One uvec2 per SCAN_ITEMS positions: lit_count.comp's bits and ranks, or lit_runs.comp's bits and leaders.
  vk::Buffer keptBits_;
  // lit_count.comp over the push's enumeration, then the scan of its block counts (the lit count to count_).
  void recordLitCount(vk::Commands& cmd, const DeviceGBuffer& g, const LitPush& push);
  // The faces' boxes over the subset of the G-buffer's pixels (ray_bounds.comp, which reads the members in
  // g.geometryRect) and their grids (ray_grids.comp); the enumeration's words (geometryRect_) first. With
  // a device count (`sortCount`: the rays the keys will take), the boxes' workgroups are launched only
  // where it is not 0: a frame whose measured order keeps the screen's sorts nothing and needs no grid.
  void recordBounds(vk::Commands& cmd, const DeviceGBuffer& g, const KeysPush& keys, const sort::Count* sortCount = nullptr);
  // keyArgs_: the keys' dispatch arguments at word 0, the boxes' (recordBounds with a device count) at word 4.
  static constexpr uint32_t kBoundsArgs = 4;
  uint32_t keyBits_ = RAY_KEY_BITS;  // of the keys the last recordKeys (or recordCompactionWithKeys) recorded
  bool runsPending_ = false;         // the last recording left its runs' items in the sort's input
};

// What ray_bounds.comp finds of the faces (LitRays::bounds()'s words): each face's box of the subset's
// face coordinates and how many of the subset's samples it has; keyGrid(face) is the grid ray_grids.comp
// makes of them for that face (faceKeyGrid: its fitted grid and run of keys).
struct FaceBounds {
  std::array<glm::uvec4, 6> boxes;
  std::array<uint32_t, 6> counts;
  static FaceBounds fromWords(const std::vector<uint32_t>& words);  // RAY_BOUNDS_WORDS, as downloaded
  glm::vec4 keyGrid(uint32_t face) const;
  glm::vec4 frameGrid(glm::vec4 rect) const;  // in a rotated frame: its grid (frameKeyGrid over face 0's box)
};
// CPU reference of ray_bounds.comp: the faces' boxes and counts over the lit pixels of the subset; under
// `keys` also in a rotated frame (framed: the box of the frame coordinates in face 0's words).
FaceBounds referenceBounds(const GBuffer& g, glm::vec3 light);
FaceBounds referenceBounds(const GBuffer& g, const KeysPush& keys);

// CPU reference of the whole step (tests, debugging): lit samples of `g` in the given order; in Hilbert
// order under `keys` also in a rotated frame.
std::vector<uint32_t> referenceRayOrder(const GBuffer& g, glm::vec3 light, RayOrder order);
std::vector<uint32_t> referenceRayOrder(const GBuffer& g, const KeysPush& keys);

}  // namespace cs::rays
