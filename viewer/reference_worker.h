// The viewer's Embree reference and ambiguity band, computed on a worker thread so the frame loop never
// waits for them: the loop hands over a snapshot of a frame at rest and picks the answer up when it is
// there; a newer snapshot replaces one not yet started. docs/ARCHITECTURE.md, "The viewer".
#pragma once
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "core/scene.h"
#include "method/epsilon.h"
#include "raster/gbuffer.h"

namespace cs::viewer {

struct ReferenceJob {
  uint64_t generation = 0;  // the loop's view-and-light generation the snapshot belongs to
  std::shared_ptr<const Scene> scene;  // the scene as posed for the snapshot (the loop poses its own on)
  GBuffer gbuffer;
  Camera camera;
  glm::vec3 light{0};
};

struct ReferenceAnswer {
  uint64_t generation = 0;
  std::vector<float> visibility;  // 1 lit, 0 shadowed, one a pixel
  std::vector<uint8_t> band;      // nonzero: in the ambiguity band
  double referenceMs = 0, bandMs = 0;
  std::string failure;            // why it could not be computed ("" = it was)
};

class ReferenceWorker {
 public:
  explicit ReferenceWorker(const EpsilonPolicy& policy);
  ~ReferenceWorker();
  ReferenceWorker(const ReferenceWorker&) = delete;
  ReferenceWorker& operator=(const ReferenceWorker&) = delete;

  // Queues a snapshot (replacing a queued one that has not started).
  void submit(ReferenceJob job);
  // The newest finished answer, once; nothing while none is new.
  std::optional<ReferenceAnswer> take();
  // The generation of the job queued or being computed, 0 when idle.
  uint64_t busyWith() const;

 private:
  void loop();
  EpsilonPolicy policy_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<ReferenceJob> queued_;
  std::optional<ReferenceAnswer> answer_;
  uint64_t running_ = 0;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace cs::viewer
