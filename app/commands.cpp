// The CLI's commands: info, devices, render.
#include "app/commands.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <unistd.h>

#include "app/dynamic.h"
#include "app/frame_runner.h"
#include "core/image_io.h"
#include "judge/frame_output.h"
#include "judge/metrics.h"
#include "harness/harness.h"
#include "harness/run.h"
#include "method/epsilon.h"
#include "viewer/viewer.h"
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
  Scene scene;
  if (arg.empty() || arg == "builtin") {
    if (o.sceneTime) throw UsageError("--time places a BART (.aff) scene in time; the built-in scene has no time");
    scene = builtinScene();
  } else if (const uint64_t triangles = parseHeightFieldArg(arg)) {
    if (o.sceneTime) throw UsageError("--time places a BART (.aff) scene in time; a height field has no time");
    scene = heightFieldScene(triangles);
  } else if (const FamilyParams family = parseFamilyArg(arg); family.valid) {
    if (o.sceneTime) throw UsageError("--time places a BART (.aff) scene in time; a family member has no time");
    scene = familyScene(family);
  } else {
    if (!fs::exists(arg))
      throw Error("no such file", arg, "give a scene file (.gltf/.glb, .aff, .obj, .ply, ...), or omit SCENE for the built-in scene");
    scene = loadSceneFile(arg, log, o.sceneTime);
  }
  if (o.groundPlane) addGroundPlane(scene);
  return scene;
}

int runDevices(const Options&) {
  for (auto& line : vk::listDevices()) std::cout << line << "\n";
  return kExitOk;
}

