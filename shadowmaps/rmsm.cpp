// Resolution-matched shadow maps over six cube faces: the algorithm and its steps are shadowmaps/README.md,
// "RMSM (paper 000) per cube face".
#include "shadowmaps/rmsm.h"

#include "shadowmaps/rmsm_inspect.h"

#include <array>

#include <algorithm>
#include <chrono>
#include <cstring>

#include "core/error.h"
#include "raster/raster.h"
#include "method/epsilon.h"
#include "shadowmaps/depth_pass.h"
#include "shadowmaps/rmsm_lookup.comp.h"
#include "shadowmaps/rmsm_prune.comp.h"
#include "shadowmaps/rmsm_requests.comp.h"
#include "shadowmaps/rmsm_tables.comp.h"
#include "shadowmaps/rmsm_unique.comp.h"
#include "shadowmaps/sm_shared.h"
#include "sort/sort.h"
#include "vk/context.h"

namespace cs {

using Clock = std::chrono::steady_clock;
static double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

namespace sm {

namespace {
bool isPow2(uint64_t v) { return v != 0 && (v & (v - 1)) == 0; }
uint32_t log2u(uint64_t v) {
  uint32_t l = 0;
  while ((uint64_t(1) << (l + 1)) <= v) ++l;
  return l;
}
std::string mib(uint64_t bytes) { return std::to_string((bytes + (1 << 19)) >> 20) + " MiB"; }
}  // namespace

RmsmLayout rmsmLayout(const RmsmOptions& o, uint64_t maxBinding) {
  RmsmLayout l;
  if (!isPow2(o.pageSize) || o.pageSize < 4 || o.pageSize > 1024)
    throw Error("page size " + std::to_string(o.pageSize) + " is not a power of two from 4 to 1024", "--rmsm-page");
  if (!isPow2(o.superpageSize) || o.superpageSize < o.pageSize || o.superpageSize > 16384)
    throw Error("superpage size " + std::to_string(o.superpageSize) +
                    " is not a power of two from the page size to 16384", "rmsm superpage");
  if (!isPow2(o.maxResolution) || o.maxResolution < o.pageSize)
    throw Error("maximum resolution " + std::to_string(o.maxResolution) +
                    " is not a power of two at least the page size (" + std::to_string(o.pageSize) + ")",
                "--rmsm-max-res");
  if (o.analysisStep != 1 && o.analysisStep != 2 && o.analysisStep != 4 && o.analysisStep != 8 &&
      o.analysisStep != 16)
    throw Error("analysis step " + std::to_string(o.analysisStep) + " is not 1, 2, 4, 8 or 16", "--rmsm-analysis");
  if (!isPow2(o.backupResolution))
    throw Error("backup resolution " + std::to_string(o.backupResolution) + " is not a power of two",
                "rmsm backup resolution");
  l.pageSize = o.pageSize;
  l.log2Page = log2u(o.pageSize);
  l.superpageSize = o.superpageSize;
  l.maxLevel = log2u(o.maxResolution / o.pageSize);
  l.backupLevel = o.backupResolution > o.pageSize ? std::min(l.maxLevel, log2u(o.backupResolution / o.pageSize)) : 0u;
  if (l.maxLevel > SM_MAX_LEVEL)
    throw Error("maximum resolution " + std::to_string(o.maxResolution) + " needs " + std::to_string(l.maxLevel) +
                    " quadtree levels above the root; page keys hold " + std::to_string(SM_MAX_LEVEL),
                "--rmsm-max-res", "at most " + std::to_string(o.pageSize << SM_MAX_LEVEL) + " with pages of " +
                                      std::to_string(o.pageSize));
  const uint64_t pagePayload = uint64_t(4) * o.pageSize * o.pageSize;
  const uint64_t pages = o.poolBytes / pagePayload;
  if (pages < 6)
    throw Error("a pool of " + std::to_string(o.poolBytes) + " bytes holds " + std::to_string(pages) + " pages of " +
                    std::to_string(o.pageSize) + "²; the coarsest frame needs 6 (one per face)",
                "--rmsm-pool", "at least " + std::to_string(6 * pagePayload) + " bytes");
  const uint64_t slotBytes = uint64_t(4) * (o.pageSize + 1) * (o.pageSize + 1);
  if (pages * slotBytes > maxBinding)
    throw Error("a pool of " + std::to_string(pages) + " pages takes " + mib(pages * slotBytes) +
                    " with their aprons, more than one storage binding of this device (" + mib(maxBinding) + ")",
                "--rmsm-pool", "at most " + std::to_string(maxBinding / slotBytes * pagePayload) + " bytes");
  l.poolPages = uint32_t(pages);
  l.poolBytes = pages * slotBytes;
  l.tableEntries = uint64_t(6) * ((uint64_t(1) << (2 * (l.maxLevel + 1))) - 1) / 3;
  l.tableBytes = l.tableEntries * 4;
  if (l.tableBytes > maxBinding)
    throw Error("page tables for " + std::to_string(o.maxResolution) + "² faces take " + mib(l.tableBytes) +
                    ", more than one storage binding of this device (" + mib(maxBinding) + ")",
                "--rmsm-max-res", "lower the maximum resolution or raise the page size");
  return l;
}

uint32_t coarsenToFit(std::vector<uint32_t>& keys, uint32_t levelLimit, uint32_t capacity) {
  CS_CHECK(capacity >= 6, "coarsenToFit: a capacity of " << capacity << " pages cannot hold the six roots");
  while (keys.size() > capacity && levelLimit > 0) {
    --levelLimit;
    for (uint32_t& k : keys) {
      const uint32_t level = keyLevel(k);
      if (level > levelLimit)
        k = (keyFace(k) << 28) | (levelLimit << 24) | ((k & 0xFFFFFFu) >> (2 * (level - levelLimit)));
    }
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  }
  return levelLimit;
}

uint32_t addBackupPages(std::vector<uint32_t>& keys, uint32_t faces, const std::vector<uint32_t>& resident,
                        uint32_t level) {
  const uint32_t side = 1u << level;
  std::vector<uint32_t> add;
  for (uint32_t f = 0; f < 6; ++f)
    if (faces & (1u << f))
      for (uint32_t y = 0; y < side; ++y)
        for (uint32_t x = 0; x < side; ++x) {
          const uint32_t k = pageKey(f, level, x, y);
          if (!std::binary_search(resident.begin(), resident.end(), k) &&
              !std::binary_search(keys.begin(), keys.end(), k))
            add.push_back(k);
        }
  if (add.empty()) return 0;
  std::sort(add.begin(), add.end());
  const size_t mid = keys.size();
  keys.insert(keys.end(), add.begin(), add.end());
  std::inplace_merge(keys.begin(), keys.begin() + long(mid), keys.end());
  return uint32_t(add.size());
}

std::vector<Superpage> binSuperpages(const std::vector<uint32_t>& keys, uint32_t log2Page, uint32_t superpageSize,
                                     float minOccupancy) {
  std::vector<Superpage> out;
  const uint32_t page = 1u << log2Page;
  const uint32_t top = log2u(superpageSize) - log2Page;  // a superpage is 2^top pages a side
  for (uint32_t i = 1; i < keys.size(); ++i)
    CS_CHECK(keys[i - 1] < keys[i], "binSuperpages: keys are not sorted and unique at " << i);
  // Pages [first, last) share the Morton prefix of an aligned square of 2^k pages a side (Z-order keeps
  // them consecutive). Emit their bounding box, or split the square in four while the box is sparse.
  auto bin = [&](auto&& self, uint32_t first, uint32_t last, uint32_t k) -> void {
    uint32_t minX = UINT32_MAX, minY = UINT32_MAX, maxX = 0, maxY = 0;
    for (uint32_t i = first; i < last; ++i) {
      const uint32_t px = keyPageX(keys[i]), py = keyPageY(keys[i]);
      minX = std::min(minX, px), maxX = std::max(maxX, px);
      minY = std::min(minY, py), maxY = std::max(maxY, py);
    }
    const double box = double(maxX - minX + 1) * double(maxY - minY + 1);
    if (k == 0 || double(last - first) >= minOccupancy * box) {
      Superpage sp;
      sp.face = keyFace(keys[first]);
      sp.level = keyLevel(keys[first]);
      sp.x0 = minX * page;
      sp.y0 = minY * page;
      sp.w = (maxX - minX + 1) * page + 1;  // + the apron of the last column of pages
      sp.h = (maxY - minY + 1) * page + 1;
      sp.first = first;
      sp.count = last - first;
      out.push_back(sp);
      return;
    }
    const uint32_t shift = 2 * (k - 1);  // Morton bits below the child squares
    for (uint32_t i = first; i < last;) {
      uint32_t j = i + 1;
      while (j < last && (keys[j] >> shift) == (keys[i] >> shift)) ++j;
      self(self, i, j, k - 1);
      i = j;
    }
  };
  for (uint32_t i = 0; i < keys.size();) {
    uint32_t j = i + 1;  // the keys of one superpage: same face, level and Morton prefix above `top`
    while (j < keys.size() && (keys[j] >> (2 * top)) == (keys[i] >> (2 * top))) ++j;
    bin(bin, i, j, top);
    i = j;
  }
  return out;
}

uint32_t tableIndexOf(uint32_t key, uint32_t maxLevel) {
  return tableIndex(keyFace(key), keyLevel(key), keyPageX(key), keyPageY(key), maxLevel);
}

}  // namespace sm

// ---- the method --------------------------------------------------------------------------------------

namespace {

// Stage times in order of first appearance; a name seen again (a flushed cache's second analysis) adds up.
struct Stages {
  std::vector<StageTime> list;
  void add(const std::string& name, double ms) {
    for (auto& s : list)
      if (s.name == name) {
        s.ms += ms;
        return;
      }
    // Pages, their tables and the superpage passes are RMSM's shadow structure, rebuilt every frame (and
    // the uploaded triangles when the geometry changes); the lookup answers the samples.
    static const char* kRebuild[] = {"upload", "allocate", "page_tables", "superpages", "pages_and_lookup"};
    StageKind kind = name == "lookup" ? StageKind::Lookup : StageKind::PerFrame;
    for (const char* r : kRebuild)
      if (name == r) kind = StageKind::Rebuild;
    list.push_back({name, ms, kind});
  }
};

struct Analysis {
  uint32_t counters[SM_COUNT_WORDS] = {};
  std::vector<uint32_t> unique;  // sorted unique page keys
};

// What the host decides between the analysis and the render (steps 9-10): the pages to render, after the
// fallback to a coarser limit where they would not fit, and their superpages.
struct PagePlan {
  std::vector<uint32_t> pages;   // sorted page keys to render this frame
  uint32_t backupPages = 0;      // of them, added by the sparse analysis's backup level
  uint32_t frameLimit = 0;       // the finest level rendered (the fallback lowers it)
  uint32_t firstSlot = 0;        // the pool slot of the first new page (cached mode: after the resident ones)
  std::vector<sm::Superpage> superpages;
  uint32_t squares = 0;          // aligned superpages touched: the paper's superpage count (Fig. 11)
};

}  // namespace

struct Rmsm::State {
  vk::Context& ctx;
  RmsmOptions opt;
  sm::RmsmLayout layout;
  sm::DepthPass pass;
  vk::Timer timer;
  vk::Kernel requests, prune, unique, tables, lookup;
  vk::Buffer tableBuf, pool, counters, updates;  // persistent across frames
  vk::Buffer windowBuf;                          // the faces' windows (fitWindows), vec4 per face
  std::array<glm::vec4, 6> windows;
  // Per G-buffer size.
  uint32_t width = 0, height = 0;
  vk::Buffer requestBuf, flags, compacted, uniqueBuf, lod, visibility;
  std::unique_ptr<sort::Compact> compact;
  std::unique_ptr<sort::RadixSort> sorter;
  sort::IndirectGroups groups;
  vk::Readback readback;
  // Residency: the key of the page in each pool slot (slots 0..resident.size()-1 are taken).
  std::vector<uint32_t> resident;
  uint32_t cacheLimit = 0;       // cached mode: finest level of the resident pages (the fallback lowers it)
  bool cacheValid = false;
  glm::vec3 cacheLight{0};
  uint64_t cacheFlushes = 0;
  Analysis last;                 // the last frame's analysis, for RmsmInspector

