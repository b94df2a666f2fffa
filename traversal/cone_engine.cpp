// The engine (cone_engine.h): a frame of 1..N lights recorded into the caller's command buffer by the cone
// path's recorder (cone_recorder.h), its counters read a frame later from a host-visible ring and its
// stages timed by timestamps in the same command buffer. docs/ARCHITECTURE.md, "The engine".
#include "traversal/cone_engine.h"

#include <cassert>
#include <cstring>

#include "core/error.h"
#include "raster/raster.h"
#include "traversal/cone_recorder.h"
#include "vk/context.h"

namespace cs {

const char* engineStageName(EngineStage stage) {
  static const char* const names[kEngineStages] = {"light term", "compact", "order",  "keys",     "sort",
                                                   "build",      "traversal", "leaves", "undecided"};
  return uint32_t(stage) < kEngineStages ? names[uint32_t(stage)] : "?";
}

namespace {

// The stage a recorder boundary ends (ConeRecorder::Boundary's names); Count for a name it does not know.
EngineStage stageEndedBy(const char* boundary) {
  static const std::pair<const char*, EngineStage> ends[] = {
      {"compact", EngineStage::Compact}, {"compact + keys", EngineStage::Compact},
      {"order", EngineStage::Order},          {"keys", EngineStage::Keys},       {"sort", EngineStage::Sort},
      {"build", EngineStage::Build},          {"traversal", EngineStage::Traversal}, {"leaves", EngineStage::Leaves}};
  for (const auto& [name, stage] : ends)
    if (std::strcmp(name, boundary) == 0) return stage;
  return EngineStage::Count;
}

class Engine : public ConeEngine {
 public:
  // framesInFlight stats slots and sphere sets of maxLights each.
  Engine(vk::Context& ctx, const ConeOptions& options, uint32_t framesInFlight, uint32_t maxLights)
      : ctx_(ctx), recorder_(ctx, options) {
    CS_CHECK(!options.twoPass, "the two-pass variants decide their update on the host between the passes: the engine "
                               "records one-pass variants only (PreciseEA, PreciseSEA and the others)");
    CS_CHECK(framesInFlight >= 1 && framesInFlight <= 4, "frames in flight " << framesInFlight << ", not 1..4");
    CS_CHECK(maxLights >= 1 && maxLights <= 64, "lights a frame " << maxLights << ", not 1..64");
    framesInFlight_ = framesInFlight;
    maxLights_ = maxLights;
    statsRing_ = vk::createBuffer(ctx_, (uint64_t(framesInFlight) * maxLights * kStatsWords + framesInFlight) * 4,
                                  vk::Memory::HostVisible);
    std::memset(statsRing_.mapped, 0, statsRing_.size);
    slots_.resize(framesInFlight);
    recorder_.layout().resizeSphereSets(size_t(framesInFlight) * maxLights);
    makeTimestamps();
  }
  ~Engine() override {
    for (Slot& es : slots_)
      if (es.queries) vkDestroyQueryPool(ctx_.device, es.queries, nullptr);
  }
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;

  void setGeometry(const Scene& scene, const GeometryRevision& revision) override {
    FrameInput frame;
    frame.scene = &scene;
    frame.revision = revision;
    recorder_.layout().upload(frame);
  }

  void setInstances(std::span<const EngineMesh> meshes, std::span<const EngineInstance> instances) override {
    recorder_.layout().setInstances(meshes, instances, framesInFlight_);
  }
  void setTransforms(std::span<const EngineInstance> instances) override {
    recorder_.layout().setTransforms(instances);
  }
  void bounds(glm::vec3& lo, glm::vec3& hi) const override {
    lo = recorder_.layout().boundsLo(), hi = recorder_.layout().boundsHi();
  }

