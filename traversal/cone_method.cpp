// The cone path as a ShadowMethod (see cone_method.h).
#include "traversal/cone_method.h"
#include "traversal/cone_engine.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>

#include "conetree/conetree.h"
#include "core/error.h"
#include "raster/raster.h"
#include "method/epsilon.h"
#include "method/settings.h"
#include "rays/rays.h"
#include "traversal/frame_triangles.comp.h"
#include "traversal/order_choice.comp.h"
#include "traversal/sample_light.comp.h"
#include "traversal/instance_triangles.comp.h"
#include "traversal/unfinished_rays.comp.h"
#include "vk/context.h"

namespace cs {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

constexpr uint32_t kOne = 0x3F800000u;  // 1.0f: the visibility words start lit
constexpr uint64_t kMaxBatches = 256;    // batches one submission may hold (see runSubmitted)
constexpr uint64_t kUploadTriangles = kConeUploadTriangles;
constexpr uint32_t kOrderRecheckFrames = 8;  // adaptive order: a loose verdict holds this many frames
static_assert(kUploadTriangles % SUPER_SIZE == 0, "uploads of whole super clusters");

// Solid angle of triangle (a, b, c), vertices relative to the apex (Van Oosterom & Strackee); 0 for a
// degenerate one.
double solidAngle(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c) {
  const double la = glm::length(a), lb = glm::length(b), lc = glm::length(c);
  const double num = std::abs(glm::dot(a, glm::cross(b, c)));
  const double den = la * lb * lc + glm::dot(a, b) * lc + glm::dot(a, c) * lb + glm::dot(b, c) * la;
  const double omega = 2.0 * std::atan2(num, den);
  return std::isfinite(omega) ? std::abs(omega) : 0.0;
}

// Both passes' counts as one (the top-level stats of a two-pass frame): per-depth sums, peaks as maxima.
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

// A cluster's bounds, in its mesh's space, taken to the world by the row-major 3x4 `m` (centres in double,
// radii scaled by the Frobenius norm of the linear part, which bounds its stretch), padded by 2^-20 of the
// magnitudes so each sphere holds the vertices as the device's fp32 transform rounds them. The identity
// leaves it as it is.
bool identityTransform(const float* m) {
  static const float kId[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  return std::equal(m, m + 12, kId);
}
double stretchOf(const float* m) {
  double s = 0;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) s += double(m[4 * r + c]) * double(m[4 * r + c]);
  return std::sqrt(s);
}
glm::dvec3 transformPoint(const float* m, glm::dvec3 p) {
  return {m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
          m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]};
}
traversal::ClusterWorld transformCluster(const traversal::ClusterWorld& o, const float* m) {
  if (identityTransform(m)) return o;
  const double s = stretchOf(m), t = glm::length(glm::dvec3(m[3], m[7], m[11]));
  auto sphere = [&](glm::dvec3 c, double r) {
    const double pad = std::ldexp(s * (glm::length(c) + r) + t, -20);
    return glm::dvec4(transformPoint(m, c), r * s + pad);
  };
  traversal::ClusterWorld w;
  w.whole = sphere(glm::dvec3(o.whole), o.whole.w);
  for (uint32_t g = 0; g < CLUSTER_GROUPS; ++g) {
    const glm::dvec4 d = sphere(glm::dvec3(glm::vec3(o.groups[g])), double(o.groups[g].w));
    // fp32 storage: the centre rounds by half an ulp of its magnitude, the radius rounds up past that
    const glm::vec3 c(d);
    const double moved = glm::length(glm::dvec3(c) - glm::dvec3(d));
    w.groups[g] = glm::vec4(c, std::nextafter(float(d.w + moved), INFINITY));
  }
  return w;
}

class ConeMethod : public ShadowMethod, public ConeEngine {
 public:
  ConeMethod(vk::Context& ctx, const ConeOptions& options)
      : ctx_(ctx),
        options_(options),
        tree_(ctx),
        timer_(ctx.adopted ? vk::Timer{} : vk::createTimer(ctx, 64)) {  // the engine times nothing on the caller's device
    // Under a memory budget the arena is what the frame's other buffers leave of it (ensureTraversal).
    if (options.arena.pairCapacity > 0) traversal_ = std::make_unique<traversal::Traversal>(ctx, options.arena);
    else if (options.memoryBudgetBytes == 0)
      traversal_ = std::make_unique<traversal::Traversal>(ctx, options.traversalMemoryBytes);
    frameTris_ = vk::createKernel(ctx, "frame triangles", spv_frame_triangles_comp, 2,
                                  sizeof(traversal::FrameTrianglesPush));
    if (options_.sorted && options_.adaptiveOrder && !options_.twoPass) {
      orderChoice_ = vk::createKernel(ctx, "ray order choice", spv_order_choice_comp, 2, 0);
      orderWords_ = vk::createBuffer(ctx, ORDER_WORDS * 4);
    }
    if (options_.twoPass) unfinished_ = vk::createKernel(ctx, "unfinished rays", spv_unfinished_rays_comp, 3,
                                                         sizeof(traversal::TraversePush));
  }

  std::string name() const override { return "cone"; }

  // ---- the engine (cone_engine.h) ----

  // Sets up the engine's frames: framesInFlight stats slots and sphere sets of maxLights each.
  void enableEngine(uint32_t framesInFlight, uint32_t maxLights) {
    CS_CHECK(!options_.twoPass, "the two-pass variants decide their update on the host between the passes: the engine "
                                "records one-pass variants only (PreciseEA, PreciseSEA and the others)");
    CS_CHECK(framesInFlight >= 1 && framesInFlight <= 4, "frames in flight " << framesInFlight << ", not 1..4");
    CS_CHECK(maxLights >= 1 && maxLights <= 64, "lights a frame " << maxLights << ", not 1..64");
    framesInFlight_ = framesInFlight;
    maxLights_ = maxLights;
    sampleLight_ = vk::createKernel(ctx_, "sample light", spv_sample_light_comp, 4, sizeof(traversal::SampleLightPush));
    instanceTriangles_ = vk::createKernel(ctx_, "instance triangles", spv_instance_triangles_comp, 4,
                                          sizeof(traversal::TraversePush));
    statsRing_ = vk::createBuffer(ctx_, uint64_t(framesInFlight) * maxLights * kStatsWords * 4, vk::Memory::HostVisible);
    std::memset(statsRing_.mapped, 0, statsRing_.size);
    slots_.clear();
    slots_.resize(framesInFlight);
    sphereSets_.resize(size_t(framesInFlight) * maxLights);
  }

  void setGeometry(const Scene& scene, const GeometryRevision& revision) override {
    FrameInput frame;
    frame.scene = &scene;
    frame.revision = revision;
    uploadTriangles(frame);
  }

  void record(vk::Commands& cmd, const DeviceGBuffer& g, std::span<const glm::vec3> lights, float eps, uint64_t frame,
              const std::function<void(uint32_t, const vk::Buffer&)>& deliver) override {
    CS_CHECK(maxLights_ > 0, "cone: the engine was not set up (enableEngine)");
    CS_CHECK(!lights.empty() && lights.size() <= maxLights_,
             lights.size() << " lights in a frame; this context takes 1 to " << maxLights_);
    CS_CHECK(!triangles_.empty(), "a frame recorded before any geometry was set");
    for (glm::vec3 light : lights) refuseUnreachableLight(light);  // before anything is recorded
    const uint32_t slot = uint32_t(frame % framesInFlight_);
    learnFromSlot(slot);  // the frame that held the slot has completed (the contract)
    EngineSlot& es = slots_[slot];
    es.staged = vk::recordPendingUploads(ctx_, cmd);  // kept until the slot is reused
    es.retired = std::move(retiring_);                 // buffers a replaced geometry left: freed with the slot
    retiring_.clear();
    if (transformsDirty_) recordTransforms(cmd, slot);
    const uint32_t pixels = g.width * g.height;
    sizeFrameBuffers(g.width, g.height);
    ensureTraversal(pixels);
    es.frame = frame;
    es.lights.assign(lights.size(), EngineSlot::Light{});
    es.learned = false;
    auto noBoundary = [](const char*) {};
    const vk::Grid grid = vk::gridFor(std::max(pixels, 1u), TRAVERSE_THREADS, ctx_.maxWorkgroups());
    for (uint32_t l = 0; l < lights.size(); ++l) {
      const glm::vec3 light = lights[l];
      cmd.barrier();  // the previous light's reads of every buffer reused below are done
      frame_ = cone::chooseFrame(light, boundsLo_, boundsHi_);
      const traversal::TraversalInput in = traversalInput(light, eps);
      traversal::SampleLightPush push{};
      push.light = glm::vec4(light, 1.0f);
      push.count = pixels;
      push.mode = SAMPLE_LIGHT_TERM;
      cmd.dispatch(sampleLight_, {g.position, g.normal, visibility_, visibility_}, push, grid.x, grid.y);
      cmd.barrier();
      const RecordedLight rec = recordLight(cmd, g, in, light, options_.sorted && options_.adaptiveOrder,
                                            slot * maxLights_ + l, noBoundary);
      if (!rec.onDevice)
        throw Error("the traversal's memory holds too few pairs to record the frame (" + std::to_string(rec.batches) +
                        " batches of " + std::to_string(rec.batch) + " triangles; one frame records at most " +
                        std::to_string(kMaxBatches) + ")",
                    "cone engine", "give a larger memory budget");
      cmd.barrier();
      push.mode = SAMPLE_UNDECIDED;
      cmd.dispatch(sampleLight_, {g.position, g.normal, visibility_, traversal_->stateBuffer()}, push, grid.x, grid.y);
      cmd.barrier();
      deliver(l, visibility_);
      const uint64_t at = (uint64_t(slot) * maxLights_ + l) * kStatsWords * 4;
      cmd.copy(traversal_->stateBuffer(), statsRing_, STATE_WORDS * 4, 0, at);
      cmd.copy(tree_.shapeBuffer(), statsRing_, SHAPE_WORDS * 4, 0, at + STATE_WORDS * 4);
      es.lights[l].clusters = rec.clusters;
    }
    cmd.barrier();  // the stats words visible to the host once the caller's submission completes
  }

