// shadowmaps/ against its peers in the same run, on the same raster samples: RMSM (paper 000), the cube
// shadow map, the cone path and Embree — median wall ms of the shadow work after one warm-up frame,
// misclassified fraction against Embree (all lit samples, and outside the ambiguity band), bytes, and
// RMSM's page counts beside paper 000's Fig. 12 (1024² images: 2,900–7,100 unique 32² pages).
//   shadowmaps_bench [--size 1024] [--frames 5] [--images DIR] [--device NAME|INDEX]
//                    [--scenes builtin,engine] [--methods cone,cubesm,rmsm] [--sm-resolution 2048]
//                    [--rmsm-pool BYTES] [--rmsm-max-res N] [--rmsm-lod-bias L] [--rmsm-superpage N]
//                    [--rmsm-occupancy F] [--rmsm-cached] [--plane-bias] [--no-cull]
// "builtin" is every named view of the built-in scene; "engine" is assimp's 2CylinderEngine with the
// automatic camera and light (or a .gltf/.glb path). --images writes <scene>_<view>_<method>_{mask,diff}.png.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "bench/bench_scenes.h"
#include "eval/frame_output.h"
#include "eval/metrics.h"
#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "reference/epsilon.h"
#include "shadowmaps/cube_sm.h"
#include "shadowmaps/rmsm.h"
#include "traversal/cone_method.h"
#include "vk/context.h"

namespace {

using namespace cs;
using bench::split;

}  // namespace

