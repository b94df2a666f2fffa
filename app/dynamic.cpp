// `coneshadow compare --animate N`: see dynamic.h.
#include "app/dynamic.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include "app/commands.h"
#include "app/frame_runner.h"
#include "core/animation.h"
#include "core/image_io.h"
#include "judge/frame_output.h"
#include "harness/harness.h"
#include "harness/run.h"
#include "judge/metrics.h"
#include "method/epsilon.h"
#include "vk/context.h"

namespace fs = std::filesystem;

namespace cs {

namespace {

// What moves a dynamic scene: the built-in motion or a glTF file's node animation (AnimatedScene), or a
// BART file's keyframes and animated triangles (AffAnimation, whose camera track moves its `animated`
// view).
struct Motion {
  Scene rest;
  bool animated = false, cyclic = false;
  double start = 0, end = 0;
  std::unique_ptr<AnimatedScene> gltf;
  std::unique_ptr<AffAnimation> aff;
  std::optional<glm::vec3> planeLo, planeHi;  // a BART scene's ground plane, from its start pose
  void pose(double t, Scene& scene) const {
    if (gltf) {
      gltf->pose(t, scene);
    } else if (aff) {
      scene = aff->sceneAt(t);
      if (planeLo) addGroundPlane(scene, *planeLo, *planeHi);
    }
  }
  double frameTime(uint32_t k, uint32_t n) const {
    if (gltf) return gltf->frameTime(k, n);
    return n <= 1 ? start : start + (end - start) * double(k) / double(n - 1);
  }
};

Motion loadMotion(const Options& o) {
  const std::string& path = o.scene;
  Motion m;
  if (path.empty() || path == "builtin") {
    m.gltf = std::make_unique<AnimatedScene>(builtinAnimatedScene());
  } else if (const uint64_t triangles = parseHeightFieldArg(path)) {
    m.gltf = std::make_unique<AnimatedScene>();  // a static scene
    m.gltf->rest = heightFieldScene(triangles);
  } else if (const FamilyParams family = parseFamilyArg(path); family.valid) {
    m.gltf = std::make_unique<AnimatedScene>();  // a static scene
    m.gltf->rest = familyScene(family);
  } else {
    if (!fs::exists(path))
      throw Error("no such file", path, "give a scene file (.gltf/.glb, .aff, .obj, .ply, ...), or omit SCENE for the built-in scene");
    std::string ext = fs::path(path).extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (isAffFile(path)) {
      m.aff = std::make_unique<AffAnimation>(path, std::cerr);
    } else if (ext == ".gltf" || ext == ".glb") {
      m.gltf = std::make_unique<AnimatedScene>(loadAnimatedGltf(path, std::cerr));
    } else {
      m.gltf = std::make_unique<AnimatedScene>();  // a format without animation: the static scene
      m.gltf->rest = loadSceneFile(path, std::cerr);
    }
  }
  // The ground plane of the rest pose, the same in every frame (it lies outside every animated range).
  if (o.groundPlane && m.gltf) addGroundPlane(m.gltf->rest);
  if (m.gltf) {
    m.rest = m.gltf->rest;
    m.animated = m.gltf->animated();
    m.cyclic = m.gltf->cyclic;
    m.start = m.gltf->start;
    m.end = m.gltf->end;
  } else {
    m.rest = m.aff->sceneAt(m.aff->start());
    if (o.groundPlane) {
      m.planeLo = m.rest.boundsMin, m.planeHi = m.rest.boundsMax;
      addGroundPlane(m.rest);
    }
    m.animated = m.aff->animated();
    m.start = m.aff->start();
    m.end = m.aff->end();
  }
  if (!path.empty() && path != "builtin") {
    m.rest.sourcePath = path;
    m.rest.sourceHash = fileHash(path);
  }
  return m;
}

}  // namespace

std::optional<viewer::Animation> viewerAnimation(const Options& o, Scene& rest) {
  auto m = std::make_shared<Motion>(loadMotion(o));
  rest = m->rest;
  if (!m->animated) return std::nullopt;
  viewer::Animation a;
  a.pose = [m](double t, Scene& scene) { m->pose(t, scene); };
  a.start = m->start;
  a.end = m->end;
  a.cyclic = m->cyclic;
  return a;
}

namespace {

std::string num(double v, int prec) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}

// One row of the report: a method (with its settings) on one view, over every frame.
struct Track {
  const MethodInfo* info = nullptr;
  std::string label;
  Settings settings;
  std::vector<FrameResult> frames;
};

struct ViewLog {
  std::string view;
  std::vector<double> rasterMs, uploadMs;
};

// Each chosen method's rows (MethodInfo::dynamicRows).
std::vector<Track> makeTracks(const Options& o, bool staticGeometry) {
  std::vector<Track> tracks;
  for (const MethodInfo* m : chosenMethods(o))
    for (SweepPoint& p : dynamicRowsOf(*m, settingsFor(o, *m), staticGeometry))
      tracks.push_back({m, p.label, std::move(p.settings), {}});
  return tracks;
}

// The per-frame rebuild stages of a track: "bvh_build 1.23" or "upload 0.40 + build 2.10 = 2.50",
// medians over the frames.
std::string rebuildText(const Track& t) {
  std::vector<std::string> names;
  for (const FrameResult& f : t.frames)
    for (const StageTime& s : f.stages)
      if (s.kind == StageKind::Rebuild && std::find(names.begin(), names.end(), s.name) == names.end())
        names.push_back(s.name);
  if (names.empty()) return "—";
  std::string text;
  std::vector<double> sums(t.frames.size(), 0.0);
  for (const std::string& n : names) {
    std::vector<double> ms;
    for (size_t k = 0; k < t.frames.size(); ++k) {
      double v = 0;
      for (const StageTime& s : t.frames[k].stages)
        if (s.name == n) v += s.ms;
      ms.push_back(v);
      sums[k] += v;
    }
    text += (text.empty() ? "" : " + ") + n + " " + num(median(ms), 2);
  }
  if (names.size() > 1) text += " = " + num(median(sums), 2);
  return text;
}

std::string dynamicMd(const std::string& sceneName, const std::string& device, const Options& o,
                      const std::string& motion, const std::vector<ViewLog>& views,
                      const std::vector<std::vector<Track>>& tracks) {
  std::ostringstream os;
  os << "# coneshadow compare --animate: " << sceneName << "\n\n"
     << "device: " << device << "\n\n"
     << o.width << "x" << o.height << ", " << o.animateFrames << " frame(s): " << motion
     << ". Every method object persists across the frames, so each frame pays the method's per-frame cost; "
        "one warm-up frame at a half-step pose comes first. ms per frame: median (min–max) over the frames. "
        "Per-frame rebuild: medians of the stages that rebuild the method's scene or shadow structure every "
        "frame, by the names the method reports. Misclassified: lit samples outside the ambiguity band whose "
        "answer differs from Embree's, summed over the frames (count, and % of the lit samples outside the "
        "band); worst frame: the one with the most.\n";
  for (size_t v = 0; v < views.size(); ++v) {
    os << "\n## " << views[v].view << "\n\n"
       << "| method | ms per frame median (min–max) | per-frame rebuild, median ms | misclassified outside band, "
          "all frames | worst frame |\n| --- | ---: | --- | ---: | --- |\n";
    for (const Track& t : tracks[v]) {
      std::vector<double> ms;
      uint64_t wrong = 0, counted = 0, worst = 0;
      size_t worstFrame = 0;
      for (size_t k = 0; k < t.frames.size(); ++k) {
        const ErrorStats& e = t.frames[k].error;
        ms.push_back(t.frames[k].totalMs);
        wrong += e.misclassifiedOutsideBand;
        counted += e.litSamples - e.bandSamples;
        if (e.misclassifiedOutsideBand > worst) {
          worst = e.misclassifiedOutsideBand;
          worstFrame = k;
        }
      }
      const double fraction = counted ? double(wrong) / double(counted) : 0.0;
      os << "| " << t.label << " | " << num(median(ms), 2) << " (" << num(*std::min_element(ms.begin(), ms.end()), 2)
         << "–" << num(*std::max_element(ms.begin(), ms.end()), 2) << ") | " << rebuildText(t) << " | " << wrong
         << " (" << num(100.0 * fraction, 4) << "%) | "
         << (worst ? "frame " + std::to_string(worstFrame) + ": " + std::to_string(worst) : std::string("none"))
         << " |\n";
    }
    os << "\nraster (the camera pass, not a shadow cost): median " << num(median(views[v].rasterMs), 2)
       << " ms per frame";
    if (!views[v].uploadMs.empty()) os << ", plus " << num(median(views[v].uploadMs), 2) << " ms geometry upload";
    os << ".\n";
  }
  return os.str();
}

}  // namespace

