// The cone path's frame recorder: one light's frame recorded into a command buffer (recordLightFrame), shared
// by the engine (cone_engine.cpp, a frame of 1..N lights in the caller's command buffer) and the bench's
// method (runFrame: one submission, with the chunked traversal and two-pass as its fallbacks; runLights: a
// view's lights in one submission).
// docs/ARCHITECTURE.md, "The cone path's code".
#pragma once
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "conetree/conetree.h"
#include "core/function_ref.h"
#include "method/method.h"
#include "rays/rays.h"
#include "sort/sort.h"
#include "traversal/cone_method.h"
#include "traversal/cone_stats.h"
#include "traversal/traversal.h"
#include "traversal/triangle_layout.h"
#include "vk/context.h"

namespace cs {

// Batches one recording may hold: a frame whose arena would need more is traversed chunked (the bench)
// or refused (the engine).
inline constexpr uint64_t kConeMaxBatches = 256;
// Lights one bench frame records together (runLights), as the engine's frames take at most.
inline constexpr size_t kConeMaxLightsTogether = 64;

class ConeRecorder {
 public:
  ConeRecorder(vk::Context& ctx, const ConeOptions& options);

  // What recordLight recorded: the ray order's choice, whether the traversal is in the recording (an arena
  // so small that the batches would number in the hundreds is not), the batches (their first triangles:
  // batchStarts()).
  struct RecordedLight {
    bool adaptive = false, clusters = false, onDevice = true;
    uint64_t batches = 0;
    uint32_t batch = 0;
  };
  // Called with each stage's name at its end; not kept (a lambda with captures costs no allocation).
  using Boundary = FunctionRef<void(const char*)>;

  // One light of a frame as the engine records it: a barrier, the cones' frame chosen, recordLight, and
  // with `markUndecided` an overflowed traversal's undecided lit samples written as 0.5. The samples are
  // only read (g.normal.w is ignored: each kernel computes the light's term, core/shared.h litSampleFor),
  // so one G-buffer serves every light. The bench's one-pass frame records through it too, without
  // markUndecided (it resumes an overflow chunked).
  RecordedLight recordLightFrame(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light, float eps, bool adaptive,
                                 uint32_t sphereSlot, bool markUndecided, const Boundary& boundary);
  // Each sample's (normal, light term for `light`) into `terms` (16 bytes a pixel): the term the frame's
  // kernels compute, for a caller that reports it (harness/samples.h). No frame needs it.
  void recordLightTerms(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light, const vk::BufferRange& terms);

  // One bench frame (the method's run): the triangles uploaded when they changed, the light checked, one
  // submission of recordLightFrame and the readback -- or with profileStages a submission a stage. Fallbacks:
  // the chunked traversal after it, when the arena holds too few pairs for one recording or its pairs
  // outgrew it on the GPU; with two-pass, the ray stages a submission each, then the passes (002 §3.4).
  struct Frame {
    std::vector<float> mask;
    double uploadMs = 0, totalMs = 0;
    std::vector<StageTime> stages;
    ConeFrameStats stats;
  };
  Frame runFrame(const FrameInput& frame);
  // A view under several lights (ShadowMethod::runLights; 1..kConeMaxLightsTogether frames of the same
  // scene and size): the upload, the frame buffers and the arena once, then recordLightFrame a light with its
  // mask and counters copied out after it, all in one submission with one wait. A light whose traversal
  // needs the host between submissions (the chunked traversal: an arena too small for one recording, or
  // pairs past it on the GPU) is run again alone (runFrame); two-pass and profiled variants, and a single
  // light, are a runFrame each. A light's totalMs is its share of the frame (stats.lights says how).
  std::vector<Frame> runLights(std::span<const FrameInput> frames);

  // Pieces the engine's frame uses around recordLightFrame.
  void refuseUnreachableLight(glm::vec3 light) const;
  void sizeFrameBuffers(uint32_t width, uint32_t height);
  void ensureTraversal(uint32_t pixels);
  // Batches a frame's traversal takes at the current arena (more than kConeMaxBatches: not recordable).
  uint64_t batchesNeeded();

  TriangleLayout& layout() { return layout_; }
  const TriangleLayout& layout() const { return layout_; }
  traversal::Traversal& traversal() { return *traversal_; }
  const cone::ConeTree& tree() const { return tree_; }
  const vk::Buffer& visibility() const { return visibility_; }
  // The scene index of each batch's first triangle, in order, of the last recordLight's traversal.
  const std::vector<uint32_t>& batchStarts() const { return batchStarts_; }
  const ConeOptions& options() const { return options_; }
  // Every buffer held for a frame.
  uint64_t heldBytes() const;