int main(int argc, char** argv) {
  uint32_t size = 1024;
  int frames = 5;
  std::string images, device, scenesArg = "builtin,engine", methodsArg = "cone,cubesm,rmsm";
  CubeSmOptions cubeOptions;
  RmsmOptions rmsmOptions;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "shadowmaps_bench: " << a << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--size") size = uint32_t(std::stoul(next()));
    else if (a == "--frames") frames = std::max(1, std::stoi(next()));
    else if (a == "--images") images = next();
    else if (a == "--device") device = next();
    else if (a == "--scenes") scenesArg = next();
    else if (a == "--sm-resolution") cubeOptions.resolution = uint32_t(std::stoul(next()));
    else if (a == "--rmsm-pool") rmsmOptions.poolBytes = std::stoull(next());
    else if (a == "--rmsm-cached") rmsmOptions.cached = true;
    else if (a == "--rmsm-lod-bias") rmsmOptions.lodBias = std::stof(next());
    else if (a == "--rmsm-superpage") rmsmOptions.superpageSize = uint32_t(std::stoul(next()));
    else if (a == "--rmsm-occupancy") rmsmOptions.minOccupancy = std::stof(next());
    else if (a == "--rmsm-max-res") rmsmOptions.maxResolution = uint32_t(std::stoul(next()));
    else if (a == "--plane-bias") rmsmOptions.planeBias = cubeOptions.planeBias = true;
    else if (a == "--no-cull") rmsmOptions.cull = cubeOptions.cull = false;
    else if (a == "--methods") methodsArg = next();
    else {
      std::cerr << "usage: shadowmaps_bench [--size N] [--frames N] [--images DIR] [--device D] [--scenes builtin,engine]"
                   " [--methods cone,cubesm,rmsm] [--sm-resolution N] [--rmsm-pool BYTES] [--rmsm-max-res N]"
                   " [--rmsm-lod-bias L] [--rmsm-superpage N] [--rmsm-occupancy F] [--rmsm-cached] [--plane-bias]"
                   " [--no-cull]\n";
      return 2;
    }
  }
  try {
    std::vector<std::unique_ptr<Scene>> scenes;
    std::vector<bench::View> views = bench::loadViews(scenesArg, scenes);
    vk::ContextOptions co;
    co.device = device;
    co.quiet = true;
    auto ctx = vk::createContext(co);
    std::printf("device: %s\n%ux%u, median of %d frames after a warm-up; cubesm %u² faces; rmsm %u² pages, "
                "max %u², pool %llu bytes%s\n\n",
                ctx->driverDescription().c_str(), size, size, frames, cubeOptions.resolution, rmsmOptions.pageSize,
                rmsmOptions.maxResolution, (unsigned long long)rmsmOptions.poolBytes,
                rmsmOptions.cached ? ", cached" : "");
    std::printf("%-24s %-7s %10s %8s %12s %12s %9s %9s %10s\n", "view", "method", "ms", "x embree", "misclass",
                "outside band", "f.shadow", "f.light", "MiB");
    for (const bench::View& v : views) {
      bench::ViewFrame vf(*ctx, v, size);
      const Scene& scene = *v.scene;
      const GBuffer& gb = vf.gb;
      const FrameInput& frame = vf.input;
      const EpsilonPolicy& policy = vf.policy;
      EmbreeReference reference;
      bench::Timed ref = bench::runTimed(reference, frame, frames);
      std::vector<uint8_t> band = reference.ambiguityBand(scene, gb, v.light, policy);
      struct Entry {
        std::string name;
        std::unique_ptr<ShadowMethod> method;
      };
      std::vector<Entry> methods;
      for (const std::string& m : split(methodsArg)) {
        if (m == "cone") methods.push_back({m, makeConeMethod(*ctx)});
        else if (m == "cubesm") methods.push_back({m, makeCubeShadowMap(*ctx, cubeOptions)});
        else if (m == "rmsm") methods.push_back({m, makeRmsm(*ctx, rmsmOptions)});
        else throw Error("unknown method '" + m + "'", "--methods", "cone, cubesm, rmsm");
      }
      auto row = [&](const std::string& name, const bench::Timed& t) {
        ErrorStats e = compareVisibility(gb, t.output.visibility, ref.output.visibility, band);
        std::printf("%-24s %-7s %10.2f %8.2f %12.6f %12.6f %9.6f %9.6f %10.1f\n", v.name.c_str(), name.c_str(),
                    t.medianMs, t.medianMs / ref.medianMs, e.misclassifiedFraction,
                    e.misclassifiedFractionOutsideBand, e.falseShadowFraction, e.falseLightFraction,
                    double(t.output.bytesAllocated) / (1 << 20));
        if (!images.empty()) {
          std::string prefix = v.name + "_" + name;
          std::replace(prefix.begin(), prefix.end(), '/', '_');
          writeFrameImages(images, prefix, gb, t.output.visibility, ref.output.visibility, band);
        }
      };
      row("embree", ref);
      for (Entry& m : methods) {
        bench::Timed t = bench::runTimed(*m.method, frame, frames);
        row(m.name, t);
        if (m.name == "rmsm") {
          const nlohmann::json& s = t.output.stats;
          std::printf("%-24s rmsm: requests %llu -> %llu pruned -> %llu unique pages (paper Fig. 12: 2,900-7,100 "
                      "at 1024²), %llu passes (%llu aligned superpages), effective %u², pool %llu/%llu pages, tables %.1f MiB, "
                      "isolated %llu, misses %llu, triangles drawn %llu (%llu a pass)\n",
                      v.name.c_str(), s["requests_before_pruning"].get<unsigned long long>(),
                      s["requests_after_pruning"].get<unsigned long long>(), s["unique_pages"].get<unsigned long long>(),
                      s["superpages"].get<unsigned long long>(), s["superpage_squares"].get<unsigned long long>(),
                      s["effective_resolution"].get<uint32_t>(),
                      s["pages_rendered"].get<unsigned long long>(), s["pool_pages"].get<unsigned long long>(),
                      double(s["page_table_bytes"].get<uint64_t>()) / (1 << 20),
                      s["isolated_samples"].get<unsigned long long>(), s["lookup_misses"].get<unsigned long long>(),
                      s["triangles_drawn"].get<unsigned long long>(), s["triangles"].get<unsigned long long>());
          std::printf("%-24s rmsm stages:", "");
          for (auto& st : t.output.stages) std::printf(" %s %.2f", st.name.c_str(), st.ms);
          std::printf(" | wall: analysis %.2f, render %.2f\n", s["analysis_wall_ms"].get<double>(),
                      s["render_wall_ms"].get<double>());
        } else if (m.name == "cubesm") {
          std::printf("%-24s cubesm stages:", "");
          for (auto& st : t.output.stages) std::printf(" %s %.2f", st.name.c_str(), st.ms);
          std::printf("\n");
        }
      }
      std::fflush(stdout);
    }
  } catch (const std::exception& e) {
    std::cerr << "shadowmaps_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