  void record(vk::Commands& cmd, const DeviceGBuffer& g, std::span<const glm::vec3> lights, float eps, uint64_t frame,
              FunctionRef<void(uint32_t, const vk::Buffer&)> deliver) override {
    TriangleLayout& layout = recorder_.layout();
    CS_CHECK(!lights.empty() && lights.size() <= maxLights_,
             lights.size() << " lights in a frame; this context takes 1 to " << maxLights_);
    CS_CHECK(!layout.triangles().empty(), "a frame recorded before any geometry was set");
    for (glm::vec3 light : lights) recorder_.refuseUnreachableLight(light);  // before anything is recorded
    const uint32_t slot = uint32_t(frame % framesInFlight_);
    learnFromSlot(slot);  // the frame that held the slot has completed (the contract)
    if (!begun_ || begunFrame_ != frame) beginFrame(cmd, frame);
    begun_ = false;
    const uint32_t pixels = g.width * g.height;
    recorder_.sizeFrameBuffers(g.width, g.height);
    recorder_.ensureTraversal(pixels);
    refuseTooFewPairs(recorder_.batchesNeeded(), recorder_.traversal().batchTriangles());  // nothing recorded yet
    Slot& es = slots_[slot];
    es.staged = vk::recordPendingUploads(ctx_, cmd);  // kept until the slot is reused
    es.retired = layout.takeRetired();                 // buffers a replaced geometry left: freed with the slot
    if (layout.transformsDirty()) layout.recordTransforms(cmd, slot);
    es.frame = frame;
    es.lights = uint32_t(lights.size());
    es.learned = false;
    es.timed = false;
    const bool adaptive = recorder_.options().sorted && recorder_.options().adaptiveOrder;
    timedCommands_ = cmd.handle();
    timedSlot_ = &es;
    for (uint32_t l = 0; l < lights.size(); ++l) {
      timedLight_ = l;
      if (es.queries) es.marks[l] = 0;
      mark(EngineStage::Count);  // the light's start
      const ConeRecorder::RecordedLight rec =
          recorder_.recordLightFrame(cmd, g, lights[l], eps, adaptive, slot * maxLights_ + l, true,
                                     [this](const char* name) { markBoundary(name); });
      mark(EngineStage::Undecided);
      if (!rec.onDevice) refuseTooFewPairs(rec.batches, rec.batch);  // the arena shrank once the tree was made
      deliver(l, recorder_.visibility());
      const uint64_t at = (uint64_t(slot) * maxLights_ + l) * kStatsWords * 4;
      cmd.copy(recorder_.traversal().stateBuffer(), statsRing_, STATE_WORDS * 4, 0, at);
      cmd.copy(recorder_.tree().shapeBuffer(), statsRing_, SHAPE_WORDS * 4, 0, at + STATE_WORDS * 4);
    }
    cmd.barrier();  // the tag is written after the lights' words: a host that sees it sees a whole frame
    cmd.fill(statsRing_, frameTag(frame), frameTagWord(slot) * 4, 4);
    cmd.barrier();  // the stats words visible to the host once the caller's submission completes
    if (es.queries) vkCmdWriteTimestamp(cmd.handle(), VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, es.queries, kFrameEnd);
    es.timed = es.queries != VK_NULL_HANDLE;
    timedSlot_ = nullptr;
  }

  void beginFrame(vk::Commands& cmd, uint64_t frame) override {
    const Slot& es = slots_[frame % framesInFlight_];
    if (es.queries) {
      vkCmdResetQueryPool(cmd.handle(), es.queries, 0, queriesPerSlot());
      vkCmdWriteTimestamp(cmd.handle(), VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, es.queries, kFrameStart);
    }
    begun_ = true;
    begunFrame_ = frame;
  }

