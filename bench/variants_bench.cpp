// Paper 002's Table 1 variants of the cone path on the same frame, against Embree in the same run: for
// every view, each variant's nodes visited ((triangle, node) pairs tested, the measure paper 002 plots),
// early-accepted nodes, rays finished in two-pass's first pass, median ms of the whole shadow frame, its
// ratio to Embree's (BVH build + one ray per sample), and the misclassified samples outside the band
// (0: every variant is exact). Prints a markdown table (the README's variants table).
//   variants_bench [--size 1024] [--frames 3] [--scenes builtin,engine] [--variants A,B,...] [--device D]
//                  [--slow-ms 5000]
// "builtin" is every named view of the built-in scene; "engine" is assimp's 2CylinderEngine (121,496
// triangles flattened) with the automatic camera and light (or a .gltf/.glb path). Each configuration
// runs a warm-up frame (pipeline compiles) and then --frames timed ones; a warm-up slower than --slow-ms
// is itself the one timed frame (compiles are noise against it) so the unsorted variants' worst views
// finish in minutes on lavapipe.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "eval/metrics.h"
#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "reference/epsilon.h"
#include "traversal/cone_method.h"
#include "vk/context.h"

namespace {

using namespace cs;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : (v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]));
}

struct Timed {
  MethodOutput output;  // of the last frame
  double medianMs = 0;
  int frames = 0;
};

Timed runTimed(ShadowMethod& m, const FrameInput& frame, int frames, double slowMs) {
  Timed t;
  t.output = m.run(frame);  // warm-up
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

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

std::string millions(uint64_t n) {
  char buf[32];
  if (n >= 100000) std::snprintf(buf, sizeof buf, "%.2f M", double(n) / 1e6);
  else std::snprintf(buf, sizeof buf, "%llu", (unsigned long long)n);
  return buf;
}

struct View {
  Scene* scene;
  Camera camera;
  glm::vec3 light;
  std::string name;
};

}  // namespace

int main(int argc, char** argv) {
  uint32_t size = 1024;
  int frames = 3;
  double slowMs = 5000;
  std::string device, scenesArg = "builtin,engine", variantsArg;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "variants_bench: " << a << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--size") size = uint32_t(std::stoul(next()));
    else if (a == "--frames") frames = std::max(1, std::stoi(next()));
    else if (a == "--slow-ms") slowMs = std::stod(next());
    else if (a == "--device") device = next();
    else if (a == "--scenes") scenesArg = next();
    else if (a == "--variants") variantsArg = next();
    else {
      std::cerr << "usage: variants_bench [--size N] [--frames N] [--scenes builtin,engine] [--variants A,B]"
                   " [--device D] [--slow-ms MS]\n";
      return 2;
    }
  }
  try {
    std::vector<std::string> variants = variantsArg.empty() ? coneVariantNames() : split(variantsArg);
    for (const std::string& v : variants) {
      ConeOptions o;
      if (!applyConeVariant(v, o)) throw Error("unknown variant '" + v + "'", "--variants", "Precise, PreciseSorted, ...");
    }
    std::vector<std::unique_ptr<Scene>> scenes;
    std::vector<View> views;
    for (const std::string& s : split(scenesArg)) {
      if (s == "builtin") {
        scenes.push_back(std::make_unique<Scene>(builtinScene()));
        for (const Camera& c : scenes.back()->cameras)
          views.push_back({scenes.back().get(), c, scenes.back()->lights.at(0).position, "builtin/" + c.name});
      } else {
        std::string path =
            s == "engine" ? "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb" : s;
        scenes.push_back(std::make_unique<Scene>(loadGltf(path, std::cerr)));
        Scene& sc = *scenes.back();
        Camera c = sc.cameras.empty() ? automaticCamera(sc) : sc.cameras.front();
        glm::vec3 l = sc.lights.empty() ? automaticLight(sc).position : sc.lights.front().position;
        views.push_back({&sc, c, l, (s == "engine" ? std::string("2CylinderEngine") : sc.name) + "/" +
                                        (c.name.empty() ? "auto" : c.name)});
      }
    }
    vk::ContextOptions co;
    co.device = device;
    co.quiet = true;
    auto ctx = vk::createContext(co);
    std::printf("device: %s; Embree on the host CPU\n%ux%u, median of %d frames after a warm-up (a warm-up over "
                "%.0f ms is the one timed frame); nodes visited = (triangle, node) pairs tested\n\n",
                ctx->driverDescription().c_str(), size, size, frames, slowMs);
    std::printf("| view | variant | nodes visited | early accepted | finished in pass one | ms | × Embree | "
                "misclassified outside band |\n|---|---|---:|---:|---:|---:|---:|---:|\n");
    std::fflush(stdout);
    for (View& v : views) {
      Scene& scene = *v.scene;
      Raster raster(*ctx, scene);
      DeviceGBuffer dev;
      GBuffer gb;
      raster.render(v.camera, v.light, size, size, dev, &gb);
      EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
      FrameInput frame;
      frame.scene = &scene;
      frame.gbuffer = &gb;
      frame.device = &dev;
      frame.vk = ctx.get();
      frame.light = v.light;
      frame.epsilon = policy.eps;
      EmbreeReference reference;
      Timed ref = runTimed(reference, frame, frames, slowMs);
      std::vector<uint8_t> band = reference.ambiguityBand(scene, gb, v.light, policy);
      std::printf("| %s | Embree (%zu lit samples) | | | | %.1f | 1.00 | |\n", v.name.c_str(), gb.litCount(),
                  ref.medianMs);
      std::fflush(stdout);
      for (const std::string& name : variants) {
        ConeOptions o;
        applyConeVariant(name, o);
        auto method = makeConeMethod(*ctx, o);
        Timed t = runTimed(*method, frame, frames, slowMs);
        ErrorStats e = compareVisibility(gb, t.output.visibility, ref.output.visibility, band);
        const nlohmann::json& s = t.output.stats;
        std::string finished = "–";
        if (s.contains("two_pass") && s["two_pass"].is_object()) {
          const nlohmann::json& tp = s["two_pass"];
          const std::string update = tp["update"].get<std::string>();
          finished = millions(tp["rays_finished_pass_one"].get<uint64_t>()) + " (" +
                     (update == "rebuilt" ? "rebuilt" : update.substr(0, update.find(':'))) + ")";
        }
        std::printf("| %s | %s | %s | %s | %s | %.1f%s | %.2f | %llu |\n", v.name.c_str(), name.c_str(),
                    millions(s["pairs_tested"].get<uint64_t>()).c_str(),
                    millions(s["early_accepted_nodes"].get<uint64_t>()).c_str(), finished.c_str(), t.medianMs,
                    t.frames == 1 && frames > 1 ? "¹" : "", t.medianMs / ref.medianMs,
                    (unsigned long long)e.misclassifiedOutsideBand);
        std::fflush(stdout);
      }
    }
    std::printf("\n¹ one frame: its warm-up was over %.0f ms.\n", slowMs);
  } catch (const std::exception& e) {
    std::cerr << "variants_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
