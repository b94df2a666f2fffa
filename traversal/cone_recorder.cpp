// The cone path's frame recorder (cone_recorder.h). docs/ARCHITECTURE.md, "The cone path's code".
#include "traversal/cone_recorder.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <sstream>

#include "core/error.h"
#include "method/epsilon.h"
#include "method/settings.h"
#include "raster/raster.h"
#include "traversal/order_choice.comp.h"
#include "traversal/sample_light.comp.h"
#include "traversal/unfinished_rays.comp.h"

namespace cs {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

constexpr uint32_t kOne = 0x3F800000u;       // 1.0f: the visibility words start lit
constexpr VkFormat kPixelTexels = VK_FORMAT_R32G32B32A32_SFLOAT;  // the G-buffer read as texels, a pixel each
constexpr uint32_t kOrderRecheckFrames = 8;  // adaptive order: a loose verdict holds this many frames

// Both passes' counts as one (the top-level stats of a two-pass frame, or a device frame and its chunked
// fallback): per-depth sums, peaks as maxima.
traversal::TraversalStats combine(const traversal::TraversalStats& a, const traversal::TraversalStats& b) {
  traversal::TraversalStats c = a;
  if (c.passes.size() < b.passes.size()) c.passes.resize(b.passes.size());
  for (size_t d = 0; d < b.passes.size(); ++d) {
    c.passes[d].inputs += b.passes[d].inputs;
    c.passes[d].tested += b.passes[d].tested;
    c.passes[d].survived += b.passes[d].survived;
    c.passes[d].chunks += b.passes[d].chunks;
    c.passes[d].overflows += b.passes[d].overflows;
  }
  for (size_t d = 0; d < b.passes.size(); ++d) c.passes[d].clusterTests += b.passes[d].clusterTests;
  c.expandedClusters += b.expandedClusters;
  c.leafPairs += b.leafPairs;
  c.leafTests += b.leafTests;
  c.leafRays = std::max(c.leafRays, b.leafRays);
  c.leafTest = b.leafTest;  // both passes run the frame's test
  c.submits += b.submits;
  c.earlyAccepted += b.earlyAccepted;
  c.droppedPairs += b.droppedPairs;
  c.peakPairs = std::max(c.peakPairs, b.peakPairs);
  c.peakChunk = std::max(c.peakChunk, b.peakChunk);
  c.peakBytes = std::max(c.peakBytes, b.peakBytes);
  c.traversalMs += b.traversalMs;
  c.leavesMs += b.leavesMs;
  c.traversalGpuMs += b.traversalGpuMs;
  c.leavesGpuMs += b.leavesGpuMs;
  return c;
}

static_assert(ORDER_SPREAD + 2 * (SHAPE_MAX_DEPTH + 1) <= ORDER_LOOSE && ORDER_LOOSE < ORDER_WORDS,
              "the order words: the spread of every depth, then the loose flag");

// The GPU's choice of ray order: the order, and the screen-order tree's spread per depth (sum of
// 1 - cos(half-angle), order_choice.comp) that decided it, with its `triangles` and `lit` samples: the
// stats say why (the GPU's verdicts, ORDER_SORTED and ORDER_LOOSE, in words; the figures as the host
// computes them).
void reportOrderChoice(const uint32_t* words, uint32_t depth, uint32_t triangles, uint32_t lit, ConeFrameStats& stats) {
  const bool sorted = words[ORDER_SORTED] != 0;
  stats.rayOrder = sorted ? "hilbert" : "screen";
  double top = 0, deep = 0;
  stats.screenTreeSolidAngleSr.clear();
  for (uint32_t d = 0; d < depth && d <= SHAPE_MAX_DEPTH; ++d) {
    const uint64_t v = uint64_t(words[ORDER_SPREAD + 2 * d]) | (uint64_t(words[ORDER_SPREAD + 2 * d + 1]) << 32);
    const double sr = 2.0 * M_PI * double(v) / double(CONE_SPREAD_UNIT);
    stats.screenTreeSolidAngleSr.push_back(sr);
    (d < ORDER_TOP_DEPTHS ? top : deep) = std::max(d < ORDER_TOP_DEPTHS ? top : deep, sr);
  }
  const double looseness = top > 0 ? deep / top : 0.0;
  stats.screenTreeLooseness = looseness;  // > ORDER_LOOSE_RATIO: loose
  std::ostringstream why;
  why << "auto: measured this frame: ";
  const double pays = double(triangles) * (looseness - 1.0) / std::sqrt(double(std::max(lit, 1u)));
  if (sorted)
    why << "sorted (the screen order's tree is loose, " << looseness << " > " << ORDER_LOOSE_RATIO
        << ", and its triangles make that cost more than the sort: triangles x (looseness - 1) / sqrt(lit) = " << pays
        << " > " << ORDER_SORT_PAYS << ")";
  else if (words[ORDER_LOOSE] != 0)
    why << "screen order kept (its tree is loose, " << looseness << " > " << ORDER_LOOSE_RATIO
        << ", but its few triangles cost less over it than the sort: triangles x (looseness - 1) / sqrt(lit) = " << pays
        << " <= " << ORDER_SORT_PAYS << ")";
  else
    why << "screen order kept (its tree is as tight as a sorted one: looseness " << looseness << " <= " << ORDER_LOOSE_RATIO
        << ")";
  stats.rayOrderChoice = why.str();
}

}  // namespace

