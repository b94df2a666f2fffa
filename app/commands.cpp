// The CLI's commands: info, devices, render.
#include "app/commands.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <unistd.h>

#include "app/frame_runner.h"
#include "app/methods.h"
#include "eval/frame_output.h"
#include "eval/metrics.h"
#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "reference/epsilon.h"
#include "vk/context.h"

namespace fs = std::filesystem;

namespace cs {

namespace {

std::string vec3Text(glm::vec3 v) {
  std::ostringstream os;
  os << std::setprecision(6) << v.x << "," << v.y << "," << v.z;
  return os.str();
}

}  // namespace

bool isAffFile(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".aff";
}

Scene loadSceneArg(const Options& o, std::ostream& log) {
  const std::string& arg = o.scene;
  if (arg.empty() || arg == "builtin") {
    if (o.sceneTime) throw UsageError("--time places a BART (.aff) scene in time; the built-in scene has no time");
    return builtinScene();
  }
  if (!fs::exists(arg))
    throw Error("no such file", arg, "give a .gltf/.glb or BART .aff path, or omit SCENE for the built-in scene");
  if (isAffFile(arg)) return loadAff(arg, log, o.sceneTime);
  if (o.sceneTime) throw UsageError("--time places a BART (.aff) scene in time; " + arg + " is glTF (use compare --animate)");
  return loadGltf(arg, log);
}

int runDevices(const Options&) {
  for (auto& line : vk::listDevices()) std::cout << line << "\n";
  return kExitOk;
}

int runInfo(const Options& options) {
  Scene scene = loadSceneArg(options, std::cerr);
  EpsilonPolicy eps = EpsilonPolicy::forScene(scene);
  std::cout << "scene: " << scene.name << "\n"
            << "triangles: " << scene.triangleCount() << " (flattened over node instances)\n"
            << "vertices: " << scene.positions.size() << "\n"
            << "bounds: min " << vec3Text(scene.boundsMin) << "  max " << vec3Text(scene.boundsMax)
            << "  diagonal " << scene.diagonal() << "\n"
            << "epsilon: " << eps.eps << " (floor " << eps.floor << ")\n"
            << "cameras: " << scene.cameras.size() << "\n";
  for (auto& c : scene.cameras)
    std::cout << "  " << c.name << ": eye " << vec3Text(c.eye) << "  target " << vec3Text(c.target)
              << "  yfov " << c.yfov << "\n";
  std::cout << "point lights: " << scene.lights.size() << "\n";
  for (auto& l : scene.lights)
    std::cout << "  " << l.name << ": position " << vec3Text(l.position) << "  intensity " << l.intensity << "\n";
  return kExitOk;
}

int runRender(const Options& o) {
  NullBuffer nullBuf;
  std::ostream quiet(&nullBuf);
  std::ostream& log = o.quiet ? quiet : std::cout;
  auto wall = [] { return std::chrono::steady_clock::now(); };
  auto msSince = [&](auto t0) { return std::chrono::duration<double, std::milli>(wall() - t0).count(); };

  // Validate what can be validated before any heavy work.
  checkMethod(o.method, o);

  log << "[1/5] scene" << std::endl;
  Scene scene = loadSceneArg(o, std::cerr);
  log << "  " << scene.name << ": " << scene.triangleCount() << " triangles, diagonal " << scene.diagonal() << "\n";

  Camera camera;
  std::string view;
  if (!o.view.empty()) {
    const Camera* c = scene.findCamera(o.view);
    if (!c) {
      std::string all;
      for (auto& cam : scene.cameras) all += (all.empty() ? "" : ", ") + cam.name;
      throw UsageError("scene " + scene.name + " has no view '" + o.view + "'" +
                       (all.empty() ? " (it has no cameras)" : " (views: " + all + ")"));
    }
    camera = *c;
  } else if (!scene.cameras.empty()) {
    camera = scene.cameras.front();
  } else {
    camera = automaticCamera(scene);
    log << "  no camera in the scene: using an automatic one (eye " << vec3Text(camera.eye) << ")\n";
  }
  view = camera.name.empty() ? "auto" : camera.name;
  glm::vec3 light = chooseLight(scene, o, log);
  log << "  view " << view << ", light " << vec3Text(light) << ", " << o.width << "x" << o.height << "\n";

  log << "[2/5] device" << std::endl;
  vk::ContextOptions co;
  co.device = o.device;
  co.validation = o.validation;
  co.quiet = true;
  auto ctx = vk::createContext(co);
  std::string device = ctx->driverDescription();
  log << "  device: " << device << "\n";

  log << "[3/5] raster" << std::endl;
  Raster raster(*ctx, scene);
  DeviceGBuffer dev;
  GBuffer gb;
  raster.render(camera, light, o.width, o.height, dev, &gb);  // warm-up: pipeline compile
  std::vector<double> rasterMs;
  RasterTiming rt;
  for (uint32_t i = 0; i < o.frames; ++i) {
    rt = raster.render(camera, light, o.width, o.height, dev, &gb);
    rasterMs.push_back(rt.gpuMs);
  }
  size_t lit = gb.litCount();
  log << "  " << std::fixed << std::setprecision(2) << median(rasterMs) << " ms (GPU), readback " << rt.readbackMs
      << " ms; " << lit << " lit samples of " << gb.size() << "\n";

  EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  FrameInput frame = frameInput(scene, gb, dev, *ctx, light, policy.eps);

  log << "[4/5] reference (embree) and band" << std::endl;
  EmbreeReference reference;
  Timed ref = runTimed(reference, frame, o.frames, log);
  StageTime bandTime;
  std::vector<uint8_t> band = reference.ambiguityBand(scene, gb, light, policy, {}, &bandTime);
  size_t bandCount = size_t(std::count_if(band.begin(), band.end(), [](uint8_t b) { return b != 0; }));
  log << "  embree: " << ref.output.totalMs << " ms (" << stageText(ref.output) << "), band " << bandCount
      << " samples in " << bandTime.ms << " ms\n";

  std::vector<FrameResult> results;
  auto addRow = [&](const std::string& name, Timed& t, const ErrorStats& err) {
    FrameResult r = makeFrameResult(scene.name, view, name, gb, name == "embree" ? "cpu (embree)" : device,
                                    t.output, err);
    r.stats["frames"] = o.frames;
    r.stats["total_ms_min"] = *std::min_element(t.totals.begin(), t.totals.end());
    r.stats["total_ms_max"] = *std::max_element(t.totals.begin(), t.totals.end());
    r.stats["deterministic"] = t.deterministic;
    r.stats["raster_ms"] = median(rasterMs);
    r.stats["lit_samples"] = lit;
    r.stats["band_samples"] = bandCount;
    results.push_back(std::move(r));
  };
  ErrorStats refErr = compareVisibility(gb, ref.output.visibility, ref.output.visibility, band);
  addRow("embree", ref, refErr);

  std::map<std::string, std::vector<float>> visibility;
  visibility["embree"] = ref.output.visibility;
  const std::vector<float>* shown = &ref.output.visibility;
  Timed method;
  if (o.method != "embree") {
    log << "[5/5] method " << o.method << std::endl;
    auto m = makeMethod(o.method, ctx.get(), o);
    method = runTimed(*m, frame, o.frames, log);
    ErrorStats err = compareVisibility(gb, method.output.visibility, ref.output.visibility, band);
    addRow(o.method, method, err);
    visibility[o.method] = method.output.visibility;
    shown = &visibility[o.method];
    log << "  " << o.method << ": " << method.output.totalMs << " ms (" << stageText(method.output) << ")\n";
  } else {
    log << "[5/5] output" << std::endl;
  }

  // Output: staged, then moved into place.
  {
    StagedDir out(o.out);
    writeFrameImages(out.path(), o.method, gb, *shown, ref.output.visibility, band);
    writeResults(out.path(), results);
    out.commit();
  }
  if (!o.dump.empty()) {
    StagedDir dump(o.dump);
    writeDump(dump.path(), scene, gb, camera, light, policy, visibility, band);
    dump.commit();
  }

  const FrameResult& row = results.back();
  std::cout << std::fixed << std::setprecision(3) << "result: " << row.method << " on " << scene.name << "/" << view
            << " " << o.width << "x" << o.height << ": " << row.totalMs << " ms (median of " << o.frames
            << "), embree " << ref.output.totalMs << " ms, misclassified " << std::setprecision(6)
            << row.error.misclassifiedFraction << " (outside band " << row.error.misclassifiedOutsideBand
            << " samples), raster " << std::setprecision(3) << median(rasterMs) << " ms; wrote " << o.out
            << "/" << (o.dump.empty() ? "" : " and " + o.dump + "/") << "\n";
  (void)msSince;
  return kExitOk;
}

}  // namespace cs
