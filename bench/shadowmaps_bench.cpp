// The registered methods against each other in the same run, on the same raster samples (by default the
// cone path, the cube shadow map and RMSM, paper 000): median wall ms of the shadow work after one warm-up
// frame and its ratio to Embree's, misclassified fraction against Embree (all lit samples, and outside the
// ambiguity band), bytes, each method's own work and stages; for a method that reports page requests
// (RMSM), its page counts beside paper 000's Fig. 12 (1024² images: 2,900–7,100 unique 32² pages).
//   shadowmaps_bench [--size 1024] [--frames 5] [--images DIR] [--device NAME|INDEX]
//                    [--scenes builtin,engine] [--methods cone,cubesm,rmsm] [--SETTING VALUE ...]
// Any registered method setting may follow (as for `coneshadow render`: --sm-resolution 2048,
// --rmsm-pool 4M, --rmsm-cached, --plane-bias, ...); it reaches the chosen methods that take it.
// "builtin" is every named view of the built-in scene; "engine" is assimp's 2CylinderEngine with the
// automatic camera and light (or a .gltf/.glb path). --images writes <scene>_<view>_<method>_{mask,diff}.png.
#include <algorithm>
#include <map>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "bench/bench_scenes.h"
#include "eval/frame_output.h"
#include "eval/registry.h"
#include "harness/harness.h"
#include "vk/context.h"

