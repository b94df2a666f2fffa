// Adaptive shadow maps as a ShadowMethod: see asm.h.
#include "shadowmaps/asm.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "core/error.h"
#include "method/epsilon.h"
#include "raster/raster.h"
#include "shadowmaps/asm_frame.comp.h"
#include "shadowmaps/asm_shared.h"
#include "shadowmaps/depth_pass.h"
#include "vk/context.h"

namespace cs {

uint32_t asmMaxDepth(uint32_t nodeResolution, uint32_t cells) {
  uint32_t depth = 0;
  uint64_t res = nodeResolution, across = 1;
  while (depth < ASM_MAX_DEPTH && res * cells <= (1ull << 21) && across * cells <= 4096) {
    res *= cells;
    across *= cells;
    ++depth;
  }
  return depth;
}

uint64_t asmSlotBytes(uint32_t nodeResolution, bool idTest) {
  return uint64_t(sm::asmSlotStride(nodeResolution)) * 4 * (idTest ? 2 : 1);
}

// ---- the host's tree ----------------------------------------------------------------------------------

AsmTree::AsmTree(uint32_t slots, uint32_t cells, uint32_t maxDepth) : nodes_(slots), cells_(cells), maxDepth_(maxDepth) {
  CS_CHECK(slots >= 7 && cells >= 2, "AsmTree: six roots and one child at least, two cells a side");
  reset();
}

void AsmTree::reset() {
  for (uint32_t s = 0; s < nodes_.size(); ++s) {
    Node& n = nodes_[s];
    n = Node{};
    n.key = s < 6 ? sm::pageKey(s, 0, 0, 0) : SM_INVALID_KEY;
    n.parent = s;
    n.benefit = s < 6 ? UINT64_MAX : 0;
  }
}

void AsmTree::markUsed(const std::vector<uint32_t>& used, uint64_t frame) {
  for (size_t s = 0; s < std::min(used.size(), nodes_.size()); ++s)
    if (used[s] && nodes_[s].key != SM_INVALID_KEY) nodes_[s].lastUsed = std::max(nodes_[s].lastUsed, frame);
}

uint32_t AsmTree::childKey(uint32_t slot, uint32_t cell) const {
  const uint32_t key = nodes_[slot].key;
  return sm::pageKey(sm::keyFace(key), sm::keyLevel(key) + 1, sm::keyPageX(key) * cells_ + cell % cells_,
                     sm::keyPageY(key) * cells_ + cell / cells_);
}

bool AsmTree::residentKey(uint32_t key) const {
  return std::any_of(nodes_.begin(), nodes_.end(), [&](const Node& n) { return n.key == key; });
}

void AsmTree::drop(uint32_t slot) {
  Node& n = nodes_[slot];
  CS_CHECK(slot >= 6 && n.key != SM_INVALID_KEY && n.children == 0, "AsmTree: only resident leaves are dropped");
  nodes_[n.parent].children--;
  n = Node{};
  n.key = SM_INVALID_KEY;
  n.parent = slot;
}

AsmTree::Refinement AsmTree::refine(std::vector<Candidate> candidates, uint64_t frame, uint32_t maxNew) {
  Refinement r;
  // The paper's cost is the same for every cell here (every node renders N² texels), so benefit / cost
  // orders as the benefit; ties by slot and cell keep the order deterministic.
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return a.benefit != b.benefit ? a.benefit > b.benefit : a.slot != b.slot ? a.slot < b.slot : a.cell < b.cell;
  });
  for (const Candidate& c : candidates) {
    if (r.created.size() >= maxNew) break;
    if (c.slot >= nodes_.size() || nodes_[c.slot].key == SM_INVALID_KEY || c.cell >= cells_ * cells_ ||
        sm::keyLevel(nodes_[c.slot].key) >= maxDepth_ || c.benefit == 0)
      continue;
    const uint32_t key = childKey(c.slot, c.cell);
    if (residentKey(key)) continue;
    // A free slot; else the least recently used leaf not used in the last frame; else the used leaf of
    // least benefit, if this cell's is greater. Never the candidate's own node, never this frame's.
    uint32_t slot = UINT32_MAX;
    for (uint32_t s = 6; s < nodes_.size() && slot == UINT32_MAX; ++s)
      if (nodes_[s].key == SM_INVALID_KEY) slot = s;
    bool replacing = false;
    if (slot == UINT32_MAX) {
      uint32_t lru = UINT32_MAX, weakest = UINT32_MAX;
      for (uint32_t s = 6; s < nodes_.size(); ++s) {
        const Node& n = nodes_[s];
        if (n.children || s == c.slot || n.lastUsed >= frame) continue;
        if (n.lastUsed + 1 < frame) {
          if (lru == UINT32_MAX || n.lastUsed < nodes_[lru].lastUsed) lru = s;
        } else if (weakest == UINT32_MAX || n.benefit < nodes_[weakest].benefit) {
          weakest = s;
        }
      }
      if (lru != UINT32_MAX) {
        slot = lru;
        ++r.evicted;
      } else if (weakest != UINT32_MAX && nodes_[weakest].benefit < c.benefit) {
        slot = weakest;
        replacing = true;
      } else {
        ++r.refused;
        continue;
      }
      drop(slot);
      if (replacing) ++r.replaced;
    }
    Node& n = nodes_[slot];
    n.key = key;
    n.parent = c.slot;
    n.children = 0;
    n.lastUsed = frame;
    n.benefit = c.benefit;
    nodes_[c.slot].children++;
    r.created.push_back({key, slot});
  }
  return r;
}

