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

MethodOutput runCounted(ShadowMethod& method, const FrameInput& input) {
  if (!input.vk) return method.run(input);
  const vk::HostCost before = input.vk->cost;
  MethodOutput out = method.run(input);
  const vk::HostCost c = input.vk->cost - before;
  out.stats["submits_per_frame"] = c.submits;
  out.stats["host_syncs_per_frame"] = c.hostSyncs;
  out.stats["readback_bytes_per_frame"] = c.readbackBytes;
  out.stats["allocations_per_frame"] = c.allocations;
  out.stats["dispatches_per_frame"] = c.dispatches;
  return out;
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
  RunRecorder r(frames, singleFrameAboveMs, lastFrame);
  if (progress) progress(0, frames);
  const MethodOutput first = runCounted(method, input);
  if (inspect) inspect(0, first);
  r.warmUp(first);
  for (uint32_t i = 0; i < r.timedFrames(); ++i) {
    if (progress) progress(i + 1, frames);
    MethodOutput out = runCounted(method, input);
    if (inspect) inspect(i + 1, out);
    r.add(std::move(out));
  }
  return r.finish();
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
  Judged j;
  if (info.reference) {
    j.runs = frame.reference;
  } else {
    CS_CHECK(method, "judge: no method object for " << info.name);
    auto inspect = [&](uint32_t, const MethodOutput& out) {
      j.perFrame.push_back({out.totalMs, compareVisibility(frame.gbuffer, out.visibility,
                                                           frame.reference.output.visibility, frame.band)});
    };
    j.runs = timeRuns(*method, frame.input, frames, progress, singleFrameAboveMs, inspect, info.progressive);
  }
  j.error = compareVisibility(frame.gbuffer, j.runs.output.visibility, frame.reference.output.visibility, frame.band);
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
  CS_CHECK(infos.size() == methods.size(), "judgeInterleaved: " << infos.size() << " methods' entries for "
                                                                << methods.size() << " method objects");
  const size_t n = infos.size();
  std::vector<Judged> judged(n);
  std::vector<RunRecorder> recorders;
  std::vector<FrameProgress> progresses(n);
  std::vector<ShadowMethod*> run(n);
  for (size_t k = 0; k < n; ++k) {
    recorders.emplace_back(frames, kAlwaysTimeEveryFrame, infos[k]->progressive);
    if (progress) progresses[k] = progress(k);
    // The reference reruns the frame's own (its mask is the frame's reference: Embree is deterministic).
    run[k] = infos[k]->reference ? static_cast<ShadowMethod*>(frame.embree.get()) : methods[k];
    CS_CHECK(run[k], "judgeInterleaved: no method object for " << infos[k]->name);
  }
  // One run of method k, its progress shown and its error recorded frame by frame as judge() does.
  auto once = [&](size_t k, uint32_t f) {
    if (progresses[k]) progresses[k](f, frames);
    MethodOutput out = runCounted(*run[k], frame.input);
    if (!infos[k]->reference)
      judged[k].perFrame.push_back({out.totalMs, compareVisibility(frame.gbuffer, out.visibility,
                                                                   frame.reference.output.visibility, frame.band)});
    return out;
  };
  for (size_t k = 0; k < n; ++k) recorders[k].warmUp(once(k, 0));
  for (uint32_t f = 1; f <= frames; ++f)
    for (size_t k = 0; k < n; ++k) recorders[k].add(once(k, f));
  for (size_t k = 0; k < n; ++k) {
    judged[k].runs = recorders[k].finish();
    judged[k].error = compareVisibility(frame.gbuffer, judged[k].runs.output.visibility,
                                        frame.reference.output.visibility, frame.band);
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
