// The cone path as an engine: a frame of 1..N lights recorded into a command buffer the caller submits
// (the public API, include/coneshadow/coneshadow.h, is a thin layer over this; the bench's "cone" method
// runs the same recorder, cone_recorder.h). docs/ARCHITECTURE.md, "The engine".
#pragma once
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "core/function_ref.h"
#include "core/scene.h"
#include "traversal/cone_method.h"
#include "traversal/triangle_layout.h"

namespace cs {
namespace vk {
struct Context;
struct Buffer;
class Commands;
}  // namespace vk
struct DeviceGBuffer;

// The stages of a light's frame, each timed on the GPU between the recorder's boundaries (the public
// API's coneshadow::Stage, in the same order). LightTerm ends at no boundary and reads 0: each kernel
// computes the light's term where it needs it, the compaction first (kept so the stages keep their values).
enum class EngineStage : uint32_t { LightTerm, Compact, Order, Keys, Sort, Build, Traversal, Leaves, Undecided, Count };
inline constexpr uint32_t kEngineStages = uint32_t(EngineStage::Count);
const char* engineStageName(EngineStage stage);  // "light term", "compact", ...

// One light's counts of a recorded frame, read a frame or more later from the stats ring.
struct EngineLightStats {
  uint32_t litSamples = 0;
  uint32_t treeDepth = 0, treeNodes = 0;
  uint64_t pairsTested = 0, pairsSurvived = 0, leafTests = 0;
  bool complete = true;  // false: the traversal's pairs passed its arena; the lit samples not shadowed by then
                         // are written as 0.5 (undecided), the next frames use smaller batches
  double stageMs[kEngineStages] = {};  // GPU ms of each stage, where EngineFrameTimes::available
};
// A recorded frame's GPU time: from beginFrame to the end of record(), from timestamps; not available on a
// queue family without valid timestamps or while the frame's timestamps are not all written.
struct EngineFrameTimes {
  bool available = false;
  double totalMs = 0;
};

class ConeEngine {
 public:
  virtual ~ConeEngine() = default;
  // The scene's triangles (world space), uploaded when `revision` differs from the one held. Host work and
  // allocations only; on a device whose memory the host cannot map, the copies go into the next frame.
  virtual void setGeometry(const Scene& scene, const GeometryRevision& revision) = 0;
  // The geometry as meshes and instances: every mesh's kept triangles in its own space, uploaded once
  // (in Hilbert order of their centroids, each instance's run padded to whole super clusters so no
  // cluster mixes instances), then transformed on the device. Host work and allocations only.
  virtual void setInstances(std::span<const EngineMesh> meshes, std::span<const EngineInstance> instances) = 0;
  // New transforms for the instances of the last setInstances (same count and order): no triangle is
  // uploaded again; the clusters' bounds are transformed on the host, the triangles at the next frame.
  virtual void setTransforms(std::span<const EngineInstance> instances) = 0;
  // The bounds of every instance's triangles as the device holds them (lo > hi when there are none).
  virtual void bounds(glm::vec3& lo, glm::vec3& hi) const = 0;
  // Records a frame into `cmd` (which records into the caller's command buffer): for each light l, the cone
  // path (its lit samples those of g.position and g.normal.xyz with l's term, core/shared.h litSampleFor;
  // g is only read, its normal.w ignored), the undecided samples of an overflowed traversal, then
  // deliver(l, visibility) records what the caller does with the mask (one uint a pixel: the bits of 1.0f
  // lit, 0.0f shadowed, 0.5f undecided; 1.0f where not lit).
  // `frame` numbers the frames from 0; the frame `frame - framesInFlight` must have completed on the
  // device (its stats slot and host-written buffers are reused). Submits nothing, waits for nothing.
  virtual void record(vk::Commands& cmd, const DeviceGBuffer& g, std::span<const glm::vec3> lights, float eps,
                      uint64_t frame, FunctionRef<void(uint32_t light, const vk::Buffer& mask)> deliver) = 0;
  // Starts frame `frame`'s GPU time in `cmd` (its slot's queries reset, the first timestamp), for a caller
  // whose own commands before record() belong to the frame; record() starts it where no one did.
  virtual void beginFrame(vk::Commands& cmd, uint64_t frame) = 0;
  // The stats of a recorded frame that has completed on the device, one per light (empty for a frame that
  // is not among the last framesInFlight recorded); with `times`, the frame's GPU times, read without
  // waiting (the stages' times in the lights' stats where times->available).
  virtual std::vector<EngineLightStats> stats(uint64_t frame, EngineFrameTimes* times = nullptr) = 0;
  // Records into `cmd` each sample's (normal, light term for `light`), the term the frame's kernels compute,
  // into `terms` from `offset` (16 bytes a pixel of g): for a caller that reports which samples face the
  // light (harness/samples.h). No frame needs it.
  virtual void recordLightTerms(vk::Commands& cmd, const DeviceGBuffer& g, glm::vec3 light, const vk::Buffer& terms,
                                uint64_t offset) = 0;
  // Bytes of device memory held.
  virtual uint64_t bytesAllocated() const = 0;
};

// framesInFlight: frames recorded before the oldest must have completed (1..4); maxLights: lights a frame
// (1..64). The options' two-pass variants need a host decision between the passes and are refused.
std::unique_ptr<ConeEngine> makeConeEngine(vk::Context& ctx, const ConeOptions& options, uint32_t framesInFlight,
                                           uint32_t maxLights);

}  // namespace cs