std::vector<uint32_t> AsmTree::hashTable(uint32_t capacity) const {
  CS_CHECK(capacity && (capacity & (capacity - 1)) == 0 && capacity > resident(), "AsmTree: hash capacity " << capacity);
  std::vector<uint32_t> table(2 * size_t(capacity), SM_INVALID_KEY);
  for (uint32_t s = 0; s < nodes_.size(); ++s) {
    if (nodes_[s].key == SM_INVALID_KEY) continue;
    uint32_t h = sm::asmHash(nodes_[s].key, capacity);
    while (table[2 * h] != SM_INVALID_KEY) h = (h + 1) & (capacity - 1);
    table[2 * h] = nodes_[s].key;
    table[2 * h + 1] = s;
  }
  return table;
}

uint32_t AsmTree::resident() const {
  return uint32_t(std::count_if(nodes_.begin(), nodes_.end(), [](const Node& n) { return n.key != SM_INVALID_KEY; }));
}

uint32_t AsmTree::deepest() const {
  uint32_t d = 0;
  for (const Node& n : nodes_)
    if (n.key != SM_INVALID_KEY) d = std::max(d, sm::keyLevel(n.key));
  return d;
}

// ---- the method ---------------------------------------------------------------------------------------

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

uint32_t slotsFor(const AsmOptions& o) {
  return uint32_t(std::min<uint64_t>(o.memoryBytes / asmSlotBytes(o.nodeResolution, o.idTest), 1u << 20));
}

class AdaptiveShadowMap : public ShadowMethod {
 public:
  AdaptiveShadowMap(vk::Context& ctx, const AsmOptions& options)
      : ctx_(ctx), o_(options), pass_(ctx, options.cull, options.idTest), tree_(7, 2, 1), timer_(vk::createTimer(ctx, 16)),
        readback_(ctx) {
    const uint32_t n = o_.nodeResolution, c = o_.cells;
    if (n < 16 || n > 4096)
      throw Error("ASM node resolution " + std::to_string(n) + " is outside [16, 4096]", "--asm-node-res",
                  "use e.g. 256 or 512");
    if (c < 2 || c > 16 || n % c)
      throw Error("ASM: " + std::to_string(c) + " cells a side for nodes of " + std::to_string(n) + "²", "--asm-cells",
                  "use 2 to 16 cells dividing the node resolution");
    const uint64_t slotBytes = asmSlotBytes(n, o_.idTest);
    const uint32_t slots = slotsFor(o_);
    if (slots < 7)
      throw Error("an ASM pool of " + std::to_string(o_.memoryBytes >> 10) + " KiB holds " + std::to_string(slots) +
                      " nodes of " + std::to_string(n) + "²; the six roots and one child need " +
                      std::to_string((7 * slotBytes + 1023) >> 10) + " KiB",
                  "--asm-memory", "raise the memory or lower --asm-node-res");
    const uint64_t poolBytes = uint64_t(slots) * sm::asmSlotStride(n) * 4;  // one of the pools
    if (poolBytes > ctx.maxStorageBufferRange())
      throw Error("an ASM pool of " + std::to_string(poolBytes >> 20) +
                      " MiB exceeds one storage binding of this device (" +
                      std::to_string(ctx.maxStorageBufferRange() >> 20) + " MiB)",
                  "--asm-memory", "lower the memory");
    const uint32_t deepest = asmMaxDepth(n, c);
    if (o_.maxDepth == 0 || o_.maxDepth > deepest) o_.maxDepth = deepest;
    CS_CHECK(o_.analysisStep >= 1 && o_.analysisStep <= 64, "ASM analysis step " << o_.analysisStep);
    CS_CHECK(o_.budgetMs >= 0, "ASM budget " << o_.budgetMs << " ms");
    tree_ = AsmTree(slots, c, o_.maxDepth);
    capacity_ = 16;
    while (capacity_ < 2 * slots) capacity_ *= 2;
    kernel_ = vk::createKernel(ctx, "asm_frame", spv_asm_frame_comp, 11, sizeof(sm::AsmPush));
    windowBuf_ = vk::createBuffer(ctx, sizeof(windows_), vk::Memory::HostVisible);
    pool_ = vk::createBuffer(ctx, poolBytes);
    idPool_ = vk::createBuffer(ctx, o_.idTest ? poolBytes : 16);  // unread without the ID test
    noTriangles_ = vk::createBuffer(ctx, 16);
    hash_ = vk::createBuffer(ctx, uint64_t(capacity_) * 8, vk::Memory::HostVisible);
    benefit_ = vk::createBuffer(ctx, uint64_t(slots) * c * c * 4);
    used_ = vk::createBuffer(ctx, uint64_t(slots) * 4);
    counters_ = vk::createBuffer(ctx, 16);
  }

