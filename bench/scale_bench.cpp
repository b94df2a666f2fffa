// The cone path at scale against Embree in the same run: generated height fields (heightfield:N), the
// BART kitchen and robots, 2CylinderEngine instanced eight times (overlapping, each turned about its
// centre: "engine8"), at each size. Per view: the lit samples, Embree's frame (BVH build + rays, rebuilt
// every frame as a moving scene needs), the cone frame and the ratio, pairs tested per lit sample and per
// triangle, the clusters' share, the device bytes and the host's working set, the memory budget's use,
// and the samples misclassified outside the ambiguity band (0 is the exactness claim); then the pairs
// tested and surviving per depth.
//   scale_bench [--sizes 512,1024] [--scenes LIST] [--frames N] [--device D] [--SETTING VALUE ...]
// LIST: heightfield:N (N triangles: 100k, 1M, 10M, ...), kitchen, robots, engine8, builtin, engine, museum
// or a scene file (default heightfield:100k,heightfield:1M,heightfield:3M,heightfield:10M,kitchen,robots,
// engine8). Any cone setting may follow (--memory-budget 1G, --clusters off, --traversal-memory 16M, ...).
// Frames: the median of N after a warm-up frame, always (the warm-up also sizes the traversal's batches:
// a first frame of a large scene may overflow the arena and take the chunked fallback).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "bench/bench_scenes.h"
#include "method/registry.h"
#include "harness/harness.h"
#include "vk/context.h"

namespace {

using namespace cs;
using bench::split;

// 2CylinderEngine eight times over itself, the k-th copy turned k * 45 degrees about the vertical axis
// through its centre and k * 20 degrees about the horizontal one: overlapping casters, no copy's root
// cone apart from the others'. A ground plane under them; the automatic camera and light.
Scene engineEight() {
  const Scene one = loadGltf("/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb", std::cerr);
  Scene s;
  s.name = "2CylinderEngine x8";
  const glm::vec3 c = 0.5f * (one.boundsMin + one.boundsMax);
  for (int k = 0; k < 8; ++k) {
    const glm::mat4 m = glm::translate(glm::mat4(1), c) *
                        glm::rotate(glm::mat4(1), glm::radians(45.0f * float(k)), glm::vec3(0, 1, 0)) *
                        glm::rotate(glm::mat4(1), glm::radians(20.0f * float(k)), glm::vec3(1, 0, 0)) *
                        glm::translate(glm::mat4(1), -c);
    const uint32_t base = uint32_t(s.positions.size());
    for (size_t v = 0; v < one.positions.size(); ++v) {
      s.positions.push_back(glm::vec3(m * glm::vec4(one.positions[v], 1.0f)));
      s.normals.push_back(glm::normalize(glm::vec3(m * glm::vec4(one.normals[v], 0.0f))));
    }
    for (uint32_t i : one.indices) s.indices.push_back(base + i);
  }
  s.computeBounds();
  addGroundPlane(s);
  return s;
}

// A view of a scene list entry scale_bench adds to bench::loadViews's: kitchen, robots, engine8.
bool loadScaleView(const std::string& name, std::vector<std::unique_ptr<Scene>>& scenes, std::vector<bench::View>& views) {
  const std::string bart = CONESHADOW_BART_SCENES;
  Scene scene;
  if (name == "kitchen") scene = loadAff(bart + "/kitchen/kitchen.aff", std::cerr);
  else if (name == "robots") scene = loadAff(bart + "/robot/Robot.aff", std::cerr);
  else if (name == "engine8") scene = engineEight();
  else return false;
  scenes.push_back(std::make_unique<Scene>(std::move(scene)));
  Scene& sc = *scenes.back();
  const Camera camera = sc.cameras.empty() ? automaticCamera(sc) : sc.cameras.front();
  const glm::vec3 light = sc.lights.empty() ? automaticLight(sc).position : sc.lights.front().position;
  views.push_back({&sc, camera, light, name + "/" + (camera.name.empty() ? "auto" : camera.name)});
  return true;
}

uint64_t u64(const nlohmann::json& s, const char* key) { return s.contains(key) ? s[key].get<uint64_t>() : 0; }

}  // namespace

