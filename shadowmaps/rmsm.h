// shadowmaps/: resolution-matched shadow maps (RMSM, paper 000: Lefohn, Sengupta, Owens 2007) for an
// omnidirectional point light. CLI name "rmsm". Each cube face is a virtual quadtree shadow map, all six
// sharing one physical page pool, and a frame renders only the pages its samples ask for, at the
// resolution they need. The adaptation to six faces, fitted faces, the frame's steps (Algorithm 2, one
// kernel or host function each), the analysis resolution, the page tables and cached mode:
// shadowmaps/README.md, "RMSM (paper 000) per cube face".
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "method/method.h"

namespace cs {
namespace vk { struct Context; }

struct RmsmOptions {
  uint32_t pageSize = 32;             // --rmsm-page: texels a page side (power of two, 4..superpageSize)
  uint32_t maxResolution = 32768;     // --rmsm-max-res: finest effective resolution a face side (power of two)
  uint64_t poolBytes = 16ull << 20;   // --rmsm-pool: the pool holds poolBytes / (4·P²) pages (the paper's
                                      //   2048² texture of 32² pages = 16 MiB = 4096 pages); stored with
                                      //   their aprons, they take (P+1)²/P² of that (+6% at P = 32)
  uint32_t superpageSize = 1024;      // texels a superpage side (power of two, >= pageSize)
  bool cached = false;                // --rmsm-cached: keep pages across frames (static scenes)
  bool fitFaces = true;               // each face's quadtree over the window of it the scene's bounds cover
                                      //   (depth_pass.h fitWindows; the whole face with the light among them)
  float minOccupancy = 0.5f;          // split a superpage's box while its pages fill less (binSuperpages)
  bool cull = true;                   // per-superpage frustum culling of triangle clusters (depth_pass.h)
  uint32_t analysisStep = 1;          // --rmsm-analysis: pages requested by every k-th pixel in x and y
                                      //   (1, 2, 4, 8 or 16; 1 = the full-resolution analysis)
  uint32_t backupResolution = 256;    // analysisStep > 1: a whole level of this many texels a face side
                                      //   is resident on every face in use (the backup shadow map)
  float lodBias = 0.0f;               // levels added to the matched level λ: 1 = texels half the pixel's
                                      //   footprint (4x the pages); 0 = the paper's eq. 1
  float constantBias = 2.0f;          // in units of the epsilon policy's eps (cube_sm.h)
  float slopeBias = 1.5f;             // in texels of the level looked up
  float maxSlope = 10.0f;             // clamp of tanθ
  bool planeBias = false;             // receiver-plane bias per tap instead of slope-scaled (sm_shared.h)
};

namespace sm {

// The sizes an RmsmOptions implies, validated against one storage binding (`maxBinding` bytes).
struct RmsmLayout {
  uint32_t pageSize = 0, log2Page = 0;
  uint32_t maxLevel = 0;             // levels 0..maxLevel
  uint32_t poolPages = 0;            // physical slots
  uint32_t superpageSize = 0;
  uint32_t backupLevel = 0;          // the level of the backup pages (analysisStep > 1)
  uint64_t poolBytes = 0;            // allocated: poolPages·(P+1)²·4
  uint64_t tableEntries = 0;         // 6 faces · (4^(maxLevel+1) - 1) / 3
  uint64_t tableBytes = 0;
};
// Throws cs::Error (naming the CLI flag) for sizes that are not powers of two, out of range, a pool
// under 6 pages (one per face: the coarsest possible frame), arrays past one binding, or an analysis step
// other than 1, 2, 4, 8, 16.
RmsmLayout rmsmLayout(const RmsmOptions& options, uint64_t maxBinding);

// The fallback of paper 000 §3.3.5: while more than `capacity` unique pages remain, lower the finest
// level by one and replace every page above it by its ancestor — exactly the pages the requests would
// have asked for under that limit. `keys`: sorted unique page keys, left sorted and unique. Returns the
// new level limit (<= levelLimit); capacity must be >= 6. One level at a time is coarse: when the pages
// crowd the middle levels, one step can take the frame from just over the pool to a small part of it.
uint32_t coarsenToFit(std::vector<uint32_t>& keys, uint32_t levelLimit, uint32_t capacity);

// The backup pages of a reduced analysis: every page of `level` on each face f with bit f of `faces`
// set, merged into `keys` (sorted, unique; left so) unless `resident` (sorted) holds it already.
// Returns how many were added.
uint32_t addBackupPages(std::vector<uint32_t>& keys, uint32_t faces, const std::vector<uint32_t>& resident,
                        uint32_t level);

// One geometry pass: a window of face `face` at `level`, covering pages [first, first + count) of the
// binned list, whose texels start at (x0, y0) and span w x h (the pages' bounding box plus the apron).
struct Superpage {
  uint32_t face = 0, level = 0;
  uint32_t x0 = 0, y0 = 0, w = 0, h = 0;
  uint32_t first = 0, count = 0;
};
// Bins sorted page keys into superpages: aligned squares of superpageSize² texels of one level of one face
// (a level smaller than a superpage is one square), each rendered as the bounding box of its pages. A box
// whose pages fill less than `minOccupancy` of it is split into its four quadrants, recursively (down to
// single pages): a pass costs its area times the depth complexity, and scattered pages would otherwise
// pay for the empty texels between them. minOccupancy = 0: the paper's plain superpages.
std::vector<Superpage> binSuperpages(const std::vector<uint32_t>& sortedKeys, uint32_t log2Page,
                                     uint32_t superpageSize, float minOccupancy = 0.0f);

}  // namespace sm

class Rmsm : public ShadowMethod {
 public:
  Rmsm(vk::Context& ctx, const RmsmOptions& options);
  ~Rmsm() override;
  std::string name() const override { return "rmsm"; }

  // visibility in [0, 1] per pixel, 1 where not lit. Stages (GPU timestamps, host wall clock for
  // "readback" and "allocate"): requests, prune, compact, sort, uniquify, readback, allocate, page_tables,
  // superpages, lookup (+ "upload" on frames that upload triangles). totalMs: wall clock up to the mask
  // on the GPU. Stats: requests_before_pruning, requests_after_pruning, unique_pages, pages_rendered,
  // pages_resident, superpages, pool_pages, pool_bytes, page_table_bytes, effective_resolution,
  // max_resolution, fallback_levels, pages_per_level, isolated_samples, lookup_misses, cache state.
  // In cached mode the request counts and unique_pages count only pages not yet resident.
  MethodOutput run(const FrameInput& frame) override;

  const sm::RmsmLayout& layout() const;

 private:
  friend class RmsmInspector;  // the tests' view of the last run (rmsm_inspect.h)
  struct State;
  std::unique_ptr<State> s_;
};

std::unique_ptr<ShadowMethod> makeRmsm(vk::Context& ctx, const RmsmOptions& options = {});

}  // namespace cs
