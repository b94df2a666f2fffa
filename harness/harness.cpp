// The frame harness: see harness.h.
#include "harness/harness.h"

#include <algorithm>
#include <cmath>

#include "vk/context.h"

namespace cs {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

namespace {

void writeCost(nlohmann::json& stats, const vk::HostCost& c) {
  stats["submits_per_frame"] = c.submits;
  stats["host_syncs_per_frame"] = c.hostSyncs;
  stats["readback_bytes_per_frame"] = c.readbackBytes;
  stats["allocations_per_frame"] = c.allocations;
  stats["dispatches_per_frame"] = c.dispatches;
}

std::vector<FrameInput> inputsOf(std::span<const PreparedFrame* const> frames) {
  std::vector<FrameInput> inputs;
  for (const PreparedFrame* f : frames) inputs.push_back(f->input);
  return inputs;
}

// Every light of a view run once by its method objects (LightMethods).
std::vector<MethodOutput> runEveryLight(LightMethods methods, std::span<const FrameInput> inputs) {
  if (methods.size() == 1) return runCountedLights(*methods.front(), inputs);
  CS_CHECK(methods.size() == inputs.size(), methods.size() << " method objects for " << inputs.size() << " lights");
  std::vector<MethodOutput> outs;
  for (size_t l = 0; l < inputs.size(); ++l) outs.push_back(runCounted(*methods[l], inputs[l]));
  return outs;
}

// A mask judged against its frame's reference and band.
ErrorStats errorOf(const PreparedFrame& frame, const std::vector<float>& mask) {
  return compareVisibility(frame.gbuffer, mask, frame.reference.output.visibility, frame.band);
}

}  // namespace

MethodOutput runCounted(ShadowMethod& method, const FrameInput& input) {
  if (!input.vk) return method.run(input);
  const vk::HostCost before = input.vk->cost;
  MethodOutput out = method.run(input);
  writeCost(out.stats, input.vk->cost - before);
  return out;
}

std::vector<MethodOutput> runCountedLights(ShadowMethod& method, std::span<const FrameInput> inputs) {
  vk::Context* ctx = inputs.empty() ? nullptr : inputs.front().vk;
  const vk::HostCost before = ctx ? ctx->cost : vk::HostCost{};
  std::vector<MethodOutput> outs = method.runLights(inputs);
  CS_CHECK(outs.size() == inputs.size(),
           method.name() << ": " << outs.size() << " outputs for a frame of " << inputs.size() << " lights");
  for (MethodOutput& out : outs) {
    if (ctx) writeCost(out.stats, ctx->cost - before);
    if (inputs.size() > 1) out.stats["lights_in_frame"] = inputs.size();
  }
  return outs;
}

RunRecorder::RunRecorder(uint32_t frames, double singleFrameAboveMs, bool lastFrame)
    : frames_(frames), singleFrameAboveMs_(singleFrameAboveMs), lastFrame_(lastFrame) {}

void RunRecorder::warmUp(const MethodOutput& first) {
  first_ = first.visibility;
  if (frames_ == 0 || first.totalMs > singleFrameAboveMs_) {
    t_.output = first;
    t_.totals = {first.totalMs};
    frames_ = 0;
  }
}

// Every timed frame's output is kept for its timings and counters, but only the first timed frame's
// mask: N frames at a large resolution would otherwise hold N masks. The masks are compared as they
// come; a method whose masks differ is reported non-deterministic (and shows its first timed mask).
void RunRecorder::add(MethodOutput out) {
  t_.totals.push_back(out.totalMs);
  if (out.visibility != first_) t_.deterministic = false;
  if (outs_.empty() || lastFrame_) mask_ = std::move(out.visibility);
  std::vector<float>().swap(out.visibility);  // `= {}` would keep the mask's memory for every frame
  outs_.push_back(std::move(out));
}

TimedRuns RunRecorder::finish() {
  TimedRuns t = std::move(t_);
  t.medianMs = median(t.totals);
  t.minMs = *std::min_element(t.totals.begin(), t.totals.end());
  t.maxMs = *std::max_element(t.totals.begin(), t.totals.end());
  if (!outs_.empty()) {
    size_t best = lastFrame_ ? outs_.size() - 1 : 0;
    for (size_t i = 0; i < outs_.size() && !lastFrame_; ++i)
      if (std::abs(outs_[i].totalMs - t.medianMs) < std::abs(outs_[best].totalMs - t.medianMs)) best = i;
    t.output = std::move(outs_[best]);
    t.output.visibility = std::move(mask_);
  }
  outs_.clear();
  first_.clear();
  return t;
}

TimedRuns timeRuns(ShadowMethod& method, const FrameInput& input, uint32_t frames, const FrameProgress& progress,
                   double singleFrameAboveMs, const FrameInspector& inspect, bool lastFrame) {
  LightInspector each;
  if (inspect) each = [&](size_t, uint32_t frame, const MethodOutput& out) { inspect(frame, out); };
  ShadowMethod* one = &method;
  return std::move(timeLightRuns({&one, 1}, {&input, 1}, frames, progress, singleFrameAboveMs, each, lastFrame).front());
}

// Each light's runs recorded apart. A light whose warm-up was slow enough to be its one timed frame
// (singleFrameAboveMs) takes no more; the others' timed frames still run every light.
std::vector<TimedRuns> timeLightRuns(LightMethods methods, std::span<const FrameInput> inputs, uint32_t frames,
                                     const FrameProgress& progress, double singleFrameAboveMs,
                                     const LightInspector& inspect, bool lastFrame) {
  std::vector<RunRecorder> recorders(inputs.size(), RunRecorder(frames, singleFrameAboveMs, lastFrame));
  auto once = [&](uint32_t frame) {
    if (progress) progress(frame, frames);
    std::vector<MethodOutput> outs = runEveryLight(methods, inputs);
    if (inspect)
      for (size_t l = 0; l < outs.size(); ++l) inspect(l, frame, outs[l]);
    return outs;
  };
  uint32_t timed = 0;
  {
    const std::vector<MethodOutput> first = once(0);
    for (size_t l = 0; l < first.size(); ++l) {
      recorders[l].warmUp(first[l]);
      timed = std::max(timed, recorders[l].timedFrames());
    }
  }
  for (uint32_t i = 0; i < timed; ++i) {
    std::vector<MethodOutput> outs = once(i + 1);
    for (size_t l = 0; l < outs.size(); ++l)
      if (i < recorders[l].timedFrames()) recorders[l].add(std::move(outs[l]));
  }
  std::vector<TimedRuns> runs;
  for (RunRecorder& r : recorders) runs.push_back(r.finish());
  return runs;
}

FrameInput frameInputOf(const Scene& scene, const GBuffer& gbuffer, const DeviceGBuffer& device, vk::Context& ctx,
                        glm::vec3 light, float epsilon, const Camera* camera, const DeviceScene* deviceScene) {
  FrameInput f;
  f.revision = geometryRevision(scene);
  f.deviceScene = deviceScene && deviceScene->revision == f.revision ? deviceScene : nullptr;
  f.camera = camera;
  f.scene = &scene;
  f.gbuffer = &gbuffer;
  f.device = &device;
  f.vk = &ctx;
  f.light = light;
  f.epsilon = epsilon;
  return f;
}

std::unique_ptr<PreparedFrame> prepareFrame(vk::Context& ctx, Raster& raster, const Scene& scene, const FrameSpec& spec,
                                            const StepProgress& step, const FrameProgress& referenceProgress) {
  auto f = std::make_unique<PreparedFrame>();
  f->scene = &scene;
  f->spec = spec;
  f->deviceName = ctx.driverDescription();
  if (step) step("raster");
  raster.render(spec.camera, spec.light, spec.width, spec.height, f->device, &f->gbuffer);  // warm-up: pipeline compile
  std::vector<double> rasterMs;
  for (uint32_t i = 0; i < std::max(1u, spec.frames); ++i) {
    const RasterTiming rt = raster.render(spec.camera, spec.light, spec.width, spec.height, f->device, &f->gbuffer);
    rasterMs.push_back(rt.gpuMs);
    f->readbackMs = rt.readbackMs;
  }
  f->rasterMs = median(rasterMs);
  f->litSamples = f->gbuffer.litCount();
  f->policy = spec.policy ? *spec.policy : EpsilonPolicy::forScene(scene);
  f->input = frameInputOf(scene, f->gbuffer, f->device, ctx, spec.light, f->policy.eps, &f->spec.camera,
                          &raster.deviceScene());
  CS_CHECK(f->input.deviceScene, "prepareFrame: the camera pass does not hold the scene's geometry (Raster::setGeometry)");

  if (step) step("reference");
  f->embree = std::make_unique<EmbreeReference>();
  f->reference = timeRuns(*f->embree, f->input, spec.frames, referenceProgress, spec.singleFrameAboveMs);
  if (step) step("band");
  StageTime bandTime;
  f->band = f->embree->ambiguityBand(scene, f->gbuffer, spec.light, f->policy, {}, &bandTime);
  f->bandMs = bandTime.ms;
  f->bandSamples = size_t(std::count_if(f->band.begin(), f->band.end(), [](uint8_t b) { return b != 0; }));
  return f;
}

Judged judge(const MethodInfo& info, ShadowMethod* method, const PreparedFrame& frame, uint32_t frames,
             const FrameProgress& progress, double singleFrameAboveMs) {
  const PreparedFrame* one = &frame;
  return std::move(
      judgeLights(info, {&method, method ? 1u : 0u}, {&one, 1}, frames, progress, singleFrameAboveMs).front());
}

std::vector<Judged> judgeLights(const MethodInfo& info, LightMethods methods,
                                std::span<const PreparedFrame* const> frames, uint32_t timedFrames,
                                const FrameProgress& progress, double singleFrameAboveMs) {
  std::vector<Judged> j(frames.size());
  if (info.reference) {
    for (size_t l = 0; l < frames.size(); ++l) j[l].runs = frames[l]->reference;
  } else {
    CS_CHECK(!methods.empty() && std::find(methods.begin(), methods.end(), nullptr) == methods.end(),
             "judge: no method object for " << info.name);
    auto inspect = [&](size_t l, uint32_t, const MethodOutput& out) {
      j[l].perFrame.push_back({out.totalMs, errorOf(*frames[l], out.visibility)});
    };
    std::vector<TimedRuns> runs = timeLightRuns(methods, inputsOf(frames), timedFrames, progress, singleFrameAboveMs,
                                                inspect, info.progressive);
    for (size_t l = 0; l < frames.size(); ++l) j[l].runs = std::move(runs[l]);
  }
  for (size_t l = 0; l < frames.size(); ++l) j[l].error = errorOf(*frames[l], j[l].runs.output.visibility);
  return j;
}

Judged judge(const MethodInfo& info, const Settings& settings, vk::Context& ctx, const PreparedFrame& frame,
             uint32_t frames, const FrameProgress& progress, double singleFrameAboveMs) {
  if (info.reference) return judge(info, nullptr, frame, frames, progress, singleFrameAboveMs);
  std::unique_ptr<ShadowMethod> method = info.make(info.usesDevice ? &ctx : nullptr, settings);
  return judge(info, method.get(), frame, frames, progress, singleFrameAboveMs);
}

std::vector<Judged> judgeInterleaved(const std::vector<const MethodInfo*>& infos,
                                     const std::vector<ShadowMethod*>& methods, const PreparedFrame& frame,
                                     uint32_t frames, const std::function<FrameProgress(size_t)>& progress) {
  const PreparedFrame* one = &frame;
  std::vector<std::vector<ShadowMethod*>> objects;
  for (ShadowMethod* m : methods) objects.push_back({m});
  std::vector<Judged> judged;
  for (std::vector<Judged>& m : judgeInterleavedLights(infos, objects, {&one, 1}, frames, progress))
    judged.push_back(std::move(m.front()));
  return judged;
}

std::vector<std::vector<Judged>> judgeInterleavedLights(const std::vector<const MethodInfo*>& infos,
                                                       const std::vector<std::vector<ShadowMethod*>>& methods,
                                                       std::span<const PreparedFrame* const> frames,
                                                       uint32_t timedFrames,
                                                       const std::function<FrameProgress(size_t)>& progress) {
  CS_CHECK(infos.size() == methods.size(), "judgeInterleaved: " << infos.size() << " methods' entries for "
                                                                << methods.size() << " method objects");
  const size_t n = infos.size(), lights = frames.size();
  const std::vector<FrameInput> inputs = inputsOf(frames);
  std::vector<std::vector<Judged>> judged(n, std::vector<Judged>(lights));
  std::vector<std::vector<RunRecorder>> recorders;
  std::vector<FrameProgress> progresses(n);
  for (size_t k = 0; k < n; ++k) {
    recorders.emplace_back(lights, RunRecorder(timedFrames, kAlwaysTimeEveryFrame, infos[k]->progressive));
    if (progress) progresses[k] = progress(k);
    CS_CHECK(infos[k]->reference || (!methods[k].empty() && methods[k].front()),
             "judgeInterleaved: no method object for " << infos[k]->name);
  }
  // One run of method k on every light, its progress shown and its error recorded frame by frame as
  // judge() does. The reference reruns each frame's own, a light at a time (its mask is the frame's
  // reference: Embree is deterministic).
  auto once = [&](size_t k, uint32_t f) {
    if (progresses[k]) progresses[k](f, timedFrames);
    std::vector<MethodOutput> outs;
    if (infos[k]->reference) {
      for (size_t l = 0; l < lights; ++l) outs.push_back(runCounted(*frames[l]->embree, inputs[l]));
      return outs;
    }
    outs = runEveryLight(methods[k], inputs);
    for (size_t l = 0; l < lights; ++l)
      judged[k][l].perFrame.push_back({outs[l].totalMs, errorOf(*frames[l], outs[l].visibility)});
    return outs;
  };
  for (size_t k = 0; k < n; ++k) {
    const std::vector<MethodOutput> outs = once(k, 0);
    for (size_t l = 0; l < lights; ++l) recorders[k][l].warmUp(outs[l]);
  }
  for (uint32_t f = 1; f <= timedFrames; ++f)
    for (size_t k = 0; k < n; ++k) {
      std::vector<MethodOutput> outs = once(k, f);
      for (size_t l = 0; l < lights; ++l) recorders[k][l].add(std::move(outs[l]));
    }
  for (size_t k = 0; k < n; ++k)
    for (size_t l = 0; l < lights; ++l) {
      judged[k][l].runs = recorders[k][l].finish();
      judged[k][l].error = errorOf(*frames[l], judged[k][l].runs.output.visibility);
    }
  return judged;
}

std::string methodDevice(const MethodInfo& info, const std::string& vulkanDevice) {
  return info.usesDevice ? vulkanDevice : "cpu (" + info.name + ")";
}

FrameResult resultRow(const MethodInfo& info, const std::string& setting, const PreparedFrame& frame,
                      const Judged& judged, bool defaults) {
  FrameResult r = makeFrameResult(frame.scene->name, frame.spec.view, info.name, frame.gbuffer,
                                  methodDevice(info, frame.deviceName), judged.runs.output, judged.error);
  nlohmann::json& st = r.stats;
  st["setting"] = setting;
  st["defaults"] = defaults;
  st["gpu"] = frame.deviceName;
  st["frames"] = judged.runs.totals.size();
  st["total_ms_min"] = judged.runs.minMs;
  st["total_ms_max"] = judged.runs.maxMs;
  st["clock"] = "wall";
  st["deterministic"] = judged.runs.deterministic;
  st["raster_ms"] = frame.rasterMs;
  st["lit_samples"] = frame.litSamples;
  st["band_samples"] = frame.bandSamples;
  if (!judged.runs.output.work.empty()) st["work"] = judged.runs.output.work;
  if (info.progressive || !judged.runs.deterministic) {
    // The run frame by frame, the warm-up first: a progressive method's error against its frame index and
    // against the time spent so far.
    nlohmann::json frames = nlohmann::json::array();
    double cumulative = 0;
    for (size_t k = 0; k < judged.perFrame.size(); ++k) {
      const Judged::Frame& f = judged.perFrame[k];
      cumulative += f.ms;
      frames.push_back({{"frame", k},
                        {"ms", f.ms},
                        {"cumulative_ms", cumulative},
                        {"misclassified_fraction", f.error.misclassifiedFraction},
                        {"misclassified_outside_band", f.error.misclassifiedOutsideBand}});
    }
    st["per_frame"] = frames;
  }
  return r;
}

}  // namespace cs