int main(int argc, char** argv) {
  std::string sizesArg = "512,1024", device;
  std::string scenesArg = "heightfield:100k,heightfield:1M,heightfield:3M,heightfield:10M,kitchen,robots,engine8";
  int frames = 1;
  std::vector<std::pair<std::string, std::string>> given;
  try {
    registerBuiltinMethods();
    const MethodInfo& cone = methodOrUsageError("cone");
    for (int i = 1; i < argc; ++i) {
      std::string a = argv[i];
      auto next = [&] { return bench::optionValue(argc, argv, i); };
      const SettingSpec* setting = bench::settingOption(cone, a);
      if (a == "--sizes") sizesArg = next();
      else if (a == "--scenes") scenesArg = next();
      else if (a == "--frames") frames = std::max(1, std::stoi(next()));
      else if (a == "--device") device = next();
      else if (setting) given.emplace_back(setting->name, next());
      else
        throw UsageError("unknown option '" + a + "' (usage: scale_bench [--sizes 512,1024] [--scenes LIST] [--frames N] "
                         "[--device D] [--CONE-SETTING VALUE ...])");
    }
    std::string settingsText;
    const Settings settings = bench::settingsOf(cone, given, settingsText);
    std::vector<uint32_t> sizes;
    for (const std::string& s : split(sizesArg)) sizes.push_back(uint32_t(std::stoul(s)));

    auto ctx = bench::benchContext(device);
    std::printf("device: %s\nmedian of %d frame(s) after a warm-up; cone settings:%s\n"
                "embree = BVH build + rays every frame; pairs = (triangle or cluster, node) tests; bytes in MiB\n\n",
                ctx->driverDescription().c_str(), frames, settingsText.empty() ? " the defaults" : settingsText.c_str());
    std::printf("%-26s %6s %9s %7s %10s %10s %8s %10s %9s %9s %7s %8s %8s %8s %6s\n", "view", "size", "triangles", "lit",
                "embree ms", "cone ms", "x embree", "pairs", "per lit", "per tri", "clust%", "device", "host", "budget",
                "wrong");
    for (const std::string& entry : split(scenesArg)) {
      std::vector<std::unique_ptr<Scene>> scenes;
      std::vector<bench::View> views;
      if (!loadScaleView(entry, scenes, views)) views = bench::loadViews(entry, scenes);
      for (const bench::View& v : views)
        for (uint32_t size : sizes) {
          harness::RunSpec spec = bench::viewRun(v, size, uint32_t(frames));
          spec.methods = {{&cone, cone.name, settings}};
          const harness::Results ran = harness::run(*ctx, spec);
          const PreparedFrame& frame = *ran.frames.front().prepared;
          const Judged& j = ran.frames.front().rows.front().judged;
          const nlohmann::json& s = j.runs.output.stats;
          const uint64_t pairs = u64(s, "pairs_tested"), lit = u64(s, "lit_samples");
          const uint64_t tris = v.scene->triangleCount();
          uint64_t clusterTests = 0;
          for (const nlohmann::json& p : s["traversal"]["passes"]) clusterTests += u64(p, "cluster_tests");
          const std::string budget =
              s.contains("memory_budget_bytes")
                  ? std::to_string(u64(s, "memory_budget_used_bytes") >> 20) + "/" + std::to_string(u64(s, "memory_budget_bytes") >> 20)
                  : "-";
          std::printf("%-26s %6u %9llu %7llu %10.1f %10.1f %8.2f %10.3gM %9.0f %9.1f %7.2f %8.1f %8.1f %8s %6llu\n",
                      v.name.c_str(), size, (unsigned long long)tris, (unsigned long long)lit, frame.reference.medianMs,
                      j.runs.medianMs, j.runs.medianMs / frame.reference.medianMs, double(pairs) / 1e6,
                      double(pairs) / double(std::max<uint64_t>(1, lit)), double(pairs) / double(std::max<uint64_t>(1, tris)),
                      100.0 * double(clusterTests) / double(std::max<uint64_t>(1, pairs)),
                      double(j.runs.output.bytesAllocated) / (1 << 20), double(u64(s, "host_peak_bytes")) / (1 << 20),
                      budget.c_str(), (unsigned long long)j.error.misclassifiedOutsideBand);
          std::printf("%-26s   per depth (tested/survived, M):", "");
          for (const nlohmann::json& p : s["traversal"]["passes"])
            std::printf(" %.3g/%.3g", double(u64(p, "pairs_tested")) / 1e6, double(u64(p, "pairs_survived")) / 1e6);
          std::printf("; leaves %.3gM tests; %s\n", double(u64(s, "leaf_tests")) / 1e6,
                      s.value("traversal_path", std::string("")).c_str());
          if (j.runs.output.stages.size() > 1) {  // --profile-stages: the frame's stages timed one by one
            std::printf("%-26s   stages (ms):", "");
            for (const StageTime& st : j.runs.output.stages) std::printf(" %s %.1f", st.name.c_str(), st.ms);
            std::printf("\n");
          }
          std::fflush(stdout);
        }
    }
  } catch (const UsageError& e) {
    std::cerr << "scale_bench: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "scale_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
