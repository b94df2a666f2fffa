// The one run entry: every command (render, compare, compare --animate, --scaling, --light-distances),
// every benchmark and the tests' reference frames call harness::run. It renders each view under each
// light (the frame harness's prepareFrame: samples, epsilon, the Embree reference and its band), makes
// every method of the run from its registry entry and judges it on the view's lights (judgeLights, or
// round-robin with judgeInterleavedLights; a method that shares work between lights takes them all at
// once, ShadowMethod::runLights), and hands back one results row per (frame, method). The caller chooses the
// rows through the registry and writes what it wants of them; it names no method, not even the reference.
// docs/ARCHITECTURE.md, "The run entry".
#pragma once
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "harness/harness.h"

namespace cs {

// The camera of frame k of n: orbiting its target about `up` by 2π·k/n, or, when `enclosed` (a camera
// inside a room), swinging by ±0.5 rad so that it stays inside.
Camera orbitCamera(const Camera& camera, uint32_t k, uint32_t n, bool enclosed);

namespace harness {

// One row of a run: a registered method (the reference's entry too: its row is the frame's reference run)
// with the settings of one point of its sweep.
struct RunMethod {
  const MethodInfo* info = nullptr;
  std::string label;      // the row's setting: "cone", "cone@64M", "rmsm (cached)"
  Settings settings;
  bool defaults = true;   // the setting is the method's defaults (stats "defaults")
};

// A view of the run: a camera and the name rows and files give it.
struct RunView {
  Camera camera;
  std::string name;  // "auto" for a camera without one
};
// The cameras as views, each named by its camera ("auto" when it has no name).
std::vector<RunView> viewsOf(const std::vector<Camera>& cameras);

// compare --animate: frames over the scene's motion and/or a camera orbiting its target. Every method
// object persists across a view's frames, so each frame pays the method's per-frame cost; one warm-up
// frame at a half-step pose comes first. The rows are the frames' (no timed repeats).
struct Motion {
  uint32_t frames = 0;
  bool animated = false;      // the geometry moves: pose(frameTime(k, frames)) before frame k
  bool movingCamera = false;  // the camera orbits its target (orbitCamera), or swings when enclosed
  bool enclosed = false;
  bool cameraTrack = false;   // a view named "animated" follows the posed scene's camera of that name
  std::function<void(double time, Scene& scene)> pose;
  std::function<double(uint32_t k, uint32_t n)> frameTime;
};

struct RunSpec {
  const Scene* scene = nullptr;  // with a motion: its rest pose
  std::vector<RunView> views;
  std::vector<glm::vec3> lights;  // each view is judged under each light: one frame per (view, light)
  uint32_t width = 0, height = 0;
  uint32_t frames = 1;            // timed frames after one warm-up (0: one untimed run each)
  std::vector<RunMethod> methods;
  bool interleave = false;        // the methods' frames round-robin (judgeInterleaved)
  std::optional<EpsilonPolicy> policy;  // unset: the scene's own
  double singleFrameAboveMs = kAlwaysTimeEveryFrame;  // the reference's and every method's timeRuns
  bool keepFrames = false;        // Results keep each prepared frame and every row's mask
  bool catchFailures = false;     // a frame or a method that fails gets its reason instead of ending the run
  std::optional<Motion> motion;   // compare --animate (one light)
};

// One method judged on one frame.
struct Row {
  size_t method = 0;      // its index in RunSpec::methods
  Judged judged;          // its runs and error; the mask in judged.runs.output.visibility (see keepFrames)
  FrameResult result;     // its results row (resultRow; a motion's rows: dynamicRow); no provenance
  std::string failure;    // catchFailures: why it failed ("" = it ran; then result is empty)
};

// One view under one light (a motion: one view at one animation frame).
struct Frame {
  size_t view = 0, light = 0;  // indices into RunSpec::views and RunSpec::lights
  std::string viewName;
  Camera camera;               // as rendered
  glm::vec3 lightPosition{0};
  // The samples, reference and band; null for a motion's frames, for a frame that failed, and, without
  // keepFrames, once the `done` event has seen it.
  std::unique_ptr<PreparedFrame> prepared;
  std::string failure;         // catchFailures: why the frame could not be prepared (then no rows)
  std::vector<Row> rows;       // in RunSpec::methods order
  // A motion's frame: its index, scene time, camera pass time and geometry upload time (ms).
  uint32_t step = 0;
  double time = 0, rasterMs = 0, uploadMs = 0;
};

struct Results {
  std::string device;          // the Vulkan device, as reports print it
  std::vector<Frame> frames;   // views x lights, view by view (a motion: views x animation frames)
};

// What run reports as it goes (each optional).
inline constexpr size_t kReferenceRuns = SIZE_MAX;
struct Events {
  // Before each step of a frame: "raster", "reference", "band", "methods" (a motion: "warm-up"). A view's
  // frames are all prepared before its methods run: "methods" comes for each once the last is.
  std::function<void(const Frame&, const std::string& step)> step;
  // The progress of spec.methods[k] on a frame (k = kReferenceRuns: the frame's reference), or empty. A
  // method that takes a view's lights together is asked on the view's first frame.
  std::function<FrameProgress(const Frame&, size_t k)> progress;
  // A row judged (one after another: as it is judged; interleaved: all once the last is).
  std::function<void(const Frame&, const Row&)> judged;
  // A frame done, its prepared frame and masks still held: where its images are written.
  std::function<void(const Frame&)> done;
};

// The run: each view under each light (or the motion), every method judged on each frame.
Results run(vk::Context& ctx, const RunSpec& spec, const Events& events = {});

}  // namespace harness
}  // namespace cs