 private:
  // A light's frame into `cmd`: the visibility words set to lit, the lit samples' compaction, the ray order
  // (sorted, screen, or measured on the GPU when `adaptive`), keys, sort, the tree, the far frame's
  // triangles, the traversal and the leaves (the mask in visibility()). boundary(name) ends each stage.
  // The cones' frame (chooseFrame) must be chosen for `light` first.
  RecordedLight recordLight(vk::Commands& cmd, const DeviceGBuffer& g, const traversal::TraversalInput& in,
                            glm::vec3 light, bool adaptive, uint32_t sphereSlot, const Boundary& boundary);
  void chooseFrame(glm::vec3 light) { frame_ = cone::chooseFrame(light, layout_.boundsLo(), layout_.boundsHi()); }
  traversal::TraversalInput traversalInput(glm::vec3 light, float eps);
  // The visibility words set to lit, the lit samples' compaction and (in Hilbert order) their keys:
  // fused into one stage where the device's sort takes pairs. Returns whether they were fused.
  bool fusedKeys(rays::RayOrder order) const;
  bool recordCompaction(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light, rays::RayOrder order,
                        const Boundary& boundary);
  traversal::TraversalStats runSubmitted(const FrameInput& frame, const DeviceGBuffer& g,
                                         const traversal::TraversalInput& in, std::vector<StageTime>& stages,
                                         ConeFrameStats& stats, std::vector<float>& mask);
  traversal::TraversalStats runTwoPass(const FrameInput& frame, const DeviceGBuffer& g,
                                       const traversal::TraversalInput& in, std::vector<StageTime>& stages,
                                       ConeFrameStats& stats);
  traversal::TraversalStats traverse(const traversal::TraversalInput& in, uint32_t first, uint32_t count);
  // The adaptive ray order's history of one light: whether its last measured frame sorted its rays, and the
  // frames since (runFrame's light in order_, runLights' light l in lightOrders_[l]).
  struct OrderHistory {
    bool loose = false;
    uint32_t framesSinceCheck = 0;
  };
  bool measuresOrder(const OrderHistory& h) const;
  // What a frame's stats say before and after its submission: the settings and the light's cone frame (the
  // frame_ chosen); the recording; the tree's shape and the ray order (orderWords: measured this frame, or
  // null); the stages' kinds and the memory.
  void describeFrame(ConeFrameStats& stats, float eps) const;
  void describeRecording(const RecordedLight& rec, ConeFrameStats& stats) const;
  void noteCounters(const uint32_t* shape, const uint32_t* orderWords, OrderHistory& order, ConeFrameStats& stats);
  void finishFrame(Frame& out) const;
  std::string raySortName() const;
  rays::KeysPush keysPush(glm::vec3 light) const;

  vk::Context& ctx_;
  ConeOptions options_;
  TriangleLayout layout_;
  vk::Kernel sampleLight_;
  cone::ConeTree tree_;
  std::unique_ptr<traversal::Traversal> traversal_;
  vk::Timer timer_;
  std::unique_ptr<rays::LitRays> rays_;
  uint32_t raysWidth_ = 0, raysHeight_ = 0;
  vk::Buffer visibility_;
  vk::Readback readback_{ctx_};  // the mask and the counters, copied inside the frame's submission
  std::chrono::steady_clock::time_point submitStart_, submitEnd_;  // the frame's one submission
  uint64_t traversalMemory_ = 0;  // the traversal's memory bound this frame (ensureTraversal)
  cone::FrameChoice frame_;       // this light's cone frame (world or far)
  std::vector<uint32_t> batchStarts_;  // room for kConeMaxBatches made once: a recording allocates nothing
  // the ray order chosen on the GPU (ConeOptions::adaptiveOrder)
  vk::Kernel orderChoice_;
  vk::Buffer orderWords_;               // ORDER_* (traversal_layout.h)
  OrderHistory order_;
  // runLights: each light's order history, and its mask and counters copied out of the one submission
  std::vector<OrderHistory> lightOrders_;
  vk::Buffer lightWords_;
  // two-pass
  vk::Kernel unfinished_;
  std::unique_ptr<sort::Compact> compact_;
  vk::Buffer rayFlags_, remaining_, kept_;
};

}  // namespace cs
