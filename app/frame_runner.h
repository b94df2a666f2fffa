// Internal helpers shared by the commands: progress, the device, output staging, the light and the views.
// (Every run goes through the one run entry, harness/run.h.)
#pragma once
#include <algorithm>
#include <ctime>
#include <cmath>
#include <filesystem>
#include <functional>
#include <iomanip>
#include <iostream>
#include <memory>
#include <ostream>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>
#include <unistd.h>

#include "core/error.h"
#include "app/cli.h"
#include "app/staged_dir.h"
#include "core/scene.h"
#include "judge/frame_output.h"
#include "method/method.h"
#include "harness/harness.h"
#include "method/epsilon.h"
#include "vk/context.h"

namespace cs {

struct NullBuffer : std::streambuf {
  int overflow(int c) override { return c; }
};

// A command's progress stream: stdout, or nowhere under --quiet.
class ProgressLog {
 public:
  explicit ProgressLog(bool quiet) : stream_(quiet ? &null_ : std::cout.rdbuf()) {}
  std::ostream& stream() { return stream_; }

 private:
  NullBuffer null_;
  std::ostream stream_;
};

// The Vulkan context of a command: --device and --validation from the CLI, no driver chatter.
inline std::unique_ptr<vk::Context> commandContext(const Options& o) {
  vk::ContextOptions co;
  co.device = o.device;
  co.validation = o.validation;
  co.quiet = true;
  return vk::createContext(co);
}

inline std::string stageText(const MethodOutput& out) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(2);
  for (size_t i = 0; i < out.stages.size(); ++i)
    os << (i ? ", " : "") << out.stages[i].name << " " << out.stages[i].ms;
  return os.str();
}

// The lights of the run, each a frame: every --light in the order given; with --all-lights every point
// light of the scene (none: a usage error naming the scene); else the scene's first point light, else an
// automatic one (a warning on stderr, shown under --quiet too).
// A light too far from the scene for fp32 ray lengths (method/epsilon.h) is refused here, before any
// work: a usage error for --light, a data error for the scene's own light.
inline std::vector<glm::vec3> chooseLights(const Scene& scene, const Options& o) {
  std::vector<glm::vec3> lights;
  for (const glm::vec3& l : o.lights) {
    if (std::string why = lightRangeProblem(l, scene.boundsMin, scene.boundsMax); !why.empty())
      throw UsageError("--light: " + why);
    lights.push_back(l);
  }
  if (!lights.empty()) return lights;
  if (o.allLights && scene.lights.empty())
    throw UsageError("--all-lights: scene " + scene.name + " has no point light" +
                     (scene.unusableLights.empty()
                          ? std::string()
                          : " (its light " + scene.unusableLights.front() + " is not a point light)") +
                     "; give one or more with --light X,Y,Z");
  for (const PointLight& light : scene.lights) {
    if (std::string why = lightRangeProblem(light.position, scene.boundsMin, scene.boundsMax); !why.empty())
      throw Error(why, "scene " + scene.name + ", light '" + light.name + "'", "give a closer one with --light X,Y,Z");
    lights.push_back(light.position);
    if (!o.allLights) return lights;  // the first
  }
  if (!lights.empty()) return lights;
  if (!scene.unusableLights.empty())
    throw Error("the scene's light " + scene.unusableLights.front() + " is not a point light; the methods shadow point lights",
                "scene " + scene.name, "give one with --light X,Y,Z");
  glm::vec3 light = automaticLight(scene).position;
  std::cerr << "coneshadow: warning: no point light in the scene: using an automatic one at " << light.x << ","
            << light.y << "," << light.z << " (give one with --light X,Y,Z)\n";
  return {light};
}

// The run's one light, for the runs that take one (--animate, --scaling, --light-distances: the parser
// refused more).
inline glm::vec3 chooseLight(const Scene& scene, const Options& o) {
  const std::vector<glm::vec3> lights = chooseLights(scene, o);
  CS_CHECK(lights.size() == 1, "a one-light run got " << lights.size() << " lights");
  return lights.front();
}

// Where a results row comes from (docs/RESULTS_FORMAT.md): the schema, the tool and its revision, the command
// line, the time (UTC), the scene file and its hash, the light and the camera.
inline nlohmann::json runProvenance(const Options& o, const Scene& scene, glm::vec3 light, const Camera& camera) {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char when[32];
  std::strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", &utc);
  auto v3 = [](glm::vec3 v) { return nlohmann::json::array({v.x, v.y, v.z}); };
  return {{"schema_version", kResultsSchemaVersion},
          {"tool", versionText()},
          {"command_line", o.commandLine},
          {"time", when},
          {"scene_path", scene.sourcePath.empty() ? std::string("builtin") : scene.sourcePath},
          {"scene_hash", scene.sourceHash},
          {"scene_time", o.sceneTime ? nlohmann::json(*o.sceneTime) : nlohmann::json()},
          {"ground_plane", o.groundPlane},
          {"triangles", scene.triangleCount()},
          {"light", v3(light)},
          {"camera",
           {{"name", camera.name}, {"eye", v3(camera.eye)}, {"target", v3(camera.target)}, {"up", v3(camera.up)},
            {"yfov", camera.yfov}}}};
}

// The views a compare run covers: --views by name, else every camera of the scene, else an automatic one.
inline std::vector<Camera> selectViews(const Scene& scene, const Options& o) {
  std::vector<Camera> cameras;
  for (auto& v : o.views) {
    const Camera* c = scene.findCamera(v);
    if (!c) {
      std::string all;
      for (auto& cam : scene.cameras) all += (all.empty() ? "" : ", ") + cam.name;
      throw UsageError("scene " + scene.name + " has no view '" + v + "'" +
                       (all.empty() ? " (it has no cameras)" : " (views: " + all + ")"));
    }
    cameras.push_back(*c);
  }
  if (!cameras.empty()) return cameras;
  if (!scene.cameras.empty()) return scene.cameras;
  return {automaticCamera(scene)};
}

}  // namespace cs