  std::string name() const override { return "asm"; }

  MethodOutput run(const FrameInput& frame) override {
    CS_CHECK(frame.scene && frame.device, "asm: the frame needs a scene and the G-buffer on the GPU");
    CS_CHECK(frame.vk == nullptr || frame.vk == &ctx_, "asm: the frame's Vulkan context is not this method's");
    if (!frame.camera)
      throw Error("asm: the frame carries no camera, and the analysis compares texels with the view's pixels",
                  "asm", "run it through the harness (render, compare)");
    const DeviceGBuffer& g = *frame.device;
    if (o_.idTest && !g.triangle)
      throw Error("asm: the ID + depth test needs the triangle under each pixel, and this frame's G-buffer has none",
                  "--asm-id-test", "render the frame on a device with the geometryShader feature, or leave the test off");
    const vk::Buffer& gTriangle = o_.idTest ? g.triangle : noTriangles_;
    const uint32_t pixels = g.width * g.height, n = o_.nodeResolution, c = o_.cells;
    const float eps = frame.epsilon > 0 ? frame.epsilon : EpsilonPolicy::forScene(*frame.scene).eps;
    MethodOutput out;
    const auto t0 = Clock::now();

    const double uploadMs = pass_.setGeometry(frame);
    pass_.takeTrianglesDrawn();
    pass_.ensureTargets(n + 1, n / 2 + 1);
    if (uploadMs > 0 || frame.light != light_ || !rootsRendered_) {  // the tree no longer holds this scene
      tree_.reset();
      light_ = frame.light;
      fitFaces(frame.light);
      frame_ = 0;
      rootsRendered_ = false;
      ++flushes_;
    }
    ++frame_;
    if (visibility_.size < uint64_t(pixels) * 4) {
      visibility_.reset();
      visibility_ = vk::createBuffer(ctx_, std::max<uint64_t>(uint64_t(pixels) * 4, 16));
    }
    if (uploadMs > 0) out.stages.push_back({"upload", uploadMs, StageKind::Rebuild});

    // The roots (and, at the very first frame, the cost model's calibration).
    if (!rootsRendered_) {
      std::vector<std::pair<uint32_t, uint32_t>> roots;
      for (uint32_t f = 0; f < 6; ++f) roots.push_back({sm::pageKey(f, 0, 0, 0), f});
      if (costA_ < 0) calibrate(frame.light, eps);
      const auto tr = Clock::now();
      {
        vk::Commands cmd(ctx_);
        recordNodes(cmd, roots, frame.light, eps);
        cmd.submit();
      }
      out.stages.push_back({"roots", msSince(tr), StageKind::Rebuild});
      rootsRendered_ = true;
    }

    sm::AsmPush push{};
    push.light = glm::vec4(frame.light, 1.0f);
    // The pixel's angle, shrunk by the LOD bias: texels must then be 2^lodBias times finer than pixels.
    push.eye = glm::vec4(frame.camera->eye, 2.0f * std::tan(0.5f * frame.camera->yfov) / float(std::max(g.height, 1u)) *
                                                std::exp2(-o_.lodBias));
    push.width = g.width;
    push.height = g.height;
    push.nodeRes = n;
    push.cells = c;
    push.maxDepth = o_.maxDepth;
    push.capacity = capacity_;
    push.analysisStep = o_.analysisStep;
    push.constantBias = o_.constantBias * eps;
    push.slopeBias = o_.slopeBias;
    push.maxSlope = o_.maxSlope;
    push.minDistance = 2.0f * eps;
    push.pcf = o_.pcf ? 1u : 0u;
    push.planeBias = o_.planeBias ? 1u : 0u;
    push.idTest = o_.idTest ? 1u : 0u;
    const vk::Grid grid = vk::gridFor(std::max(pixels, 1u), ASM_THREADS, ctx_.maxWorkgroups());
    const uint32_t slots = uint32_t(tree_.nodes().size());

    // 1. Analysis on the current tree.
    writeHash();
    std::vector<uint32_t> benefit(size_t(slots) * c * c), used(slots);
    uint32_t counters[4] = {};
    const auto ta = Clock::now();
    {
      readback_.clear();
      // The host vectors' sizes, not the buffers' (a buffer may be allocated larger than asked).
      const uint32_t bSlot = readback_.add(benefit_, benefit.size() * 4), uSlot = readback_.add(used_, used.size() * 4),
                     cSlot = readback_.add(counters_, 16);
      vk::Commands cmd(ctx_);
      cmd.fill(benefit_, 0);
      cmd.fill(used_, 0);
      cmd.fill(counters_, 0);
      cmd.barrier();
      push.mode = ASM_MODE_ANALYSE;
      if (pixels)
        cmd.dispatch(kernel_, {g.position, g.normal, pool_, hash_, benefit_, used_, visibility_, counters_, idPool_, gTriangle,
                      windowBuf_},
                     push, grid.x, grid.y);
      cmd.barrier();
      readback_.record(cmd);
      cmd.submit();
      readback_.read(bSlot, benefit);
      readback_.read(uSlot, used);
      readback_.read(cSlot, counters);
    }
    out.stages.push_back({"analysis", msSince(ta), StageKind::Rebuild});

    // 2. Refinement on the host.
    const auto tf = Clock::now();
    tree_.markUsed(used, frame_);
    std::vector<AsmTree::Candidate> candidates;
    for (uint32_t s = 0; s < slots; ++s)
      for (uint32_t k = 0; k < c * c; ++k)
        if (benefit[size_t(s) * c * c + k]) candidates.push_back({s, k, benefit[size_t(s) * c * c + k]});
    const double cost = costA_ * double(n) * n + costB_;
    const uint32_t maxNew = o_.budgetMs > 0 ? uint32_t(std::clamp(std::floor(o_.budgetMs / std::max(cost, 1e-6)), 1.0, 1e6))
                                            : UINT32_MAX;
    const AsmTree::Refinement ref = tree_.refine(candidates, frame_, maxNew);
    writeHash();
    out.stages.push_back({"refine", msSince(tf), StageKind::Rebuild});

    // 3. The new nodes, then the lookup on the refined tree.
    std::vector<float> visibility;
    double submitMs = 0, maskMs = 0;  // maskMs: the mask's copy to the host, not in totalMs
    {
      timer_.restart();
      readback_.clear();
      const uint32_t vSlot = readback_.add(visibility_, uint64_t(pixels) * 4), uSlot = readback_.add(used_, used.size() * 4);
      vk::Commands cmd(ctx_, &timer_);
      cmd.mark("start");
      recordNodes(cmd, ref.created, frame.light, eps);
      cmd.fill(used_, 0);
      cmd.barrier();
      cmd.mark("nodes");
      push.mode = ASM_MODE_LOOKUP;
      if (pixels)
        cmd.dispatch(kernel_, {g.position, g.normal, pool_, hash_, benefit_, used_, visibility_, counters_, idPool_, gTriangle,
                      windowBuf_},
                     push, grid.x, grid.y);
      cmd.barrier();
      cmd.mark("lookup");
      readback_.record(cmd);
      const auto ts = Clock::now();
      cmd.submit();
      submitMs = msSince(ts);
      readback_.read(uSlot, used);
      const auto tm = Clock::now();
      visibility.resize(pixels);
      if (pixels) readback_.read(vSlot, visibility);
      maskMs = msSince(tm);
    }
    // Where timestamps cannot split the submission, it is one stage (vk::Timer::intervalsOr).
    for (auto& [stage, ms] : timer_.intervalsOr("nodes_and_lookup", submitMs))
      out.stages.push_back({stage, ms, stage == "lookup" ? StageKind::Lookup : StageKind::Rebuild});
    tree_.markUsed(used, frame_);
    created_ += ref.created.size();
    out.visibility = std::move(visibility);
    out.totalMs = msSince(t0) - maskMs;

    const uint32_t deepest = tree_.deepest();
    const uint64_t slotBytes = asmSlotBytes(n, o_.idTest);
    out.bytesAllocated = pass_.bytesAllocated() + pool_.size + idPool_.size + noTriangles_.size + hash_.size + benefit_.size + used_.size + counters_.size +
                         visibility_.size + readback_.bytesAllocated();
    out.peakBytes = out.bytesAllocated;
    out.work = std::to_string(tree_.resident()) + " nodes, depth " + std::to_string(deepest);
    out.stats = {{"frame", frame_},
                 {"readback_ms", maskMs},
                 {"node_resolution", n},
                 {"cells", c},
                 {"max_depth", o_.maxDepth},
                 {"deepest", deepest},
                 {"face_zoom", nlohmann::json::array({windows_[0].z, windows_[1].z, windows_[2].z, windows_[3].z,
                                                      windows_[4].z, windows_[5].z})},
                 {"effective_resolution", double(n) * std::pow(double(c), double(deepest))},
                 {"nodes_resident", tree_.resident()},
                 {"nodes_created", ref.created.size()},
                 {"nodes_created_total", created_},
                 {"nodes_evicted", ref.evicted},
                 {"nodes_replaced", ref.replaced},
                 {"candidates", candidates.size()},
                 {"refused", ref.refused},
                 {"node_budget", maxNew == UINT32_MAX ? -1.0 : double(maxNew)},
                 {"pool_slots", slots},
                 {"pool_bytes", uint64_t(slots) * slotBytes},
                 {"memory_limit", o_.memoryBytes},
                 {"node_cost_a_ms_per_texel", costA_},
                 {"node_cost_b_ms", costB_},
                 {"flushes", flushes_},
                 {"analysis_step", o_.analysisStep},
                 {"analysed_samples", counters[0]},
                 {"straddling", counters[1]},
                 {"coarser_than_pixel", counters[2]},
                 {"benefit_total", counters[3]},
                 {"triangles", pass_.triangleCount()},
                 {"triangles_drawn", pass_.takeTrianglesDrawn()},
                 {"pcf", o_.pcf},
                 {"plane_bias", o_.planeBias},
                 {"id_test", o_.idTest},
                 {"constant_bias", o_.constantBias * eps},
                 {"slope_bias_texels", o_.slopeBias},
                 {"max_slope", o_.maxSlope},
                 {"lod_bias", o_.lodBias},
                 {"epsilon", eps}};
    if (o_.keepTree) {
      nlohmann::json keys = nlohmann::json::array();
      for (const AsmTree::Node& node : tree_.nodes())
        if (node.key != SM_INVALID_KEY) keys.push_back(node.key);
      out.stats["node_keys"] = keys;
    }
    return out;
  }

