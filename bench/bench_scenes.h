// What the scene benchmarks share: the views named on their command line ("builtin": every view of the
// built-in scene; "engine": assimp's 2CylinderEngine with its automatic camera and light; "museum": the
// BART museum paper 002 measured on, its view and its camera track at t = 0 and 2.5 with the scene at
// that time, lit by its first light; "heightfield:N": the generated height field of N triangles;
// "family:...": a member of the generated scene family with its own camera and light; or a
// .gltf/.glb/.aff path), a view's run (the one run entry, harness/run.h), and list parsing.
#pragma once
#include <algorithm>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/scene.h"
#include "method/method.h"
#include "method/registry.h"
#include "harness/harness.h"
#include "harness/run.h"
#include "raster/raster.h"
#include "method/epsilon.h"
#include "vk/context.h"

namespace cs::bench {

inline std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

// The value after option argv[i] (i moves onto it); a UsageError naming the option when there is none.
inline std::string optionValue(int argc, char** argv, int& i) {
  if (i + 1 >= argc) throw UsageError(std::string(argv[i]) + " needs a value");
  return argv[++i];
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
    if (const uint64_t triangles = parseHeightFieldArg(s)) {  // heightfield:N, generated, automatic camera
      scenes.push_back(std::make_unique<Scene>(heightFieldScene(triangles)));
      Scene& sc = *scenes.back();
      views.push_back({&sc, automaticCamera(sc), sc.lights.at(0).position, sc.name + "/auto"});
      continue;
    }
    if (const FamilyParams family = parseFamilyArg(s); family.valid) {  // family:..., its own camera and light
      scenes.push_back(std::make_unique<Scene>(familyScene(family)));
      Scene& sc = *scenes.back();
      views.push_back({&sc, sc.cameras.at(0), sc.lights.at(0).position, sc.name});
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

// The setting of `method` an option names ("--leaf-rays" -> leaf-rays); nullptr for any other option.
inline const SettingSpec* settingOption(const MethodInfo& method, const std::string& option) {
  for (const SettingSpec& s : method.settings)
    if ("--" + s.name == option) return &s;
  return nullptr;
}

// The settings given on a benchmark's command line, checked by the method; `text` lists them (" --k v").
inline Settings settingsOf(const MethodInfo& method, const std::vector<std::pair<std::string, std::string>>& given,
                           std::string& text) {
  Settings settings(method.name);
  for (auto& [k, v] : given) {
    settings.set(k, v);
    text += " --" + k + " " + v;
  }
  if (method.check) method.check(settings);
  return settings;
}

// The benchmarks' Vulkan context: --device D (index or name part; "" = automatic), no driver chatter.
inline std::unique_ptr<vk::Context> benchContext(const std::string& device) {
  vk::ContextOptions co;
  co.device = device;
  co.quiet = true;
  return vk::createContext(co);
}

// The run of a view at size x size (harness/run.h: samples, epsilon, the Embree reference timed over
// `frames`, the band; slowMs as timeRuns takes it), for a benchmark to add its methods to. The frame is
// kept, for the reference's time and the lit samples.
inline harness::RunSpec viewRun(const View& v, uint32_t size, uint32_t frames, double slowMs = kAlwaysTimeEveryFrame) {
  harness::RunSpec spec;
  spec.scene = v.scene;
  spec.views = {{v.camera, v.name}};
  spec.lights = {v.light};
  spec.width = spec.height = size;
  spec.frames = frames;
  spec.singleFrameAboveMs = slowMs;
  spec.keepFrames = true;
  return spec;
}

}  // namespace cs::bench
