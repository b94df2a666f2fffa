// The one run entry: see run.h.
#include "harness/run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <utility>

#include <glm/gtc/matrix_transform.hpp>

#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "vk/context.h"

namespace cs {

Camera orbitCamera(const Camera& camera, uint32_t k, uint32_t n, bool enclosed) {
  if (n == 0) return camera;
  const double phase = double(k) / double(n), twoPi = 2 * glm::pi<double>();
  const double angle = enclosed ? 0.5 * std::sin(twoPi * phase) : twoPi * phase;
  glm::dvec3 up(camera.up);
  if (!(glm::length(up) > 0)) up = {0, 1, 0};
  const glm::dvec3 target(camera.target), offset = glm::dvec3(camera.eye) - target;
  Camera out = camera;
  out.eye = glm::vec3(target + glm::dvec3(glm::rotate(glm::dmat4(1), angle, glm::normalize(up)) * glm::dvec4(offset, 0)));
  return out;
}

namespace harness {

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

std::string num(double v, int prec) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}

std::unique_ptr<ShadowMethod> makeMethod(const RunMethod& m, vk::Context& ctx) {
  if (m.info->reference) return nullptr;  // the reference's row is the frame's own reference run
  return m.info->make(m.info->usesDevice ? &ctx : nullptr, m.settings);
}

// A row's mask is dropped once its frame is done, unless the caller keeps the frames.
void dropMasks(Frame& f) {
  f.prepared.reset();
  for (Row& r : f.rows) std::vector<float>().swap(r.judged.runs.output.visibility);
}

void finish(Frame& f, const RunSpec& spec, const Events& ev, Results& res) {
  if (ev.done) ev.done(f);
  if (!spec.keepFrames) dropMasks(f);
  res.frames.push_back(std::move(f));
}

// One view under one light prepared: its samples, reference and band (catchFailures: a failure leaves
// the frame its reason and no prepared frame).
void prepare(vk::Context& ctx, const RunSpec& spec, const Events& ev, std::shared_ptr<Raster>& raster, Frame& f) {
  auto step = [&](const std::string& s) {
    if (ev.step) ev.step(f, s);
  };
  try {
    step("raster");
    if (!raster) raster = std::make_shared<Raster>(ctx, *spec.scene);
    FrameSpec fs;
    fs.camera = f.camera;
    fs.view = f.viewName;
    fs.light = f.lightPosition;
    fs.width = spec.width;
    fs.height = spec.height;
    fs.frames = spec.frames;
    fs.singleFrameAboveMs = spec.singleFrameAboveMs;
    fs.policy = spec.policy;
    f.prepared = prepareFrame(
        ctx, *raster, *spec.scene, fs,
        [&](const std::string& s) {
          if (s != "raster") step(s);  // said above, before the camera pass was made
        },
        ev.progress ? ev.progress(f, kReferenceRuns) : FrameProgress{});
    f.prepared->raster = raster;
  } catch (const std::exception& e) {
    if (!spec.catchFailures) throw;
    f.prepared.reset();
    f.failure = e.what();
  }
}

// Every method judged on a view's prepared frames, one a light, each light's row against that light's own
// reference and band. A method that shares work between lights (ShadowMethod::sharesLights: the cone path
// records them in one submission) is made once for the view and runs all its lights together, its progress
// reported on the view's first frame; any other gets a fresh object a light, run as alone.
void judgeView(vk::Context& ctx, const RunSpec& spec, const Events& ev, const std::vector<Frame*>& view) {
  std::vector<const PreparedFrame*> frames;
  for (Frame* f : view) {
    if (ev.step) ev.step(*f, "methods");
    frames.push_back(f->prepared.get());
  }
  auto progressOf = [&](size_t k, size_t l = 0) { return ev.progress ? ev.progress(*view[l], k) : FrameProgress{}; };
  auto row = [&](const Frame& f, size_t k, Judged j) {
    const RunMethod& m = spec.methods[k];
    Row r;
    r.method = k;
    r.result = resultRow(*m.info, m.label, *f.prepared, j, m.defaults);
    r.result.stats["light_index"] = f.light;  // which of the run's lights (RunSpec::lights), and where
    r.result.stats["light"] = {f.lightPosition.x, f.lightPosition.y, f.lightPosition.z};
    r.judged = std::move(j);
    return r;
  };
  if (spec.interleave) {
    // Every row's method objects made first, then their frames round-robin.
    std::vector<std::unique_ptr<ShadowMethod>> owned;
    std::vector<const MethodInfo*> infos;
    std::vector<std::vector<ShadowMethod*>> methods;
    for (const RunMethod& m : spec.methods) {
      infos.push_back(m.info);
      owned.push_back(makeMethod(m, ctx));
      methods.push_back({owned.back().get()});
      if (owned.back() && !owned.back()->sharesLights())
        while (methods.back().size() < view.size()) {
          owned.push_back(makeMethod(m, ctx));
          methods.back().push_back(owned.back().get());
        }
    }
    std::vector<std::vector<Judged>> judged =
        judgeInterleavedLights(infos, methods, frames, spec.frames, [&](size_t k) { return progressOf(k); });
    owned.clear();
    for (size_t l = 0; l < view.size(); ++l)
      for (size_t k = 0; k < judged.size(); ++k) view[l]->rows.push_back(row(*view[l], k, std::move(judged[k][l])));
    if (ev.judged)
      for (const Frame* f : view)
        for (const Row& r : f->rows) ev.judged(*f, r);
    return;
  }
  for (size_t k = 0; k < spec.methods.size(); ++k) {
    const RunMethod& m = spec.methods[k];
    std::vector<Judged> judged;
    std::string failure;
    try {
      std::unique_ptr<ShadowMethod> method = makeMethod(m, ctx);
      if (!method || method->sharesLights()) {
        ShadowMethod* one = method.get();
        judged = judgeLights(*m.info, {&one, one ? 1u : 0u}, frames, spec.frames, progressOf(k),
                             spec.singleFrameAboveMs);
      } else {
        for (size_t l = 0; l < frames.size(); ++l) {
          if (l > 0) method = makeMethod(m, ctx);
          judged.push_back(judge(*m.info, method.get(), *frames[l], spec.frames, progressOf(k, l),
                                 spec.singleFrameAboveMs));
          method.reset();  // its memory freed before the next light's
        }
      }
    } catch (const std::exception& e) {
      if (!spec.catchFailures) throw;
      failure = e.what();
    }
    for (size_t l = 0; l < view.size(); ++l) {
      Row r;
      r.method = k;
      if (failure.empty()) r = row(*view[l], k, std::move(judged[l]));
      else r.failure = failure;
      view[l]->rows.push_back(std::move(r));
      if (ev.judged) ev.judged(*view[l], view[l]->rows.back());
    }
  }
}

// A motion's results row: the method's output on one animation frame against that frame's reference.
FrameResult dynamicRow(const RunMethod& m, const Scene& rest, const Frame& f, const GBuffer& gb, const std::string& device,
                       const MethodOutput& out, const ErrorStats& err, const Motion& motion, size_t lit) {
  FrameResult r = makeFrameResult(rest.name, f.viewName, m.info->name, gb, methodDevice(*m.info, device), out, err);
  double rebuildMs = 0;
  for (const StageTime& s : out.stages)
    if (s.kind == StageKind::Rebuild) rebuildMs += s.ms;
  nlohmann::json& st = r.stats;
  st["frame"] = f.step;
  st["time"] = f.time;
  st["frames"] = motion.frames;
  st["setting"] = m.label;
  st["animated"] = motion.animated;
  st["moving_camera"] = motion.movingCamera;
  st["rebuild_ms"] = rebuildMs;
  st["raster_ms"] = f.rasterMs;
  st["geometry_upload_ms"] = f.uploadMs;
  st["lit_samples"] = lit;
  st["band_samples"] = err.bandSamples;
  if (!out.work.empty()) st["work"] = out.work;
  return r;
}

// compare --animate: per view, every method object made once and run on each animation frame's own
// scene state and samples; each frame's reference and band from that frame.
void runMotion(vk::Context& ctx, const RunSpec& spec, const Events& ev, Results& res) {
  const Motion& motion = *spec.motion;
  CS_CHECK(spec.lights.size() == 1, "harness::run: a motion runs under one light, not " << spec.lights.size());
  const Scene& rest = *spec.scene;
  const glm::vec3 light = spec.lights.front();
  const uint32_t n = motion.frames;
  Raster raster(ctx, rest);
  Scene scene = rest;
  for (size_t vi = 0; vi < spec.views.size(); ++vi) {
    const Camera& camera = spec.views[vi].camera;
    EmbreeReference reference;
    std::vector<std::unique_ptr<ShadowMethod>> objects;
    for (const RunMethod& m : spec.methods) objects.push_back(makeMethod(m, ctx));

    DeviceGBuffer dev;
    GBuffer gb;
    // One frame's scene state and samples.
    Camera current = camera;  // the view of the frame frameAt rendered last
    auto frameAt = [&](double time, Camera cam) {
      current = cam;
      double uploadMs = 0;
      if (motion.animated) {
        motion.pose(time, scene);
        // An animation may carry the scene past what fp32 rays reach (a key of 1e37): refused per frame,
        // by the rule a light is refused by, before any method or Embree traces it.
        scene.computeBounds();
        if (const std::string why = lightRangeProblem(light, scene.boundsMin, scene.boundsMax); !why.empty())
          throw Error(why, rest.name + " at t = " + num(time, 4), "the animation moves the scene out of range: check its keys");
        // A BART camera track moves the `animated` view (unless the camera orbits instead); the frame's
        // input keeps the camera the view asked for (as compare --animate always has).
        if (motion.cameraTrack && camera.name == "animated")
          if (const Camera* tracked = scene.findCamera("animated")) cam = *tracked;
        const auto t0 = Clock::now();
        raster.setGeometry(scene);
        uploadMs = msSince(t0);
      }
      const RasterTiming rt = raster.render(cam, light, spec.width, spec.height, dev, &gb);
      return std::make_pair(rt.gpuMs, uploadMs);
    };

    Frame warm;
    warm.view = vi;
    warm.viewName = spec.views[vi].name;
    warm.camera = camera;
    warm.lightPosition = light;
    if (ev.step) ev.step(warm, "warm-up");
    {
      const double tw = motion.animated ? 0.5 * (motion.frameTime(0, n) + motion.frameTime(std::min(1u, n - 1), n)) : 0.0;
      frameAt(tw, motion.movingCamera ? orbitCamera(camera, 1, 2 * n, motion.enclosed) : camera);
      const EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
      const FrameInput frame = frameInputOf(scene, gb, dev, ctx, light, policy.eps, &current, &raster.deviceScene());
      reference.run(frame);
      for (auto& o : objects)
        if (o) o->run(frame);
    }

    for (uint32_t k = 0; k < n; ++k) {
      Frame f;
      f.view = vi;
      f.viewName = spec.views[vi].name;
      f.lightPosition = light;
      f.step = k;
      f.time = motion.animated ? motion.frameTime(k, n) : 0.0;
      std::tie(f.rasterMs, f.uploadMs) =
          frameAt(f.time, motion.movingCamera ? orbitCamera(camera, k, n, motion.enclosed) : camera);
      f.camera = current;
      const EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
      const FrameInput frame = frameInputOf(scene, gb, dev, ctx, light, policy.eps, &current, &raster.deviceScene());
      const MethodOutput ref = reference.run(frame);
      const std::vector<uint8_t> band = reference.ambiguityBand(scene, gb, light, policy);
      const size_t lit = gb.litCount();
      for (size_t t = 0; t < spec.methods.size(); ++t) {
        Row r;
        r.method = t;
        MethodOutput out = objects[t] ? runCounted(*objects[t], frame) : ref;
        r.judged.error = compareVisibility(gb, out.visibility, ref.visibility, band);
        r.result = dynamicRow(spec.methods[t], rest, f, gb, res.device, out, r.judged.error, motion, lit);
        r.judged.runs.totals = {out.totalMs};
        r.judged.runs.medianMs = r.judged.runs.minMs = r.judged.runs.maxMs = out.totalMs;
        if (!spec.keepFrames) std::vector<float>().swap(out.visibility);
        r.judged.runs.output = std::move(out);
        f.rows.push_back(std::move(r));
        if (ev.judged) ev.judged(f, f.rows.back());
      }
      finish(f, spec, ev, res);
    }
    objects.clear();  // free the view's GPU memory before the next one
  }
}

}  // namespace