 private:
  // Each face's tree over the window of the face the scene's bounds cover (fitWindows, as RMSM's): the
  // roots start at the scene's own footprint instead of the whole face, which a far light's scene covers
  // a sliver of. A face's deepest level keeps its finest texel at least 2^-21 of the face, as
  // asmMaxDepth does for unfitted faces: N C^D zoom <= 2^21 (fp32 face coordinates, a texel's quarter).
  void fitFaces(glm::vec3 light) {
    const uint32_t n = o_.nodeResolution;
    if (o_.fitFaces) {
      windows_ = sm::fitWindows(light, pass_.boundsLo(), pass_.boundsHi(), n, 2 * n);
    } else {
      windows_.fill(glm::vec4(0, 0, 1, 0));
    }
    for (glm::vec4& w : windows_) {
      uint32_t depth = 0;
      double res = double(n) * double(w.z);
      while (depth < o_.maxDepth && res * o_.cells <= double(1u << 21)) res *= o_.cells, ++depth;
      w.w = float(depth);
    }
    vk::upload(ctx_, windowBuf_, windows_.data(), sizeof(windows_));
  }

  // Each node (key, slot): its window of the face at its depth's resolution, N + 1 texels a side (the
  // apron), copied into its pool slot. A fitted face's level covers its window: the face's texels are
  // zoom times as many, the window's first texel at s0, t0.
  void recordNodes(vk::Commands& cmd, const std::vector<std::pair<uint32_t, uint32_t>>& nodes, glm::vec3 light, float eps) {
    const uint32_t n = o_.nodeResolution;
    for (const auto& [key, slot] : nodes) {
      const uint32_t face = sm::keyFace(key);
      const glm::vec4 w = windows_[face];
      const double faceRes = double(n) * std::pow(double(o_.cells), double(sm::keyLevel(key))) * double(w.z);
      pass_.recordWindow(cmd, face, faceRes, uint32_t(std::llround(double(w.x) * faceRes)) + sm::keyPageX(key) * n,
                         uint32_t(std::llround(double(w.y) * faceRes)) + sm::keyPageY(key) * n, n + 1, n + 1, light, eps);
      VkBufferImageCopy region{};
      region.bufferOffset = uint64_t(slot) * sm::asmSlotStride(n) * 4;
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
      region.imageExtent = {n + 1, n + 1, 1};
      pass_.recordCopy(cmd, {region}, pool_);
      if (o_.idTest) pass_.recordCopyIds(cmd, {region}, idPool_);
    }
    cmd.barrier();
  }

