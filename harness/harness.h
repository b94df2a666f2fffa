// One frame harness for every command, benchmark and test: prepare a frame once (the camera pass's
// samples on the host and the device, the epsilon policy, the Embree reference and its ambiguity band),
// then judge any method on it the same way (one warm-up, N timed frames, the median frame's mask against
// the reference, the common statistics of a results row).
//
// Time: a method's totalMs is its shadow work as it measures it -- the host's wall clock around its
// submissions and waits (lavapipe's timestamps are not trusted, docs/ARCHITECTURE.md), raster excluded;
// the harness reports the median, min and max over the timed frames and names the clock ("wall").
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/scene.h"
#include "judge/frame_output.h"
#include "method/method.h"
#include "judge/metrics.h"
#include "method/registry.h"
#include "raster/gbuffer.h"
#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "method/epsilon.h"

namespace cs {

double median(std::vector<double> values);

// One run of `method`, with what it cost the host (vk::HostCost, counted over the run when the frame has a
// Vulkan context) in its stats under submits_per_frame, host_syncs_per_frame, readback_bytes_per_frame,
// allocations_per_frame and dispatches_per_frame. Every command runs methods through this.
MethodOutput runCounted(ShadowMethod& method, const FrameInput& input);
// One run of `method` on a view's lights together (ShadowMethod::runLights: a frame a light), an output a
// light. The host's cost is counted over that one call -- the view's frame of every light -- and written in
// every output's stats under runCounted's keys, with lights_in_frame (the lights of the call) when above 1.
std::vector<MethodOutput> runCountedLights(ShadowMethod& method, std::span<const FrameInput> inputs);

// Called before each run of a method: frame 0 is the warm-up, then 1..frames.
using FrameProgress = std::function<void(uint32_t frame, uint32_t frames)>;

// One warm-up run (shader compiles, caches), then `frames` timed ones -- except that a warm-up slower than
// singleFrameAboveMs is itself the one timed frame (compiles are noise against it; long benchmark runs).
struct TimedRuns {
  MethodOutput output;         // the median frame's output (its mask: the first timed frame's, the same
                               //   mask when deterministic; only one mask is held, whatever `frames`);
                               //   with lastFrame, the last timed frame's output and mask
  std::vector<double> totals;  // each timed frame's totalMs
  double medianMs = 0, minMs = 0, maxMs = 0;
  bool deterministic = true;   // every timed frame's mask equals the warm-up's (the cone path promises it)
};
inline constexpr double kAlwaysTimeEveryFrame = 1e300;
// Sees each run's output, the warm-up (frame 0) included, before its mask is dropped.
using FrameInspector = std::function<void(uint32_t frame, const MethodOutput& out)>;
TimedRuns timeRuns(ShadowMethod& method, const FrameInput& input, uint32_t frames, const FrameProgress& progress = {},
                   double singleFrameAboveMs = kAlwaysTimeEveryFrame, const FrameInspector& inspect = {},
                   bool lastFrame = false);
// A method's objects on a view's lights: one taking them together (ShadowMethod::sharesLights: its
// runLights, counted by runCountedLights), or one a light, each run as alone (runCounted).
using LightMethods = std::span<ShadowMethod* const>;
// timeRuns on a view's lights: each run every light once; a TimedRuns per light, each timed by its
// output's totalMs. inspect(light, frame, output).
using LightInspector = std::function<void(size_t light, uint32_t frame, const MethodOutput& out)>;
std::vector<TimedRuns> timeLightRuns(LightMethods methods, std::span<const FrameInput> inputs, uint32_t frames,
                                     const FrameProgress& progress = {},
                                     double singleFrameAboveMs = kAlwaysTimeEveryFrame,
                                     const LightInspector& inspect = {}, bool lastFrame = false);

// One method's runs as timeRuns records them (timeRuns is this, in a loop), for callers that interleave
// several methods' frames: the warm-up's output, then each timed frame's, then the summary.
class RunRecorder {
 public:
  RunRecorder(uint32_t frames, double singleFrameAboveMs, bool lastFrame);
  void warmUp(const MethodOutput& first);
  uint32_t timedFrames() const { return frames_; }  // 0 after a warm-up above singleFrameAboveMs
  void add(MethodOutput out);
  TimedRuns finish();

