// traversal/: the bounded breadth-first traversal (the scheme: docs/ARCHITECTURE.md, "The traversal").
#include "traversal/traversal.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <thread>

#include "core/error.h"
#include "traversal/traverse_advance.comp.h"
#include "traversal/leaf_hits.comp.h"
#include "traversal/traverse_leaves.comp.h"
#include "traversal/traverse_test.comp.h"

namespace cs::traversal {

// ---- sizing ------------------------------------------------------------------------------------------

namespace {
// The test kernel reads triangles and nodes as uniform texel buffers of 16-byte texels (traverse_test.comp).
constexpr VkFormat kTexelFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kWordFormat = VK_FORMAT_R32G32B32A32_UINT;  // the state words as texels (traverse_test.comp)
constexpr VkFormat kPairFormat = VK_FORMAT_R32G32B32A32_UINT;  // (triangle, node) pairs, two a texel
constexpr VkFormat kRayFormat = VK_FORMAT_R32G32B32A32_UINT;   // ConeTree::rays(), one texel a ray (traverse_leaves.comp)
constexpr uint64_t kPairBytes = 8;          // uvec2
constexpr uint64_t kStatsBytes = STAT_WORDS * 4;
constexpr uint64_t kStateBytes = STATE_WORDS * 4;  // the state words, bound whole as a uniform buffer
// Levels of the tree the leaves take (leafStepOf): 1 for four rays a leaf pair, 2 for sixteen, 3 for 64.
// The leaf choice's costs on a CPU device, in leaf tests (LeafChoiceCosts).
constexpr float kLeafChoiceStepCost = 40.0f, kLeafChoiceLaneCost = 4.0f;
// The leaves' cull on a CPU device: from this many leaf tests a ray (leafCullTestsPerRay).
constexpr float kLeafCullTestsPerRay = 512.0f;
uint32_t leafLevels(LeafRays rays) { return rays == LeafRays::SixtyFour ? 3u : rays == LeafRays::Sixteen ? 2u : 1u; }
}  // namespace

// A buffer of `pairs` uvec2 pairs, rounded up to whole 16-byte texels: the kernels read pairs as RGBA32UI
// texels, two a texel, and a view holds whole texels only.
uint64_t pairBufferBytes(uint64_t pairs) { return (pairs * kPairBytes + 15) / 16 * 16; }

uint64_t chunkScratchBytes(uint32_t chunkCapacity) {
  // the chunk copy (uvec2 per input; the device path's second pair buffer), the counters and the state words
  return pairBufferBytes(std::max<uint64_t>(chunkCapacity, 1)) + kStatsBytes + STATE_WORDS * 4;
}

uint64_t reserveBelow(uint32_t treeDepth, uint32_t d) { return d + 1 >= treeDepth ? 0 : 4 * uint64_t(treeDepth - 1 - d); }

uint64_t minimumPairs(uint32_t treeDepth) { return reserveBelow(treeDepth, 0) + 1; }

ArenaPlan planArena(uint64_t memoryBytes, uint64_t maxBinding) {
  ArenaPlan p;
  // Arena 4/5, chunks of a quarter of the arena's pairs (a full chunk expands into at most the whole arena).
  uint64_t pairs = std::min<uint64_t>(memoryBytes / 10, maxBinding / 16 * 2);  // whole texels within the binding
  for (;;) {
    uint64_t chunk = std::max<uint64_t>(1, std::min<uint64_t>(pairs / 4, maxBinding / 4));
    chunk = std::min<uint64_t>(chunk, uint64_t(1) << 30);
    uint64_t bytes = pairBufferBytes(pairs) + chunkScratchBytes(uint32_t(chunk));
    if (bytes <= memoryBytes && pairs >= kMinPairs) {
      p.pairCapacity = pairs;
      p.chunkCapacity = uint32_t(chunk);
      p.bytes = bytes;
      return p;
    }
    CS_CHECK(pairs > kMinPairs, "traversal memory of " << memoryBytes << " bytes is too small: it must hold at least "
                                                       << kMinPairs << " pairs and one chunk's scratch ("
                                                       << pairBufferBytes(kMinPairs) + chunkScratchBytes(1) << " bytes)");
    pairs = std::max<uint64_t>(kMinPairs, pairs - std::max<uint64_t>(1, pairs / 16));
  }
}

// ---- cluster spheres -------------------------------------------------------------------------------------

glm::dvec4 clusterBounds(const glm::vec4* vertices, size_t count) {
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (size_t v = 0; v < count; ++v) {
    lo = glm::min(lo, glm::dvec3(glm::vec3(vertices[v])));
    hi = glm::max(hi, glm::dvec3(glm::vec3(vertices[v])));
  }
  const glm::dvec3 c = 0.5 * (lo + hi);
  double r = 0;
  for (size_t v = 0; v < count; ++v) r = std::max(r, glm::length(glm::dvec3(glm::vec3(vertices[v])) - c));
  return glm::dvec4(c, r);
}

ClusterWorld clusterWorld(const glm::vec4* vertices, size_t triangles) {
  ClusterWorld w;
  w.whole = clusterBounds(vertices, 3 * triangles);
  for (size_t g = 0; g < CLUSTER_GROUPS; ++g) {
    const size_t first = g * GROUP_SIZE;
    const glm::dvec4 b = first < triangles
                             ? clusterBounds(vertices + 3 * first, 3 * std::min<size_t>(GROUP_SIZE, triangles - first))
                             : w.whole;
    const glm::vec3 c(b);  // each component within 2^-24 of itself: |c - b| <= 2^-24 (|x| + |y| + |z|)
    const double grown = b.w + std::ldexp(std::abs(b.x) + std::abs(b.y) + std::abs(b.z), -23);
    float r = float(grown);
    if (double(r) < grown) r = std::nextafter(r, INFINITY);
    w.groups[g] = glm::vec4(c, r);
  }
  return w;
}

glm::dvec4 superBounds(const ClusterWorld* clusters, size_t count) {
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (size_t q = 0; q < count; ++q) {
    lo = glm::min(lo, glm::dvec3(clusters[q].whole) - clusters[q].whole.w);
    hi = glm::max(hi, glm::dvec3(clusters[q].whole) + clusters[q].whole.w);
  }
  const glm::dvec3 centre = 0.5 * (lo + hi);
  double radius = 0;
  for (size_t q = 0; q < count; ++q)
    radius = std::max(radius, glm::length(glm::dvec3(clusters[q].whole) - centre) + clusters[q].whole.w);
  return glm::dvec4(centre, radius * (1.0 + std::ldexp(1.0, -40)));  // (the sum's rounding, outward)
}

glm::vec4 clusterSphere(glm::dvec3 rel, double radius, double operands) {
  const double pad = std::ldexp(glm::length(rel) + radius + operands, -16);
  return glm::vec4(glm::vec3(rel), float((radius + pad) * (1.0 + std::ldexp(1.0, -20))));
}

glm::vec4 clusterSphereFar(glm::dvec3 rel, double radius, double lateralOperands) {
  const double pad = std::ldexp(glm::length(glm::dvec2(rel)) + radius + lateralOperands, -16);
  return glm::vec4(glm::vec3(rel), float((radius + pad) * (1.0 + std::ldexp(1.0, -20))));
}

uint64_t hilbertIndex3(uint32_t x, uint32_t y, uint32_t z, int bits) {
  // Skilling's form: undo the excess work of each level on the transposed coordinates, then Gray-decode;
  // the index is the coordinates' bits interleaved, x's first, from the top level down.
  uint32_t X[3] = {x, y, z};
  for (uint32_t q = 1u << (bits - 1); q > 1; q >>= 1) {
    const uint32_t low = q - 1;
    for (int i = 0; i < 3; ++i) {
      if (X[i] & q) {
        X[0] ^= low;  // invert the low bits of x
      } else {
        const uint32_t t = (X[0] ^ X[i]) & low;  // exchange the low bits of x and axis i
        X[0] ^= t, X[i] ^= t;
      }
    }
  }
  X[1] ^= X[0], X[2] ^= X[1];
  uint32_t flip = 0;
  for (uint32_t q = 1u << (bits - 1); q > 1; q >>= 1)
    if (X[2] & q) flip ^= q - 1;
  uint64_t h = 0;
  for (int b = bits - 1; b >= 0; --b)
    for (int i = 0; i < 3; ++i) h = (h << 1) | (((X[i] ^ flip) >> b) & 1u);
  return h;
}

// ---- statistics ----------------------------------------------------------------------------------------

uint64_t TraversalStats::pairsTested() const {
  uint64_t n = 0;
  for (auto& p : passes) n += p.tested;
  return n;
}

uint64_t TraversalStats::pairsSurvived() const {
  uint64_t n = 0;
  for (auto& p : passes) n += p.survived;
  return n;
}

nlohmann::json TraversalStats::toJson() const {
  nlohmann::json levels = nlohmann::json::array();
  for (size_t d = 0; d < passes.size(); ++d)
    levels.push_back({{"depth", d},
                      {"inputs", passes[d].inputs},
                      {"pairs_tested", passes[d].tested},
                      {"pairs_survived", passes[d].survived},
                      {"chunks", passes[d].chunks},
                      {"cluster_tests", passes[d].clusterTests},
                      {"overflows", passes[d].overflows}});
  return {{"passes", levels},
          {"pairs_tested", pairsTested()},
          {"pairs_survived", pairsSurvived()},
          {"expanded_clusters", expandedClusters},
          {"leaf_pairs", leafPairs},
          {"leaf_tests", leafTests},
          {"leaf_rays", leafRays},
          {"leaf_pairs_by_rays", {{"4", leafPairsByRays[0]}, {"16", leafPairsByRays[1]}, {"64", leafPairsByRays[2]}}},
          {"leaf_rays_choice", leafChoice.empty() ? std::string("given") : leafChoice},
          {"leaf_choices_by_clusters", leafChoicesByClusters},
          {"leaf_test", leafTestName(leafTest)},
          {"leaf_pairs_by_cull", {{"culled", leafPairsByCull[0]}, {"not_culled", leafPairsByCull[1]}}},
          {"leaf_cull", leafCull.empty() ? std::string("never (the chunked traversal)") : leafCull},
          {"expansion_lanes", expansionLanes},
          {"expansion_lanes_by_batch", {{"cluster", expansionsByLanes[0]}, {"triangle", expansionsByLanes[1]}}},
          {"expansion_pairs_by_lanes", {{"cluster", expansionPairsByLanes[0]}, {"triangle", expansionPairsByLanes[1]}}},
          {"expansion_lanes_choice", expansionLanesChoice.empty() ? std::string("given") : expansionLanesChoice},
          {"submits", submits},
          {"early_accepted_nodes", earlyAccepted},
          {"early_dropped_pairs", droppedPairs},
          {"peak_pairs", peakPairs},
          {"peak_chunk", peakChunk},
          {"peak_bytes", peakBytes},
          {"traversal_ms", traversalMs},
          {"leaves_ms", leavesMs},
          {"traversal_timestamp_ms", traversalGpuMs},
          {"leaves_timestamp_ms", leavesGpuMs}};
}

// ---- the traversal -------------------------------------------------------------------------------------

struct Traversal::Frame {
  const TraversalInput* in = nullptr;
  vk::Timer* timer = nullptr;
  const cone::TreeShape* shape = nullptr;
  uint32_t treeDepth = 0;   // the tree's depth D
  uint32_t depth = 0;       // the depth whose pairs go to the leaves, plus one (leafStepOf)
  uint32_t leafShift = 2;   // a leaf pair's rays: [node << leafShift, (node + 1) << leafShift)
  std::vector<uint64_t> base, end;  // arena range of each depth's pairs
  std::vector<double> ratio;        // survivors per input of the last chunk out of each depth
  TraversalStats stats;
  uint32_t words[STAT_WORDS] = {};  // the counters of the last submit
  bool shadowedCleared = false;     // the leaves' hint cleared in this traversal (by its first leaves)
};

uint64_t maxPairBufferBytes(const vk::Context& ctx) {
  return std::min<uint64_t>(ctx.maxStorageBufferRange(), uint64_t(16) * ctx.properties.limits.maxTexelBufferElements);
}

Traversal::Traversal(vk::Context& ctx, uint64_t memoryBytes)
    : Traversal(ctx, planArena(memoryBytes, maxPairBufferBytes(ctx))) {
  CS_CHECK(bytesAllocated() <= memoryBytes, "traversal buffers take " << bytesAllocated() << " bytes, over the bound of "
                                                                      << memoryBytes);
}

Traversal::Traversal(vk::Context& ctx, const ArenaPlan& plan) : ctx_(ctx), plan_(plan) {
  CS_CHECK(plan_.pairCapacity >= kMinPairs && plan_.chunkCapacity >= 1, "traversal arena plan too small");
  batchTriangles_ = plan_.chunkCapacity;
  leaves_ = vk::createKernel(ctx, "traverse leaves", spv_traverse_leaves_comp, 7, sizeof(TraversePush), {{0, 0u}, {1, 0u}});
  leavesFromLight_ = vk::createKernel(ctx, "traverse leaves (from the light)", spv_traverse_leaves_comp, 7,
                                      sizeof(TraversePush), {{0, 1u}, {1, 0u}});
  leavesCull_ = vk::createKernel(ctx, "traverse leaves (culled)", spv_traverse_leaves_comp, 7, sizeof(TraversePush),
                                 {{0, 0u}, {1, 1u}});
  leavesFromLightCull_ = vk::createKernel(ctx, "traverse leaves (from the light, culled)", spv_traverse_leaves_comp, 7,
                                          sizeof(TraversePush), {{0, 1u}, {1, 1u}});
  leavesFromSample_ = vk::createKernel(ctx, "traverse leaves (from the sample)", spv_traverse_leaves_comp, 7,
                                       sizeof(TraversePush), {{0, 2u}, {1, 0u}});
  leavesFromSampleCull_ = vk::createKernel(ctx, "traverse leaves (from the sample, culled)", spv_traverse_leaves_comp,
                                           7, sizeof(TraversePush), {{0, 2u}, {1, 1u}});
  leafHits_ = vk::createKernel(ctx, "leaf hits", spv_leaf_hits_comp, 4, sizeof(LeafHitsPush));
  advance_ = vk::createKernel(ctx, "traverse advance", spv_traverse_advance_comp, 2, sizeof(AdvancePush));
  arena_ = vk::createBuffer(ctx, pairBufferBytes(plan_.pairCapacity));
  chunk_ = vk::createBuffer(ctx, pairBufferBytes(plan_.chunkCapacity));
  stats_ = vk::createBuffer(ctx, kStatsBytes, vk::Memory::HostVisible);
  state_ = vk::createBuffer(ctx, STATE_WORDS * 4, vk::Memory::Device, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
}

Traversal::~Traversal() = default;

// The test kernel specialised for the switches in `p` (traverse_test.comp), made on first use.
// `clusters`: the kernel of (cluster, node) steps instead (device path); `whole`: the whole-cluster
// expansion's (STEP_EXPAND_WHOLE: the sphere test, no early accept; front-face culling from `p`).
const vk::Kernel& Traversal::testKernel(const TraversePush& p, bool clusters, bool whole) {
  // The cluster kernel runs the sphere test alone whatever the switches: one pipeline for every frame.
  const bool sphere = whole || p.test == TRAVERSE_TEST_SPHERE, early = !clusters && !whole && p.earlyAccept,
             culling = !clusters && p.frontFaceCulling;
  const bool scaled = p.coneScale != 1.0f;  // SPEC_SCALED: the kernel holds the scale 1 as a constant otherwise
  const uint32_t key =
      (clusters ? 8u : whole ? 9u + (culling ? 1u : 0u) : (sphere ? 1u : 0u) | (early ? 2u : 0u) | (culling ? 4u : 0u)) +
      (scaled ? 11u : 0u);
  std::unique_ptr<vk::Kernel>& k = tests_[key];
  if (!k)
    k = std::make_unique<vk::Kernel>(vk::createKernel(
        ctx_, clusters ? "traverse test (clusters)" : whole ? "traverse test (whole clusters)" : "traverse test",
        spv_traverse_test_comp, 12, sizeof(TraversePush),
        {{0, sphere && !clusters ? TRAVERSE_TEST_SPHERE : TRAVERSE_TEST_PRECISE}, {1, early ? 1u : 0u},
         {2, culling ? 1u : 0u}, {3, clusters ? 1u : 0u}, {4, whole ? 1u : 0u}, {5, scaled ? 1u : 0u}}));
  return *k;
}

uint64_t Traversal::bytesAllocated() const {
  return arena_.size + chunk_.size + stats_.size + state_.size;
}

// Submits and waits; the wall time of the submit goes to `wallMs`, the timestamp intervals to the stats.
void Traversal::submit(Frame& f, vk::Commands& cmd, double& wallMs) {
  auto t0 = std::chrono::steady_clock::now();
  cmd.submit();
  wallMs += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  f.stats.submits++;
  vk::download(ctx_, stats_, f.words, sizeof(f.words));
  if (f.timer) {
    for (auto& [name, ms] : f.timer->intervals()) {
      if (name == "traversal") f.stats.traversalGpuMs += ms;
      if (name == "leaves") f.stats.leavesGpuMs += ms;
    }
  }
}

// Expands `count` inputs into depth `child`: the arena pairs [first, first + count) of depth child - 1,
// or (child == 0 with fromTriangles) the triangles first .. first + count - 1 against the root. The
// inputs are copied to the chunk buffer first, so the survivors may overwrite them: they are written from
// arena slot `first` on (`outFirst`), all of them, or -- when they would pass slot `limit` -- those below
// it, the inputs then restored for the retry. Returns whether all were written; f.words[STAT_TOTAL] holds
// their count either way.
bool Traversal::expandChunk(Frame& f, uint32_t child, bool fromTriangles, uint64_t first, uint32_t count,
                            uint64_t outFirst, uint64_t limit) {
  TraversePush p{};
  p.light = glm::vec4(f.in->light, 0.0f);
  p.first = fromTriangles ? uint32_t(first) : 0u;
  p.count = count;
  p.fromTriangles = fromTriangles ? 1u : 0u;
  p.childOffset = f.shape->offsets[child];
  p.childCount = f.shape->counts[child];
  p.outFirst = uint32_t(outFirst);
  p.outLimit = uint32_t(limit);
  p.eps = f.in->eps;
  p.minLength = 2.0f * f.in->eps;
  p.test = f.in->test;
  p.frontFaceCulling = f.in->frontFaceCulling ? 1u : 0u;
  const bool early = f.in->earlyAccept && f.in->test == TRAVERSE_TEST_PRECISE;
  p.earlyAccept = early ? 1u : 0u;
  p.leafCount = f.shape->leaves;
  p.leafShift = 2u * (f.treeDepth - child);
  p.inputOffset = fromTriangles ? 0u : f.shape->offsets[child - 1];
  p.frameVertices = f.in->frameTriangles ? 1u : 0u;
  p.coneScale = f.in->frameTriangles ? f.in->coneScale : 1.0f;
  const vk::Buffer& tris = f.in->frameTriangles ? *f.in->frameTriangles : *f.in->triangles;

  if (f.timer) f.timer->restart();
  vk::Commands cmd(ctx_, f.timer);
  cmd.fill(stats_, 0);
  if (!fromTriangles) cmd.copy(arena_, chunk_, uint64_t(count) * kPairBytes, first * kPairBytes, 0);
  cmd.barrier();
  cmd.mark("start");
  vk::Grid g = vk::gridFor(count, TRAVERSE_THREADS, ctx_.maxWorkgroups());
  if (early)
    cmd.dispatch(testKernel(p, false), {vk::texels(tris, kTexelFormat), vk::texels(f.in->tree->nodes(), kTexelFormat), vk::texels(chunk_, kPairFormat), arena_,
                         stats_, f.in->tree->rays(), *f.in->visibility, flags_, stats_,
                         vk::uniforms(state_, kStateBytes), vk::texels(*f.in->triangles, kTexelFormat),
                         vk::texels(f.in->tree->boxes(), kTexelFormat)}, p, g.x, g.y);
  else  // bindings 5-8 unused: any valid buffer
    cmd.dispatch(testKernel(p, false), {vk::texels(tris, kTexelFormat), vk::texels(f.in->tree->nodes(), kTexelFormat), vk::texels(chunk_, kPairFormat), arena_,
                         stats_, stats_, stats_, stats_, stats_, vk::uniforms(state_, kStateBytes), vk::texels(*f.in->triangles, kTexelFormat),
                         vk::texels(f.in->tree->boxes(), kTexelFormat)}, p, g.x, g.y);
  cmd.barrier();
  cmd.mark("traversal");
  submit(f, cmd, f.stats.traversalMs);

  const uint32_t survived = f.words[STAT_TOTAL];
  PassStats& s = f.stats.passes[child];
  f.stats.earlyAccepted += f.words[STAT_ACCEPTED];  // distinct nodes: a retried chunk finds them flagged
  f.stats.peakChunk = std::max(f.stats.peakChunk, count);
  if (outFirst + survived > limit) {
    s.overflows++;
    // The pairs that fitted overwrote inputs from slot outFirst on, and the retry takes a tail of these
    // same inputs: put them back from the chunk buffer's copy (a submit on this rare path only).
    if (!fromTriangles && survived > 0) {
      vk::Commands restore(ctx_);
      restore.copy(chunk_, arena_, uint64_t(count) * kPairBytes, 0, first * kPairBytes);
      restore.barrier();
      restore.submit();
      f.stats.submits++;
    }
    return false;
  }
  s.inputs += count;
  s.tested += uint64_t(count) * (fromTriangles ? 1 : 4) - f.words[STAT_MISSING];
  s.survived += survived;
  s.chunks++;
  f.stats.droppedPairs += f.words[STAT_DROPPED];
  f.stats.peakPairs = std::max(f.stats.peakPairs, outFirst + survived);
  return true;
}

// Chunk size for expanding the tail of a depth whose pairs end at `end` into the next depth, whose pairs
// may reach `limit`: the inputs' slots are reused, so m inputs with r survivors each need
// end - m + r m <= limit; sized with a 25 % margin on the r seen so far.
uint64_t Traversal::chunkSize(uint64_t available, uint64_t end, uint64_t limit, double ratio) const {
  const double r = 1.25 * ratio;
  const double room = double(limit - std::min(limit, end));
  uint64_t m = r <= 1.0 ? available : uint64_t(room / (r - 1.0));
  return std::max<uint64_t>(1, std::min<uint64_t>({m, available, plan_.chunkCapacity}));
}

void Traversal::leaves(Frame& f, uint32_t d) {
  const uint64_t pairs = f.end[d] - f.base[d];
  TraversePush p{};
  p.light = glm::vec4(f.in->light, 0.0f);
  p.first = uint32_t(f.base[d]);
  p.count = uint32_t(pairs);
  p.childCount = f.shape->leaves;
  p.leafShift = f.leafShift;
  p.eps = f.in->eps;
  p.minLength = 2.0f * f.in->eps;
  if (f.timer) f.timer->restart();
  vk::Commands cmd(ctx_, f.timer);
  cmd.fill(stats_, 0);
  cmd.barrier();
  cmd.mark("start");
  vk::Grid g = vk::gridFor(pairs, TRAVERSE_THREADS, ctx_.maxWorkgroups());
  if (!f.shadowedCleared) {  // the hint starts empty in each traversal
    ensureShadowed(f.in->tree->rays().size / 16);
    cmd.fill(shadowed_, 0);
    cmd.barrier();
    f.shadowedCleared = true;
  }
  cmd.dispatch(leafKernel(f.in->leafTest, false), {vk::texels(*f.in->triangles, kTexelFormat), vk::texels(arena_, kPairFormat), vk::texels(f.in->tree->rays(), kRayFormat), stats_,
                         vk::texels(stats_, kWordFormat), shadowed_, vk::texels(f.in->tree->boxes(), kTexelFormat)}, p,
               g.x, g.y);
  cmd.barrier();
  cmd.mark("leaves");
  submit(f, cmd, f.stats.leavesMs);
  f.stats.leafPairs += pairs;
  f.stats.leafTests += (pairs << f.leafShift) - f.words[STAT_MISSING];
}

// Finishes every pair of depth d, [base[d], end[d]), then leaves it empty. Chunks are taken from the
// tail, expanded into depth d+1 in the slots they free, and depth d+1 is finished before the next
// chunk: breadth-first when the whole depth fits as one chunk, depth-first over chunks when it does not.
void Traversal::processDepth(Frame& f, uint32_t d) {
  if (f.end[d] == f.base[d]) return;
  if (d + 1 == f.depth) {
    leaves(f, d);
    f.end[d] = f.base[d];
    return;
  }
  const uint32_t next = d + 1;
  const uint64_t limit = plan_.pairCapacity - reserveBelow(f.depth, next);
  double& ratio = f.ratio[d];
  while (f.end[d] > f.base[d]) {
    const uint64_t m = chunkSize(f.end[d] - f.base[d], f.end[d], limit, ratio);
    const uint64_t first = f.end[d] - m;
    const bool fits = expandChunk(f, next, false, first, uint32_t(m), first, limit);
    const double seen = double(f.words[STAT_TOTAL]) / double(m);
    if (!fits) {  // a smaller chunk next time; one pair always fits (<= 4 survivors, reserve of 4)
      CS_CHECK(m > 1, "traversal arena cannot make progress at depth " << d);
      ratio = std::min(4.0, std::max(2.0 * ratio, seen));
      continue;
    }
    ratio = std::clamp(seen, 0.05, 4.0);
    f.end[d] = first;
    f.base[next] = first;
    f.end[next] = first + f.words[STAT_TOTAL];
    processDepth(f, next);
  }
}

TraversalStats Traversal::run(const TraversalInput& in, vk::Timer* timer) {
  CS_CHECK(in.triangles && in.tree && in.visibility, "traversal input incomplete");
  Frame f;
  f.in = &in;
  f.timer = timer;
  f.shape = &in.tree->shape();
  f.treeDepth = f.shape->depth;
  leafRays_ = resolveLeafRays(in.leafRays);
  leafTest_ = in.leafTest;
  f.depth = leafStepOf(f.treeDepth, leafLevels(leafRays_));
  f.leafShift = 2u * (f.treeDepth - f.depth + 1u);
  f.stats.leafRays = 1u << f.leafShift;
  if (in.leafRays == LeafRays::Auto)
    f.stats.leafChoice = "auto on the chunked path (host counts): 64 rays on a CPU device, four on a GPU";
  f.stats.leafTest = in.leafTest;
  CS_CHECK(plan_.pairCapacity >= minimumPairs(f.depth),
           "traversal memory too small for this view: a tree of depth " << f.treeDepth << " needs at least "
               << minimumPairs(f.depth) << " pairs (" << minimumPairs(f.depth) * kPairBytes
               << " bytes of arena), the bound gives " << plan_.pairCapacity);
  f.base.assign(f.depth, 0);
  f.end.assign(f.depth, 0);
  f.ratio.assign(f.depth, 1.0);
  f.stats.passes.resize(f.depth);
  if (in.earlyAccept && in.test == TRAVERSE_TEST_PRECISE) {  // the flags, cleared per frame
    ensureFlags(f.shape->nodes());
    vk::Commands cmd(ctx_);
    cmd.fill(flags_, 0);
    cmd.barrier();
    cmd.submit();
    f.stats.submits++;
  }

  // Pass 0: every triangle against the root, as many at a time as depth 0 can hold beside the reserve of
  // the deeper depths (each triangle gives at most one pair), each batch finished before the next.
  const uint64_t limit = plan_.pairCapacity - reserveBelow(f.depth, 0);
  uint64_t pos = in.firstTriangle;
  const uint64_t endTriangle = uint64_t(in.firstTriangle) + in.triangleCount;
  while (pos < endTriangle) {
    const uint64_t m = std::min<uint64_t>({endTriangle - pos, plan_.chunkCapacity, limit});
    CS_CHECK(expandChunk(f, 0, true, pos, uint32_t(m), 0, limit), "pass 0 cannot overflow");
    f.base[0] = 0;
    f.end[0] = f.words[STAT_TOTAL];
    processDepth(f, 0);
    pos += m;
  }
  if (f.shadowedCleared) {  // the leaves ran: their hits into the visibility
    vk::Commands cmd(ctx_);
    LeafHitsPush p{f.shape->leaves, 0u, 0u, 0u};
    recordLeafHits(cmd, *in.tree, *in.visibility, p);
    cmd.submit();
    f.stats.submits++;
  }
  // The scratch in use at the largest chunk (the estimate's alignment slack capped by what is allocated).
  const uint64_t scratch = bytesAllocated() - arena_.size;
  f.stats.peakBytes = f.stats.peakPairs * kPairBytes +
                      (f.stats.peakChunk ? std::min(chunkScratchBytes(f.stats.peakChunk), scratch) : 0);
  f.stats.leafPairsByRays[std::min(f.leafShift / 2u, 3u) - 1u] = f.stats.leafPairs;
  return f.stats;
}

void Traversal::ensureShadowed(uint64_t rays) {
  const uint64_t bytes = shadowedBytes(rays);  // a bit a ray, and a word past the last (the leaves read two)
  if (shadowed_.size < bytes) {
    shadowed_.reset();
    shadowed_ = vk::createBuffer(ctx_, bytes);
  }
}

void Traversal::recordLeafHits(vk::Commands& cmd, const cone::ConeTree& tree, const vk::Buffer& visibility,
                               const LeafHitsPush& p) {
  // A lane per LEAF_HITS_RAYS rays: on the device path the arguments pass 0's advance wrote from the
  // tree's shape (zero workgroups when no batch ran: no bit is set then).
  if (p.fromShape) {
    cmd.dispatchIndirect(leafHits_, {vk::texels(tree.rays(), kRayFormat), vk::texels(shadowed_, VK_FORMAT_R32_UINT), visibility,
                                     vk::texels(tree.shapeBuffer(), kWordFormat)},
                         &p, sizeof(p), state_, STATE_HITS_ARGS * 4);
  } else {
    vk::Grid g = vk::gridFor((uint64_t(p.count) + LEAF_HITS_RAYS - 1) / LEAF_HITS_RAYS, CONE_BUILD_THREADS, ctx_.maxWorkgroups());
    cmd.dispatch(leafHits_, {vk::texels(tree.rays(), kRayFormat), vk::texels(shadowed_, VK_FORMAT_R32_UINT), visibility,
                             vk::texels(tree.shapeBuffer(), kWordFormat)},
                 p, g.x, g.y);
  }
  cmd.barrier();
}

void Traversal::recordEnd(vk::Commands& cmd, const TraversalInput& in) {
  CS_CHECK(in.tree && in.visibility, "traversal input incomplete");
  recordLeafHits(cmd, *in.tree, *in.visibility, LeafHitsPush{0u, 1u, 0u, 0u});
}

void Traversal::ensureFlags(uint64_t nodes) {
  const uint64_t bytes = std::max<uint64_t>(nodes * 4, 16);
  if (flags_.size < bytes) {
    flags_.reset();
    flags_ = vk::createBuffer(ctx_, bytes);
  }
}

// ---- the device path -------------------------------------------------------------------------------

void Traversal::recordBegin(vk::Commands& cmd, const TraversalInput& in) {
  CS_CHECK(in.tree, "traversal input incomplete");
  cmd.fill(state_, 0);
  ensureShadowed(in.tree->rays().size / 16);
  cmd.fill(shadowed_, 0);
  if (in.earlyAccept && in.test == TRAVERSE_TEST_PRECISE) {
    ensureFlags(in.tree->nodes().size / sizeof(cone::ConeNode));  // a flag per node the tree can have
    cmd.fill(flags_, 0);
  }
  cmd.barrier();
}

void Traversal::record(vk::Commands& cmd, const TraversalInput& in, std::vector<uint32_t>& batchStarts,
                       FunctionRef<void(const char*)> boundary) {
  CS_CHECK(in.triangles && in.tree && in.visibility, "traversal input incomplete");
  const uint32_t maxDepth = in.tree->maxDepth();
  CS_CHECK(maxDepth >= 1 && maxDepth < STATE_MAX_STEPS, "traversal: tree depth bound " << maxDepth);
  const uint32_t capacity = plan_.chunkCapacity;
  const bool early = in.earlyAccept && in.test == TRAVERSE_TEST_PRECISE;
  const vk::Buffer& tris = in.frameTriangles ? *in.frameTriangles : *in.triangles;
  // Clusters need batches of whole clusters and an arena that holds one cluster's expansion.
  const bool clusters = in.clusterSpheres && clustersFit_ && capacity >= CLUSTER_SIZE && batchTriangles_ >= CLUSTER_SIZE &&
                        in.firstTriangle % CLUSTER_SIZE == 0;
  usedClusters_ = clusters;
  // Super clusters likewise need batches of whole super clusters and an arena that holds one's split.
  const bool supers = clusters && in.superClusters && supersFit_ && capacity >= SUPER_SIZE &&
                      batchTriangles_ >= SUPER_SIZE && in.firstTriangle % SUPER_SIZE == 0;
  usedSupers_ = supers;
  // The last depth's expansions in the sphere-test kernel ("Clusters"); its pairs, like the precise
  // kernel's, go on to the leaves.
  const bool sphereExpansion = clusters && in.test == TRAVERSE_TEST_PRECISE && in.sphereLastExpansion;
  const bool cpu = ctx_.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
  // Auto where the device's threshold is known (or given): the lanes chosen per batch on the device.
  expansionAuto_ = in.lastExpansionLanes == ExpansionLanes::Auto;
  const std::optional<uint32_t> minPairs =
      in.expansionLanesMinPairs ? in.expansionLanesMinPairs : expansionLanesMinPairs(ctx_);
  expansionMinPairs_ = minPairs.value_or(0);
  expansionLanes_ = in.lastExpansionLanes == ExpansionLanes::PerCluster    ? EXPANSION_PER_CLUSTER
                    : in.lastExpansionLanes == ExpansionLanes::PerTriangle ? EXPANSION_PER_TRIANGLE
                    : minPairs                                             ? EXPANSION_CHOSEN
                                                                           : EXPANSION_PER_TRIANGLE;
  // Auto on a CPU device: the leaves' span chosen per batch from its counts, 64 rays the earliest.
  leafAuto_ = in.leafRays == LeafRays::Auto;
  leafChoice_ = leafAuto_ && (cpu || in.leafChoiceCosts);
  leafRays_ = leafChoice_ ? LeafRays::SixtyFour : resolveLeafRays(in.leafRays);
  leafCosts_ = in.leafChoiceCosts.value_or(leafChoiceCosts(cpu));
  const LeafChoiceCosts costs = leafCosts_;
  leafCullTestsPerRay_ = in.leafCullTestsPerRay.value_or(leafCullTestsPerRay(cpu));
  const bool leafCullNever = !(leafCullTestsPerRay_ <= std::numeric_limits<float>::max()),
             leafCullAlways = leafCullTestsPerRay_ <= 0.0f;
  leafTest_ = in.leafTest;
  const vk::Buffer& shape = in.tree->shapeBuffer();
  const vk::Buffer* buffers[2] = {&arena_, &chunk_};  // step c writes buffers[c % 2]

  TraversePush base{};
  base.light = glm::vec4(in.light, 0.0f);
  base.eps = in.eps;
  base.minLength = 2.0f * in.eps;
  base.test = in.test;
  base.frontFaceCulling = in.frontFaceCulling ? 1u : 0u;
  base.earlyAccept = early ? 1u : 0u;
  base.frameVertices = in.frameTriangles ? 1u : 0u;
  base.coneScale = in.frameTriangles ? in.coneScale : 1.0f;
  base.countWord = STATE_COUNT;
  base.deviceParams = 1u;
  base.outFirst = 0;
  base.outLimit = capacity;
  base.triangleEnd = in.firstTriangle + in.triangleCount;

  auto advance = [&](uint32_t step, uint32_t triangles) {
    AdvancePush a{step, triangles, capacity, ctx_.maxWorkgroups(), supers ? 2u : clusters ? 1u : 0u, in.triangleCount,
                  sphereExpansion ? 1u : 0u, expansionLanes_, leafLevels(leafRays_), leafChoice_ ? 1u : 0u,
                  costs.step, costs.lane, expansionMinPairs_, leafCullTestsPerRay_};
    // Step 0 and the batch's end always run; a step c >= 1 only where step c - 1 had inputs (the advance
    // before it says so in STATE_ADVANCE_ARGS).
    if (step == 0 || step == ADVANCE_END_OF_BATCH)
      cmd.dispatch(advance_, {shape, state_}, a, 1);
    else
      cmd.dispatchIndirect(advance_, {shape, state_}, &a, sizeof(a), state_, STATE_ADVANCE_ARGS * 4);
    cmd.barrier();
  };
  // The test of one step: inputs in `src`, survivors appended to `dst`.
  // The test of one step: inputs in `src`, survivors appended to `dst`; the triangle kernel and, with
  // clusters, the cluster kernel, each dispatched for the step's inputs when they are its kind (the
  // advance kernel's arguments).
  auto testStep = [&](const TraversePush& p, const vk::Buffer& src, const vk::Buffer& dst) {
    const vk::Buffer& spheres = clusters ? *in.clusterSpheres : state_;
    if (sphereExpansion) {  // early accept needs the precise test: off in this kernel (its pairs go to the leaves)
      TraversePush ps = p;
      ps.test = TRAVERSE_TEST_SPHERE;
      ps.earlyAccept = 0u;
      // A lane per triangle pair, a lane per (super) cluster pair, or both where the batch chooses (the
      // other given no workgroups).
      for (bool whole : {false, true}) {
        if (expansionLanes_ != EXPANSION_CHOSEN && whole != (expansionLanes_ == EXPANSION_PER_CLUSTER)) continue;
        cmd.dispatchIndirect(testKernel(ps, false, whole),
                             {vk::texels(tris, kTexelFormat), vk::texels(in.tree->nodes(), kTexelFormat), vk::texels(src, kPairFormat), dst, state_,
                              state_, state_, state_, spheres, vk::uniforms(state_, kStateBytes),
                              vk::texels(*in.triangles, kTexelFormat), vk::texels(in.tree->boxes(), kTexelFormat)},
                             &ps, sizeof(ps), state_, (whole ? STATE_WHOLE_ARGS : STATE_SPHERE_ARGS) * 4);
      }
    }
    for (bool clusterKernel : {false, true}) {
      if (clusterKernel && !clusters) continue;
      const uint32_t args = clusterKernel ? STATE_CLUSTER_ARGS : STATE_TEST_ARGS;
      if (early)
        cmd.dispatchIndirect(testKernel(p, clusterKernel),
                             {vk::texels(tris, kTexelFormat), vk::texels(in.tree->nodes(), kTexelFormat), vk::texels(src, kPairFormat), dst, state_,
                              in.tree->rays(), *in.visibility, flags_, spheres, vk::uniforms(state_, kStateBytes),
                              vk::texels(*in.triangles, kTexelFormat), vk::texels(in.tree->boxes(), kTexelFormat)},
                             &p, sizeof(p), state_, args * 4);
      else
        cmd.dispatchIndirect(testKernel(p, clusterKernel),
                             {vk::texels(tris, kTexelFormat), vk::texels(in.tree->nodes(), kTexelFormat), vk::texels(src, kPairFormat), dst, state_,
                              state_, state_, state_, spheres, vk::uniforms(state_, kStateBytes),
                              vk::texels(*in.triangles, kTexelFormat), vk::texels(in.tree->boxes(), kTexelFormat)},
                             &p, sizeof(p), state_, args * 4);
    }
    cmd.barrier();
  };

  const uint64_t end = uint64_t(in.firstTriangle) + in.triangleCount;
  uint32_t batch = std::max(1u, std::min(capacity, batchTriangles_));
  if (supers) batch = batch / SUPER_SIZE * SUPER_SIZE;
  else if (clusters) batch = batch / CLUSTER_SIZE * CLUSTER_SIZE;
  for (uint64_t pos = in.firstTriangle; pos < end; pos += batch) {
    const uint32_t m = uint32_t(std::min<uint64_t>(batch, end - pos));
    batchStarts.push_back(uint32_t(pos));
    advance(0, m);
    TraversePush p0 = base;
    p0.first = uint32_t(pos);
    p0.count = m;
    p0.fromTriangles = 1u;
    testStep(p0, chunk_, *buffers[0]);  // pass 0: the triangles (or clusters) against the root
    for (uint32_t c = 1; c <= maxDepth; ++c) {
      advance(c, 0);
      if (c < maxDepth) testStep(base, *buffers[(c - 1) % 2], *buffers[c % 2]);
    }
    if (boundary) boundary("traversal");
    // The batch's leaves, from the buffer the step that took them wrote, with the cull or without: one
    // of these dispatches has workgroups (none where the batch overflowed), whatever the tree's depth.
    for (uint32_t k = 0; k < LEAF_SLOTS; ++k) {
      const bool cull = k >= 2;
      if (cull ? leafCullNever : leafCullAlways) continue;
      TraversePush p = base;
      p.first = 0;
      p.countWord = STATE_LEAF_ARGS + 4 * k + 3;
      p.missingWord = STATE_LEAF_MISSING;
      cmd.dispatchIndirect(leafKernel(in.leafTest, cull), {vk::texels(*in.triangles, kTexelFormat), vk::texels(*buffers[k % 2], kPairFormat), vk::texels(in.tree->rays(), kRayFormat), state_,
                                     vk::texels(state_, kWordFormat), shadowed_, vk::texels(in.tree->boxes(), kTexelFormat)},
                           &p, sizeof(p), state_, (STATE_LEAF_ARGS + 4 * k) * 4);
    }
    cmd.barrier();
    advance(ADVANCE_END_OF_BATCH, 0);
    if (boundary) boundary("leaves");
  }
}

void Traversal::learnBatch(const uint32_t* w, const TraversalStats& frame, uint64_t triangles) {
  uint64_t worst = 0;
  for (const PassStats& p : frame.passes) worst = std::max(worst, p.survived);
  learnBatch(w, worst, triangles);
}

void Traversal::learnBatch(const uint32_t* w, uint64_t worst, uint64_t triangles) {
  const uint32_t capacity = plan_.chunkCapacity;
  const uint32_t used = std::max(1u, std::min(capacity, batchTriangles_));
  if (overflowed(w) && usedClusters_ && used <= CLUSTER_SIZE) {
    clustersFit_ = false;  // even one cluster's expansion does not fit: triangles only
  } else if (overflowed(w) && usedSupers_ && used <= SUPER_SIZE) {
    supersFit_ = false;  // even one super cluster's batch does not fit: clusters from then on
  } else if (overflowed(w)) {
    // The most pairs any depth held per triangle over the whole frame: a batch of b triangles holds about
    // b times that at its worst depth; aim at half the capacity (the triangles are not all alike).
    // An expansion's inputs (CLUSTER_SIZE per expanded cluster pair) must fit as well: the GPU's count of
    // expansions covers the batches that completed and the one that overflowed (the fallback runs without
    // clusters).
    double perTriangle = double(worst) / double(std::max<uint64_t>(1, triangles));
    const uint64_t expanded = uint64_t(w[STATE_EXPANDED]) | (uint64_t(w[STATE_EXPANDED + 1]) << 32);
    const uint64_t ran = std::min<uint64_t>(triangles, (uint64_t(batchesDone(w)) + 1) * used);
    if (ran > 0) perTriangle = std::max(perTriangle, double(expanded) * CLUSTER_SIZE / double(ran));
    const double fit = perTriangle > 0 ? 0.5 * double(capacity) / perTriangle : double(used) / 4;
    batchTriangles_ = uint32_t(std::clamp(fit, 1.0, std::max(1.0, double(used) / 2)));
  } else if (w[STATE_PEAK_PAIRS] < capacity / 8 && used < capacity) {
    batchTriangles_ = uint32_t(std::min<uint64_t>(capacity, 2ull * used));
  }
}

std::optional<uint32_t> expansionLanesMinPairs(const vk::Context& ctx) {
  if (ctx.properties.deviceType != VK_PHYSICAL_DEVICE_TYPE_CPU) return std::nullopt;
  // lavapipe runs a dispatch's workgroups on a worker thread a core, each workgroup's lanes on one thread.
  return std::max(1u, std::thread::hardware_concurrency()) * uint32_t(TRAVERSE_THREADS);
}

float leafCullTestsPerRay(bool cpuDevice) {
  // Measured on lavapipe (docs/ARCHITECTURE.md, "The leaves' cull"). On a GPU, unmeasured: never.
  return cpuDevice ? kLeafCullTestsPerRay : std::numeric_limits<float>::infinity();
}

LeafChoiceCosts leafChoiceCosts(bool cpuDevice) {
  // Measured on lavapipe (docs/ARCHITECTURE.md, "Leaf pairs chosen per frame"). On a GPU, unmeasured: not used.
  return cpuDevice ? LeafChoiceCosts{kLeafChoiceStepCost, kLeafChoiceLaneCost} : LeafChoiceCosts{};
}

LeafRays Traversal::resolveLeafRays(LeafRays wanted) const {
  if (wanted != LeafRays::Auto) return wanted;
  return ctx_.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU ? LeafRays::SixtyFour : LeafRays::Four;
}

const char* leafTestName(LeafTest test) {
  switch (test) {
    case LeafTest::TwoEnds: return "two_ends";
    case LeafTest::FromLight: return "from_light";
    case LeafTest::FromSample: return "from_sample";
  }
  return "?";
}

LeafTest leafTestFor(bool farFrame, glm::vec3 lo, glm::vec3 hi, glm::vec3 light) {
  if (!(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z)) return LeafTest::TwoEnds;
  const float halfDiagonal = 0.5f * glm::length(hi - lo);
  const glm::vec3 m = glm::max(glm::max(glm::abs(lo), glm::abs(hi)), glm::abs(light));
  const bool inRange = halfDiagonal >= std::ldexp(1.0f, -12) && std::max(m.x, std::max(m.y, m.z)) <= std::ldexp(1.0f, 40);
  if (!inRange) return LeafTest::TwoEnds;
  return farFrame ? LeafTest::FromSample : LeafTest::FromLight;
}

const char* expansionLanesName(ExpansionLanes lanes) {
  switch (lanes) {
    case ExpansionLanes::Auto: return "auto";
    case ExpansionLanes::PerCluster: return "cluster";
    case ExpansionLanes::PerTriangle: return "triangle";
  }
  return "?";
}

namespace {

// The committed copy holds STATE_LEAF_MISSING, then the words from STATE_ACC on: read it through a view
// that puts them where the live words are (on the stack).
std::array<uint32_t, STATE_WORDS> stateView(const uint32_t* words, bool committed) {
  std::array<uint32_t, STATE_WORDS> view;
  std::copy(words, words + STATE_WORDS, view.begin());
  if (committed) {
    view[STATE_LEAF_MISSING] = words[STATE_COMMITTED];
    for (uint32_t k = 0; k + 1 < STATE_COMMITTED_WORDS; ++k) view[STATE_ACC + k] = words[STATE_COMMITTED + 1 + k];
  }
  return view;
}

uint64_t stateU64(const uint32_t* w, uint32_t at) { return uint64_t(w[at]) | (uint64_t(w[at + 1]) << 32); }

PassStats passFromState(const uint32_t* w, uint32_t d) {
  const uint32_t at = STATE_ACC + STATE_ACC_WORDS * d;
  PassStats ps;
  ps.inputs = stateU64(w, at);
  ps.tested = stateU64(w, at + 2);
  ps.survived = stateU64(w, at + 4);
  ps.chunks = w[at + 6];
  ps.clusterTests = w[at + 7];
  return ps;
}

}  // namespace

uint32_t Traversal::passesInState(const uint32_t* w, uint32_t depth) const {
  uint32_t leafStep = leafStepOf(depth, leafLevels(leafRays_));
  if (leafChoice_)
    for (uint32_t d = leafStep; d < std::min<uint32_t>(depth, STATE_MAX_STEPS); ++d)
      if (w[STATE_ACC + STATE_ACC_WORDS * d + 6] > 0) leafStep = d + 1;
  return leafStep;
}

uint64_t Traversal::mostSurvived(const uint32_t* words, uint32_t depth, bool committed) const {
  const std::array<uint32_t, STATE_WORDS> view = stateView(words, committed);
  uint64_t worst = 0;
  const uint32_t passes = std::min<uint32_t>(passesInState(view.data(), depth), STATE_MAX_STEPS);
  for (uint32_t d = 0; d < passes; ++d) worst = std::max(worst, passFromState(view.data(), d).survived);
  return worst;
}

TraversalStats Traversal::statsFromState(const uint32_t* words, uint32_t depth, bool committed) const {
  const std::array<uint32_t, STATE_WORDS> view = stateView(words, committed);
  const uint32_t* w = view.data();
  auto u64 = [&](uint32_t at) { return stateU64(w, at); };
  TraversalStats s;
  const uint32_t leafStep = passesInState(w, depth);
  for (uint32_t d = 0; d < std::min<uint32_t>(leafStep, STATE_MAX_STEPS); ++d) s.passes.push_back(passFromState(w, d));
  s.expandedClusters = uint64_t(words[STATE_EXPANDED]) | (uint64_t(words[STATE_EXPANDED + 1]) << 32);
  s.leafPairs = u64(STATE_LEAF_PAIRS);
  s.leafRays = 1u << (2u * (depth - leafStep + 1u));
  for (uint32_t l = 0; l < 3; ++l) s.leafPairsByRays[l] = w[STATE_LEAF_BY_LEVEL + l];
  if (leafChoice_) {
    // The span that took the most leaf pairs; why: what the last batch's choices saw against the
    // thresholds (LeafChoiceCosts::threshold).
    uint32_t most = 0;
    for (uint32_t l = 1; l < 3; ++l)
      if (s.leafPairsByRays[l] > s.leafPairsByRays[most]) most = l;
    if (s.leafPairs > 0) s.leafRays = 4u << (2u * most);
    const LeafChoiceCosts& costs = leafCosts_;
    std::ostringstream why;
    why.precision(2);
    why << "per batch from its counts: leaf pairs of 4/16/64 rays " << s.leafPairsByRays[0] << "/" << s.leafPairsByRays[1]
        << "/" << s.leafPairsByRays[2] << "; the last batch's predicted survival";
    for (uint32_t l = 3; l >= 2; --l) {
      const uint32_t seen = w[STATE_LEAF_SEEN + l - 2];
      why << (l == 3 ? " at the 64-ray step " : ", at the 16-ray step ");
      if (seen == 0) why << "-";
      else why << double(seen) / 65536.0;
      why << " (one more depth below " << costs.threshold(double(1u << (2 * l))) << ")";
    }
    s.leafChoicesByClusters = w[STATE_DEFERRED];
    if (s.leafChoicesByClusters > 0)
      why << "; " << s.leafChoicesByClusters
          << " choices made from cluster pairs' survival, which kept them clusters one depth further (there one more "
             "depth below "
          << costs.threshold(64.0, CLUSTER_SIZE) << " and " << costs.threshold(16.0, CLUSTER_SIZE) << " at 64 and 16 rays, "
          << costs.threshold(64.0, SUPER_SIZE) << " and " << costs.threshold(16.0, SUPER_SIZE) << " for super clusters)";
    s.leafChoice = why.str();
  } else if (leafAuto_) {
    s.leafChoice = "auto: four on a GPU, where the choice's costs have not been measured";
  }
  for (uint32_t form = 0; form < 2; ++form) {
    s.expansionsByLanes[form] = words[STATE_LANES + form];
    s.expansionPairsByLanes[form] = words[STATE_LANES_PAIRS + form];
  }
  if (expansionLanes_ != EXPANSION_CHOSEN) {
    s.expansionLanes = expansionLanesName(expansionLanes_ == EXPANSION_PER_CLUSTER ? ExpansionLanes::PerCluster
                                                                                   : ExpansionLanes::PerTriangle);
    if (expansionAuto_) s.expansionLanesChoice = "auto: a lane per triangle pair on a GPU, where the threshold has not been measured";
  } else {
    const bool none = s.expansionsByLanes[0] + s.expansionsByLanes[1] == 0;
    s.expansionLanes = none ? "none"
                       : expansionLanesName(s.expansionPairsByLanes[0] >= s.expansionPairsByLanes[1] ? ExpansionLanes::PerCluster
                                                                                                     : ExpansionLanes::PerTriangle);
    std::ostringstream why;
    why << "per batch from its (super) cluster pairs: a lane a pair from " << expansionMinPairs_
        << " pairs (the lanes the device runs at once), a lane per triangle pair below; batches a lane per pair "
        << s.expansionsByLanes[0] << " (" << s.expansionPairsByLanes[0] << " pairs), per triangle pair "
        << s.expansionsByLanes[1] << " (" << s.expansionPairsByLanes[1] << " pairs)";
    s.expansionLanesChoice = why.str();
  }
  for (uint32_t k = 0; k < 2; ++k) s.leafPairsByCull[k] = w[STATE_LEAF_CULL + k];
  {
    std::ostringstream why;
    if (leafCullTestsPerRay_ <= 0.0f) why << "always (given)";
    else if (!(leafCullTestsPerRay_ <= std::numeric_limits<float>::max())) why << "never (a GPU, where the cull has not been measured, or given)";
    else why << "per batch: where its leaf tests a ray (scaled to the frame's triangles) reach " << leafCullTestsPerRay_;
    s.leafCull = why.str();
  }
  s.leafTests = u64(STATE_LEAF_TESTS) - w[STATE_LEAF_MISSING];
  s.leafTest = leafTest_;
  s.earlyAccepted = u64(STATE_ACCEPTED);
  s.droppedPairs = u64(STATE_DROPPED);
  s.peakPairs = w[STATE_PEAK_PAIRS];
  s.peakChunk = w[STATE_PEAK_CHUNK];
  const uint64_t scratch = bytesAllocated() - arena_.size;
  s.peakBytes = s.peakPairs * kPairBytes + (s.peakChunk ? std::min(chunkScratchBytes(s.peakChunk), scratch) : 0);
  return s;
}

}  // namespace cs::traversal
