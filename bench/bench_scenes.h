// What the scene benchmarks share: the views named on their command line ("builtin": every view of the
// built-in scene; "engine": assimp's 2CylinderEngine with its automatic camera and light; "museum": the
// BART museum paper 002 measured on, its view and its camera track at t = 0 and 2.5 with the scene at
// that time, lit by its first light; or a .gltf/.glb/.aff path), one frame's input for a view, the median
// of a method's frames after a warm-up, and list parsing.
#pragma once
#include <algorithm>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "core/scene.h"
#include "eval/method.h"
#include "raster/raster.h"
#include "reference/epsilon.h"
#include "vk/context.h"

namespace cs::bench {

inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : (v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]));
}

inline std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

struct Timed {
  MethodOutput output;  // of the last frame
  double medianMs = 0;
  int frames = 0;       // timed frames: `frames`, or 1 when the warm-up alone was slower than slowMs
};

// One warm-up frame (pipeline compiles) then `frames` timed ones; a warm-up slower than `slowMs` is
// itself the one timed frame (compiles are noise against it).
inline Timed runTimed(ShadowMethod& m, const FrameInput& frame, int frames, double slowMs = 1e30) {
  Timed t;
  t.output = m.run(frame);
  if (t.output.totalMs > slowMs) {
    t.medianMs = t.output.totalMs;
    t.frames = 1;
    return t;
  }
  std::vector<double> ms;
  for (int i = 0; i < frames; ++i) {
    t.output = m.run(frame);
    ms.push_back(t.output.totalMs);
  }
  t.medianMs = median(ms);
  t.frames = frames;
  return t;
}

struct View {
  Scene* scene;
  Camera camera;
  glm::vec3 light;
  std::string name;  // "builtin/wall", "2CylinderEngine/camera0", ...
};

// The views of a comma-separated scene list; the scenes are kept in `scenes`.
inline std::vector<View> loadViews(const std::string& list, std::vector<std::unique_ptr<Scene>>& scenes) {
  std::vector<View> views;
  for (const std::string& s : split(list)) {
    if (s == "builtin") {
      scenes.push_back(std::make_unique<Scene>(builtinScene()));
      for (const Camera& c : scenes.back()->cameras)
        views.push_back({scenes.back().get(), c, scenes.back()->lights.at(0).position, "builtin/" + c.name});
      continue;
    }
    if (s == "museum") {
      const std::string museum = std::string(CONESHADOW_BART_SCENES) + "/museum/museum5.aff";
      for (double t : {0.0, 2.5}) {
        scenes.push_back(std::make_unique<Scene>(loadAff(museum, std::cerr, t)));
        Scene& sc = *scenes.back();
        std::ostringstream at;
        at << "@" << t;
        for (const Camera& c : sc.cameras)
          if (t == 0.0 || c.name == "animated")
            views.push_back({&sc, c, sc.lights.at(0).position, "museum5/" + c.name + at.str()});
      }
      continue;
    }
    const std::string path =
        s == "engine" ? "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb" : s;
    const bool aff = path.size() > 4 && path.compare(path.size() - 4, 4, ".aff") == 0;
    scenes.push_back(std::make_unique<Scene>(aff ? loadAff(path, std::cerr) : loadGltf(path, std::cerr)));
    Scene& sc = *scenes.back();
    Camera c = sc.cameras.empty() ? automaticCamera(sc) : sc.cameras.front();
    glm::vec3 l = sc.lights.empty() ? automaticLight(sc).position : sc.lights.front().position;
    views.push_back({&sc, c, l, (s == "engine" ? std::string("2CylinderEngine") : sc.name) + "/" +
                                    (c.name.empty() ? "auto" : c.name)});
  }
  return views;
}

// A view rasterised at size x size, and the frame every method of a benchmark is fed.
struct ViewFrame {
  Raster raster;
  DeviceGBuffer dev;
  GBuffer gb;
  EpsilonPolicy policy;
  FrameInput input;
  ViewFrame(vk::Context& ctx, const View& v, uint32_t size)
      : raster(ctx, *v.scene), policy(EpsilonPolicy::forScene(*v.scene)) {
    raster.render(v.camera, v.light, size, size, dev, &gb);
    input.scene = v.scene;
    input.gbuffer = &gb;
    input.device = &dev;
    input.vk = &ctx;
    input.light = v.light;
    input.epsilon = policy.eps;
  }
};

}  // namespace cs::bench