std::vector<RunView> viewsOf(const std::vector<Camera>& cameras) {
  std::vector<RunView> views;
  for (const Camera& c : cameras) views.push_back({c, c.name.empty() ? "auto" : c.name});
  return views;
}

Results run(vk::Context& ctx, const RunSpec& spec, const Events& ev) {
  CS_CHECK(spec.scene, "harness::run: no scene");
  for (const RunMethod& m : spec.methods) CS_CHECK(m.info, "harness::run: a row without its registry entry");
  Results res;
  res.device = ctx.driverDescription();
  if (spec.motion) {
    runMotion(ctx, spec, ev, res);
    return res;
  }
  std::shared_ptr<Raster> raster;  // one camera pass for every frame: the scene's geometry uploaded once
  for (size_t v = 0; v < spec.views.size(); ++v) {
    // The view under each light prepared, then the methods on all of them.
    std::vector<Frame> frames(spec.lights.size());
    std::vector<Frame*> prepared;
    for (size_t l = 0; l < frames.size(); ++l) {
      Frame& f = frames[l];
      f.view = v;
      f.light = l;
      f.viewName = spec.views[v].name;
      f.camera = spec.views[v].camera;
      f.lightPosition = spec.lights[l];
      prepare(ctx, spec, ev, raster, f);
      if (f.prepared) prepared.push_back(&f);
    }
    if (!prepared.empty()) judgeView(ctx, spec, ev, prepared);
    for (Frame& f : frames) finish(f, spec, ev, res);
  }
  return res;
}

}  // namespace harness
}  // namespace cs