  // The cost model of §3.1, cost = a·texels + b per node: six passes at N/2 and six at N (the roots'
  // windows, into the roots' slots, which the roots' own passes overwrite next), each batch one
  // submission timed by the wall clock; the median of three rounds.
  void calibrate(glm::vec3 light, float eps) {
    const uint32_t n = o_.nodeResolution;
    auto timeBatch = [&](uint32_t side) {
      std::vector<double> ms;
      for (int round = 0; round < 3; ++round) {
        const auto t = Clock::now();
        vk::Commands cmd(ctx_);
        for (uint32_t f = 0; f < 6; ++f) {
          pass_.recordWindow(cmd, f, double(side - 1), 0, 0, side, side, light, eps);
          VkBufferImageCopy region{};
          region.bufferOffset = uint64_t(f) * sm::asmSlotStride(n) * 4;
          region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
          region.imageExtent = {side, side, 1};
          pass_.recordCopy(cmd, {region}, pool_);
          if (o_.idTest) pass_.recordCopyIds(cmd, {region}, idPool_);
        }
        cmd.submit();
        ms.push_back(msSince(t) / 6.0);
      }
      std::sort(ms.begin(), ms.end());
      return ms[1];
    };
    const double small = timeBatch(n / 2 + 1), full = timeBatch(n + 1);
    const double texSmall = double(n / 2 + 1) * (n / 2 + 1), texFull = double(n + 1) * (n + 1);
    costA_ = (full - small) / (texFull - texSmall);
    if (!(costA_ > 0)) costA_ = full / texFull;  // noise: all of it per texel
    costB_ = std::max(0.0, full - costA_ * texFull);
    pass_.takeTrianglesDrawn();
  }