namespace {

using namespace cs;
using bench::split;

// The registered setting a flag names, or null.
const SettingSpec* settingOf(const std::string& flag) {
  for (const MethodInfo& m : registeredMethods())
    for (const SettingSpec& s : m.settings)
      if ("--" + s.name == flag) return &s;
  return nullptr;
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t size = 1024;
  int frames = 5;
  std::string images, device, scenesArg = "builtin,engine", methodsArg = "cone,cubesm,rmsm";
  std::vector<std::pair<std::string, std::string>> given;
  try {
    registerBuiltinMethods();
    for (int i = 1; i < argc; ++i) {
      std::string a = argv[i];
      auto next = [&]() -> std::string {
        if (i + 1 >= argc) throw UsageError(a + " needs a value");
        return argv[++i];
      };
      if (a == "--size") size = uint32_t(std::stoul(next()));
      else if (a == "--frames") frames = std::max(1, std::stoi(next()));
      else if (a == "--images") images = next();
      else if (a == "--device") device = next();
      else if (a == "--scenes") scenesArg = next();
      else if (a == "--methods") methodsArg = next();
      else if (const SettingSpec* s = settingOf(a)) given.emplace_back(s->name, s->value.empty() ? "" : next());
      else
        throw UsageError("unknown option '" + a + "' (usage: shadowmaps_bench [--size N] [--frames N] [--images DIR] "
                         "[--device D] [--scenes builtin,engine] [--methods A,B] [--SETTING VALUE ...])");
    }
    std::vector<const MethodInfo*> methods;
    std::vector<Settings> settings;
    for (const std::string& name : split(methodsArg)) {
      const MethodInfo& m = methodOrUsageError(name);
      Settings s(m.name);
      for (auto& [k, v] : given)
        if (std::any_of(m.settings.begin(), m.settings.end(), [&](const SettingSpec& spec) { return spec.name == k; }))
          s.set(k, v);
      if (m.check) m.check(s);
      methods.push_back(&m);
      settings.push_back(s);
    }
    std::vector<std::unique_ptr<Scene>> scenes;
    std::vector<bench::View> views = bench::loadViews(scenesArg, scenes);
    auto ctx = bench::benchContext(device);
    std::string settingsText;
    for (auto& [k, v] : given) settingsText += " --" + k + (v.empty() ? "" : " " + v);
    std::printf("device: %s\n%ux%u, median of %d frames after a warm-up; settings:%s\n\n", ctx->driverDescription().c_str(),
                size, size, frames, settingsText.empty() ? " the methods' defaults" : settingsText.c_str());
    std::printf("%-24s %-7s %10s %8s %12s %12s %9s %9s %10s\n", "view", "method", "ms", "x embree", "misclass",
                "outside band", "f.shadow", "f.light", "MiB");
    for (const bench::View& v : views) {
      bench::ViewFrame vf(*ctx, v, size, uint32_t(frames));
      const PreparedFrame& frame = *vf.frame;
      auto row = [&](const std::string& name, const Judged& j) {
        const ErrorStats& e = j.error;
        std::printf("%-24s %-7s %10.2f %8.2f %12.6f %12.6f %9.6f %9.6f %10.1f\n", v.name.c_str(), name.c_str(),
                    j.runs.medianMs, j.runs.medianMs / frame.reference.medianMs, e.misclassifiedFraction,
                    e.misclassifiedFractionOutsideBand, e.falseShadowFraction, e.falseLightFraction,
                    double(j.runs.output.bytesAllocated) / (1 << 20));
        if (!images.empty()) {
          std::string prefix = v.name + "_" + name;
          std::replace(prefix.begin(), prefix.end(), '/', '_');
          writeFrameImages(images, prefix, frame.gbuffer, j.runs.output.visibility, frame.reference.output.visibility,
                           frame.band);
        }
      };
      row(referenceMethod().name, judge(referenceMethod(), Settings(), *ctx, frame, uint32_t(frames)));
      std::map<std::string, double> medians;  // method -> median ms, for the ratios below
      for (size_t k = 0; k < methods.size(); ++k) {
        if (methods[k]->reference) continue;
        const Judged j = judge(*methods[k], settings[k], *ctx, frame, uint32_t(frames));
        row(methods[k]->name, j);
        const nlohmann::json& s = j.runs.output.stats;
        std::printf("%-24s %s: %s; stages:", "", methods[k]->name.c_str(), j.runs.output.work.c_str());
        for (auto& st : j.runs.output.stages) std::printf(" %s %.2f", st.name.c_str(), st.ms);
        std::printf("\n");
        if (s.contains("submits_per_frame"))
          std::printf("%-24s %s host cost per frame: %llu submits, %llu host syncs, %.1f KiB read back, %llu allocations, "
                      "%llu dispatches\n",
                      "", methods[k]->name.c_str(), s["submits_per_frame"].get<unsigned long long>(),
                      s["host_syncs_per_frame"].get<unsigned long long>(),
                      double(s["readback_bytes_per_frame"].get<uint64_t>()) / 1024.0,
                      s["allocations_per_frame"].get<unsigned long long>(),
                      s["dispatches_per_frame"].get<unsigned long long>());
        medians[methods[k]->name] = j.runs.medianMs;
        if (s.contains("unique_pages") && s.contains("requests_before_pruning"))
          std::printf("%-24s page requests %llu -> %llu pruned -> %llu unique pages (paper 000 Fig. 12: 2,900-7,100 "
                      "at 1024²), %llu passes (%llu aligned superpages), effective %u², pool %llu/%llu pages, "
                      "tables %.1f MiB, isolated %llu, misses %llu, triangles drawn %llu (%llu a pass); wall: "
                      "analysis %.2f, render %.2f\n",
                      "", s["requests_before_pruning"].get<unsigned long long>(),
                      s["requests_after_pruning"].get<unsigned long long>(), s["unique_pages"].get<unsigned long long>(),
                      s["superpages"].get<unsigned long long>(), s["superpage_squares"].get<unsigned long long>(),
                      s["effective_resolution"].get<uint32_t>(), s["pages_rendered"].get<unsigned long long>(),
                      s["pool_pages"].get<unsigned long long>(), double(s["page_table_bytes"].get<uint64_t>()) / (1 << 20),
                      s["isolated_samples"].get<unsigned long long>(), s["lookup_misses"].get<unsigned long long>(),
                      s["triangles_drawn"].get<unsigned long long>(), s["triangles"].get<unsigned long long>(),
                      s["analysis_wall_ms"].get<double>(), s["render_wall_ms"].get<double>());
      }
      if (medians.count("cone")) {  // the cone path against each peer, same run
        std::printf("%-24s cone / embree %.2fx", "", medians["cone"] / frame.reference.medianMs);
        for (auto& [name, ms] : medians)
          if (name != "cone") std::printf(", cone / %s %.2fx", name.c_str(), medians["cone"] / ms);
        std::printf("\n");
      }
      std::fflush(stdout);
    }
  } catch (const UsageError& e) {
    std::cerr << "shadowmaps_bench: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "shadowmaps_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