  std::vector<EngineLightStats> stats(uint64_t frame, EngineFrameTimes* times) override {
    std::vector<EngineLightStats> out;
    const uint32_t slot = uint32_t(frame % framesInFlight_);
    const Slot& es = slots_[slot];
    if (times) *times = {};
    // Before its tag is written the slot's words are the frame before's, or being written.
    if (es.frame != frame || tagOf(slot) != frameTag(frame)) return out;
    for (uint32_t l = 0; l < es.lights; ++l) {
      const uint32_t* state = statsWords(slot, l);
      const uint32_t* shape = state + STATE_WORDS;
      const bool overflow = traversal::Traversal::overflowed(state);
      const traversal::TraversalStats ts = recorder_.traversal().statsFromState(state, shape[SHAPE_DEPTH], overflow);
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
    if (times) *times = readTimes(es, out);
    return out;
  }

  void recordLightTerms(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light, const vk::Buffer& terms,
                        uint64_t offset) override {
    const uint64_t bytes = uint64_t(g.width) * g.height * 16;
    CS_CHECK(offset + bytes <= terms.size, "light terms: " << bytes << " bytes at " << offset << " of a buffer of "
                                                           << terms.size);
    if (bytes) recorder_.recordLightTerms(cmd, g, light, vk::BufferRange(terms, offset, bytes));
  }

  uint64_t bytesAllocated() const override { return recorder_.heldBytes() + statsRing_.size; }

 private:
  // A frame whose batches pass what one recording holds needs the chunked traversal's submits, which the
  // engine never makes.
  static void refuseTooFewPairs(uint64_t batches, uint32_t batch) {
    if (batches > kConeMaxBatches)
      throw Error("the traversal's memory holds too few pairs to record the frame (" + std::to_string(batches) +
                      " batches of " + std::to_string(batch) + " triangles; one frame records at most " +
                      std::to_string(kConeMaxBatches) + ")",
                  "cone engine", "give a larger memory budget");
  }

  // A slot per frame in flight: its stats words (the traversal's state and the tree's shape a light, copied
  // at the light's end), the staging buffers of the uploads it carried, and its timestamps.
  static constexpr uint32_t kStatsWords = STATE_WORDS + SHAPE_WORDS;
  // A slot's queries: the frame's start and end, then a run a light: its start, then a timestamp at each
  // boundary (two a traversal batch) and one after its undecided samples.
  static constexpr uint32_t kFrameStart = 0, kFrameEnd = 1, kLightRuns = 2;
  static constexpr uint32_t kLightQueries = 2 * uint32_t(kConeMaxBatches) + 16;
  struct Slot {
    uint64_t frame = ~uint64_t(0);
    bool learned = true;
    uint32_t lights = 0;
    std::vector<std::unique_ptr<vk::Buffer>> staged;
    std::vector<vk::Buffer> retired;
    VkQueryPool queries = VK_NULL_HANDLE;  // none where the queue family has no valid timestamps
    bool timed = false;                    // the frame's timestamps were all recorded
    std::vector<uint32_t> marks;           // a light: timestamps written in its run
    std::vector<uint8_t> stageOf;          // a light's run: the stage each timestamp ends (EngineStage)
  };
  uint32_t queriesPerSlot() const { return kLightRuns + maxLights_ * kLightQueries; }

  // The query pools and their bookkeeping, made once: nothing of the timing is allocated per frame.
  void makeTimestamps() {
    uint32_t families = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(ctx_.physical, &families, nullptr);
    std::vector<VkQueueFamilyProperties> props(families);
    vkGetPhysicalDeviceQueueFamilyProperties(ctx_.physical, &families, props.data());
    const uint32_t validBits = ctx_.queueFamily < families ? props[ctx_.queueFamily].timestampValidBits : 0;
    if (validBits == 0 || ctx_.timestampPeriodNs() <= 0) return;
    tickMask_ = validBits >= 64 ? ~uint64_t(0) : (uint64_t(1) << validBits) - 1;
    ticks_.resize(2 * kLightQueries);
    for (Slot& es : slots_) {
      VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
      qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
      qi.queryCount = queriesPerSlot();
      VK_CHECK(vkCreateQueryPool(ctx_.device, &qi, nullptr, &es.queries));
      es.marks.assign(maxLights_, 0);
      es.stageOf.assign(size_t(maxLights_) * kLightQueries, uint8_t(EngineStage::Count));
    }
  }
  // A timestamp in the light's run of the slot being recorded, ending `stage` (Count: the light's start).
  void mark(EngineStage stage) {
    Slot* es = timedSlot_;
    if (!es || !es->queries) return;
    uint32_t& n = es->marks[timedLight_];
    assert(n < kLightQueries && "a light's boundaries outnumber its run of queries");
    if (n >= kLightQueries) return;
    vkCmdWriteTimestamp(timedCommands_, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, es->queries,
                        kLightRuns + timedLight_ * kLightQueries + n);
    es->stageOf[size_t(timedLight_) * kLightQueries + n] = uint8_t(stage);
    ++n;
  }
  // Queries [first, first + count) into ticks_ (value, availability pairs), without waiting: false when
  // one of them is not available yet.
  bool readQueries(VkQueryPool pool, uint32_t first, uint32_t count) {
    if (count == 0) return true;
    const VkResult r = vkGetQueryPoolResults(ctx_.device, pool, first, count, size_t(count) * 16, ticks_.data(), 16,
                                             VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WITH_AVAILABILITY_BIT);
    if (r == VK_NOT_READY) return false;
    VK_CHECK(r);
    for (uint32_t i = 0; i < count; ++i)
      if (ticks_[2 * i + 1] == 0) return false;
    return true;
  }
  double ticksToMs(uint64_t from, uint64_t to) const {
    return double((to - from) & tickMask_) * ctx_.timestampPeriodNs() * 1e-6;
  }
  // The frame's total and, into `lights`, each light's stage times; all or nothing.
  EngineFrameTimes readTimes(const Slot& es, std::vector<EngineLightStats>& lights) {
    EngineFrameTimes t;
    const uint32_t slot = uint32_t(es.frame % framesInFlight_);
    // Before its tag is written, the slot's queries may still hold the times of the frame before.
    if (!es.queries || !es.timed || tagOf(slot) != frameTag(es.frame) || !readQueries(es.queries, kFrameStart, 2))
      return t;
    t.totalMs = ticksToMs(ticks_[0], ticks_[2]);
    for (uint32_t l = 0; l < lights.size(); ++l) {
      const uint32_t n = es.marks[l];
      if (!readQueries(es.queries, kLightRuns + l * kLightQueries, n)) {
        for (EngineLightStats& st : lights) std::fill(std::begin(st.stageMs), std::end(st.stageMs), 0.0);
        return {};
      }
      for (uint32_t k = 1; k < n; ++k) {
        const uint8_t stage = es.stageOf[size_t(l) * kLightQueries + k];
        if (stage < kEngineStages) lights[l].stageMs[stage] += ticksToMs(ticks_[2 * (k - 1)], ticks_[2 * k]);
      }
    }
    t.available = true;
    return t;
  }
  // After the lights' words, a word a slot: the tag of the last frame of the slot that has run to its end on
  // the device (never 0, the ring's initial value).
  uint64_t frameTagWord(uint32_t slot) const { return uint64_t(framesInFlight_) * maxLights_ * kStatsWords + slot; }
  static uint32_t frameTag(uint64_t frame) { return uint32_t(frame % 0xFFFFFFFFu) + 1; }
  uint32_t tagOf(uint32_t slot) const {
    return static_cast<const volatile uint32_t*>(statsRing_.mapped)[frameTagWord(slot)];
  }
  const uint32_t* statsWords(uint32_t slot, uint32_t light) const {
    return static_cast<const uint32_t*>(statsRing_.mapped) + (uint64_t(slot) * maxLights_ + light) * kStatsWords;
  }
  // The batch size learnt from a completed frame's lights (Traversal::learnBatch), once.
  void learnFromSlot(uint32_t slot) {
    Slot& es = slots_[slot];
    if (es.learned) return;
    es.learned = true;
    // A caller that broke the contract gets no learning from words that are not yet that frame's.
    if (tagOf(slot) != frameTag(es.frame)) return;
    traversal::Traversal& t = recorder_.traversal();
    for (uint32_t l = 0; l < es.lights; ++l) {
      const uint32_t* state = statsWords(slot, l);
      const uint32_t depth = state[STATE_WORDS + SHAPE_DEPTH];
      t.learnBatch(state, t.mostSurvived(state, depth, traversal::Traversal::overflowed(state)),
                   recorder_.layout().triangleCount());
    }
  }

  vk::Context& ctx_;
  ConeRecorder recorder_;
  uint32_t framesInFlight_ = 0, maxLights_ = 0;
  vk::Buffer statsRing_;
  std::vector<Slot> slots_;
  // timing: the boundary the recorder calls, what it marks into, the frame begun
  void markBoundary(const char* name) {
    const EngineStage stage = stageEndedBy(name);
    assert(stage != EngineStage::Count && "a recorder boundary the engine does not time");
    if (stage != EngineStage::Count) mark(stage);
  }
  VkCommandBuffer timedCommands_ = VK_NULL_HANDLE;
  Slot* timedSlot_ = nullptr;
  uint32_t timedLight_ = 0;
  bool begun_ = false;
  uint64_t begunFrame_ = 0;
  uint64_t tickMask_ = 0;
  std::vector<uint64_t> ticks_;  // readQueries' results, sized once
};

}  // namespace

std::unique_ptr<ConeEngine> makeConeEngine(vk::Context& ctx, const ConeOptions& options, uint32_t framesInFlight,
                                           uint32_t maxLights) {
  return std::make_unique<Engine>(ctx, options, framesInFlight, maxLights);
}

}  // namespace cs