ConeRecorder::ConeRecorder(vk::Context& ctx, const ConeOptions& options)
    : ctx_(ctx),
      options_(options),
      layout_(ctx, options),
      tree_(ctx),
      timer_(ctx.adopted ? vk::Timer{} : vk::createTimer(ctx, 64)) {  // the engine times nothing on the caller's device
  // Under a memory budget the arena is what the frame's other buffers leave of it (ensureTraversal).
  if (options.arena.pairCapacity > 0) traversal_ = std::make_unique<traversal::Traversal>(ctx, options.arena);
  else if (options.memoryBudgetBytes == 0)
    traversal_ = std::make_unique<traversal::Traversal>(ctx, options.traversalMemoryBytes);
  sampleLight_ = vk::createKernel(ctx_, "sample light", spv_sample_light_comp, 5, sizeof(traversal::SampleLightPush));
  if (options_.sorted && options_.adaptiveOrder && !options_.twoPass) {
    orderChoice_ = vk::createKernel(ctx, "ray order choice", spv_order_choice_comp, 2, sizeof(OrderPush));
    orderWords_ = vk::createBuffer(ctx, ORDER_WORDS * 4, vk::Memory::Device, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
  }
  if (options_.twoPass) unfinished_ = vk::createKernel(ctx, "unfinished rays", spv_unfinished_rays_comp, 3,
                                                       sizeof(traversal::TraversePush));
  batchStarts_.reserve(kConeMaxBatches);
}

// A light too far for fp32 ray lengths would give a silently wrong mask: refuse it (epsilon.h).
void ConeRecorder::refuseUnreachableLight(glm::vec3 light) const {
  if (std::string why = lightRangeProblem(light, layout_.boundsLo(), layout_.boundsHi()); !why.empty())
    throw Error(why, "cone path", "the limit is 2^62, documented in docs/LIMITS.md");
}

// The per-pixel buffers (the rays, the two-pass variant's update, the visibility words) for a G-buffer of
// width x height; kept while the size stays.
void ConeRecorder::sizeFrameBuffers(uint32_t width, uint32_t height) {
  const uint32_t pixels = width * height;
  if (!rays_ || raysWidth_ != width || raysHeight_ != height) {
    rays_.reset();
    rays_ = std::make_unique<rays::LitRays>(ctx_, width, height);
    rays_->keepSortedKeys(false);  // the tree reads the order (samples()) only
    raysWidth_ = width;
    raysHeight_ = height;
    if (options_.twoPass) {
      compact_.reset();
      compact_ = std::make_unique<sort::Compact>(ctx_, std::max(pixels, 1u));
      rayFlags_.reset();
      rayFlags_ = vk::createBuffer(ctx_, uint64_t(std::max(pixels, 1u)) * 4);
      remaining_.reset();
      remaining_ = vk::createBuffer(ctx_, uint64_t(std::max(pixels, 1u)) * 4);
      if (!kept_) kept_ = vk::createBuffer(ctx_, 16);
    }
  }
  if (visibility_.size < uint64_t(pixels) * 4) {
    visibility_.reset();
    visibility_ = vk::createBuffer(ctx_, uint64_t(pixels) * 4);
  }
}

// What the traversal reads for this light: the tree (with its sorted rays: positions and pixels), the
// visibility words, the light, epsilon and the variant's tests.
traversal::TraversalInput ConeRecorder::traversalInput(glm::vec3 light, float eps) {
  traversal::TraversalInput in;
  in.tree = &tree_;
  in.visibility = &visibility_;
  in.light = light;
  in.eps = eps;
  in.test = options_.test == ConeTest::Sphere ? TRAVERSE_TEST_SPHERE : TRAVERSE_TEST_PRECISE;
  in.frontFaceCulling = options_.frontFaceCulling;
  in.earlyAccept = options_.earlyAccept;
  in.sphereLastExpansion = options_.sphereLastExpansion;
  in.lastExpansionLanes = options_.lastExpansionLanes;
  in.expansionLanesMinPairs = options_.expansionLanesMinPairs;
  in.leafRays = options_.leafRays;
  in.leafChoiceCosts = options_.leafChoiceCosts;
  in.leafCullTestsPerRay = options_.leafCullTestsPerRay;
  in.leafTest = options_.leafTestAuto
                    ? traversal::leafTestFor(frame_.far, layout_.boundsLo(), layout_.boundsHi(), light)
                    : traversal::LeafTest::TwoEnds;
  in.superClusters = options_.superClusters;
  return in;
}

// Sorted without measuring: compaction and keys fused (LitRays::recordCompactionWithKeys), one stage.
bool ConeRecorder::fusedKeys(rays::RayOrder order) const {
  return order == rays::RayOrder::Hilbert && rays_->fusedKeys();
}

bool ConeRecorder::recordCompaction(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light, rays::RayOrder order,
                                    const Boundary& boundary) {
  const uint32_t pixels = g.width * g.height;
  cmd.fill(visibility_, kOne, 0, uint64_t(pixels) * 4);
  const bool fused = fusedKeys(order);
  if (fused) {
    rays_->recordCompactionWithKeys(cmd, g, keysPush(light));
    boundary("compact + keys");
  } else {
    rays_->recordCompaction(cmd, g, light, order);
    boundary("compact");
  }
  return fused;
}

ConeRecorder::RecordedLight ConeRecorder::recordLight(vk::Commands& cmd, const DeviceGBuffer& g,
                                                      const traversal::TraversalInput& in, glm::vec3 light,
                                                      bool adaptive, uint32_t sphereSlot, const Boundary& boundary) {
  const uint32_t pixels = g.width * g.height;
  const rays::RayOrder order =
      options_.sorted && !adaptive ? rays::RayOrder::Hilbert : rays::RayOrder::ScreenMorton;
  const uint32_t maxRays = std::max(pixels, 1u);
  const bool fused = recordCompaction(cmd, g, light, order, boundary);
  sort::Count sortCount = rays_->count();
  if (adaptive) {
    tree_.recordDevice(cmd, g.position, rays_->samples(), rays_->countBuffer(), 0, maxRays, light,
                       2.0f * in.eps, &frame_);
    cmd.fill(orderWords_, 0);
    cmd.barrier();
    tree_.recordSpread(cmd, orderWords_, ORDER_SPREAD, frame_.scale);
    const OrderPush op{layout_.triangleCount()};
    cmd.dispatch(orderChoice_, {tree_.shapeBuffer(), orderWords_}, op, 1);
    cmd.barrier();
    boundary("order");
    sortCount = sort::Count::device(sort::GpuWord(orderWords_, ORDER_SORT_COUNT), maxRays)
                    .withGate(orderWords_.buffer, ORDER_GATE_ARGS * 4);
  }
  bool recordsGiven = false;
  if (options_.sorted) {
    if (!fused) {
      rays_->recordKeys(cmd, g, keysPush(light), sortCount);
      boundary("keys");
    }
    // The fused path's sort also writes the sorted rays' records for the build (the positions read in
    // pixel order there, not gathered in the sorted order by the build).
    recordsGiven = fused ? rays_->recordSort(cmd, sortCount, &tree_.rayRecords(maxRays), &g.position)
                         : rays_->recordSort(cmd, sortCount);
    boundary("sort");
  }
  if (adaptive)
    tree_.recordDevice(cmd, g.position, rays_->samples(), orderWords_, ORDER_SORT_COUNT, maxRays, light,
                       2.0f * in.eps, &frame_, /*keepWhenZero=*/true, /*recordsGiven=*/false, orderWords_.buffer,
                       ORDER_GATE_ARGS * 4);
  else
    tree_.recordDevice(cmd, g.position, rays_->samples(), rays_->countBuffer(), 0, maxRays, light,
                       2.0f * in.eps, &frame_, /*keepWhenZero=*/false, recordsGiven);
  if (frame_.far && layout_.frameTrianglesStale(frame_)) layout_.recordFrameTriangles(cmd, frame_);
  boundary("build");
  ensureTraversal(pixels);
  const bool clusters =
      options_.clusters && traversal_->clustersFit() && layout_.chunkTriangles() >= CLUSTER_SIZE;
  if (clusters) layout_.updateClusterSpheres(light, sphereSlot, frame_);
  traversal_->recordBegin(cmd, in);
  RecordedLight rec;
  rec.adaptive = adaptive;
  rec.clusters = clusters;
  rec.batch = traversal_->batchTriangles();
  rec.batches = batchesNeeded();
  // An arena so small that the batches would number in the hundreds (each ~10 dispatches a depth) is
  // traversed chunked instead, after the submission.
  rec.onDevice = rec.batches <= kConeMaxBatches;
  batchStarts_.clear();
  if (rec.onDevice) {
    const uint32_t triangles = layout_.triangleCount();
    layout_.forEachTriangleBuffer(in, 0, triangles, frame_, [&](traversal::TraversalInput part) {
      const size_t b = size_t(part.triangles - layout_.triangles().data());
      if (clusters) part.clusterSpheres = layout_.clusterSpheres(sphereSlot, b);
      const size_t from = batchStarts_.size();
      traversal_->record(cmd, part, batchStarts_, boundary);
      for (size_t i = from; i < batchStarts_.size(); ++i) batchStarts_[i] += uint32_t(b) * layout_.chunkTriangles();
    });
    // The hits of the batches that completed (all of them but after an overflow, which the chunked
    // traversal resumes) into the visibility.
    traversal_->recordEnd(cmd, in);
    boundary("leaves");
  }
  return rec;
}

ConeRecorder::RecordedLight ConeRecorder::recordLightFrame(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light,
                                                           float eps, bool adaptive, uint32_t sphereSlot,
                                                           bool markUndecided, const Boundary& boundary) {
  const uint32_t pixels = g.width * g.height;
  const vk::Grid grid = vk::gridFor(std::max(pixels, 1u), TRAVERSE_THREADS, ctx_.maxWorkgroups());
  cmd.barrier();  // the previous light's reads of every buffer reused below are done
  chooseFrame(light);
  const traversal::TraversalInput in = traversalInput(light, eps);
  // No pass writes the light's term into the samples: every kernel that asks whether a pixel is lit
  // computes it for this light (core/shared.h litSampleFor), so g is only read.
  const RecordedLight rec = recordLight(cmd, g, in, light, adaptive, sphereSlot, boundary);
  if (markUndecided && rec.onDevice) {
    cmd.barrier();
    traversal::SampleLightPush push{};
    push.light = glm::vec4(light, 1.0f);
    push.count = pixels;
    push.mode = SAMPLE_UNDECIDED;
    // Binding 1 (the terms) is not written in this mode: any buffer.
    cmd.dispatch(sampleLight_,
                 {vk::texels(g.position, kPixelTexels), visibility_, visibility_, traversal_->stateBuffer(),
                  vk::texels(g.normal, kPixelTexels)},
                 push, grid.x, grid.y);
    cmd.barrier();
  }
  return rec;
}

void ConeRecorder::recordLightTerms(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light,
                                    const vk::BufferRange& terms) {
  const uint32_t pixels = g.width * g.height;
  if (pixels == 0) return;
  const vk::Grid grid = vk::gridFor(pixels, TRAVERSE_THREADS, ctx_.maxWorkgroups());
  traversal::SampleLightPush push{};
  push.light = glm::vec4(light, 1.0f);
  push.count = pixels;
  push.mode = SAMPLE_LIGHT_TERM;
  // Bindings 2 and 3 are not read in this mode: any buffers.
  cmd.dispatch(sampleLight_,
               {vk::texels(g.position, kPixelTexels), terms, terms, terms, vk::texels(g.normal, kPixelTexels)},
               push, grid.x, grid.y);
}

uint64_t ConeRecorder::batchesNeeded() {
  const uint32_t batch = traversal_->batchTriangles();
  uint64_t batches = 0;
  layout_.forEachTriangleBuffer(traversal::TraversalInput{}, 0, layout_.triangleCount(), cone::FrameChoice{},
                                [&](const traversal::TraversalInput& part) {
                                  batches += (uint64_t(part.triangleCount) + batch - 1) / batch;
                                });
  return batches;
}

ConeRecorder::Frame ConeRecorder::runFrame(const FrameInput& frame) {
  CS_CHECK(frame.scene && frame.device, "cone: the frame needs a scene and the G-buffer on the GPU");
  CS_CHECK(frame.vk == nullptr || frame.vk == &ctx_, "cone: the frame's Vulkan context is not this method's");
  const DeviceGBuffer& g = *frame.device;
  const float eps = frame.epsilon > 0 ? frame.epsilon : EpsilonPolicy::forScene(*frame.scene).eps;
  const auto t0 = Clock::now();

  Frame out;
  out.uploadMs = layout_.upload(frame);
  refuseUnreachableLight(frame.light);
  sizeFrameBuffers(g.width, g.height);
  // The frame of the cones: world, or for a light far outside the triangles' bounds the far-light frame
  // (traversal.h): the keys, the tree and the pass tests in it, the leaves in the world.
  chooseFrame(frame.light);
  ConeFrameStats& stats = out.stats;
  describeFrame(stats, eps);
  const traversal::TraversalInput in = traversalInput(frame.light, eps);
  if (out.uploadMs > 0) out.stages.push_back({"upload", out.uploadMs, StageKind::Rebuild});
  if (options_.twoPass) {
    stats.traversal = runTwoPass(frame, g, in, out.stages, stats);
    const auto t1 = Clock::now();
    out.totalMs = msSince(t0);
    const uint32_t pixels = g.width * g.height;
    out.mask.resize(pixels);
    if (pixels) vk::download(ctx_, visibility_, out.mask.data(), uint64_t(pixels) * 4);
    stats.readbackMs = msSince(t1);
  } else {
    stats.traversal = runSubmitted(frame, g, in, out.stages, stats, out.mask);
    out.totalMs = msSince(t0) - stats.readbackMs;
    // Where the frame's wall clock goes on the host: preparing and recording the command buffer, the one
    // submission and its wait (the GPU's work and the driver's latency), and reading the results into the
    // stats (the mask's readback excluded, as from totalMs).
    ConeFrameStats::HostSplit split;
    split.prepareAndRecord = std::chrono::duration<double, std::milli>(submitStart_ - t0).count();
    split.submitAndWait = std::chrono::duration<double, std::milli>(submitEnd_ - submitStart_).count();
    split.after = std::max(0.0, out.totalMs - split.prepareAndRecord - split.submitAndWait);
    stats.hostSplit = split;
  }
  finishFrame(out);
  return out;
}

void ConeRecorder::describeFrame(ConeFrameStats& stats, float eps) const {
  stats.triangles = layout_.triangleCount();
  stats.trianglesDropped = layout_.droppedTriangles();
  stats.triangleBuffers = layout_.triangles().size();
  stats.sorted = options_.sorted;
  stats.variant = coneVariantName(options_);
  stats.test = options_.test == ConeTest::Sphere ? "sphere" : "precise";
  stats.frontFaceCulling = options_.frontFaceCulling;
  stats.earlyAccept = options_.earlyAccept && options_.test == ConeTest::Precise;
  stats.twoPass = options_.twoPass;
  stats.epsilon = eps;
  stats.far = frame_.far;
  stats.frameScale = frame_.scale;
  if (frame_.far) {
    stats.frameSigma = frame_.sigma;
    stats.frameBeta = frame_.beta;
    stats.lightDistanceHalfDiagonals =
        frame_.distance / std::max(1e-30, 0.5 * double(glm::length(layout_.boundsHi() - layout_.boundsLo())));
  }
}

void ConeRecorder::finishFrame(Frame& out) const {
  ConeFrameStats& stats = out.stats;
  for (StageTime& st : out.stages) {  // the ray tree is the cone path's shadow structure, rebuilt every frame
    if (st.name == "build" || st.name == "rebuild") st.kind = StageKind::Rebuild;
    if (st.name == "traversal" || st.name == "leaves") st.kind = StageKind::Lookup;
  }
  if (traversal_) {
    stats.traversalMade = true;
    stats.traversalMemoryBytes = traversalMemory_;
    stats.pairCapacity = traversal_->plan().pairCapacity;
    stats.chunkCapacity = traversal_->plan().chunkCapacity;
    stats.traversalBytes = traversal_->bytesAllocated();
  }
  stats.hostPeakBytes = layout_.hostPeakBytes();
}

std::vector<ConeRecorder::Frame> ConeRecorder::runLights(std::span<const FrameInput> frames) {
  const size_t n = frames.size();
  CS_CHECK(n >= 1 && n <= kConeMaxLightsTogether,
           "cone: " << n << " lights in one frame; it takes 1 to " << kConeMaxLightsTogether);
  const FrameInput& first = frames.front();
  CS_CHECK(first.scene && first.device, "cone: the frame needs a scene and the G-buffer on the GPU");
  for (const FrameInput& f : frames)
    CS_CHECK(f.scene == first.scene && f.vk == first.vk && f.device && f.device->width == first.device->width &&
                 f.device->height == first.device->height,
             "cone: the lights of one frame share its scene, its Vulkan context and its samples' size");
  std::vector<Frame> out;
  out.reserve(n);
  auto perLight = [&](const char* why) {
    double frameMs = 0;
    for (const FrameInput& f : frames) frameMs += out.emplace_back(runFrame(f)).totalMs;
    if (n > 1)
      for (Frame& o : out) o.stats.lights = ConeFrameStats::Lights{uint32_t(n), false, why, frameMs, "its own frame's", ""};
    return std::move(out);
  };
  if (n == 1) return perLight("");
  if (options_.twoPass) return perLight("two-pass decides its update on the host between submissions: a frame a light");
  if (options_.profileStages) return perLight("--profile-stages submits every stage: a frame a light");
  CS_CHECK(first.vk == nullptr || first.vk == &ctx_, "cone: the frame's Vulkan context is not this method's");
  auto epsOf = [](const FrameInput& f) { return f.epsilon > 0 ? f.epsilon : EpsilonPolicy::forScene(*f.scene).eps; };
  const uint32_t pixels = first.device->width * first.device->height;
  const auto t0 = Clock::now();

  // Once for every light: the triangles, the per-pixel buffers, the arena; a set of cluster spheres a
  // light (written by the host at recording), and the host-visible copy of each light's mask and counters.
  const double uploadMs = layout_.upload(first);
  for (const FrameInput& f : frames) refuseUnreachableLight(f.light);  // before anything is recorded
  sizeFrameBuffers(first.device->width, first.device->height);
  if (layout_.sphereSetCount() < n) layout_.resizeSphereSets(n);
  if (lightOrders_.size() < n) lightOrders_.resize(n);
  const uint64_t stateAt = uint64_t(pixels) * 4, shapeAt = stateAt + STATE_WORDS * 4,
                 orderAt = shapeAt + SHAPE_WORDS * 4, stride = (orderAt + ORDER_WORDS * 4 + 15) & ~uint64_t(15);
  if (lightWords_.size < n * stride) {
    lightWords_.reset();
    lightWords_ = vk::createBuffer(ctx_, n * stride, vk::Memory::HostVisible);
  }
  ensureTraversal(pixels);
  if (batchesNeeded() > kConeMaxBatches)  // every light would need the chunked traversal
    return perLight("the traversal memory holds too few pairs for one recording: a frame a light");

  std::array<OrderHistory, kConeMaxLightsTogether> before;  // a light run again alone starts from its own
  std::vector<RecordedLight> recs;
  recs.reserve(n);
  timer_.restart();
  vk::Commands cmd(ctx_, &timer_);
  cmd.mark("start");
  // A far light's copy of the triangles made before the first light is recorded: what the frame holds
  // then stays, so an arena sized under a memory budget (ensureTraversal) is the same for every light.
  for (const FrameInput& f : frames) {
    chooseFrame(f.light);
    if (!frame_.far) continue;
    if (layout_.frameTrianglesStale(frame_)) layout_.recordFrameTriangles(cmd, frame_);
    break;
  }
  const traversal::Traversal* arena = nullptr;
  auto none = [](const char*) {};  // named: a Boundary refers to it, never owns it
  for (size_t l = 0; l < n; ++l) {
    const FrameInput& f = frames[l];
    before[l] = lightOrders_[l];
    const RecordedLight& rec = recs.emplace_back(recordLightFrame(cmd, *f.device, f.light, epsOf(f),
                                                                  measuresOrder(lightOrders_[l]), uint32_t(l), false, none));
    if (l == 0) arena = traversal_.get();
    CS_CHECK(traversal_.get() == arena, "cone: the arena was remade between the lights of one recording");
    Frame& o = out.emplace_back();
    describeFrame(o.stats, epsOf(f));  // frame_: this light's
    describeRecording(rec, o.stats);
    cmd.barrier();
    const uint64_t at = l * stride;
    cmd.copy(visibility_, lightWords_, stateAt, 0, at);
    cmd.copy(traversal_->stateBuffer(), lightWords_, STATE_WORDS * 4, 0, at + stateAt);
    cmd.copy(tree_.shapeBuffer(), lightWords_, SHAPE_WORDS * 4, 0, at + shapeAt);
    if (rec.adaptive) cmd.copy(orderWords_, lightWords_, ORDER_WORDS * 4, 0, at + orderAt);
    if (timer_.names.size() + 1 < timer_.capacity) cmd.mark("light");
  }
  cmd.barrier();
  cmd.submit();

  // The frame's wall clock split between the lights: by each light's GPU interval where the device's
  // timestamps are trusted, evenly elsewhere.
  std::vector<double> weight(n, 1.0 / double(n));
  std::string share = "the frame's wall clock split evenly between its lights";
  if (ctx_.timestampsTrusted()) {
    const std::vector<std::pair<std::string, double>> iv = timer_.intervals();
    double sum = 0;
    for (const auto& [name, ms] : iv) sum += ms;
    if (iv.size() == n && sum > 0) {
      for (size_t l = 0; l < n; ++l) weight[l] = iv[l].second / sum;
      share = "the frame's wall clock split between its lights by their GPU time (timestamps)";
    }
  }
  // Each light's counters and mask, read from the host-visible copy. The arena's batch learnt from the
  // light that needed the most pairs (an overflow first): it must fit them all.
  const char* words = static_cast<const char*>(lightWords_.mapped);
  auto read = [&](void* dst, uint64_t offset, uint64_t bytes) {
    std::memcpy(dst, words + offset, bytes);
    ctx_.cost.readbackBytes += bytes;
  };
  std::vector<size_t> alone;
  size_t worst = n;
  uint32_t worstPeak = 0;
  bool worstOverflow = false;
  double readbackMs = 0;
  for (size_t l = 0; l < n; ++l) {
    Frame& o = out[l];
    const RecordedLight& rec = recs[l];
    const uint64_t at = l * stride;
    uint32_t state[STATE_WORDS], shape[SHAPE_WORDS], order[ORDER_WORDS];
    read(state, at + stateAt, sizeof(state));
    read(shape, at + shapeAt, sizeof(shape));
    if (rec.adaptive) read(order, at + orderAt, sizeof(order));
    noteCounters(shape, rec.adaptive ? order : nullptr, lightOrders_[l], o.stats);
    const bool overflow = traversal::Traversal::overflowed(state);
    o.stats.traversal = traversal_->statsFromState(state, shape[SHAPE_DEPTH], overflow);
    o.stats.traversalPath = "one submission for " + std::to_string(n) + " lights";
    if (rec.onDevice && (worst == n || overflow > worstOverflow ||
                         (overflow == worstOverflow && state[STATE_PEAK_PAIRS] > worstPeak))) {
      worst = l, worstPeak = state[STATE_PEAK_PAIRS], worstOverflow = overflow;
    }
    if (!rec.onDevice || overflow) {
      alone.push_back(l);
      continue;
    }
    const auto r0 = Clock::now();
    o.mask.resize(pixels);
    read(o.mask.data(), at, stateAt);
    o.stats.readbackMs = msSince(r0);
    readbackMs += o.stats.readbackMs;
  }
  if (worst < n) {
    uint32_t state[STATE_WORDS];
    read(state, worst * stride + stateAt, sizeof(state));
    traversal_->learnBatch(state, out[worst].stats.traversal, layout_.triangleCount());
  }
  const double frameMs = msSince(t0) - readbackMs;
  for (size_t l = 0; l < n; ++l) {
    Frame& o = out[l];
    o.uploadMs = uploadMs * weight[l];
    o.totalMs = frameMs * weight[l];
    if (uploadMs > 0) o.stages.push_back({"upload", o.uploadMs, StageKind::Rebuild});
    o.stages.push_back({"frame", o.totalMs - o.uploadMs});
    o.stats.stageTiming = share;
    o.stats.lights = ConeFrameStats::Lights{uint32_t(n), true, "", frameMs, share, ""};
  }
  // A light whose traversal overflowed (or never fitted one recording) again, alone, from its own order
  // history as it stood before this frame: its mask then is a one-light frame's.
  for (size_t l : alone) {
    const OrderHistory kept = order_;
    order_ = before[l];
    Frame again = runFrame(frames[l]);
    lightOrders_[l] = order_;
    order_ = kept;
    again.totalMs += out[l].totalMs;
    again.stats.lights = out[l].stats.lights;
    again.stats.lights->alone = recs[l].onDevice ? "its pairs passed the arena on the GPU: run again alone (" +
                                                       again.stats.traversalPath + ")"
                                                 : "too many batches for one recording: run again alone (" +
                                                       again.stats.traversalPath + ")";
    for (auto it = out[l].stages.rbegin(); it != out[l].stages.rend(); ++it)
      again.stages.insert(again.stages.begin(), {"shared " + it->name, it->ms, it->kind});
    out[l] = std::move(again);
  }
  for (Frame& o : out) finishFrame(o);
  return out;
}

// The one-pass frame as one recording (traversal.h, "One submission"): recordLight and the readback,
// submitted once -- or, with profileStages, at each stage's end. Falls back to the chunked traversal
// (several submits) only when the arena holds too few pairs for the recording or overflowed on the GPU.
traversal::TraversalStats ConeRecorder::runSubmitted(const FrameInput& frame, const DeviceGBuffer& g,
                                                     const traversal::TraversalInput& in,
                                                     std::vector<StageTime>& stages, ConeFrameStats& stats,
                                                     std::vector<float>& mask) {
  const uint32_t pixels = g.width * g.height;
  const bool profile = options_.profileStages;
  timer_.restart();
  vk::Commands cmd(ctx_, &timer_);
  auto s0 = Clock::now();
  cmd.mark("start");
  std::vector<std::pair<std::string, double>> wall;  // profile: wall ms per stage, in order
  auto addWall = [&](const std::string& name, double ms) {
    for (auto& [n, v] : wall)
      if (n == name) return void(v += ms);
    wall.push_back({name, ms});
  };
  auto addTimestamps = [&] {
    for (auto& [n, ms] : timer_.intervals()) stats.addTimestamp(n, ms);
  };
  auto boundary = [&](const char* name) {
    if (!profile) {
      if (timer_.names.size() + 1 < timer_.capacity) cmd.mark(name);
      return;
    }
    cmd.mark(name);
    cmd.submit();
    addWall(name, msSince(s0));
    addTimestamps();
    timer_.restart();
    s0 = Clock::now();
    cmd.mark("start");
  };

  // The ray order: sorted, screen, or chosen on the GPU (adaptiveOrder): the screen-order tree is built
  // and measured first, and the keys, sort and rebuild cover ORDER_SORT_COUNT rays -- all of them, or
  // none, the screen-order tree then standing. After a frame that found the screen order loose, the next
  // kOrderRecheckFrames - 1 frames sort without measuring: a loose frame's check costs a tree build, and
  // the sort is slower on screen-ordered input than on row-major input.
  const bool adaptive = measuresOrder(order_);
  const RecordedLight rec = recordLightFrame(cmd, g, frame.light, in.eps, adaptive, 0, false, boundary);
  describeRecording(rec, stats);
  readback_.clear();
  const uint32_t maskSlot = readback_.add(visibility_, uint64_t(pixels) * 4);
  const uint32_t stateSlot = readback_.add(traversal_->stateBuffer(), STATE_WORDS * 4);
  const uint32_t shapeSlot = readback_.add(tree_.shapeBuffer(), SHAPE_WORDS * 4);
  const uint32_t orderSlot = adaptive ? readback_.add(orderWords_, ORDER_WORDS * 4) : 0;
  readback_.record(cmd);
  cmd.barrier();
  cmd.mark("readback");
  submitStart_ = Clock::now();
  cmd.submit();
  submitEnd_ = Clock::now();
  if (profile) addWall("readback copy", msSince(s0));
  else wall.push_back({"frame", msSince(s0)});
  addTimestamps();

  uint32_t state[STATE_WORDS], shape[SHAPE_WORDS], words[ORDER_WORDS];
  readback_.read(stateSlot, state);
  readback_.read(shapeSlot, shape);
  if (adaptive) readback_.read(orderSlot, words);
  noteCounters(shape, adaptive ? words : nullptr, order_, stats);
  const bool overflow = traversal::Traversal::overflowed(state);
  traversal::TraversalStats ts = traversal_->statsFromState(state, shape[SHAPE_DEPTH], overflow);

  stats.traversalPath = "one submission";
  auto t1 = Clock::now();
  if (!rec.onDevice || overflow) {
    // The chunked traversal (its own submits) on the tree already built: all of it when the memory bound
    // holds too few pairs for one submission; after an overflow on the GPU, from the first batch that did
    // not complete (the hits written so far are hits; the completed batches' counts are in ts).
    const uint32_t triangles = layout_.triangleCount();
    const uint32_t done = traversal::Traversal::batchesDone(state);
    const uint32_t from = !rec.onDevice ? 0 : done < batchStarts_.size() ? batchStarts_[done] : triangles;
    auto f0 = Clock::now();
    if (from < triangles) ts = combine(ts, traverse(in, from, triangles - from));
    addWall("traversal (chunked)", msSince(f0));
    stats.traversalPath =
        !rec.onDevice ? "chunked: the traversal memory holds too few pairs for one submission (" +
                            std::to_string(rec.batches) + " batches of " + std::to_string(rec.batch) + " triangles)"
                      : "chunked from triangle " + std::to_string(from) +
                            ": a step's pairs passed the arena on the GPU (the next frame's batches are smaller)";
    t1 = Clock::now();
    mask.resize(pixels);
    if (pixels) vk::download(ctx_, visibility_, mask.data(), uint64_t(pixels) * 4);
  } else {
    mask.resize(pixels);
    readback_.read(maskSlot, mask);
  }
  stats.readbackMs = msSince(t1);

  if (rec.onDevice) traversal_->learnBatch(state, ts, layout_.triangleCount());
  if (profile) {
    stats.stageTiming = "one submission per stage, host wall clock (--profile-stages)";
    for (auto& [n, ms] : wall) stages.push_back({n, ms});
  } else if (ctx_.timestampsTrusted()) {
    stats.stageTiming = "one submission; stages from GPU timestamps";
    for (const char* n : {"compact", "compact + keys", "order", "keys", "sort", "build", "traversal", "leaves"})
      if (const double* ms = stats.timestamp(n)) stages.push_back({n, *ms});
    for (auto& [n, ms] : wall)
      if (n != "frame") stages.push_back({n, ms});
  } else {
    stats.stageTiming = "one submission; the frame's wall clock (this device's timestamps are not trusted "
                        "inside a submission: --profile-stages on splits it)";
    for (auto& [n, ms] : wall) stages.push_back({n, ms});
  }
  return ts;
}

// Whether a light's frame measures its ray order (runSubmitted says when and why).
bool ConeRecorder::measuresOrder(const OrderHistory& h) const {
  return options_.sorted && options_.adaptiveOrder && !(h.loose && h.framesSinceCheck + 1 < kOrderRecheckFrames);
}

void ConeRecorder::describeRecording(const RecordedLight& rec, ConeFrameStats& stats) const {
  stats.oneSubmission = true;
  stats.clusters = rec.clusters && rec.onDevice;
  stats.lastExpansionTest = options_.sphereLastExpansion && options_.test == ConeTest::Precise ? "sphere" : "precise";
  stats.traversalBatchTriangles = rec.batch;
}

void ConeRecorder::noteCounters(const uint32_t* shape, const uint32_t* orderWords, OrderHistory& order,
                                ConeFrameStats& stats) {
  const uint32_t lit = shape[SHAPE_LEAVES];
  tree_.setShape(lit);
  stats.litSamples = lit;
  stats.raySort = raySortName();
  if (options_.sorted) stats.rayKeyBits = rays_->keyBits();
  stats.treeDepth = shape[SHAPE_DEPTH];
  stats.treeNodes = shape[SHAPE_NODES];
  if (orderWords) {
    reportOrderChoice(orderWords, shape[SHAPE_DEPTH], layout_.triangleCount(), lit, stats);
    order.loose = orderWords[ORDER_SORTED] != 0;
    order.framesSinceCheck = 0;
  } else {
    stats.rayOrder = options_.sorted ? "hilbert" : "screen";
    if (options_.sorted && options_.adaptiveOrder) {
      ++order.framesSinceCheck;
      stats.rayOrderChoice = "auto: sorted without measuring (the screen order was loose " +
                             std::to_string(order.framesSinceCheck) + " frame(s) ago; measured again every " +
                             std::to_string(kOrderRecheckFrames) + " frames)";
    }
  }
}

// How the rays are sorted on this device: the radix sort's scheme and tile (sort::sortSchemeFor,
// sortShapeFor). The key's width is "ray_key_bits" (18 in the world and in the far frame: two passes).
std::string ConeRecorder::raySortName() const {
  const sort::RadixSort& s = rays_->sorter();
  return std::string(sort::sortSchemeName(s.scheme())) + ", tiles of " + std::to_string(s.shape().threads) + " x " +
         std::to_string(s.shape().items) + " keys";
}

// What the ray keys are made from: the light, and in the far frame its rotation and the bounds'
// projection (where the frame's key grid starts; it is fitted to the rays on the device).
rays::KeysPush ConeRecorder::keysPush(glm::vec3 light) const {
  rays::KeysPush k{};
  k.light = glm::vec4(light, 1.0f);
  if (!frame_.far) return k;
  k.framed = 1u;
  k.rowX = frame_.frame.rowX, k.rowY = frame_.frame.rowY, k.rowZ = frame_.frame.rowZ;
  k.origin = frame_.frame.centre;
  k.lightFrame = frame_.frame.lightFrame;
  k.rect = frame_.keyRect;
  return k;
}

// Two-pass frames (002 §3.4): the ray stages a submission each (recordCompaction, the keys and the sort),
// timed by the host's wall clock around each submit (waits included); the lit count read back to shape
// the tree; pass one over the blockers (triangles [0, blockerCount)), the update decided on the host,
// pass two over the rest -- both passes with the chunked traversal.
traversal::TraversalStats ConeRecorder::runTwoPass(const FrameInput& frame, const DeviceGBuffer& g,
                                                   const traversal::TraversalInput& in,
                                                   std::vector<StageTime>& stages, ConeFrameStats& stats) {
  const uint32_t pixels = g.width * g.height;
  auto stage = [&](const char* name, auto&& record) {
    timer_.restart();
    vk::Commands cmd(ctx_, &timer_);
    cmd.mark("start");
    record(cmd);
    cmd.mark(name);
    auto s0 = Clock::now();
    cmd.submit();
    stages.push_back({name, msSince(s0)});
    for (auto& [n, ms] : timer_.intervals()) stats.setTimestamp(n, ms);
  };
  auto none = [](const char*) {};
  const rays::RayOrder order = options_.sorted ? rays::RayOrder::Hilbert : rays::RayOrder::ScreenMorton;
  const bool fused = fusedKeys(order);
  stage(fused ? "compact + keys" : "compact",
        [&](vk::Commands& cmd) { recordCompaction(cmd, g, frame.light, order, none); });
  if (options_.sorted) {
    if (!fused)
      stage("keys", [&](vk::Commands& cmd) { rays_->recordKeys(cmd, g, keysPush(frame.light), rays_->count()); });
    stage("sort", [&](vk::Commands& cmd) { rays_->recordSort(cmd, rays_->count()); });
  }
  const uint32_t lit = rays_->readCount();
  stats.litSamples = lit;
  stats.raySort = raySortName();
  if (options_.sorted) stats.rayKeyBits = rays_->keyBits();
  stats.traversalPath = "per-stage submits (two-pass: the update is decided on the host)";
  stats.stageTiming = "one submission per stage, host wall clock (two-pass)";
  traversal::TraversalStats ts;
  const uint32_t triangles = layout_.triangleCount(), blockers = layout_.blockerCount();
  if (lit > 0 && triangles > 0) {
    stage("build", [&](vk::Commands& cmd) {
      tree_.record(cmd, g.position, rays_->samples(), lit, frame.light, 2.0f * in.eps, &frame_);
      if (frame_.far && layout_.frameTrianglesStale(frame_)) layout_.recordFrameTriangles(cmd, frame_);
    });
    stats.treeDepth = tree_.shape().depth;
    stats.treeNodes = tree_.shape().nodes();
    ensureTraversal(pixels);
    ConeFrameStats::TwoPass tp;
    tp.blockers = blockers;
    tp.blockerSolidAngle = options_.blockerSolidAngle;
    tp.blockerMaxFraction = options_.blockerMaxFraction;
    tp.updateMinFinished = options_.updateMinFinished;
    if (blockers == 0 || blockers >= triangles) {
      // Nothing to split: one pass over every triangle (the stats say why).
      tp.update = blockers == 0 ? "none: no triangle qualifies as a blocker, one pass"
                                : "none: every triangle is a blocker, one pass";
      ts = traverse(in, 0, triangles);
    } else {
      const traversal::TraversalStats one = traverse(in, 0, blockers);
      // Update: the rays still lit, in their order.
      traversal::TraversePush p{};
      p.count = lit;
      stage("update", [&](vk::Commands& cmd) {
        const vk::Grid grid = vk::gridFor(lit, TRAVERSE_THREADS, ctx_.maxWorkgroups());
        cmd.dispatch(unfinished_, {rays_->samples(), visibility_, rayFlags_}, p, grid.x, grid.y);
        cmd.barrier();
        compact_->record(cmd, rayFlags_, sort::Count(lit), remaining_, sort::GpuWord(kept_, 0), rays_->samples());
        cmd.barrier();
      });
      uint32_t remaining = 0;
      vk::download(ctx_, kept_, &remaining, 4);
      CS_CHECK(remaining <= lit, "cone: two-pass update kept " << remaining << " of " << lit << " rays");
      const uint32_t finished = lit - remaining;
      tp.raysFinishedPassOne = finished;
      tp.raysRemaining = remaining;
      tp.passOne = one;
      traversal::TraversalStats two;
      if (remaining == 0) {
        tp.update = "done: every ray finished in pass one, no pass two";
      } else if (double(finished) < double(options_.updateMinFinished) * double(lit)) {
        // Too few finished rays for a smaller tree to pay: pass two on the first tree (002 §3.4).
        tp.update = "skipped: pass one finished too few rays, pass two reuses the first tree";
        two = traverse(in, blockers, triangles - blockers);
      } else {
        tp.update = "rebuilt";
        stage("rebuild", [&](vk::Commands& cmd) {
          tree_.record(cmd, g.position, remaining_, remaining, in.light, 2.0f * in.eps, &frame_);
        });
        tp.treeDepthPassTwo = tree_.shape().depth;
        tp.treeNodesPassTwo = tree_.shape().nodes();
        two = traverse(in, blockers, triangles - blockers);
      }
      tp.passTwo = two;
      ts = combine(one, two);
    }
    stats.twoPassDetail = tp;
  }
  stages.push_back({"traversal", ts.traversalMs});
  stages.push_back({"leaves", ts.leavesMs});
  stats.setTimestamp("traversal", ts.traversalGpuMs);
  stats.setTimestamp("leaves", ts.leavesGpuMs);
  return ts;
}

uint64_t ConeRecorder::heldBytes() const {
  return layout_.bytes() + (rays_ ? rays_->bytesAllocated() : 0) + visibility_.size + tree_.bytesAllocated() +
         (traversal_ ? traversal_->bytesAllocated() + traversal_->flagBytes() + traversal_->shadowedBytes() : 0) +
         readback_.bytesAllocated() + layout_.clusterSphereBytes() + (compact_ ? compact_->bytesAllocated() : 0) +
         rayFlags_.size + remaining_.size + kept_.size + orderWords_.size + lightWords_.size;
}

// The traversal's arena and scratch. Without a budget: --traversal-memory, made once. Under
// --memory-budget: --traversal-memory or what the budget leaves after every other buffer of this frame
// (allocated by now: triangles, rays, tree, visibility; or estimated: the cluster spheres, the readback
// copy, the early-accept flags) and the host working set, whichever is smaller; remade when that changes
// (a new resolution or scene), so a warm frame allocates nothing.
void ConeRecorder::ensureTraversal(uint32_t pixels) {
  if (!options_.memoryBudgetBytes || options_.arena.pairCapacity > 0) {
    traversalMemory_ = options_.arena.pairCapacity > 0 ? traversal_->plan().bytes : options_.traversalMemoryBytes;
    return;
  }
  const uint64_t budget = options_.memoryBudgetBytes;
  uint64_t others = heldBytes() - (traversal_ ? traversal_->bytesAllocated() + traversal_->flagBytes() +
                                                        traversal_->shadowedBytes()
                                                  : 0);
  // The leaves' hint, made at the first traversal for the rays the tree's buffer holds.
  others += traversal::Traversal::shadowedBytes(std::max<uint64_t>(tree_.rays().size / 16, pixels));
  const uint64_t spheres = layout_.expectedClusterSphereBytes() * layout_.sphereSetCount();
  others += spheres - std::min(spheres, layout_.clusterSphereBytes());
  if (!ctx_.hostVisibleDeviceLocal) {  // the mask and the counters copied for the readback (once allocated: in `others`)
    const uint64_t readback = uint64_t(pixels) * 4 + (STATE_WORDS + SHAPE_WORDS + ORDER_WORDS) * 4 + 64;
    others += readback - std::min(readback, readback_.bytesAllocated());
  }
  if (options_.earlyAccept && options_.test == ConeTest::Precise)  // a flag word per node (not in `others`)
    others += std::max<uint64_t>(tree_.nodes().size / sizeof(cone::ConeNode) * 4, traversal_ ? traversal_->flagBytes() : 0);
  const uint64_t hostPeak = layout_.hostPeakBytes();
  const uint64_t fixed = others + hostPeak;
  const uint64_t least = traversal::kMinPairs * sizeof(glm::uvec2) + traversal::chunkScratchBytes(1);
  if (fixed + least > budget)
    throw Error("--memory-budget " + byteSizeLabel(budget) + " cannot hold this frame: the cone path needs " +
                    byteSizeLabel(others) + " on the device for " + std::to_string(layout_.triangleCount()) +
                    " triangles at " + std::to_string(pixels) + " pixels, " + byteSizeLabel(hostPeak) +
                    " of host working set, and at least " + byteSizeLabel(least) + " for the traversal",
                "cone path", "give --memory-budget " + byteSizeLabel(fixed + (uint64_t(1) << 20)) +
                                 " or more (the traversal then runs chunked; more is faster), or fewer pixels");
  const uint64_t memory = std::min(options_.traversalMemoryBytes, budget - fixed);
  const traversal::ArenaPlan plan = traversal::planArena(memory, traversal::maxPairBufferBytes(ctx_));
  if (!traversal_ || traversal_->plan().pairCapacity != plan.pairCapacity ||
      traversal_->plan().chunkCapacity != plan.chunkCapacity) {
    traversal_.reset();
    traversal_ = std::make_unique<traversal::Traversal>(ctx_, memory);
  }
  traversalMemory_ = memory;
}

// Triangles [first, first + count) through the tree of `in` with the chunked traversal (its own submits),
// one run per triangle buffer; the stats summed.
traversal::TraversalStats ConeRecorder::traverse(const traversal::TraversalInput& in, uint32_t first, uint32_t count) {
  traversal::TraversalStats total;
  bool any = false;
  layout_.forEachTriangleBuffer(in, first, count, frame_, [&](const traversal::TraversalInput& part) {
    traversal::TraversalStats ts = traversal_->run(part, &timer_);
    total = any ? combine(total, ts) : ts;
    any = true;
  });
  return total;
}

}  // namespace cs