  void writeHash() {
    const std::vector<uint32_t> table = tree_.hashTable(capacity_);
    std::memcpy(hash_.mapped, table.data(), table.size() * 4);
  }

  vk::Context& ctx_;
  AsmOptions o_;
  sm::DepthPass pass_;
  AsmTree tree_;
  vk::Timer timer_;
  vk::Readback readback_;
  vk::Kernel kernel_;
  uint32_t capacity_ = 0;
  vk::Buffer pool_;      // (N + 1)² floats per slot
  vk::Buffer idPool_;    // (N + 1)² triangle IDs per slot with the ID + depth test; 16 bytes otherwise
  vk::Buffer noTriangles_;  // bound in place of the G-buffer's triangle IDs without the test
  vk::Buffer hash_;      // (key, slot) per entry, host-visible, written before each submission
  vk::Buffer benefit_;   // uint per slot and cell
  vk::Buffer used_;      // uint per slot
  vk::Buffer counters_;  // asm_frame.comp's four counters
  vk::Buffer visibility_;
  glm::vec3 light_{NAN};
  bool rootsRendered_ = false;
  // Per face (s0, t0, zoom, deepest level): the window the face's tree covers (fitFaces), in windowBuf_.
  std::array<glm::vec4, 6> windows_;
  vk::Buffer windowBuf_;
  uint64_t frame_ = 0, created_ = 0, flushes_ = 0;
  double costA_ = -1, costB_ = 0;
};

}  // namespace

std::unique_ptr<ShadowMethod> makeAdaptiveShadowMap(vk::Context& ctx, const AsmOptions& options) {
  return std::make_unique<AdaptiveShadowMap>(ctx, options);
}

}  // namespace cs
