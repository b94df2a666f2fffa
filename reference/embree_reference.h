// The ray-traced ground truth (docs/ARCHITECTURE.md, "Contracts": ground truth): Embree 3, one occlusion
// ray per lit sample under the shared epsilon policy (method/epsilon.h), and the ambiguity band traced on
// the same BVH.
#pragma once
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <embree3/rtcore.h>
#include <glm/glm.hpp>

#include "method/method.h"
#include "method/epsilon.h"

namespace cs {

class ThreadPool;

// One RTCDevice, shared across frames (and by anything else that traces): creating a device costs
// milliseconds and spins up TBB, which no frame should pay. Captures Embree's errors (the callback runs
// on whichever thread failed; rtcGetDeviceError only sees the calling thread's) and tracks the memory
// Embree allocates through its memory-monitor callback.
class EmbreeDevice {
 public:
  // config: Embree's device configuration string ("" = defaults: all threads, best ISA).
  explicit EmbreeDevice(const std::string& config = {});
  ~EmbreeDevice();
  EmbreeDevice(const EmbreeDevice&) = delete;
  EmbreeDevice& operator=(const EmbreeDevice&) = delete;

  RTCDevice handle() const { return device_; }
  // Throws cs::Error naming `where` and Embree's message if any Embree call failed since the last check.
  void check(const std::string& where);

  int64_t liveBytes() const { return live_.load(); }        // Embree memory held now
  int64_t peakBytes() const { return peak_.load(); }        // highest liveBytes since resetPeak()
  uint64_t allocatedBytes() const { return allocated_.load(); }  // all allocations ever (cumulative)
  void resetPeak() { peak_.store(live_.load()); }

 private:
  static bool onMemory(void* self, ssize_t bytes, bool post);
  static void onError(void* self, RTCError code, const char* message);

  RTCDevice device_ = nullptr;
  std::atomic<int64_t> live_{0}, peak_{0};
  std::atomic<uint64_t> allocated_{0};
  std::mutex errorMutex_;
  std::string error_;  // first error since the last check(), empty if none
};

struct EmbreeOptions {
  // MEDIUM: Embree's binned-SAH build. Embree is timed as build + rays because a dynamic scene rebuilds
  // every frame (docs/ARCHITECTURE.md, "Contracts"); HIGH adds spatial splits, which build several times
  // slower and only pay off when far more rays than one frame's ~1M shadow rays are traced per build.
  RTCBuildQuality quality = RTC_BUILD_QUALITY_MEDIUM;
  unsigned threads = 0;   // ray-tracing threads, 0 = all hardware threads (the build uses Embree's TBB)
  size_t grain = 4096;    // pixels per work item: a few scanlines, so packets stay coherent
};

class EmbreeReference : public ShadowMethod {
 public:
  // device: shared across frames / instances; null creates one for this instance.
  explicit EmbreeReference(std::shared_ptr<EmbreeDevice> device = nullptr, EmbreeOptions options = {});
  ~EmbreeReference() override;

  std::string name() const override { return "embree"; }

  // Builds the BVH of frame.scene (stage "bvh_build"), then traces the base ray of every lit sample
  // toward frame.light (stage "rays"); totalMs = both. visibility: 1 lit / 0 shadowed, 1 where the
  // sample is not lit. frame.epsilon is the along-ray epsilon; 0 means "the policy's eps for this scene".
  // The BVH stays alive for ambiguityBand() and traceOccluded() until the next run()/build().
  MethodOutput run(const FrameInput& frame) override;

  // The ambiguity band (method/epsilon.h): 1 for each lit sample where any family member disagrees
  // with the base answer, 0 elsewhere. Reuses the BVH of the last run() when it was built from a scene
  // with exactly these positions and indices (checked against Embree's copy), else builds one. The time
  // (including any build) goes to *timing as stage "band"; it is not part of run()'s totalMs.
  std::vector<uint8_t> ambiguityBand(const Scene& scene, const GBuffer& gbuffer, glm::vec3 light,
                                     const EpsilonPolicy& policy, const BandOptions& options = {},
                                     StageTime* timing = nullptr);

  // Builds the BVH of `scene` now (replacing any previous one); returns milliseconds.
  double build(const Scene& scene);
  // True when the current BVH was built from exactly these positions and indices.
  bool builtFrom(const Scene& scene) const;
  // 1 where the ray hits geometry with t in its interval, 0 where it does not; on the current BVH.
  std::vector<uint8_t> traceOccluded(const std::vector<ShadowRay>& rays);

  const std::shared_ptr<EmbreeDevice>& device() const { return device_; }
  unsigned threadCount() const;

 private:
  void releaseScene();

  std::shared_ptr<EmbreeDevice> device_;
  EmbreeOptions options_;
  std::unique_ptr<ThreadPool> pool_;
  RTCScene scene_ = nullptr;
  const float* vertices_ = nullptr;    // Embree's copies, for builtFrom()
  const uint32_t* indices_ = nullptr;
  size_t vertexCount_ = 0, triangleCount_ = 0;
};

// The band without a prior run(): builds its own BVH on a fresh device.
std::vector<uint8_t> ambiguityBand(const Scene& scene, const GBuffer& gbuffer, glm::vec3 light,
                                   const EpsilonPolicy& policy, const BandOptions& options = {});

}  // namespace cs
