// The engine (cone_engine.h): a frame of 1..N lights recorded into the caller's command buffer by the cone
// path's recorder (cone_recorder.h), its counters read a frame later from a host-visible ring.
// docs/ARCHITECTURE.md, "The engine".
#include "traversal/cone_engine.h"

#include <cstring>

#include "core/error.h"
#include "raster/raster.h"
#include "traversal/cone_recorder.h"
#include "vk/context.h"

namespace cs {
namespace {

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
    statsRing_ = vk::createBuffer(ctx_, uint64_t(framesInFlight) * maxLights * kStatsWords * 4, vk::Memory::HostVisible);
    std::memset(statsRing_.mapped, 0, statsRing_.size);
    slots_.resize(framesInFlight);
    recorder_.layout().resizeSphereSets(size_t(framesInFlight) * maxLights);
  }

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
    auto noBoundary = [](const char*) {};
    const bool adaptive = recorder_.options().sorted && recorder_.options().adaptiveOrder;
    for (uint32_t l = 0; l < lights.size(); ++l) {
      const ConeRecorder::RecordedLight rec =
          recorder_.recordLightFrame(cmd, g, lights[l], eps, adaptive, slot * maxLights_ + l, true, noBoundary);
      if (!rec.onDevice) refuseTooFewPairs(rec.batches, rec.batch);  // the arena shrank once the tree was made
      deliver(l, recorder_.visibility());
      const uint64_t at = (uint64_t(slot) * maxLights_ + l) * kStatsWords * 4;
      cmd.copy(recorder_.traversal().stateBuffer(), statsRing_, STATE_WORDS * 4, 0, at);
      cmd.copy(recorder_.tree().shapeBuffer(), statsRing_, SHAPE_WORDS * 4, 0, at + STATE_WORDS * 4);
    }
    cmd.barrier();  // the stats words visible to the host once the caller's submission completes
  }

  std::vector<EngineLightStats> stats(uint64_t frame) override {
    std::vector<EngineLightStats> out;
    const uint32_t slot = uint32_t(frame % framesInFlight_);
    const Slot& es = slots_[slot];
    if (es.frame != frame) return out;
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
    return out;
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
  // at the light's end) and the staging buffers of the uploads it carried.
  static constexpr uint32_t kStatsWords = STATE_WORDS + SHAPE_WORDS;
  struct Slot {
    uint64_t frame = ~uint64_t(0);
    bool learned = true;
    uint32_t lights = 0;
    std::vector<std::unique_ptr<vk::Buffer>> staged;
    std::vector<vk::Buffer> retired;
  };
  const uint32_t* statsWords(uint32_t slot, uint32_t light) const {
    return static_cast<const uint32_t*>(statsRing_.mapped) + (uint64_t(slot) * maxLights_ + light) * kStatsWords;
  }
  // The batch size learnt from a completed frame's lights (Traversal::learnBatch), once.
  void learnFromSlot(uint32_t slot) {
    Slot& es = slots_[slot];
    if (es.learned) return;
    es.learned = true;
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
};

}  // namespace

std::unique_ptr<ConeEngine> makeConeEngine(vk::Context& ctx, const ConeOptions& options, uint32_t framesInFlight,
                                           uint32_t maxLights) {
  return std::make_unique<Engine>(ctx, options, framesInFlight, maxLights);
}

}  // namespace cs