int runDynamicCompare(const Options& o) {
  ProgressLog progress(o.quiet);
  std::ostream& log = progress.stream();
  const uint32_t n = o.animateFrames;

  if (o.sceneTime) throw UsageError("--time places a static scene; compare --animate plays the whole animation");
  Motion anim = loadMotion(o);
  const bool animated = anim.animated;
  if (!animated && !o.movingCamera)
    throw UsageError("scene " + anim.rest.name +
                     " has no node animation that moves its triangles: add --moving-camera to orbit the camera "
                     "around the static scene");
  const bool enclosed = o.scene.empty() || o.scene == "builtin";  // the built-in views are inside a closed room
  std::string motion = animated ? (anim.cyclic ? "one cycle of the built-in motion, t = k/" + std::to_string(n)
                                               : "the file's animation at evenly spaced times over t = " +
                                                     num(anim.start, 3) + ".." + num(anim.end, 3))
                                : std::string("static scene");
  if (animated && anim.aff) motion += " (the `animated` view follows the file's camera track)";
  if (o.movingCamera)
    motion += enclosed ? ", the camera swinging ±0.5 rad about its target" : ", the camera orbiting its target once";

  const Scene& rest = anim.rest;
  std::vector<Camera> cameras = selectViews(rest, o);
  const glm::vec3 light = chooseLight(rest, o);
  // The device before the rows whose methods use it: on an error they are destroyed first, while the
  // device they call into still exists.
  std::unique_ptr<vk::Context> ctx;
  std::vector<std::vector<Track>> tracks;
  for (size_t v = 0; v < cameras.size(); ++v) tracks.push_back(makeTracks(o, !animated));
  log << "scene " << rest.name << ": " << rest.triangleCount() << " triangles, " << cameras.size() << " view(s), "
      << tracks.front().size() << " method row(s), " << n << " frame(s), " << o.width << "x" << o.height << "; "
      << motion << std::endl;

  ctx = commandContext(o);
  const std::string device = ctx->driverDescription();
  log << "device: " << device << std::endl;
  // Rows this device cannot run (MethodInfo::unsupported) are left out, each said once.
  for (size_t v = 0; v < tracks.size(); ++v)
    std::erase_if(tracks[v], [&](const Track& t) {
      const std::string why = unsupportedOn(*t.info, *ctx, t.settings);
      if (!why.empty() && v == 0) log << "skipping " << t.label << ": " << why << std::endl;
      return !why.empty();
    });

  StagedDir out(o.out, runInputs(o));
  harness::RunSpec spec;
  spec.scene = &rest;
  spec.views = harness::viewsOf(cameras);
  spec.lights = {light};
  spec.width = o.width;
  spec.height = o.height;
  for (const Track& t : tracks.front()) spec.methods.push_back({t.info, t.label, t.settings});
  harness::Motion& moving = spec.motion.emplace();
  moving.frames = n;
  moving.animated = animated;
  moving.movingCamera = o.movingCamera;
  moving.enclosed = enclosed;
  moving.cameraTrack = anim.aff && !o.movingCamera;  // a BART camera track moves the `animated` view
  moving.pose = [&anim](double t, Scene& s) { anim.pose(t, s); };
  moving.frameTime = [&anim](uint32_t k, uint32_t frames) { return anim.frameTime(k, frames); };

  std::vector<ViewLog> viewLogs(cameras.size());
  for (size_t v = 0; v < cameras.size(); ++v) viewLogs[v].view = spec.views[v].name;
  auto tagOf = [&](const harness::Frame& f) {
    return "[view " + std::to_string(f.view + 1) + "/" + std::to_string(cameras.size()) + "] " + f.viewName;
  };
  harness::Events events;
  events.step = [&](const harness::Frame& f, const std::string& step) {
    if (step == "warm-up") log << tagOf(f) << ": warm-up" << std::endl;
  };
  // Each animation frame's rows into their tracks, and its line in the log.
  events.done = [&](const harness::Frame& f) {
    ViewLog& vl = viewLogs[f.view];
    vl.rasterMs.push_back(f.rasterMs);
    if (animated) vl.uploadMs.push_back(f.uploadMs);
    const nlohmann::json provenance = runProvenance(o, rest, light, cameras[f.view]);
    std::ostringstream line;
    line << tagOf(f) << ": frame " << (f.step + 1) << "/" << n << " (t " << num(f.time, 3) << "):";
    for (const harness::Row& row : f.rows) {
      Track& t = tracks[f.view][row.method];
      FrameResult r = row.result;
      r.provenance = provenance;
      t.frames.push_back(std::move(r));
      line << " " << t.label << " " << num(row.result.totalMs, 1) << " ms (" << row.judged.error.misclassifiedOutsideBand
           << " outside band)";
    }
    log << line.str() << std::endl;
  };
  harness::run(*ctx, spec, events);

  std::vector<FrameResult> results;
  for (auto& view : tracks)
    for (Track& t : view) results.insert(results.end(), t.frames.begin(), t.frames.end());
  writeResults(out.path(), results);
  writeFileAtomic((fs::path(out.path()) / "dynamic.md").string(),
                  dynamicMd(rest.name, device, o, motion, viewLogs, tracks));
  out.commit();

  std::cout << "result: dynamic compare of " << tracks.front().size() << " method row(s) over " << n << " frame(s) on "
            << cameras.size() << " view(s) of " << rest.name << " at " << o.width << "x" << o.height << " ("
            << motion << "); wrote " << o.out << "/ (dynamic.md, results.json, results.csv)\n";
  return kExitOk;
}

}  // namespace cs