int runView(const Options& o) {
  viewer::ViewerSpec spec;
  if (o.sceneTime) spec.scene = loadSceneArg(o, std::cerr);  // a BART scene placed at --time: held there
  else spec.animation = viewerAnimation(o, spec.scene);
  spec.lights = chooseLights(spec.scene, o);
  for (const MethodInfo* m : chosenMethods(o)) spec.methods.push_back({m, settingsFor(o, *m)});
  spec.view = o.view;
  spec.width = o.width;
  spec.height = o.height;
  spec.script = o.script;
  spec.screenshot = o.screenshot;
  spec.frames = o.frames;
  spec.hideUi = o.hideUi;
  spec.stats = o.stats;
  spec.display = uint32_t(std::find(std::begin(viewer::kDisplayNames), std::end(viewer::kDisplayNames), o.display) -
                          std::begin(viewer::kDisplayNames));
  spec.device = o.device;
  spec.commandLine = o.commandLine;
  return viewer::runViewer(std::move(spec));
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
  ProgressLog progressLog(o.quiet);
  std::ostream& log = progressLog.stream();
  std::vector<const MethodInfo*> methods = chosenMethods(o);  // parseArgs checked them and their settings

  log << "[1/5] scene" << std::endl;
  Scene scene = loadSceneArg(o, std::cerr);
  log << "  " << scene.name << ": " << scene.triangleCount() << " triangles, diagonal " << scene.diagonal() << "\n";

  Camera camera;
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
    std::cerr << "coneshadow: warning: no camera in the scene: using an automatic one (eye " << vec3Text(camera.eye)
              << ")\n";
  }
  const std::string view = camera.name.empty() ? "auto" : camera.name;
  const std::vector<glm::vec3> lights = chooseLights(scene, o);
  // Several lights: each a frame of its own, its images and dump named by its index.
  const bool several = lights.size() > 1;
  auto lightSuffix = [&](size_t l) { return several ? "_light" + std::to_string(l) : std::string(); };
  auto lightText = [&](size_t l) { return "light " + std::to_string(l) + " (" + vec3Text(lights[l]) + ")"; };
  std::string lightList;
  for (const glm::vec3& l : lights) lightList += (lightList.empty() ? "" : "; ") + vec3Text(l);
  log << "  view " << view << ", " << (several ? std::to_string(lights.size()) + " lights " : "light ") << lightList
      << ", " << o.width << "x" << o.height << "\n";

  const std::vector<std::string> inputs = runInputs(o);
  const bool dumpInOut = !o.dump.empty() && pathWithin(o.dump, o.out);
  const bool outInDump = !o.dump.empty() && !dumpInOut && pathWithin(o.out, o.dump);
  std::unique_ptr<StagedDir> dump =
      !o.dump.empty() && !dumpInOut ? std::make_unique<StagedDir>(o.dump, inputs) : nullptr;
  std::unique_ptr<StagedDir> out = outInDump ? nullptr : std::make_unique<StagedDir>(o.out, inputs);
  auto inside = [](const StagedDir& staged, const std::string& path) {
    return (fs::path(staged.path()) / fs::absolute(path).lexically_normal().lexically_relative(staged.target()))
        .lexically_normal()
        .string();
  };

  log << "[2/5] device" << std::endl;
  auto ctx = commandContext(o);
  log << "  device: " << ctx->driverDescription() << "\n";

  // The reference's row first, then each chosen method on the same samples.
  const MethodInfo* reference = &referenceMethod();
  harness::RunSpec spec;
  spec.scene = &scene;
  spec.views = {{camera, view}};
  spec.lights = lights;
  spec.width = o.width;
  spec.height = o.height;
  spec.frames = o.frames;
  spec.keepFrames = true;  // the images and the dump are written once every row is in
  spec.methods.push_back({reference, reference->name, settingsFor(o, *reference)});
  for (const MethodInfo* m : methods)
    if (!m->reference) spec.methods.push_back({m, m->name, settingsFor(o, *m)});

  harness::Events events;
  events.step = [&](const harness::Frame& f, const std::string& step) {
    if (step == "raster")
      log << "[3/5] raster, [4/5] reference (" << reference->name << ") and band"
          << (several ? " under " + lightText(f.light) : std::string()) << std::endl;
    if (step != "methods") return;
    const PreparedFrame& frame = *f.prepared;
    log << "  raster " << std::fixed << std::setprecision(2) << frame.rasterMs << " ms (GPU), readback "
        << frame.readbackMs << " ms; " << frame.litSamples << " lit samples of " << frame.gbuffer.size() << "\n"
        << "  " << reference->name << ": " << frame.reference.medianMs << " ms (" << stageText(frame.reference.output)
        << "), band " << frame.bandSamples << " samples in " << frame.bandMs << " ms\n";
    log << "[5/5] methods" << (several ? " under " + lightText(f.light) : std::string()) << std::endl;
  };
  events.progress = [&](const harness::Frame&, size_t k) -> FrameProgress {
    if (k == harness::kReferenceRuns) return {};
    const std::string name = spec.methods[k].info->name;
    return [&log, name](uint32_t f, uint32_t n) {
      log << (f == 0 ? "  " + name + ": warm-up" : ", frame " + std::to_string(f) + "/" + std::to_string(n))
          << (f == n ? "\n" : "") << std::flush;
    };
  };
  events.judged = [&](const harness::Frame& f, const harness::Row& row) {
    const MethodInfo& m = *spec.methods[row.method].info;
    if (m.reference) return;
    log << "  " << m.name;
    if (several) log << " under light " << f.light;
    log << ": " << row.judged.runs.medianMs << " ms (" << stageText(row.judged.runs.output) << ")\n";
  };
  harness::Results ran = harness::run(*ctx, spec, events);

  // Per light: its rows (the reference's first) and their masks by method.
  std::vector<FrameResult> results;
  std::vector<std::map<std::string, std::vector<float>>> visibility(ran.frames.size());
  for (size_t i = 0; i < ran.frames.size(); ++i) {
    harness::Frame& frame = ran.frames[i];
    const nlohmann::json provenance = runProvenance(o, scene, frame.lightPosition, camera);
    for (harness::Row& row : frame.rows) {
      FrameResult r = row.result;
      r.provenance = provenance;
      visibility[i][r.method] = std::move(row.judged.runs.output.visibility);
      results.push_back(std::move(r));
    }
  }

  // Output: --out and --dump both written in full into their staging folders (made before the run, so a
  // folder that may not be replaced is refused first), then each put in place in one step, so a failure
  // while writing either leaves neither. A dump folder inside the output folder (or the same one) is
  // written inside its staging folder, and the other way round. Several lights: each light's images
  // with its index (<m>_light<i>_shaded.png), its dump in light<i>/.
  {
    const std::string outDir = out ? out->path() : inside(*dump, o.out);
    const std::string dumpDir = o.dump.empty() ? "" : dump ? dump->path() : inside(*out, o.dump);
    for (size_t i = 0; i < ran.frames.size(); ++i) {
      const harness::Frame& frame = ran.frames[i];
      const PreparedFrame& prepared = *frame.prepared;
      std::map<std::string, std::vector<float>>& masks = visibility[i];
      const std::vector<float>& ref = masks[reference->name];
      for (const harness::Row& row : frame.rows)
        writeFrameImages(outDir, fileStem(row.result.method) + lightSuffix(frame.light), prepared.gbuffer,
                         masks[row.result.method], ref, prepared.band);
      if (!dumpDir.empty())
        writeDump(several ? (fs::path(dumpDir) / ("light" + std::to_string(frame.light))).string() : dumpDir, scene,
                  prepared.gbuffer, camera, frame.lightPosition, prepared.policy, masks, prepared.band);
    }
    writeResults(outDir, results);
    if (out) out->commit();
    if (dump) dump->commit();
  }

  for (const harness::Frame& frame : ran.frames) {
    const PreparedFrame& prepared = *frame.prepared;
    for (const harness::Row& r : frame.rows) {
      const FrameResult& row = r.result;
      if (row.method == reference->name && frame.rows.size() > 1) continue;
      std::cout << std::fixed << std::setprecision(3) << "result: " << row.method << " on " << scene.name << "/" << view
                << (several ? " " + lightText(frame.light) : std::string()) << " " << o.width << "x" << o.height
                << ": " << row.totalMs << " ms (median of " << o.frames << "), " << reference->name << " "
                << prepared.reference.medianMs << " ms, misclassified " << std::setprecision(6)
                << row.error.misclassifiedFraction << " (outside band " << row.error.misclassifiedOutsideBand
                << " samples; band " << std::setprecision(3) << 100.0 * row.error.bandFraction << " % of the lit samples"
                << (row.error.undecided ? ", UNDECIDED: " + row.error.undecidedReason() : std::string()) << "), raster "
                << std::setprecision(3) << prepared.rasterMs << " ms; wrote " << o.out << "/"
                << (o.dump.empty() ? "" : " and " + o.dump + "/") << "\n";
      if (row.stats.contains("per_frame") && !o.quiet) {  // a progressive method: its error frame by frame
        std::cout << "  " << row.method << " per frame (0 = warm-up): ";
        for (const auto& f : row.stats["per_frame"])
          std::cout << f["frame"].get<int>() << ": " << std::setprecision(4)
                    << 100 * f["misclassified_fraction"].get<double>() << " % (" << std::setprecision(1)
                    << f["ms"].get<double>() << " ms)  ";
        std::cout << "\n";
      }
    }
  }
  return kExitOk;
}

}  // namespace cs