 private:
  uint32_t frames_;
  double singleFrameAboveMs_;
  bool lastFrame_;
  TimedRuns t_;
  std::vector<float> first_, mask_;  // the warm-up's mask; the mask kept
  std::vector<MethodOutput> outs_;   // the timed frames' outputs, masks dropped
};

struct FrameSpec {
  Camera camera;
  std::string view;  // the camera's name ("auto" for an automatic one)
  glm::vec3 light{0};
  uint32_t width = 0, height = 0;
  uint32_t frames = 1;  // timed frames of the raster and the reference (after one warm-up each)
  double singleFrameAboveMs = kAlwaysTimeEveryFrame;  // the reference's timeRuns
  std::optional<EpsilonPolicy> policy;  // unset: the scene's own (EpsilonPolicy::forScene)
};

// What every method is fed for one frame: the same samples, light and epsilon.
// The scene's geometry revision is computed here, once; `deviceScene` (the camera pass's geometry) is
// shared when it holds that revision.
FrameInput frameInputOf(const Scene& scene, const GBuffer& gbuffer, const DeviceGBuffer& device, vk::Context& ctx,
                        glm::vec3 light, float epsilon, const Camera* camera = nullptr,
                        const DeviceScene* deviceScene = nullptr);

// A prepared frame. Not movable: `input` points into it.
struct PreparedFrame {
  const Scene* scene = nullptr;
  FrameSpec spec;
  GBuffer gbuffer;
  DeviceGBuffer device;
  EpsilonPolicy policy;
  FrameInput input;
  std::string deviceName;  // the Vulkan device, as reports print it
  std::shared_ptr<Raster> raster;  // the camera pass that drew it, when harness::run kept it (input.deviceScene is its)
  double rasterMs = 0, readbackMs = 0;  // median GPU time of the camera pass; its last readback
  size_t litSamples = 0;
  std::unique_ptr<EmbreeReference> embree;
  TimedRuns reference;
  std::vector<uint8_t> band;
  size_t bandSamples = 0;
  double bandMs = 0;

  PreparedFrame() = default;
  PreparedFrame(const PreparedFrame&) = delete;
  PreparedFrame& operator=(const PreparedFrame&) = delete;
};

// What prepare reports as it goes: "raster", "reference", "band".
using StepProgress = std::function<void(const std::string& step)>;

// Renders the view (one warm-up, spec.frames timed), runs the reference (timeRuns) and the band. The
// raster must hold `scene`'s geometry.
std::unique_ptr<PreparedFrame> prepareFrame(vk::Context& ctx, Raster& raster, const Scene& scene, const FrameSpec& spec,
                                            const StepProgress& step = {}, const FrameProgress& referenceProgress = {});

struct Judged {
  TimedRuns runs;
  ErrorStats error;
  // Each run's wall ms and error, the warm-up first (frame 0): a progressive method's convergence.
  struct Frame {
    double ms = 0;
    ErrorStats error;
  };
  std::vector<Frame> perFrame;
};

// The method on the prepared frame (a reference method's row is the reference run itself).
Judged judge(const MethodInfo& info, ShadowMethod* method, const PreparedFrame& frame, uint32_t frames,
             const FrameProgress& progress = {}, double singleFrameAboveMs = kAlwaysTimeEveryFrame);
// judge(), making the method from its registry entry and settings first.
Judged judge(const MethodInfo& info, const Settings& settings, vk::Context& ctx, const PreparedFrame& frame,
             uint32_t frames, const FrameProgress& progress = {}, double singleFrameAboveMs = kAlwaysTimeEveryFrame);
// judge() on a view's frames, one a light (timeLightRuns; methods empty for the reference): a Judged a
// light, against that light's reference and band.
std::vector<Judged> judgeLights(const MethodInfo& info, LightMethods methods,
                                std::span<const PreparedFrame* const> frames, uint32_t timedFrames,
                                const FrameProgress& progress = {}, double singleFrameAboveMs = kAlwaysTimeEveryFrame);

// The results row of a judged method: the method's output and error, and the statistics every row
// carries (frames, min/max, the clock, determinism, raster time, lit and band samples, the device).
// defaults: the setting is the method's defaults (stats "defaults": true; a single-setting run is).
FrameResult resultRow(const MethodInfo& info, const std::string& setting, const PreparedFrame& frame,
                      const Judged& judged, bool defaults = true);

// Where a method runs, as rows name it: the Vulkan device, or "cpu (<name>)".
std::string methodDevice(const MethodInfo& info, const std::string& vulkanDevice);
// judge() for several methods on one frame, their timed frames round-robin: every method's warm-up in
// turn, then frame 1 of each, then frame 2, ...: a slow spell of a shared machine falls on all of them
// alike, so the ratios of their medians hold where one method's frames after another's drift apart
// (docs/ARCHITECTURE.md, "Timing side by side"). A reference entry (info.reference; its method object may be null)
// reruns the frame's reference for its times; its mask is the frame's. Every method is alive at once,
// with two masks each (RunRecorder's): their memory adds up. progress(k): method k's progress, or empty.
std::vector<Judged> judgeInterleaved(const std::vector<const MethodInfo*>& infos,
                                     const std::vector<ShadowMethod*>& methods, const PreparedFrame& frame,
                                     uint32_t frames, const std::function<FrameProgress(size_t)>& progress = {});
// judgeInterleaved on a view's frames, one a light, each method's objects as LightMethods: [method][light].
std::vector<std::vector<Judged>> judgeInterleavedLights(const std::vector<const MethodInfo*>& infos,
                                                       const std::vector<std::vector<ShadowMethod*>>& methods,
                                                       std::span<const PreparedFrame* const> frames,
                                                       uint32_t timedFrames,
                                                       const std::function<FrameProgress(size_t)>& progress = {});



}  // namespace cs