  State(vk::Context& c, const RmsmOptions& o)
      : ctx(c), opt(o), layout(sm::rmsmLayout(o, c.maxStorageBufferRange())), pass(c, o.cull), timer(vk::createTimer(c, 64)),
        groups(c), readback(c) {
    CS_CHECK(o.constantBias >= 0 && o.slopeBias >= 0 && o.maxSlope >= 0, "rmsm biases must be >= 0");
    const uint32_t push = sizeof(sm::RmsmPush);
    requests = vk::createKernel(c, "rmsm_requests", spv_rmsm_requests_comp, 7, push);
    prune = vk::createKernel(c, "rmsm_prune", spv_rmsm_prune_comp, 3, push);
    unique = vk::createKernel(c, "rmsm_unique", spv_rmsm_unique_comp, 3, push);
    tables = vk::createKernel(c, "rmsm_tables", spv_rmsm_tables_comp, 2, push);
    lookup = vk::createKernel(c, "rmsm_lookup", spv_rmsm_lookup_comp, 8, push);
    windows.fill(glm::vec4(0, 0, 1, 0));
    windowBuf = vk::createBuffer(c, sizeof(windows), vk::Memory::HostVisible);
    vk::upload(c, windowBuf, windows.data(), sizeof(windows));
    tableBuf = vk::createBuffer(c, layout.tableBytes);
    pool = vk::createBuffer(c, layout.poolBytes);
    counters = vk::createBuffer(c, SM_COUNT_WORDS * 4, vk::Memory::Device, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
    // Written by the host every frame, read once by the tables kernel: host visible on every device, so
    // the update costs no staged copy (a submission and a wait) where device memory is not host visible.
    updates = vk::createBuffer(c, uint64_t(2) * layout.poolPages * 8, vk::Memory::HostVisible);
    vk::Commands cmd(c);
    cmd.fill(tableBuf, 0);
    cmd.fill(pool, 0);
    cmd.barrier();
    cmd.submit();
    cacheLimit = layout.maxLevel;
  }

  uint64_t pixelBytes() const {
    return requestBuf.size + flags.size + compacted.size + uniqueBuf.size + lod.size + visibility.size +
           (compact ? compact->bytesAllocated() : 0) + (sorter ? sorter->bytesAllocated() : 0);
  }
  uint64_t bytesAllocated() const {
    return pass.bytesAllocated() + tableBuf.size + pool.size + counters.size + updates.size + pixelBytes() +
           readback.bytesAllocated();
  }

  void ensurePixels(uint32_t w, uint32_t h) {
    if (w == width && h == height && requestBuf) return;
    const uint64_t pixels = uint64_t(w) * h;
    CS_CHECK(pixels * 2 < (1u << 30), "rmsm: " << w << "x" << h << " is too many pixels");
    sort::checkBinding(ctx, 2 * pixels, 4, "rmsm page requests");
    compact.reset();
    sorter.reset();
    requestBuf = vk::createBuffer(ctx, 8 * pixels);
    flags = vk::createBuffer(ctx, 8 * pixels);
    compacted = vk::createBuffer(ctx, 8 * pixels);
    // The unique pages go to the host after the analysis: host visible, so that reading them is a copy
    // out of the mapping and not a staged copy of its own.
    uniqueBuf = vk::createBuffer(ctx, 8 * pixels, vk::Memory::HostVisible);
    lod = vk::createBuffer(ctx, 4 * pixels);
    visibility = vk::createBuffer(ctx, 4 * pixels);
    compact = std::make_unique<sort::Compact>(ctx, uint32_t(2 * pixels));
    sorter = std::make_unique<sort::RadixSort>(ctx, uint32_t(2 * pixels));
    width = w;
    height = h;
  }

  sm::RmsmPush push(glm::vec3 light, float eps, uint32_t levelLimit) const {
    sm::RmsmPush p{};
    p.light = glm::vec4(light, 1.0f);
    p.width = width;
    p.height = height;
    p.log2Page = layout.log2Page;
    p.maxLevel = layout.maxLevel;
    p.levelLimit = levelLimit;
    p.constantBias = opt.constantBias * eps;
    p.slopeBias = opt.slopeBias;
    p.maxSlope = opt.maxSlope;
    p.minDistance = 2.0f * eps;
    p.lodBias = opt.lodBias;
    p.planeBias = opt.planeBias ? 1u : 0u;
    p.analysisStep = opt.analysisStep;
    return p;
  }

  // Steps 1-8 of Algorithm 2 in one submission: requests -> prune -> compact -> sort -> uniquify ->
  // compact, every count on the GPU (the sort and the compactions take the pruned count as a device
  // count bounded by two requests a pixel; the uniquify pass is dispatched indirectly for it), the
  // counters read back with it; then the unique pages on the host (the allocation of steps 9-10 is the
  // host's), one more copy sized by the unique count.
  Analysis analyse(const DeviceGBuffer& g, glm::vec3 light, float eps, uint32_t levelLimit, bool filter,
                   bool clearTables, Stages& stages) {
    const uint32_t pixels = width * height, slots = 2 * pixels;
    sm::RmsmPush p = push(light, eps, levelLimit);
    p.cachedFilter = filter ? 1u : 0u;
    Analysis a;
    double submitMs = 0;
    timer.restart();
    {
      readback.clear();
      const uint32_t countersSlot = readback.add(counters, sizeof(a.counters));
      vk::Commands cmd(ctx, &timer);
      cmd.mark("start");  // first: every command of the submission falls in a stage
      if (clearTables) cmd.fill(tableBuf, 0);
      cmd.fill(counters, 0);
      cmd.barrier();
      vk::Grid grid = vk::gridFor(pixels, SM_PIXEL_THREADS, ctx.maxWorkgroups());
      cmd.dispatch(requests, {g.position, g.normal, tableBuf, lod, requestBuf, counters, windowBuf}, p, grid.x, grid.y);
      cmd.barrier();
      cmd.mark("requests");
      cmd.dispatch(prune, {requestBuf, flags, counters}, p, grid.x, grid.y);
      cmd.barrier();
      cmd.mark("prune");
      compact->record(cmd, flags, sort::Count(slots), compacted, sort::GpuWord(counters, SM_COUNT_PRUNED), requestBuf);
      cmd.mark("compact");
      const sort::Count pruned = sort::Count::device(sort::GpuWord(counters, SM_COUNT_PRUNED), slots);
      sorter->record(cmd, compacted, vk::BufferRange(), pruned, 31);
      groups.record(cmd, pruned, SM_LIST_THREADS, counters, SM_COUNT_UNIQUE_ARGS);
      cmd.barrier();
      cmd.mark("sort");
      p.count = slots;  // the kernel clamps the device count to it
      cmd.dispatchIndirect(unique, {compacted, flags, counters}, &p, sizeof(p), counters, SM_COUNT_UNIQUE_ARGS * 4);
      cmd.barrier();
      compact->record(cmd, flags, pruned, uniqueBuf, sort::GpuWord(counters, SM_COUNT_UNIQUE), compacted);
      cmd.mark("uniquify");
      readback.record(cmd);
      const auto ts = Clock::now();
      cmd.submit();
      submitMs = msSince(ts);  // recording excluded, as timestamps do
      readback.read(countersSlot, a.counters);
    }
    for (auto& [n, ms] : timer.intervalsOr("analysis", submitMs)) stages.add(n, ms);
    const auto t0 = Clock::now();
    const uint32_t uniqueCount = std::min(a.counters[SM_COUNT_UNIQUE], std::min(a.counters[SM_COUNT_PRUNED], slots));
    a.unique = uniqueCount ? vk::download<uint32_t>(ctx, uniqueBuf, uniqueCount) : std::vector<uint32_t>{};
    stages.add("readback", msSince(t0));
    return a;
  }

  // Uploads (table index, value) pairs — clears first, then writes — and records their scatter.
  void recordTableUpdates(vk::Commands& cmd, const std::vector<glm::uvec2>& clears,
                          const std::vector<glm::uvec2>& writes) {
    std::vector<glm::uvec2> all(clears);
    all.insert(all.end(), writes.begin(), writes.end());
    CS_CHECK(all.size() * 8 <= updates.size, "rmsm: " << all.size() << " page-table updates overflow their buffer");
    if (!all.empty()) vk::upload(ctx, updates, all.data(), all.size() * 8);
    sm::RmsmPush p = push(glm::vec3(0), 0, layout.maxLevel);
    uint32_t first = 0;
    for (uint32_t n : {uint32_t(clears.size()), uint32_t(writes.size())}) {
      if (n) {
        p.first = first;
        p.count = n;
        vk::Grid grid = vk::gridFor(n, SM_LIST_THREADS, ctx.maxWorkgroups());
        cmd.dispatch(tables, {updates, tableBuf}, p, grid.x, grid.y);
        cmd.barrier();
      }
      first += n;
    }
  }

  // Makes `keys` (sorted, unique, fitting the free slots) resident: table updates now recorded, slots
  // appended to `resident`. `evict`: drop every resident page first (its entries are cleared).
  // Each face fitted to what it can see of the scene (fitWindows), before anything asks for a page.
  void fitFaces(glm::vec3 light) {
    if (opt.fitFaces) {
      windows = sm::fitWindows(light, pass.boundsLo(), pass.boundsHi(), layout.pageSize, opt.maxResolution);
    } else {
      windows.fill(glm::vec4(0, 0, 1, 0));
    }
    vk::upload(ctx, windowBuf, windows.data(), sizeof(windows));
  }

  // Cached mode: the resident pages stay valid while the light and the geometry stay put. True when the
  // page tables must be cleared with the pages.
  bool flushCacheIfStale(bool geometryChanged, glm::vec3 light) {
    if (!opt.cached || (cacheValid && !geometryChanged && light == cacheLight)) return false;
    if (cacheValid) cacheFlushes++;
    resident.clear();
    cacheLimit = layout.maxLevel;
    return true;
  }

  // Steps 1-8; in cached mode, when the new pages do not fit beside the resident ones, the cache is
  // flushed and the frame analysed afresh (`limit` back to the finest level).
  Analysis analyseToFit(const DeviceGBuffer& g, glm::vec3 light, float eps, uint32_t& limit, bool flushTables,
                        Stages& stages) {
    Analysis a = analyse(g, light, eps, limit, opt.cached, flushTables, stages);
    if (opt.cached && !resident.empty() && resident.size() + a.unique.size() > layout.poolPages) {
      cacheFlushes++;
      resident.clear();
      cacheLimit = limit = layout.maxLevel;
      a = analyse(g, light, eps, limit, true, true, stages);
    }
    last = a;
    return a;
  }

  // Steps 9-10 on the host: the backup pages of a sparse analysis, the fallback to a coarser limit where
  // the pages would not fit the pool, and the superpage bins.
  PagePlan planPages(const Analysis& a, uint32_t limit) {
    PagePlan plan;
    plan.pages = a.unique;
    if (opt.analysisStep > 1) {
      // Cached mode: resident backup pages are not asked again.
      std::vector<uint32_t> residentSorted(opt.cached ? resident : std::vector<uint32_t>{});
      std::sort(residentSorted.begin(), residentSorted.end());
      plan.backupPages = sm::addBackupPages(plan.pages, a.counters[SM_COUNT_FACES], residentSorted,
                                            std::min(layout.backupLevel, limit));
    }
    const uint32_t freeSlots = layout.poolPages - (opt.cached ? uint32_t(resident.size()) : 0u);
    plan.frameLimit = sm::coarsenToFit(plan.pages, limit, freeSlots);
    if (opt.cached) cacheLimit = plan.frameLimit;
    plan.firstSlot = opt.cached ? uint32_t(resident.size()) : 0u;
    plan.superpages = sm::binSuperpages(plan.pages, layout.log2Page, layout.superpageSize, opt.minOccupancy);
    const uint32_t squareShift = 2 * (sm::log2u(layout.superpageSize) - layout.log2Page);
    for (size_t i = 0; i < plan.pages.size(); ++i)
      plan.squares += i == 0 || (plan.pages[i] >> squareShift) != (plan.pages[i - 1] >> squareShift);
    pass.ensureTargets(layout.superpageSize + 1, layout.pageSize + 1);
    return plan;
  }

  // Phase 2 in one submission: page tables, one geometry pass per superpage copied into the pool, the
  // lookup, the readback. Fills `mask`; returns the lookup's misses; the submission's wall ms to submitMs.
  uint32_t renderAndLookup(const DeviceGBuffer& g, glm::vec3 light, float eps, const PagePlan& plan,
                           std::vector<float>& mask, double& submitMs, double& maskMs) {
    const uint32_t page = layout.pageSize;
    const uint32_t pixels = g.width * g.height;
    uint32_t misses = 0;
    timer.restart();
    readback.clear();
    const uint32_t visibilitySlot = readback.add(visibility, uint64_t(pixels) * 4),
                   missesSlot = readback.add(counters, 4, SM_COUNT_MISSES * 4);
    vk::Commands cmd(ctx, &timer);
    cmd.mark("start");
    recordAllocation(cmd, plan.pages, !opt.cached);
    cmd.mark("page_tables");
    const uint32_t stride = (page + 1) * (page + 1);
    std::vector<VkBufferImageCopy> regions;
    for (const sm::Superpage& sp : plan.superpages) {
      // The level's texels over the whole face, and the superpage's first texel there (fitted faces).
      const glm::vec4 fw = windows[sp.face];
      const double faceRes = double(page) * double(1u << sp.level) * double(fw.z);
      pass.recordWindow(cmd, sp.face, faceRes, uint32_t(double(fw.x) * faceRes) + sp.x0,
                        uint32_t(double(fw.y) * faceRes) + sp.y0, sp.w, sp.h, light, eps);
      regions.clear();
      for (uint32_t i = sp.first; i < sp.first + sp.count; ++i) {
        VkBufferImageCopy r{};
        r.bufferOffset = VkDeviceSize(plan.firstSlot + i) * stride * 4;
        r.bufferRowLength = page + 1;
        r.bufferImageHeight = page + 1;
        r.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        r.imageOffset = {int32_t(sm::keyPageX(plan.pages[i]) * page - sp.x0),
                         int32_t(sm::keyPageY(plan.pages[i]) * page - sp.y0), 0};
        r.imageExtent = {page + 1, page + 1, 1};
        regions.push_back(r);
      }
      pass.recordCopy(cmd, regions, pool);
    }
    cmd.barrier();
    cmd.mark("superpages");
    sm::RmsmPush p = push(light, eps, plan.frameLimit);
    vk::Grid grid = vk::gridFor(pixels, SM_PIXEL_THREADS, ctx.maxWorkgroups());
    cmd.dispatch(lookup, {g.position, g.normal, lod, tableBuf, pool, visibility, counters, windowBuf}, p, grid.x, grid.y);
    cmd.barrier();
    cmd.mark("lookup");
    readback.record(cmd);
    const auto ts = Clock::now();
    cmd.submit();
    submitMs = msSince(ts);
    readback.read(missesSlot, std::span<uint32_t>(&misses, 1));
    const auto tm = Clock::now();
    mask.resize(pixels);
    if (pixels) readback.read(visibilitySlot, mask);
    maskMs = msSince(tm);
    return misses;
  }

  // The frame's counters for reports: requests, pages, superpages, the fallback, the cache, the biases.
  nlohmann::json frameStats(const Analysis& a, const PagePlan& plan, uint32_t limit, uint32_t misses, float eps,
                            uint64_t flushes) {
    const uint32_t page = layout.pageSize;
    std::vector<uint32_t> perLevel(layout.maxLevel + 1, 0);
    for (uint32_t k : resident) perLevel[sm::keyLevel(k)]++;
    nlohmann::json stats = {
        {"requests_before_pruning", a.counters[SM_COUNT_REQUESTS]},
        {"requests_after_pruning", a.counters[SM_COUNT_PRUNED]},
        {"unique_pages", a.counters[SM_COUNT_UNIQUE]},
        {"pages_rendered", plan.pages.size()},
        {"pages_resident", resident.size()},
        {"pages_per_level", perLevel},
        {"superpages", plan.superpages.size()},
        {"superpage_squares", plan.squares},
        {"page_size", page},
        {"superpage_size", layout.superpageSize},
        {"pool_pages", layout.poolPages},
        {"face_zoom", nlohmann::json::array({windows[0].z, windows[1].z, windows[2].z, windows[3].z, windows[4].z,
                                             windows[5].z})},
        {"pool_bytes", layout.poolBytes},
        {"page_table_bytes", layout.tableBytes},
        {"max_resolution", page << layout.maxLevel},
        {"effective_resolution", page << plan.frameLimit},
        {"fallback", plan.frameLimit < layout.maxLevel},
        {"fallback_levels", layout.maxLevel - plan.frameLimit},
        {"isolated_samples", a.counters[SM_COUNT_ISOLATED]},
        {"analysis_step", opt.analysisStep},
        {"backup_pages", plan.backupPages},
        {"backup_resolution", opt.analysisStep > 1 ? page << std::min(layout.backupLevel, limit) : 0u},
        {"lookup_misses", misses},
        {"cached", opt.cached},
        {"cache_flushes", flushes},
        {"triangles", pass.triangleCount()},
        {"geometry_passes", plan.superpages.size()},
        {"triangles_drawn", pass.takeTrianglesDrawn()},
        {"lod_bias", opt.lodBias},
        {"constant_bias", opt.constantBias * eps},
        {"slope_bias_texels", opt.slopeBias},
        {"plane_bias", opt.planeBias},
        {"epsilon", eps}};
    stats["stage_timing"] = ctx.timestampsTrusted()
                                ? "GPU timestamps per stage; readback and allocate on the host clock"
                                : "this device's timestamps are not trusted inside a submission: each submission's "
                                  "wall clock (analysis, pages_and_lookup), readback and allocate on the host clock";
    return stats;
  }

  void recordAllocation(vk::Commands& cmd, const std::vector<uint32_t>& keys, bool evict) {
    std::vector<glm::uvec2> clears, writes;
    if (evict) {
      for (uint32_t k : resident) clears.push_back({sm::tableIndexOf(k, layout.maxLevel), 0u});
      resident.clear();
    }
    CS_CHECK(resident.size() + keys.size() <= layout.poolPages,
             "rmsm: " << keys.size() << " new pages do not fit the " << layout.poolPages - resident.size()
                      << " free slots");
    for (uint32_t k : keys) {
      writes.push_back({sm::tableIndexOf(k, layout.maxLevel), uint32_t(resident.size()) + 1u});
      resident.push_back(k);
    }
    recordTableUpdates(cmd, clears, writes);
  }
};

Rmsm::Rmsm(vk::Context& ctx, const RmsmOptions& options) : s_(std::make_unique<State>(ctx, options)) {}
Rmsm::~Rmsm() = default;

const sm::RmsmLayout& Rmsm::layout() const { return s_->layout; }


// One frame, as named steps (paper 000, Algorithm 2): the geometry (uploaded when it changed), each face
// fitted to the scene, the cache kept or flushed, the analysis on the GPU (steps 1-8, one submission), the
// page plan on the host (9-10), then page tables, superpage passes and the lookup in one submission.
MethodOutput Rmsm::run(const FrameInput& frame) {
  State& s = *s_;
  CS_CHECK(frame.scene && frame.device, "rmsm: the frame needs a scene and the G-buffer on the GPU");
  CS_CHECK(frame.vk == nullptr || frame.vk == &s.ctx, "rmsm: the frame's Vulkan context is not this method's");
  const DeviceGBuffer& g = *frame.device;
  const float eps = frame.epsilon > 0 ? frame.epsilon : EpsilonPolicy::forScene(*frame.scene).eps;
  Stages stages;
  const auto t0 = Clock::now();

  const double uploadMs = s.pass.setGeometry(frame);
  s.pass.takeTrianglesDrawn();
  if (uploadMs > 0) stages.add("upload", uploadMs);
  s.ensurePixels(g.width, g.height);
  s.fitFaces(frame.light);
  const uint64_t flushesBefore = s.cacheFlushes;
  const bool flushTables = s.flushCacheIfStale(uploadMs > 0, frame.light);

  const auto tAnalysis = Clock::now();
  uint32_t limit = s.opt.cached ? s.cacheLimit : s.layout.maxLevel;
  const Analysis a = s.analyseToFit(g, frame.light, eps, limit, flushTables, stages);
  const double analysisWallMs = msSince(tAnalysis);

  const auto tAlloc = Clock::now();
  const PagePlan plan = s.planPages(a, limit);
  stages.add("allocate", msSince(tAlloc));

  const auto tRender = Clock::now();
  MethodOutput out;
  double submitMs = 0, maskMs = 0;  // maskMs: the mask's copy into out.visibility, not in totalMs
  const uint32_t misses = s.renderAndLookup(g, frame.light, eps, plan, out.visibility, submitMs, maskMs);
  for (auto& [n, ms] : s.timer.intervalsOr("pages_and_lookup", submitMs)) stages.add(n, ms);
  if (s.opt.cached) {
    s.cacheValid = true;
    s.cacheLight = frame.light;
  }
  const double renderWallMs = msSince(tRender) - maskMs;
  out.totalMs = msSince(t0) - maskMs;

  double gpuMs = 0;
  for (auto& st : stages.list) gpuMs += st.ms;
  out.stages = std::move(stages.list);
  const uint32_t page = s.layout.pageSize;
  out.work = std::to_string(plan.pages.size()) + " pages" +
             (plan.frameLimit < s.layout.maxLevel ? " (fallback to " + std::to_string(page << plan.frameLimit) + "²)" : "");
  out.bytesAllocated = s.bytesAllocated();
  out.peakBytes = out.bytesAllocated;
  out.stats = s.frameStats(a, plan, limit, misses, eps, s.cacheFlushes - flushesBefore);
  out.stats["gpu_and_host_ms"] = gpuMs;
  out.stats["analysis_wall_ms"] = analysisWallMs;  // steps 1-8: submits, waits and readbacks included
  out.stats["render_wall_ms"] = renderWallMs;      // page tables, superpages and lookup: recording included
  out.stats["readback_ms"] = maskMs;               // the mask's copy to the host (not in totalMs)
  return out;
}

// ---- test hooks ----------------------------------------------------------------------------------------

// ---- RmsmInspector (tests) -------------------------------------------------------------------------

std::vector<uint32_t> RmsmInspector::requests() const {
  const auto& s_ = rmsm_.s_;
  return vk::download<uint32_t>(s_->ctx, s_->requestBuf, size_t(2) * s_->width * s_->height);
}

std::vector<uint32_t> RmsmInspector::compacted() const {
  const auto& s_ = rmsm_.s_;
  return vk::download<uint32_t>(s_->ctx, s_->compacted, s_->last.counters[SM_COUNT_PRUNED]);
}

std::vector<uint32_t> RmsmInspector::uniquePages() const { return rmsm_.s_->last.unique; }

std::vector<uint32_t> RmsmInspector::residentPages() const { return rmsm_.s_->resident; }

std::vector<float> RmsmInspector::pool() const {
  const auto& s_ = rmsm_.s_;
  return vk::download<float>(s_->ctx, s_->pool, size_t(s_->layout.poolPages) * (s_->layout.pageSize + 1) *
                                                    (s_->layout.pageSize + 1));
}

void RmsmInspector::installPages(const std::vector<uint32_t>& keys, float (*texel)(uint32_t, uint32_t, uint32_t)) {
  Rmsm::State& s = *rmsm_.s_;
  std::vector<uint32_t> sorted(keys);
  std::sort(sorted.begin(), sorted.end());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  {
    vk::Commands cmd(s.ctx);
    s.recordAllocation(cmd, sorted, true);
    cmd.submit();
  }
  const uint32_t p = s.layout.pageSize, side = p + 1;
  std::vector<float> data(size_t(s.layout.poolPages) * side * side, 0.0f);
  for (size_t slot = 0; slot < s.resident.size(); ++slot) {
    const uint32_t k = s.resident[slot];
    for (uint32_t y = 0; y < side; ++y)
      for (uint32_t x = 0; x < side; ++x)
        data[slot * side * side + y * side + x] = texel(k, sm::keyPageX(k) * p + x, sm::keyPageY(k) * p + y);
  }
  vk::upload(s.ctx, s.pool, data.data(), data.size() * 4);
}

std::vector<glm::uvec4> RmsmInspector::probe(const vk::Kernel& kernel, const std::vector<Probe>& probes) {
  Rmsm::State& s = *rmsm_.s_;
  std::vector<glm::uvec4> queries;
  for (const Probe& q : probes) {
    uint32_t sb, tb;
    std::memcpy(&sb, &q.s, 4);
    std::memcpy(&tb, &q.t, 4);
    queries.push_back({q.face, q.level, sb, tb});
  }
  vk::Buffer in = vk::createBuffer(s.ctx, queries.size() * 16), out = vk::createBuffer(s.ctx, queries.size() * 16);
  if (!queries.empty()) vk::upload(s.ctx, in, queries.data(), queries.size() * 16);
  sm::RmsmPush p = s.push(glm::vec3(0), 0, s.layout.maxLevel);
  p.count = uint32_t(queries.size());
  vk::Commands cmd(s.ctx);
  vk::Grid grid = vk::gridFor(queries.size(), SM_LIST_THREADS, s.ctx.maxWorkgroups());
  cmd.dispatch(kernel, {in, s.tableBuf, s.pool, out, s.windowBuf}, p, grid.x, grid.y);
  cmd.barrier();
  cmd.submit();
  return vk::download<glm::uvec4>(s.ctx, out, queries.size());
}

std::unique_ptr<ShadowMethod> makeRmsm(vk::Context& ctx, const RmsmOptions& options) {
  return std::make_unique<Rmsm>(ctx, options);
}

}  // namespace cs
