// The one deliberate virtual seam: every shadow path (embree, cone, rmsm, cubesm, ...) implements it.
// Samples in (the shared raster output) -> visibility per sample + per-stage timings + bytes.
#pragma once
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "core/scene.h"
#include "raster/gbuffer.h"

namespace cs {
namespace vk { struct Context; }
struct DeviceGBuffer;
struct DeviceScene;

struct FrameInput {
  const Scene* scene = nullptr;
  const GBuffer* gbuffer = nullptr;          // host copy of the raster output
  const DeviceGBuffer* device = nullptr;     // the same samples, resident on the GPU (GPU methods)
  vk::Context* vk = nullptr;                 // null for CPU-only runs
  glm::vec3 light{0};
  float epsilon = 0;                         // along-ray epsilon of the shared policy (method/epsilon.h)
  // The view the samples were rendered from (methods whose analysis weighs samples by their distance to
  // the eye or the view frustum: RTW); null when the caller has none.
  const Camera* camera = nullptr;
  // The scene's geometry revision (computed once per frame by the harness: frameInputOf) and, when the
  // camera pass holds that revision, its geometry on the device for the other passes to draw
  // (raster/raster.h). Not known / null when a caller builds the frame by hand: a method then computes
  // the revision itself and uploads its own copy.
  GeometryRevision revision;
  const DeviceScene* deviceScene = nullptr;
};

// The frame's geometry revision: the one the harness computed, or the scene's own.
inline GeometryRevision revisionOf(const FrameInput& frame) {
  return frame.revision.known() ? frame.revision : geometryRevision(*frame.scene);
}

// What a stage is for, so reports can group stages without knowing the method: a rebuild of the
// method's scene or shadow structure (an acceleration structure, uploaded triangles, a ray tree, shadow
// map faces or pages), the per-sample lookup that answers visibility, or other per-frame work.
enum class StageKind { PerFrame, Rebuild, Lookup };

struct StageTime {
  std::string name;
  double ms = 0;
  StageKind kind = StageKind::PerFrame;
};

inline const char* stageKindName(StageKind k) {
  return k == StageKind::Rebuild ? "rebuild" : k == StageKind::Lookup ? "lookup" : "per-frame";
}

struct MethodOutput {
  std::vector<float> visibility;             // one per pixel, in [0,1], 1 = lit; 1 where the sample is not lit
  std::vector<StageTime> stages;             // in execution order
  // Shadow work only: raster excluded, and the mask's copy into `visibility` (with that vector's
  // allocation) excluded, on every method alike -- stats.readback_ms holds it.
  double totalMs = 0;
  uint64_t bytesAllocated = 0;               // bytes this method allocated for the frame
  uint64_t peakBytes = 0;                    // peak working set
  std::string work;                          // the method's own measure of its work, for reports:
                                             //   "1234 nodes visited, 56 leaf tests", "812 pages", ...
  nlohmann::json stats = nlohmann::json::object();  // method-specific counters (pairs, pages, ...)
};

class ShadowMethod {
 public:
  virtual ~ShadowMethod() = default;
  virtual std::string name() const = 0;
  virtual MethodOutput run(const FrameInput& frame) = 0;
  // One view under several lights: a frame each (the same scene, camera and size; its own light and light
  // term), an output each, in order. Each frame carries its own samples because the light term and the lit
  // samples depend on the light. By default run() a light at a time; a method that shares work between the
  // lights (the cone path: one submission for all of them) overrides it, its masks those of run(), and
  // says so in sharesLights(): the harness then gives it a view's lights together, and any other method a
  // fresh object a light, each run as alone.
  virtual bool sharesLights() const { return false; }
  virtual std::vector<MethodOutput> runLights(std::span<const FrameInput> frames) {
    std::vector<MethodOutput> out;
    out.reserve(frames.size());
    for (const FrameInput& f : frames) out.push_back(run(f));
    return out;
  }
};

}  // namespace cs