  std::vector<EngineLightStats> stats(uint64_t frame) override {
    std::vector<EngineLightStats> out;
    if (framesInFlight_ == 0) return out;
    const uint32_t slot = uint32_t(frame % framesInFlight_);
    const EngineSlot& es = slots_[slot];
    if (es.frame != frame) return out;
    for (uint32_t l = 0; l < es.lights.size(); ++l) {
      const uint32_t* state = statsWords(slot, l);
      const uint32_t* shape = state + STATE_WORDS;
      const bool overflow = traversal::Traversal::overflowed(state);
      const traversal::TraversalStats ts = traversal_->statsFromState(state, shape[SHAPE_DEPTH], overflow);
      EngineLightStats st;
      st.litSamples = shape[SHAPE_LEAVES];
      st.treeDepth = shape[SHAPE_DEPTH];
      st.treeNodes = shape[SHAPE_NODES];
      st.pairsTested = ts.pairsTested();
      st.pairsSurvived = ts.pairsSurvived();
      st.leafTests = ts.leafTests;
      st.complete = !overflow;
      out.push_back(st);
    }
    return out;
  }

  uint64_t bytesAllocated() const override { return heldBytes() + statsRing_.size; }

  // ---- the engine's meshes and instances (cone_engine.h) ----

  void setInstances(std::span<const EngineMesh> meshes, std::span<const EngineInstance> instances) override {
    // Each used mesh's kept triangles (finite) in Hilbert order of their centroids over its own bounds.
    std::vector<std::vector<uint32_t>> order(meshes.size());
    std::vector<glm::vec3> meshLo(meshes.size(), glm::vec3(INFINITY)), meshHi(meshes.size(), glm::vec3(-INFINITY));
    std::vector<uint8_t> used(meshes.size(), 0);
    for (const EngineInstance& inst : instances) {
      CS_CHECK(inst.mesh < meshes.size(), "instance of mesh " << inst.mesh << " of " << meshes.size());
      used[inst.mesh] = 1;
    }
    uint64_t dropped = 0;
    for (size_t m = 0; m < meshes.size(); ++m) {
      if (!used[m]) continue;
      const EngineMesh& mesh = meshes[m];
      auto vertex = [&](uint32_t t, int k) { return mesh.positions[mesh.indices[3 * size_t(t) + k]]; };
      std::vector<uint32_t>& kept = order[m];
      for (size_t t = 0; t < mesh.indexCount / 3; ++t) {
        const glm::vec3 a = vertex(uint32_t(t), 0), b = vertex(uint32_t(t), 1), c = vertex(uint32_t(t), 2);
        auto finite = [](glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
        if (!(finite(a) && finite(b) && finite(c))) {
          ++dropped;
          continue;
        }
        kept.push_back(uint32_t(t));
        meshLo[m] = glm::min(meshLo[m], glm::min(a, glm::min(b, c)));
        meshHi[m] = glm::max(meshHi[m], glm::max(a, glm::max(b, c)));
      }
      if (kept.empty()) continue;
      boundsLo_ = meshLo[m], boundsHi_ = meshHi[m];  // orderForClusters reads the bounds
      std::vector<uint32_t> none;
      orderForClusters(kept, none, vertex);
    }
    // Slots: each instance's run, padded to whole super clusters (with its last triangle again) but the last.
    std::vector<InstanceRun> runs;
    uint64_t total = 0;
    for (size_t i = 0; i < instances.size(); ++i) {
      const uint64_t count = order[instances[i].mesh].size();
      const bool last = i + 1 == instances.size();
      const uint64_t padded = last || count == 0 ? count : (count + SUPER_SIZE - 1) / SUPER_SIZE * SUPER_SIZE;
      runs.push_back({instances[i].mesh, total, count, padded, meshLo[instances[i].mesh], meshHi[instances[i].mesh]});
      total += padded;
    }
    if (total > UINT32_MAX)
      throw Error(std::to_string(total) + " triangle slots in the instances", "cone engine", "at most 2^32 - 1 a scene");
    retireGeometry();
    triangleCount_ = uint32_t(total);
    droppedTriangles_ = dropped;
    planChunks();
    const size_t chunks = std::max<size_t>(1, (total + chunkTriangles_ - 1) / chunkTriangles_);
    objectClusters_.assign((total + CLUSTER_SIZE - 1) / CLUSTER_SIZE, traversal::ClusterWorld{});
    clusterInstance_.assign(objectClusters_.size(), 0);
    triangles_.resize(chunks);
    objectTriangles_.resize(chunks);
    slotInstance_.resize(chunks);
    // The slot's mesh triangle, in order: instance by instance, padding repeating the run's last one.
    size_t run = 0;
    auto slotSource = [&](uint64_t slot, uint32_t& inst) -> const EngineMesh* {
      while (run < runs.size() && slot >= runs[run].first + runs[run].padded) ++run;
      inst = uint32_t(run);
      return &meshes[runs[run].mesh];
    };
    for (size_t c = 0; c < chunks; ++c) {
      const uint64_t first = uint64_t(c) * chunkTriangles_;
      const uint64_t count = std::min<uint64_t>(chunkTriangles_, total - std::min<uint64_t>(first, total));
      const uint64_t bytes = std::max<uint64_t>(count * 48, 16);
      triangles_[c] = vk::createBuffer(ctx_, bytes);
      objectTriangles_[c] = vk::createBuffer(ctx_, bytes);
      slotInstance_[c] = vk::createBuffer(ctx_, std::max<uint64_t>(count * 4, 16));
      if (count == 0) continue;
      std::vector<uint32_t> ids(count);
      vk::uploadInPlace(ctx_, objectTriangles_[c], count * 48, 0, [&](void* out) {
        glm::vec4 cluster[3 * CLUSTER_SIZE];
        for (uint64_t t = 0; t < count; t += CLUSTER_SIZE) {
          const uint64_t k = std::min<uint64_t>(CLUSTER_SIZE, count - t);
          uint32_t inst = 0;
          for (uint64_t j = 0; j < k; ++j) {
            const EngineMesh* mesh = slotSource(first + t + j, inst);
            const InstanceRun& r = runs[inst];
            const uint64_t within = std::min(first + t + j - r.first, r.count - 1);
            const uint32_t tri = order[r.mesh][within];
            for (int v = 0; v < 3; ++v) cluster[3 * j + v] = glm::vec4(mesh->positions[mesh->indices[3 * size_t(tri) + v]], 1.0f);
            ids[t + j] = inst;
          }
          const uint64_t index = (first + t) / CLUSTER_SIZE;
          objectClusters_[index] = traversal::clusterWorld(cluster, k);
          clusterInstance_[index] = inst;  // a cluster never mixes instances (runs are padded)
          std::memcpy(static_cast<glm::vec4*>(out) + 3 * t, cluster, 3 * k * sizeof(glm::vec4));
        }
      });
      vk::upload(ctx_, slotInstance_[c], ids.data(), count * 4);
    }
    runs_ = std::move(runs);
    transformRing_ = vk::createBuffer(ctx_, std::max<uint64_t>(uint64_t(framesInFlight_) * runs_.size() * 64, 16),
                                      vk::Memory::HostVisible);
    revision_ = {};
    hostPeakBytes_ = objectClusters_.size() * (sizeof(traversal::ClusterWorld) * 2 + 4);
    setTransforms(instances);
  }

  void setTransforms(std::span<const EngineInstance> instances) override {
    CS_CHECK(instances.size() == runs_.size(), "cone engine: " << instances.size() << " transforms for "
                                                               << runs_.size() << " instances");
    glm::dvec3 lo(INFINITY), hi(-INFINITY);
    for (size_t i = 0; i < runs_.size(); ++i) {
      std::memcpy(runs_[i].transform, instances[i].transform, sizeof(runs_[i].transform));
      const InstanceRun& r = runs_[i];
      if (r.count == 0) continue;
      for (int corner = 0; corner < 8; ++corner) {
        const glm::dvec3 p((corner & 1) ? r.lo.x : r.hi.x, (corner & 2) ? r.lo.y : r.hi.y, (corner & 4) ? r.lo.z : r.hi.z);
        const glm::dvec3 w = identityTransform(r.transform) ? p : transformPoint(r.transform, p);
        const double pad = identityTransform(r.transform) ? 0 : std::ldexp(glm::length(w) + stretchOf(r.transform), -20);
        lo = glm::min(lo, w - pad), hi = glm::max(hi, w + pad);
      }
    }
    const bool any = lo.x <= hi.x;
    const auto down = [](double v) { const float f = float(v); return double(f) > v ? std::nextafter(f, -INFINITY) : f; };
    const auto up = [](double v) { const float f = float(v); return double(f) < v ? std::nextafter(f, INFINITY) : f; };
    boundsLo_ = any ? glm::vec3(down(lo.x), down(lo.y), down(lo.z)) : glm::vec3(0);
    boundsHi_ = any ? glm::vec3(up(hi.x), up(hi.y), up(hi.z)) : glm::vec3(0);
    clusterWorld_.resize(objectClusters_.size());
    for (size_t c = 0; c < objectClusters_.size(); ++c)
      clusterWorld_[c] = transformCluster(objectClusters_[c], runs_[clusterInstance_[c]].transform);
    transformsDirty_ = true;
    uploads_++;  // the spheres and far-frame triangles made for the old triangles are stale
  }

  void bounds(glm::vec3& lo, glm::vec3& hi) const override { lo = boundsLo_, hi = boundsHi_; }

  // One frame, as named steps: the scene's triangles (uploaded when they changed), the light checked, the
  // frame's buffers sized, the cones' frame chosen; then the frame itself -- one submission, or the
  // two-pass variant's staged submits -- and its output.
  MethodOutput run(const FrameInput& frame) override {
    CS_CHECK(frame.scene && frame.device, "cone: the frame needs a scene and the G-buffer on the GPU");
    CS_CHECK(frame.vk == nullptr || frame.vk == &ctx_, "cone: the frame's Vulkan context is not this method's");
    const DeviceGBuffer& g = *frame.device;
    const uint32_t pixels = g.width * g.height;
    const float eps = frame.epsilon > 0 ? frame.epsilon : EpsilonPolicy::forScene(*frame.scene).eps;
    const auto t0 = Clock::now();

    const double uploadMs = uploadTriangles(frame);
    refuseUnreachableLight(frame.light);
    sizeFrameBuffers(g.width, g.height);
    // The frame of the cones: world, or for a light far outside the triangles' bounds the far-light frame
    // (traversal.h): the keys, the tree and the pass tests in it, the leaves in the world.
    frame_ = cone::chooseFrame(frame.light, boundsLo_, boundsHi_);
    nlohmann::json stats = settingsStats(eps);
    const traversal::TraversalInput in = traversalInput(frame.light, eps);

    std::vector<StageTime> stages;
    if (uploadMs > 0) stages.push_back({"upload", uploadMs, StageKind::Rebuild});
    nlohmann::json timestamps = nlohmann::json::object();
    MethodOutput out;
    double readbackMs = 0;  // the mask's copy into out.visibility, and that vector's allocation: not in totalMs
    traversal::TraversalStats ts;
    if (options_.twoPass) {
      ts = runStaged(frame, g, in, stages, timestamps, stats);
      const auto t1 = Clock::now();
      out.totalMs = msSince(t0);
      out.visibility.resize(pixels);
      if (pixels) vk::download(ctx_, visibility_, out.visibility.data(), uint64_t(pixels) * 4);
      readbackMs = msSince(t1);
    } else {
      ts = runSubmitted(frame, g, in, stages, timestamps, stats, out.visibility, readbackMs);
      out.totalMs = msSince(t0) - readbackMs;
      // Where the frame's wall clock goes on the host: preparing and recording the command buffer, the
      // one submission and its wait (the GPU's work and the driver's latency), and reading the results
      // into the stats (the mask's readback excluded, as from totalMs).
      const double recordMs = std::chrono::duration<double, std::milli>(submitStart_ - t0).count();
      const double submitMs = std::chrono::duration<double, std::milli>(submitEnd_ - submitStart_).count();
      stats["host_split_ms"] = {{"prepare_and_record", recordMs},
                                {"submit_and_wait", submitMs},
                                {"after", std::max(0.0, out.totalMs - recordMs - submitMs)}};
    }
    // The words hold 1.0f or 0.0f bits; nothing else is ever written, so no NaN or inf can appear.
    stats["readback_ms"] = readbackMs;
    stats["timestamp_ms"] = timestamps;
    finishOutput(out, ts, std::move(stages), std::move(stats));
    return out;
  }

 private:
  // A light too far for fp32 ray lengths would give a silently wrong mask: refuse it (epsilon.h).
  void refuseUnreachableLight(glm::vec3 light) const {
    if (std::string why = lightRangeProblem(light, boundsLo_, boundsHi_); !why.empty())
      throw Error(why, "cone path", "the limit is 2^62, documented in docs/LIMITS.md");
  }

  // The per-pixel buffers (the rays, the two-pass variant's update, the visibility words) for a G-buffer
  // of width x height; kept while the size stays.
  void sizeFrameBuffers(uint32_t width, uint32_t height) {
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

  // The stats that describe the frame's settings and geometry (the traversal's counters come later).
  nlohmann::json settingsStats(float eps) const {
    nlohmann::json stats = {{"triangles", triangleCount_},
                            {"triangles_dropped", droppedTriangles_},
                            {"triangle_buffers", triangles_.size()},
                            {"sorted", options_.sorted},
                            {"variant", coneVariantName(options_)},
                            {"test", options_.test == ConeTest::Sphere ? "sphere" : "precise"},
                            {"front_face_culling", options_.frontFaceCulling},
                            {"early_accept", options_.earlyAccept && options_.test == ConeTest::Precise},
                            {"two_pass", options_.twoPass},
                            {"epsilon", eps},
                            {"frame", frame_.far ? "far" : "world"},
                            {"frame_scale", frame_.scale}};
    if (frame_.far) {
      stats["frame_sigma"] = frame_.sigma;
      stats["frame_beta"] = frame_.beta;
      stats["light_distance_half_diagonals"] =
          frame_.distance / std::max(1e-30, 0.5 * double(glm::length(boundsHi_ - boundsLo_)));
    }
    return stats;
  }

  // What the traversal reads for this frame: the tree (with its sorted rays: positions and pixels), the
  // visibility words, the light, epsilon and the variant's tests.
  traversal::TraversalInput traversalInput(glm::vec3 light, float eps) {
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
    in.leafRays = options_.leafRays;
    in.leafChoiceCosts = options_.leafChoiceCosts;
    in.leafTest = options_.leafTestFromLight ? traversal::leafTestFor(frame_.far, boundsLo_, boundsHi_, light)
                                             : traversal::LeafTest::TwoEnds;
    in.superClusters = options_.superClusters;
    return in;
  }

  // The output's stages, work, bytes and the traversal's counters; the memory budget checked.
  void finishOutput(MethodOutput& out, const traversal::TraversalStats& ts, std::vector<StageTime> stages,
                    nlohmann::json stats) {
    for (StageTime& st : stages) {  // the ray tree is the cone path's shadow structure, rebuilt every frame
      if (st.name == "build" || st.name == "rebuild") st.kind = StageKind::Rebuild;
      if (st.name == "traversal" || st.name == "leaves") st.kind = StageKind::Lookup;
    }
    double stageMs = 0;
    for (auto& st : stages) stageMs += st.ms;
    stats["stages_ms"] = stageMs;
    stats["traversal"] = ts.toJson();
    stats["pairs_tested"] = ts.pairsTested();
    stats["pairs_survived"] = ts.pairsSurvived();
    stats["leaf_tests"] = ts.leafTests;
    stats["leaf_rays"] = ts.leafRays;
    stats["leaf_test"] = traversal::leafTestName(ts.leafTest);
    stats["early_accepted_nodes"] = ts.earlyAccepted;
    stats["traversal_peak_bytes"] = ts.peakBytes;
    if (traversal_) {
      stats["traversal_memory_bytes"] = traversalMemory_;
      stats["pair_capacity"] = traversal_->plan().pairCapacity;
      stats["chunk_capacity"] = traversal_->plan().chunkCapacity;
      stats["traversal_bytes"] = traversal_->bytesAllocated();
    }
    out.work = std::to_string(ts.pairsTested()) + " nodes visited, " + std::to_string(ts.leafTests) + " leaf tests";
    out.stages = std::move(stages);
    out.stats = std::move(stats);
    out.bytesAllocated = heldBytes();
    // Working set: everything resident for the frame, with the traversal's share at its measured peak.
    out.peakBytes = out.bytesAllocated - (traversal_ ? traversal_->bytesAllocated() : 0) + ts.peakBytes;
    // The budget (--memory-budget) holds the device buffers as allocated (the arena whole, not its peak)
    // and the host working set of the upload; ensureTraversal() planned the arena to make it hold.
    out.stats["host_peak_bytes"] = hostPeakBytes_;
    if (options_.memoryBudgetBytes) {
      const uint64_t used = out.bytesAllocated + hostPeakBytes_;
      out.stats["memory_budget_bytes"] = options_.memoryBudgetBytes;
      out.stats["memory_budget_used_bytes"] = used;
      CS_CHECK(used <= options_.memoryBudgetBytes, "cone: the frame held " << used << " bytes, over its --memory-budget of "
                                                                          << options_.memoryBudgetBytes);
    }
  }

  // What recordLight recorded: the ray order's choice, whether the traversal is in the recording (an arena so
  // small that the batches would number in the hundreds is traversed chunked after it), the batches.
  struct RecordedLight {
    bool adaptive = false, clusters = false, onDevice = true;
    std::vector<uint32_t> batchStarts;
    uint64_t batches = 0;
    uint32_t batch = 0;
  };

  // One light's frame into `cmd`: the visibility words set to lit, the lit samples' compaction, the ray
  // order (sorted, screen, or measured on the GPU when `adaptive`), keys, sort, the tree, the far frame's
  // triangles, the traversal and the leaves (the mask in visibility_). boundary(name) ends each stage.
  template <class Boundary>
  RecordedLight recordLight(vk::Commands& cmd, const DeviceGBuffer& g, const traversal::TraversalInput& in,
                            glm::vec3 light, bool adaptive, uint32_t sphereSlot, Boundary&& boundary) {
    const uint32_t pixels = g.width * g.height;
    const rays::RayOrder order =
        options_.sorted && !adaptive ? rays::RayOrder::Hilbert : rays::RayOrder::ScreenMorton;
    const uint32_t maxRays = std::max(pixels, 1u);
    cmd.fill(visibility_, kOne, 0, uint64_t(pixels) * 4);
    // Sorted without measuring: compaction and keys fused (LitRays::recordCompactionWithKeys), one stage.
    const bool fused = order == rays::RayOrder::Hilbert && rays_->fusedKeys();
    if (fused) {
      rays_->recordCompactionWithKeys(cmd, g, keysPush(light));
      boundary("compact + keys");
    } else {
      rays_->recordCompaction(cmd, g, order);
      boundary("compact");
    }
    sort::Count sortCount = rays_->count();
    if (adaptive) {
      tree_.recordDevice(cmd, g.position, rays_->samples(), rays_->countBuffer(), 0, maxRays, light,
                         2.0f * in.eps, &frame_);
      cmd.fill(orderWords_, 0);
      cmd.barrier();
      tree_.recordSpread(cmd, orderWords_, ORDER_SPREAD, frame_.scale);
      cmd.dispatch(orderChoice_, {tree_.shapeBuffer(), orderWords_}, static_cast<const void*>(nullptr), 0u, 1u, 1u, 1u);
      cmd.barrier();
      boundary("order");
      sortCount = sort::Count::device(sort::GpuWord(orderWords_, ORDER_SORT_COUNT), maxRays);
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
                         2.0f * in.eps, &frame_, /*keepWhenZero=*/true);
    else
      tree_.recordDevice(cmd, g.position, rays_->samples(), rays_->countBuffer(), 0, maxRays, light,
                         2.0f * in.eps, &frame_, /*keepWhenZero=*/false, recordsGiven);
    if (frame_.far && frameTrianglesStale()) recordFrameTriangles(cmd);
    boundary("build");
    ensureTraversal(pixels);
    const bool clusters = options_.clusters && traversal_->clustersFit() && chunkTriangles_ >= CLUSTER_SIZE;
    if (clusters) updateClusterSpheres(light, sphereSlot);
    traversal_->recordBegin(cmd, in);
    RecordedLight rec;
    rec.adaptive = adaptive;
    rec.clusters = clusters;
    std::vector<uint32_t>& batchStarts = rec.batchStarts;  // scene index of each batch's first triangle, in order
    const uint32_t batch = traversal_->batchTriangles();
    uint64_t& batches = rec.batches;
    rec.batch = batch;
    forEachTriangleBuffer(in, 0, triangleCount_, [&](const traversal::TraversalInput& part) {
      batches += (uint64_t(part.triangleCount) + batch - 1) / batch;
    });
    // An arena so small that the batches would number in the hundreds (each ~10 dispatches a depth) is
    // traversed chunked instead, after the submission.
    const bool onDevice = rec.onDevice = batches <= kMaxBatches;
    if (onDevice)
      forEachTriangleBuffer(in, 0, triangleCount_, [&](traversal::TraversalInput part) {
        const size_t b = size_t(part.triangles - triangles_.data());
        if (clusters) part.clusterSpheres = &sphereSets_[sphereSlot].buffers[b];
        for (uint32_t first : traversal_->record(cmd, part, boundary)) batchStarts.push_back(uint32_t(b) * chunkTriangles_ + first);
      });
    if (onDevice) {
      // The hits of the batches that completed (all of them but after an overflow, which the chunked
      // traversal below resumes) into the visibility.
      traversal_->recordEnd(cmd, in);
      boundary("leaves");
    }
    return rec;
  }

  // The frame as one recording (traversal.h, "One submission"): compaction, keys, sort, the tree's shape
  // and build, the far frame's triangles, the traversal and the readback, submitted once -- or, with
  // profileStages, submitted at each stage's end. Falls back to the chunked traversal (several submits)
  // only when the pair arena overflowed on the GPU. Fills `mask`; the readback's wall time to readbackMs.
  traversal::TraversalStats runSubmitted(const FrameInput& frame, const DeviceGBuffer& g, traversal::TraversalInput in,
                                         std::vector<StageTime>& stages, nlohmann::json& timestamps,
                                         nlohmann::json& stats, std::vector<float>& mask, double& readbackMs) {
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
      for (auto& [n, ms] : timer_.intervals()) timestamps[n] = timestamps.value(n, 0.0) + ms;
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
    // none, the screen-order tree then standing. After a frame that found the screen order loose, the
    // next kOrderRecheckFrames - 1 frames sort without measuring: a loose frame's check costs a tree
    // build, and the sort is slower on screen-ordered input than on row-major input.
    const bool adaptive = options_.sorted && options_.adaptiveOrder &&
                          !(orderLoose_ && framesSinceOrderCheck_ + 1 < kOrderRecheckFrames);
    const RecordedLight rec = recordLight(cmd, g, in, frame.light, adaptive, 0, boundary);
    const bool clusters = rec.clusters, onDevice = rec.onDevice;
    const std::vector<uint32_t>& batchStarts = rec.batchStarts;
    const uint32_t batch = rec.batch;
    const uint64_t batches = rec.batches;
    stats["clusters"] = clusters && onDevice;
    stats["last_expansion_test"] = options_.sphereLastExpansion && options_.test == ConeTest::Precise ? "sphere" : "precise";
    // a lane per cluster pair or per triangle pair, where that expansion runs in the sphere-test kernel
    stats["last_expansion_lanes"] = traversal::expansionLanesName(traversal_->lastExpansionLanes());
    stats["traversal_batch_triangles"] = batch;
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

    uint32_t state[STATE_WORDS], shape[SHAPE_WORDS];
    readback_.read(stateSlot, state);
    readback_.read(shapeSlot, shape);
    const uint32_t lit = shape[SHAPE_LEAVES];
    tree_.setShape(lit);
    stats["lit_samples"] = lit;
    stats["ray_sort"] = raySortName();
    if (options_.sorted) stats["ray_key_bits"] = rays_->keyBits();
    stats["tree_depth"] = shape[SHAPE_DEPTH];
    stats["tree_nodes"] = shape[SHAPE_NODES];
    if (adaptive) {
      uint32_t words[ORDER_WORDS];
      readback_.read(orderSlot, words);
      reportOrderChoice(words, shape[SHAPE_DEPTH], stats);
      orderLoose_ = words[ORDER_SORTED] != 0;
      framesSinceOrderCheck_ = 0;
    } else {
      stats["ray_order"] = options_.sorted ? "hilbert" : "screen";
      if (options_.sorted && options_.adaptiveOrder) {
        ++framesSinceOrderCheck_;
        stats["ray_order_choice"] = "auto: sorted without measuring (the screen order was loose " +
                                    std::to_string(framesSinceOrderCheck_) + " frame(s) ago; measured again every " +
                                    std::to_string(kOrderRecheckFrames) + " frames)";
      }
    }
    const bool overflow = traversal::Traversal::overflowed(state);
    traversal::TraversalStats ts = traversal_->statsFromState(state, shape[SHAPE_DEPTH], overflow);

    stats["traversal_path"] = "one submission";
    auto t1 = Clock::now();
    if (!onDevice || overflow) {
      // The chunked traversal (its own submits) on the tree already built: all of it when the memory
      // bound holds too few pairs for one submission; after an overflow on the GPU, from the first batch
      // that did not complete (the hits written so far are hits; the completed batches' counts are in ts).
      const uint32_t done = traversal::Traversal::batchesDone(state);
      const uint32_t from = !onDevice ? 0 : done < batchStarts.size() ? batchStarts[done] : triangleCount_;
      auto f0 = Clock::now();
      if (from < triangleCount_) ts = combine(ts, traverse(in, from, triangleCount_ - from));
      addWall("traversal (chunked)", msSince(f0));
      stats["traversal_path"] =
          !onDevice ? "chunked: the traversal memory holds too few pairs for one submission (" + std::to_string(batches) +
                          " batches of " + std::to_string(batch) + " triangles)"
                    : "chunked from triangle " + std::to_string(from) +
                          ": a step's pairs passed the arena on the GPU (the next frame's batches are smaller)";
      t1 = Clock::now();
      mask.resize(pixels);
      if (pixels) vk::download(ctx_, visibility_, mask.data(), uint64_t(pixels) * 4);
    } else {
      mask.resize(pixels);
      readback_.read(maskSlot, mask);
    }
    readbackMs = msSince(t1);

    if (onDevice) traversal_->learnBatch(state, ts, triangleCount_);
    if (profile) {
      stats["stage_timing"] = "one submission per stage, host wall clock (--profile-stages)";
      for (auto& [n, ms] : wall) stages.push_back({n, ms});
    } else if (ctx_.timestampsTrusted()) {
      stats["stage_timing"] = "one submission; stages from GPU timestamps";
      for (const char* n : {"compact", "compact + keys", "keys", "sort", "build", "traversal", "leaves"})
        if (timestamps.contains(n)) stages.push_back({n, timestamps[n].get<double>()});
      for (auto& [n, ms] : wall)
        if (n != "frame") stages.push_back({n, ms});
    } else {
      stats["stage_timing"] = "one submission; the frame's wall clock (this device's timestamps are not trusted "
                              "inside a submission: --profile-stages on splits it)";
      for (auto& [n, ms] : wall) stages.push_back({n, ms});
    }
    return ts;
  }

  // How the rays are sorted on this device: the radix sort's scheme and tile (sort::sortSchemeFor,
  // sortShapeFor). The key's width is "ray_key_bits" (18 in the world frame: two passes; 31 in the far
  // frame: four).
  std::string raySortName() const {
    const sort::RadixSort& s = rays_->sorter();
    return std::string(sort::sortSchemeName(s.scheme())) + ", tiles of " + std::to_string(s.shape().threads) + " x " +
           std::to_string(s.shape().items) + " keys";
  }

  // The GPU's choice of ray order in the stats: the order, and the screen-order tree's spread per depth
  // (sum of 1 - cos(half-angle), order_choice.comp) that decided it.
  static void reportOrderChoice(const uint32_t* words, uint32_t depth, nlohmann::json& stats) {
    stats["ray_order"] = words[ORDER_SORTED] ? "hilbert" : "screen";
    nlohmann::json spread = nlohmann::json::array();
    double top = 0, deep = 0;
    for (uint32_t d = 0; d < depth && d <= SHAPE_MAX_DEPTH; ++d) {
      const uint64_t v = uint64_t(words[ORDER_SPREAD + 2 * d]) | (uint64_t(words[ORDER_SPREAD + 2 * d + 1]) << 32);
      const double sr = 2.0 * M_PI * double(v) / double(CONE_SPREAD_UNIT);
      spread.push_back(sr);
      (d < ORDER_TOP_DEPTHS ? top : deep) = std::max(d < ORDER_TOP_DEPTHS ? top : deep, sr);
    }
    stats["ray_order_choice"] = "auto: measured this frame";
    stats["screen_tree_solid_angle_sr"] = spread;  // per depth, the sum over its cones
    stats["screen_tree_looseness"] = top > 0 ? deep / top : 0.0;  // > ORDER_LOOSE_RATIO: sorted
  }

  // What the ray keys are made from: the light, and in the far frame its rotation and the bounds'
  // projection.
  rays::KeysPush keysPush(glm::vec3 light) const {
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

  // Two-pass frames (002 §3.4): each stage its own submit, timed by the host's wall clock around it (waits
  // included), the lit count read back to shape the tree and the update decided on the host.
  traversal::TraversalStats runStaged(const FrameInput& frame, const DeviceGBuffer& g, traversal::TraversalInput in,
                                      std::vector<StageTime>& stages, nlohmann::json& timestamps,
                                      nlohmann::json& stats) {
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
      for (auto& [n, ms] : timer_.intervals()) timestamps[n] = ms;
    };
    const rays::RayOrder order = options_.sorted ? rays::RayOrder::Hilbert : rays::RayOrder::ScreenMorton;
    const bool fused = order == rays::RayOrder::Hilbert && rays_->fusedKeys();
    stage(fused ? "compact + keys" : "compact", [&](vk::Commands& cmd) {
      cmd.fill(visibility_, kOne, 0, uint64_t(pixels) * 4);
      if (fused) rays_->recordCompactionWithKeys(cmd, g, keysPush(frame.light));
      else rays_->recordCompaction(cmd, g, order);
    });
    if (options_.sorted) {
      if (!fused)
        stage("keys", [&](vk::Commands& cmd) { rays_->recordKeys(cmd, g, keysPush(frame.light), rays_->count()); });
      stage("sort", [&](vk::Commands& cmd) { rays_->recordSort(cmd, rays_->count()); });
    }
    const uint32_t lit = rays_->readCount();
    stats["lit_samples"] = lit;
    stats["ray_sort"] = raySortName();
    if (options_.sorted) stats["ray_key_bits"] = rays_->keyBits();
    stats["traversal_path"] = "per-stage submits (two-pass: the update is decided on the host)";
    stats["stage_timing"] = "one submission per stage, host wall clock (two-pass)";
    traversal::TraversalStats ts;
    if (lit > 0 && triangleCount_ > 0) {
      stage("build", [&](vk::Commands& cmd) {
        tree_.record(cmd, g.position, rays_->samples(), lit, frame.light, 2.0f * in.eps, &frame_);
        if (frame_.far && frameTrianglesStale()) recordFrameTriangles(cmd);
      });
      stats["tree_depth"] = tree_.shape().depth;
      stats["tree_nodes"] = tree_.shape().nodes();
      ensureTraversal(pixels);
      ts = runTwoPass(in, lit, g, stage, stats);
    } else {
      stats["tree_depth"] = 0;
      stats["tree_nodes"] = 0;
    }
    stages.push_back({"traversal", ts.traversalMs});
    stages.push_back({"leaves", ts.leavesMs});
    timestamps["traversal"] = ts.traversalGpuMs;
    timestamps["leaves"] = ts.leavesGpuMs;
    return ts;
  }

  uint64_t heldBytes() const {
    uint64_t triangleBytes = 0;
    for (const vk::Buffer& b : triangles_) triangleBytes += b.size;
    for (const vk::Buffer& b : frameTriangles_) triangleBytes += b.size;
    for (const vk::Buffer& b : objectTriangles_) triangleBytes += b.size;
    for (const vk::Buffer& b : slotInstance_) triangleBytes += b.size;
    triangleBytes += transformRing_.size;
    return triangleBytes + (rays_ ? rays_->bytesAllocated() : 0) + visibility_.size + tree_.bytesAllocated() +
           (traversal_ ? traversal_->bytesAllocated() + traversal_->flagBytes() + traversal_->shadowedBytes() : 0) +
           readback_.bytesAllocated() +
           clusterSphereBytes() +
           (compact_ ? compact_->bytesAllocated() : 0) +
           rayFlags_.size + remaining_.size + kept_.size + orderWords_.size;
  }

  // The traversal's arena and scratch. Without a budget: --traversal-memory, made once. Under
  // --memory-budget: --traversal-memory or what the budget leaves after every other buffer of this frame
  // (allocated by now: triangles, rays, tree, visibility; or estimated: the cluster spheres, the readback
  // copy, the early-accept flags) and the host working set, whichever is smaller; remade when that
  // changes (a new resolution or scene), so a warm frame allocates nothing.
  void ensureTraversal(uint32_t pixels) {
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
    const uint64_t spheres = expectedClusterSphereBytes() * sphereSets_.size();
    others += spheres - std::min(spheres, clusterSphereBytes());
    if (!ctx_.hostVisibleDeviceLocal) {  // the mask and the counters copied for the readback (once allocated: in `others`)
      const uint64_t readback = uint64_t(pixels) * 4 + (STATE_WORDS + SHAPE_WORDS + ORDER_WORDS) * 4 + 64;
      others += readback - std::min(readback, readback_.bytesAllocated());
    }
    if (options_.earlyAccept && options_.test == ConeTest::Precise)  // a flag word per node (not in `others`)
      others += std::max<uint64_t>(tree_.nodes().size / sizeof(cone::ConeNode) * 4, traversal_ ? traversal_->flagBytes() : 0);
    const uint64_t fixed = others + hostPeakBytes_;
    const uint64_t least = traversal::kMinPairs * sizeof(glm::uvec2) + traversal::chunkScratchBytes(1);
    if (fixed + least > budget)
      throw Error("--memory-budget " + byteSizeLabel(budget) + " cannot hold this frame: the cone path needs " +
                      byteSizeLabel(others) + " on the device for " + std::to_string(triangleCount_) + " triangles at " +
                      std::to_string(pixels) + " pixels, " + byteSizeLabel(hostPeakBytes_) +
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

  // The cluster spheres' bytes updateClusterSpheres() allocates for the current triangles.
  uint64_t expectedClusterSphereBytes() const {
    if (!options_.clusters || options_.twoPass || chunkTriangles_ < CLUSTER_SIZE) return 0;
    uint64_t bytes = 0;
    const uint64_t perBuffer = chunkTriangles_ / CLUSTER_SIZE, clusters = (triangleCount_ + CLUSTER_SIZE - 1) / CLUSTER_SIZE;
    for (uint64_t b = 0; b < triangles_.size(); ++b)
      bytes += std::max<uint64_t>(1, (std::min(perBuffer, clusters - std::min(clusters, b * perBuffer)) + SUPER_CLUSTERS - 1) / SUPER_CLUSTERS) *
               SUPER_SPHERES * sizeof(glm::vec4);
    return bytes;
  }

  uint64_t clusterSphereBytes() const {
    uint64_t n = 0;
    for (const SphereSet& set : sphereSets_)
      for (const vk::Buffer& b : set.buffers) n += b.size;
    return n;
  }

  // Whether the far frame's triangle copies predate the triangles or this frame's far frame (a static
  // scene under a static light keeps them).
  bool frameTrianglesStale() const {
    const cone::ConeFrame& a = frame_.frame;
    const cone::ConeFrame& b = frameTrianglesOf_;
    return frameTrianglesUpload_ != uploads_ || a.rowX != b.rowX || a.rowY != b.rowY || a.rowZ != b.rowZ ||
           a.centre != b.centre || a.lightFrame != b.lightFrame;
  }

  // The far-light frame's copy of every triangle buffer (frame_triangles.comp), for the pass tests.
  void recordFrameTriangles(vk::Commands& cmd) {
    frameTrianglesUpload_ = uploads_;
    frameTrianglesOf_ = frame_.frame;
    frameTriangles_.resize(triangles_.size());
    for (size_t c = 0; c < triangles_.size(); ++c) {
      if (frameTriangles_[c].size < triangles_[c].size) {
        frameTriangles_[c].reset();
        frameTriangles_[c] = vk::createBuffer(ctx_, triangles_[c].size);
      }
      const uint64_t first = uint64_t(c) * chunkTriangles_;
      const uint32_t count = uint32_t(std::min<uint64_t>(chunkTriangles_, triangleCount_ - std::min<uint64_t>(first, triangleCount_)));
      if (count == 0) continue;
      traversal::FrameTrianglesPush p{};
      p.rowX = frame_.frame.rowX, p.rowY = frame_.frame.rowY, p.rowZ = frame_.frame.rowZ;
      p.centre = frame_.frame.centre;
      p.lightFrame = frame_.frame.lightFrame;
      p.count = count;
      vk::Grid grid = vk::gridFor(count, TRAVERSE_THREADS, ctx_.maxWorkgroups());
      cmd.dispatch(frameTris_, {triangles_[c], frameTriangles_[c]}, p, grid.x, grid.y);
    }
    cmd.barrier();
  }

  // Calls fn with `in` narrowed to each triangle buffer that triangles [first, first + count) fall in
  // (one, unless the scene exceeds a storage binding).
  template <class Fn>
  void forEachTriangleBuffer(traversal::TraversalInput in, uint32_t first, uint32_t count, Fn&& fn) {
    const uint64_t end = uint64_t(first) + count;
    for (uint64_t c = first / chunkTriangles_; c < triangles_.size() && c * chunkTriangles_ < end; ++c) {
      const uint64_t lo = std::max<uint64_t>(first, c * chunkTriangles_);
      const uint64_t hi = std::min<uint64_t>(end, (c + 1) * uint64_t(chunkTriangles_));
      if (lo >= hi) continue;
      in.triangles = &triangles_[c];
      in.frameTriangles = frame_.far ? &frameTriangles_[c] : nullptr;
      in.coneScale = frame_.scale;
      in.firstTriangle = uint32_t(lo - c * chunkTriangles_);
      in.triangleCount = uint32_t(hi - lo);
      fn(in);
    }
  }

  // Triangles [first, first + count) through the tree of `in` with the chunked traversal (its own
  // submits), one run per triangle buffer; the stats summed.
  traversal::TraversalStats traverse(const traversal::TraversalInput& in, uint32_t first, uint32_t count) {
    traversal::TraversalStats total;
    bool any = false;
    forEachTriangleBuffer(in, first, count, [&](const traversal::TraversalInput& part) {
      traversal::TraversalStats ts = traversal_->run(part, &timer_);
      total = any ? combine(total, ts) : ts;
      any = true;
    });
    return total;
  }

  // 002 §3.4: pass one over the blockers (triangles [0, blockerCount_)), the update step, pass two over
  // the rest. `in` is the one-pass input over the full tree; `stage` times a recorded submit.
  template <class Stage>
  traversal::TraversalStats runTwoPass(traversal::TraversalInput in, uint32_t lit, const DeviceGBuffer& g,
                                       Stage& stage, nlohmann::json& stats) {
    nlohmann::json tp = {{"blockers", blockerCount_},
                         {"blocker_solid_angle_sr", options_.blockerSolidAngle},
                         {"blocker_max_fraction", options_.blockerMaxFraction},
                         {"update_min_finished", options_.updateMinFinished}};
    if (blockerCount_ == 0 || blockerCount_ >= triangleCount_) {
      // Nothing to split: one pass over every triangle (the stats say why).
      tp["update"] = blockerCount_ == 0 ? "none: no triangle qualifies as a blocker, one pass"
                                        : "none: every triangle is a blocker, one pass";
      tp["rays_finished_pass_one"] = 0;
      stats["two_pass"] = tp;
      return traverse(in, 0, triangleCount_);
    }
    traversal::TraversalStats one = traverse(in, 0, blockerCount_);

    // Update: the rays still lit, in their order.
    traversal::TraversePush p{};
    p.count = lit;
    stage("update", [&](vk::Commands& cmd) {
      vk::Grid grid = vk::gridFor(lit, TRAVERSE_THREADS, ctx_.maxWorkgroups());
      cmd.dispatch(unfinished_, {rays_->samples(), visibility_, rayFlags_}, p, grid.x, grid.y);
      cmd.barrier();
      compact_->record(cmd, rayFlags_, sort::Count(lit), remaining_, sort::GpuWord(kept_, 0), rays_->samples());
      cmd.barrier();
    });
    uint32_t remaining = 0;
    vk::download(ctx_, kept_, &remaining, 4);
    CS_CHECK(remaining <= lit, "cone: two-pass update kept " << remaining << " of " << lit << " rays");
    const uint32_t finished = lit - remaining;
    tp["rays_finished_pass_one"] = finished;
    tp["rays_remaining"] = remaining;
    tp["pass_one"] = one.toJson();

    traversal::TraversalStats two;
    if (remaining == 0) {
      tp["update"] = "done: every ray finished in pass one, no pass two";
    } else if (double(finished) < double(options_.updateMinFinished) * double(lit)) {
      // Too few finished rays for a smaller tree to pay: pass two on the first tree (002 §3.4).
      tp["update"] = "skipped: pass one finished too few rays, pass two reuses the first tree";
      two = traverse(in, blockerCount_, triangleCount_ - blockerCount_);
    } else {
      tp["update"] = "rebuilt";
      const float eps = in.eps;
      stage("rebuild", [&](vk::Commands& cmd) {
        tree_.record(cmd, g.position, remaining_, remaining, in.light, 2.0f * eps, &frame_);
      });
      tp["tree_depth_pass_two"] = tree_.shape().depth;
      tp["tree_nodes_pass_two"] = tree_.shape().nodes();
      two = traverse(in, blockerCount_, triangleCount_ - blockerCount_);
    }
    tp["pass_two"] = two.toJson();
    stats["two_pass"] = tp;
    return combine(one, two);
  }

  // One buffer per `perBinding` triangles: a scene larger than one storage binding of the device
  // (128 MiB on lavapipe: 2.8 M triangles) is traversed binding by binding (traverse()), and within one
  // texel buffer's maxTexelBufferElements (the traversal reads them as texels, three a triangle).
  void planChunks() {
    const uint64_t perBinding =
        options_.trianglesPerBinding
            ? options_.trianglesPerBinding
            : std::min<uint64_t>(ctx_.maxStorageBufferRange() / 48, ctx_.properties.limits.maxTexelBufferElements / 3);
    CS_CHECK(perBinding >= 1, "cone: a storage binding of this device cannot hold one triangle");
    chunkTriangles_ = uint32_t(std::min<uint64_t>(perBinding, UINT32_MAX));
    if (chunkTriangles_ >= SUPER_SIZE) chunkTriangles_ -= chunkTriangles_ % SUPER_SIZE;  // whole super clusters a buffer
    else if (chunkTriangles_ >= CLUSTER_SIZE) chunkTriangles_ -= chunkTriangles_ % CLUSTER_SIZE;  // whole clusters
  }

  // Uploads the scene's triangles (vec4 x 3, world space) when they changed (with two-pass, also when the
  // light moved: the blockers, first in the buffer, depend on it). Triangles with a non-finite coordinate
  // are dropped, as Embree drops them. Returns the wall ms, 0 if cached.
  // The host working set stays small beside the scene: the buffers' order of the kept triangles (4 bytes
  // each; 8 more while clusters sort them, 9 while two-pass ranks them), the cluster bounds, and one
  // chunk of at most kUploadBytes written into the buffers at a time. A change is seen from a 128-bit
  // hash of the positions and the indices -- the frame's geometry revision (core/scene.h), computed once
  // per frame by the harness -- not from a copy of them (hostPeakBytes_ counts all of it).
  double uploadTriangles(const FrameInput& frame) {
    const Scene& scene = *frame.scene;
    const GeometryRevision revision = revisionOf(frame);
    if (revision == revision_ && !triangles_.empty() && (!options_.twoPass || cachedLight_ == frame.light)) return 0.0;
    auto t0 = Clock::now();
    // The one geometry policy (checkGeometry), unless the camera pass's upload of this revision checked it.
    if (!frame.deviceScene) checkGeometry(scene);
    const size_t sceneTriangles = scene.indices.size() / 3;
    // The kept triangles and their bounds.
    const bool sameIndices = revision.indices == revision_.indices && droppedTriangles_ == 0;
    std::vector<uint32_t> previous;  // the last order: clusters keep it while the index list stays
    previous.swap(order_);
    if (!sameIndices) std::vector<uint32_t>().swap(previous);
    std::vector<uint32_t> kept;
    kept.reserve(sceneTriangles);
    glm::vec3 lo(INFINITY), hi(-INFINITY);
    for (size_t t = 0; t < sceneTriangles; ++t) {
      if (!finiteTriangle(scene, t)) continue;  // the policy: no geometry
      kept.push_back(uint32_t(t));
      for (int k = 0; k < 3; ++k) {
        lo = glm::min(lo, scene.positions[scene.indices[3 * t + k]]);
        hi = glm::max(hi, scene.positions[scene.indices[3 * t + k]]);
      }
    }
    droppedTriangles_ = sceneTriangles - kept.size();
    boundsLo_ = kept.empty() ? glm::vec3(0) : lo;
    boundsHi_ = kept.empty() ? glm::vec3(0) : hi;
    triangleCount_ = uint32_t(kept.size());
    auto vertex = [&](uint32_t t, int k) { return scene.positions[scene.indices[3 * size_t(t) + k]]; };

    constexpr uint64_t kTriangleBytes = 3 * sizeof(glm::vec4);
    planChunks();
    const size_t chunks = std::max<size_t>(1, (triangleCount_ + uint64_t(chunkTriangles_) - 1) / chunkTriangles_);
    const bool clusters = options_.clusters && !options_.twoPass;

    // The host working set of this upload, checked against the budget before any buffer is made.
    const uint64_t n = kept.size();
    const uint64_t chunkBytes = std::min<uint64_t>(kUploadTriangles, std::max<uint64_t>(n, 1)) * kTriangleBytes;
    const uint64_t orderBytes = n * sizeof(uint32_t);
    // two-pass: the solid angles, the blocker flags, the ranked candidates and the new order; clusters:
    // the Hilbert keys and the new order
    const uint64_t rankBytes = options_.twoPass ? n * (sizeof(double) + 1 + 2 * sizeof(uint32_t))
                               : clusters       ? n * (sizeof(uint64_t) + sizeof(uint32_t))
                                                : 0;
    const uint64_t boundsBytes = clusters ? (n + CLUSTER_SIZE - 1) / CLUSTER_SIZE * sizeof(traversal::ClusterWorld) : 0;
    // The vertices are written straight into the device buffer's mapping, or where device memory is not
    // host visible into the staging buffer (one chunk): the host holds no copy of them.
    const uint64_t staging = ctx_.hostVisibleDeviceLocal ? 0 : chunkBytes;
    hostPeakBytes_ = orderBytes + std::max({rankBytes, orderBytes, boundsBytes + staging});
    if (options_.memoryBudgetBytes) {
      uint64_t device = 0;
      for (size_t c = 0; c < chunks; ++c)
        device += std::max<uint64_t>(16, std::min<uint64_t>(chunkTriangles_, n - std::min<uint64_t>(n, c * chunkTriangles_)) * kTriangleBytes);
      if (device + hostPeakBytes_ > options_.memoryBudgetBytes)
        throw Error("--memory-budget " + byteSizeLabel(options_.memoryBudgetBytes) + " cannot hold this scene: its " +
                        std::to_string(n) + " triangles take " + byteSizeLabel(device) + " on the device (48 bytes each) and " +
                        byteSizeLabel(hostPeakBytes_) + " of host working set while they are uploaded",
                    "cone path", "give --memory-budget well above " + byteSizeLabel(device + hostPeakBytes_) +
                                     ": the frame's rays, tree and traversal come on top");
    }

    // The buffers' order of the kept triangles: blockers first (two-pass), Hilbert order of the centroids
    // (clusters; kept while the index list stays, so moving vertices keep their clusters), else scene order.
    if (options_.twoPass) orderBlockersFirst(kept, vertex, frame.light);
    else if (clusters) orderForClusters(kept, previous, vertex);
    order_.swap(kept);
    std::vector<uint32_t>().swap(kept);

    triangles_.resize(chunks);
    if (clusters) clusterWorld_.assign((n + CLUSTER_SIZE - 1) / CLUSTER_SIZE, traversal::ClusterWorld{});
    else std::vector<traversal::ClusterWorld>().swap(clusterWorld_);
    const uint64_t perChunk = chunkBytes / kTriangleBytes;  // a multiple of CLUSTER_SIZE or all triangles
    for (size_t c = 0; c < chunks; ++c) {
      const uint64_t first = uint64_t(c) * chunkTriangles_;
      const uint64_t count = std::min<uint64_t>(chunkTriangles_, n - std::min<uint64_t>(first, n));
      const uint64_t bytes = std::max<uint64_t>(count * kTriangleBytes, 16);
      if (triangles_[c].size < bytes || triangles_[c].size > 2 * bytes) {
        triangles_[c].reset();
        triangles_[c] = vk::createBuffer(ctx_, bytes);
      }
      for (uint64_t done = 0; done < count; done += perChunk) {
        const uint64_t m = std::min(perChunk, count - done);
        // A cluster's vertices at a time (chunks start on a cluster: perChunk and chunkTriangles_ are
        // multiples of it): its bounds from them, then written out, never read back from the mapping.
        vk::uploadInPlace(ctx_, triangles_[c], m * kTriangleBytes, done * kTriangleBytes, [&](void* out) {
          glm::vec4 cluster[3 * CLUSTER_SIZE];
          for (uint64_t t = 0; t < m; t += CLUSTER_SIZE) {
            const uint64_t k = std::min<uint64_t>(CLUSTER_SIZE, m - t);
            for (uint64_t i = 0; i < k; ++i)
              for (int v = 0; v < 3; ++v) cluster[3 * i + v] = glm::vec4(vertex(order_[first + done + t + i], v), 1.0f);
            if (clusters) clusterWorld_[(first + done + t) / CLUSTER_SIZE] = traversal::clusterWorld(cluster, k);
            std::memcpy(static_cast<glm::vec4*>(out) + 3 * t, cluster, 3 * k * sizeof(glm::vec4));
          }
        });
      }
    }
    revision_ = revision;
    uploads_++;
    cachedLight_ = frame.light;
    return msSince(t0);
  }

  // Clusters (traversal.h, "Clusters"): the triangles in Hilbert order of their centroids on a grid of
  // 2^10 cubes a side over the bounds, so every CLUSTER_SIZE consecutive ones are one piece of space and
  // their sphere is small. Cubes, not the bounds' box cut 2^10 ways per axis: on a flat scene (a terrain)
  // the thin axis' cells would be far finer than the others, and a run of cells a thin strip. Measured
  // at 512² (scale_bench), pairs tested: the 1 M height field 17.8 M with the Morton order over the box,
  // 11.1 M over cubes, 9.1 M in Hilbert order; 2CylinderEngine x8 19.1 / 15.9 / 14.9 M. The previous
  // order is kept when there is one (the same index list, no triangle dropped: moving vertices keep their
  // clusters, whose spheres follow them).
  template <class Vertex>
  void orderForClusters(std::vector<uint32_t>& kept, std::vector<uint32_t>& previous, const Vertex& vertex) {
    if (previous.size() == kept.size() && kept.size() > 0) {
      kept.swap(previous);
      return;
    }
    std::vector<uint32_t>().swap(previous);
    const glm::vec3 lo = boundsLo_, size = boundsHi_ - boundsLo_;
    const glm::vec3 ext(std::max({size.x, size.y, size.z, 1e-30f}));  // cubes
    std::vector<uint64_t> keys(kept.size());  // Hilbert position, then the position in scene order: stable
    for (size_t t = 0; t < kept.size(); ++t) {
      const glm::vec3 c = (vertex(kept[t], 0) + vertex(kept[t], 1) + vertex(kept[t], 2)) / 3.0f;
      const glm::vec3 u = glm::clamp((c - lo) / ext, 0.0f, 1.0f) * 1023.0f;
      const uint32_t code = traversal::hilbertIndex3(uint32_t(u.x), uint32_t(u.y), uint32_t(u.z), 10);
      keys[t] = (uint64_t(code) << 32) | t;
    }
    std::sort(keys.begin(), keys.end());
    std::vector<uint32_t> ordered(kept.size());
    for (size_t t = 0; t < kept.size(); ++t) ordered[t] = kept[uint32_t(keys[t])];
    kept.swap(ordered);
  }

  // The clusters' spheres relative to the light in the pass tests' coordinates (the world, or the far
  // frame through its fp32 rows), written to host-visible buffers when the triangles or the frame
  // changed. Padded by 2^-16 of the magnitudes: the GPU's vertices are fp32 differences of up to those
  // magnitudes (v - light, or S R (v - C) - S R (light - C)), a few ulp off the exact ones.
  void updateClusterSpheres(glm::vec3 light, uint32_t slot) {
    const cone::ConeFrame& f = frame_.frame;
    if (sphereSets_.size() <= slot) sphereSets_.resize(slot + 1);
    SphereSet& set = sphereSets_[slot];
    if (set.upload == uploads_ && set.light == light && set.far == frame_.far && set.of.rowX == f.rowX &&
        set.of.rowY == f.rowY && set.of.rowZ == f.rowZ && set.of.centre == f.centre && set.of.lightFrame == f.lightFrame)
      return;
    set.upload = uploads_, set.light = light, set.far = frame_.far;
    set.of = f;
    const size_t perBuffer = chunkTriangles_ / CLUSTER_SIZE;
    std::vector<vk::Buffer>& clusterSpheres_ = set.buffers;
    clusterSpheres_.resize(triangles_.size());
    const glm::dvec3 C(glm::vec3(f.centre)), LF(glm::vec3(f.lightFrame)), L(light);
    auto sphere = [&](glm::dvec3 c, double r) {
      if (frame_.far)
        return traversal::clusterSphereFar(cone::toConeFrameExact(c, f) - LF, r,
                                           glm::length(c - C) + r + glm::length(glm::dvec2(LF)));
      return traversal::clusterSphere(c - L, r, glm::length(c) + r + glm::length(L));
    };
    for (size_t b = 0; b < triangles_.size(); ++b) {
      const size_t first = b * perBuffer, end = std::min(clusterWorld_.size(), first + perBuffer);
      const size_t supers = std::max<size_t>(1, (end - std::min(first, end) + SUPER_CLUSTERS - 1) / SUPER_CLUSTERS);
      const uint64_t bytes = supers * SUPER_SPHERES * sizeof(glm::vec4);
      if (clusterSpheres_[b].size < bytes) {
        clusterSpheres_[b].reset();
        clusterSpheres_[b] = vk::createBuffer(ctx_, bytes, vk::Memory::HostVisible);
      }
      // Written straight into the mapping, never read back (no host copy of the spheres): per super
      // cluster its sphere (holding its clusters' world spheres), then each cluster's and its groups'.
      glm::vec4* out = static_cast<glm::vec4*>(clusterSpheres_[b].mapped);
      // Every slot is written below but a last super cluster's missing clusters', never read: zeroed once.
      std::fill_n(out + (supers - 1) * SUPER_SPHERES, SUPER_SPHERES, glm::vec4(0));
      auto write = [&, first, end, out](size_t from, size_t to) {  // super clusters [from, to) of the buffer
        for (size_t i = from; i < to; ++i) {
          const size_t k = first + i * SUPER_CLUSTERS, last = std::min(end, k + SUPER_CLUSTERS);
          if (k >= last) break;
          glm::vec4* at = out + i * SUPER_SPHERES;
          const glm::dvec4 s = traversal::superBounds(&clusterWorld_[k], last - k);
          at[0] = sphere(glm::dvec3(s), s.w);
          for (size_t q = k; q < last; ++q) {
            const traversal::ClusterWorld& w = clusterWorld_[q];
            glm::vec4* c = at + 1 + CLUSTER_SPHERES * (q - k);
            c[0] = sphere(glm::dvec3(w.whole), w.whole.w);
            for (uint32_t g = 0; g < CLUSTER_GROUPS; ++g) c[1 + g] = sphere(glm::dvec3(glm::vec3(w.groups[g])), w.groups[g].w);
          }
        }
      };
      // On the host's cores, a run of at least 8192 super clusters each (the 10 M height field's 156 k took
      // 89 ms on one thread); where a thread cannot start, this one does its share.
      const size_t hw = std::max(1u, std::thread::hardware_concurrency());
      const size_t parts = std::clamp<size_t>(supers / 8192, 1, std::min<size_t>(hw, 16));
      std::vector<std::thread> threads;
      for (size_t t = 1; t < parts; ++t) {
        const size_t from = supers * t / parts, to = supers * (t + 1) / parts;
        try {
          threads.emplace_back(write, from, to);
        } catch (...) {  // (std::system_error; or no memory for the thread list)
          write(from, to);
        }
      }
      write(0, supers / parts);
      for (std::thread& th : threads) th.join();
    }
  }

  // Two-pass blockers (cone_method.h): triangles subtending at least blockerSolidAngle at the light, the
  // largest blockerMaxFraction of all at most, moved to the front in their scene order; sets blockerCount_.
  template <class Vertex>
  void orderBlockersFirst(std::vector<uint32_t>& kept, const Vertex& vertex, glm::vec3 light) {
    const size_t n = kept.size();
    std::vector<double> omega(n);
    const glm::dvec3 l(light);
    for (size_t t = 0; t < n; ++t)
      omega[t] = solidAngle(glm::dvec3(vertex(kept[t], 0)) - l, glm::dvec3(vertex(kept[t], 1)) - l,
                            glm::dvec3(vertex(kept[t], 2)) - l);
    size_t candidates = 0;
    for (size_t t = 0; t < n; ++t) candidates += omega[t] >= double(options_.blockerSolidAngle);
    const size_t cap = size_t(std::floor(double(options_.blockerMaxFraction) * double(n)));
    std::vector<uint8_t> isBlocker(n, 0);
    if (candidates <= cap) {
      for (size_t t = 0; t < n; ++t) isBlocker[t] = omega[t] >= double(options_.blockerSolidAngle);
    } else if (cap > 0) {  // the largest `cap`, ties broken by scene order: deterministic
      std::vector<uint32_t> rank;
      rank.reserve(candidates);
      for (size_t t = 0; t < n; ++t)
        if (omega[t] >= double(options_.blockerSolidAngle)) rank.push_back(uint32_t(t));
      auto larger = [&](uint32_t a, uint32_t b) { return omega[a] != omega[b] ? omega[a] > omega[b] : a < b; };
      std::nth_element(rank.begin(), rank.begin() + cap, rank.end(), larger);
      for (size_t k = 0; k < cap; ++k) isBlocker[rank[k]] = 1;
      candidates = cap;
    } else {
      candidates = 0;
    }
    std::vector<uint32_t> ordered;
    ordered.reserve(n);
    for (int pass = 1; pass >= 0; --pass)
      for (size_t t = 0; t < n; ++t)
        if (isBlocker[t] == pass) ordered.push_back(kept[t]);
    kept.swap(ordered);
    blockerCount_ = uint32_t(candidates);
  }

  // The engine's frames: a slot per frame in flight, its stats words (the traversal's state and the tree's
  // shape a light, copied at the light's end) and the staging buffers of the uploads it carried.
  static constexpr uint32_t kStatsWords = STATE_WORDS + SHAPE_WORDS;
  struct EngineSlot {
    uint64_t frame = ~uint64_t(0);
    bool learned = true;
    struct Light {
      bool clusters = false;
    };
    std::vector<Light> lights;
    std::vector<std::unique_ptr<vk::Buffer>> staged;
    std::vector<vk::Buffer> retired;
  };
  const uint32_t* statsWords(uint32_t slot, uint32_t light) const {
    return static_cast<const uint32_t*>(statsRing_.mapped) + (uint64_t(slot) * maxLights_ + light) * kStatsWords;
  }
  // The batch size learnt from a completed frame's lights (Traversal::learnBatch), once.
  void learnFromSlot(uint32_t slot) {
    EngineSlot& es = slots_[slot];
    if (es.learned) return;
    es.learned = true;
    for (uint32_t l = 0; l < es.lights.size(); ++l) {
      const uint32_t* state = statsWords(slot, l);
      const uint32_t depth = state[STATE_WORDS + SHAPE_DEPTH];
      traversal_->learnBatch(state, traversal_->statsFromState(state, depth, traversal::Traversal::overflowed(state)),
                             triangleCount_);
    }
  }
  // An instance's run of triangle slots: its mesh's kept triangles (count), padded to whole super clusters,
  // the mesh's bounds of them and the instance's transform.
  struct InstanceRun {
    uint32_t mesh = 0;
    uint64_t first = 0, count = 0, padded = 0;
    glm::vec3 lo{0}, hi{0};
    float transform[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  };
  std::vector<InstanceRun> runs_;
  std::vector<vk::Buffer> objectTriangles_, slotInstance_;  // per triangle buffer: the mesh-space vertices, the instances
  std::vector<traversal::ClusterWorld> objectClusters_;    // per cluster, in its mesh's space
  std::vector<uint32_t> clusterInstance_;                   // per cluster, its instance
  vk::Buffer transformRing_;                                // per frame in flight: 4 vec4 an instance
  bool transformsDirty_ = false;
  std::vector<vk::Buffer> retiring_;                        // replaced buffers, until the next frame's slot holds them
  vk::Kernel instanceTriangles_;

  // The buffers of the geometry being replaced, kept until no frame in flight can read them.
  void retireGeometry() {
    for (std::vector<vk::Buffer>* list : {&triangles_, &objectTriangles_, &slotInstance_, &frameTriangles_})
      for (vk::Buffer& b : *list)
        if (b) retiring_.push_back(std::move(b));
    triangles_.clear(), objectTriangles_.clear(), slotInstance_.clear(), frameTriangles_.clear();
    if (transformRing_) retiring_.push_back(std::move(transformRing_));
    for (SphereSet& set : sphereSets_) {
      for (vk::Buffer& b : set.buffers)
        if (b) retiring_.push_back(std::move(b));
      set = SphereSet{};
    }
  }

  // The instances' transforms into this frame's ring slot, and every slot's world vertices from them.
  void recordTransforms(vk::Commands& cmd, uint32_t slot) {
    glm::vec4* rows = static_cast<glm::vec4*>(transformRing_.mapped) + uint64_t(slot) * runs_.size() * 4;
    for (size_t i = 0; i < runs_.size(); ++i) {
      const float* m = runs_[i].transform;
      rows[4 * i] = {m[0], m[1], m[2], m[3]};
      rows[4 * i + 1] = {m[4], m[5], m[6], m[7]};
      rows[4 * i + 2] = {m[8], m[9], m[10], m[11]};
      rows[4 * i + 3] = {identityTransform(m) ? 1.0f : 0.0f, 0, 0, 0};
    }
    const uint64_t ringBytes = std::max<uint64_t>(runs_.size() * 64, 16);
    for (size_t c = 0; c < triangles_.size(); ++c) {
      const uint64_t first = uint64_t(c) * chunkTriangles_;
      const uint32_t count = uint32_t(std::min<uint64_t>(chunkTriangles_, triangleCount_ - std::min<uint64_t>(first, triangleCount_)));
      if (count == 0) continue;
      traversal::TraversePush p{};
      p.count = count;
      const vk::Grid grid = vk::gridFor(count, TRAVERSE_THREADS, ctx_.maxWorkgroups());
      cmd.dispatch(instanceTriangles_,
                   {objectTriangles_[c], slotInstance_[c],
                    vk::BufferRange(transformRing_, uint64_t(slot) * runs_.size() * 64, ringBytes), triangles_[c]},
                   p, grid.x, grid.y);
    }
    cmd.barrier();
    transformsDirty_ = false;
  }

  uint32_t framesInFlight_ = 0, maxLights_ = 0;
  vk::Kernel sampleLight_;
  vk::Buffer statsRing_;
  std::vector<EngineSlot> slots_;

  vk::Context& ctx_;
  ConeOptions options_;
  cone::ConeTree tree_;
  std::unique_ptr<traversal::Traversal> traversal_;
  vk::Timer timer_;
  std::unique_ptr<rays::LitRays> rays_;
  uint32_t raysWidth_ = 0, raysHeight_ = 0;
  std::vector<vk::Buffer> triangles_;  // chunkTriangles_ triangles each (the last: the rest)
  uint32_t chunkTriangles_ = 1;
  vk::Buffer visibility_;
  vk::Readback readback_{ctx_};  // the mask and the counters, copied inside the frame's submission
  uint32_t triangleCount_ = 0;
  uint64_t droppedTriangles_ = 0;
  GeometryRevision revision_;  // of the uploaded scene
  std::vector<uint32_t> order_;         // scene triangle (the kept ones) of each triangle buffer slot, in order
  uint64_t hostPeakBytes_ = 0;          // host working set of the last upload (uploadTriangles)
  Clock::time_point submitStart_, submitEnd_;  // the frame's one submission (runSubmitted)
  uint64_t traversalMemory_ = 0;        // the traversal's memory bound this frame (ensureTraversal)
  glm::vec3 cachedLight_{0};
  glm::vec3 boundsLo_{0}, boundsHi_{0};  // of the uploaded (finite) triangles
  cone::FrameChoice frame_;              // this frame's cone frame (world or far)
  std::vector<vk::Buffer> frameTriangles_;  // far frame: the triangles relative to the light in the frame
  uint64_t uploads_ = 0;                    // triangle uploads so far
  // clusters (traversal.h, "Clusters")
  std::vector<traversal::ClusterWorld> clusterWorld_;  // per cluster: its world bound and its groups'
  // The clusters' spheres of one light of one frame (per triangle buffer), host written when the frame is
  // recorded: one set a (frame in flight, light) so that no set is rewritten while a frame reads it.
  struct SphereSet {
    std::vector<vk::Buffer> buffers;
    uint64_t upload = ~uint64_t(0);  // the triangles, the light and the frame they were made for
    glm::vec3 light{0};
    bool far = false;
    cone::ConeFrame of{};
  };
  std::vector<SphereSet> sphereSets_ = std::vector<SphereSet>(1);
  uint64_t frameTrianglesUpload_ = ~uint64_t(0);  // the upload and the frame frameTriangles_ were made for
  cone::ConeFrame frameTrianglesOf_{};
  vk::Kernel frameTris_;
  // the ray order chosen on the GPU (ConeOptions::adaptiveOrder)
  vk::Kernel orderChoice_;
  vk::Buffer orderWords_;  // ORDER_* (traversal_layout.h)
  bool orderLoose_ = false;              // the last measured frame sorted its rays
  uint32_t framesSinceOrderCheck_ = 0;   // frames since that measurement
  // two-pass
  uint32_t blockerCount_ = 0;
  vk::Kernel unfinished_;
  std::unique_ptr<sort::Compact> compact_;
  vk::Buffer rayFlags_, remaining_, kept_;
};

}  // namespace

bool applyConeVariant(const std::string& name, ConeOptions& o) {
  struct Row {
    const char* name;
    ConeTest test;
    bool sorted, earlyAccept, twoPass;
  };
  static const Row rows[] = {{"Precise", ConeTest::Precise, false, false, false},
                             {"PreciseSorted", ConeTest::Precise, true, false, false},
                             {"Spheres", ConeTest::Sphere, false, false, false},
                             {"SpheresSorted", ConeTest::Sphere, true, false, false},
                             {"PreciseSEA", ConeTest::Precise, true, true, false},
                             {"PreciseEATP", ConeTest::Precise, false, true, true},
                             {"PreciseSEATP", ConeTest::Precise, true, true, true}};
  for (const Row& r : rows)
    if (name == r.name) {
      o.test = r.test;
      o.sorted = r.sorted;
      o.earlyAccept = r.earlyAccept;
      o.twoPass = r.twoPass;
      return true;
    }
  return false;
}

const std::vector<std::string>& coneVariantNames() {
  static const std::vector<std::string> names = {"Precise",    "PreciseSorted", "Spheres",     "SpheresSorted",
                                                 "PreciseSEA", "PreciseEATP",   "PreciseSEATP"};
  return names;
}

std::string coneVariantName(const ConeOptions& o) {
  const bool early = o.earlyAccept && o.test == ConeTest::Precise;
  std::string name = o.test == ConeTest::Sphere ? "Spheres" : "Precise";
  if (!early && !o.twoPass) return name + (o.sorted ? "Sorted" : "");
  return name + (o.sorted ? "S" : "") + (early ? "EA" : "") + (o.twoPass ? "TP" : "");
}

std::unique_ptr<ConeEngine> makeConeEngine(vk::Context& ctx, const ConeOptions& options, uint32_t framesInFlight,
                                           uint32_t maxLights) {
  auto engine = std::make_unique<ConeMethod>(ctx, options);
  engine->enableEngine(framesInFlight, maxLights);
  return engine;
}

std::unique_ptr<ShadowMethod> makeConeMethod(vk::Context& ctx, const ConeOptions& options) {
  return std::make_unique<ConeMethod>(ctx, options);
}

}  // namespace cs
