// Several point lights in one frame against as many one-light frames, on the engine (traversal/
// cone_engine.h, what libconeshadow records): for each view and N in --lights, the median wall time of
// one submission recording N lights over that of N submissions of one light each (the same lights, the
// same samples, the frames interleaved so a slow spell of the machine falls on both). What the N-light
// frame shares: the geometry, its buffers and kernels, the samples (read, never written), one submission
// and one wait; what each light costs: its rays, sort, tree and traversal (docs/ARCHITECTURE.md, "The
// engine").
//   lights_bench [--size 256] [--frames 5] [--scenes builtin,museum] [--lights 1,2,4,8] [--device D]
// Prints a markdown table (docs/RESULTS.md, "Several lights a frame").
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <vector>

#include "bench/bench_scenes.h"
#include "method/epsilon.h"
#include "raster/raster.h"
#include "traversal/cone_engine.h"
#include "vk/context.h"

namespace {

using namespace cs;
using Clock = std::chrono::steady_clock;

// Up to 8 lights around the view's own: its light, then points spread over the upper half of the bounds.
std::vector<glm::vec3> lightsOf(const bench::View& v) {
  const glm::vec3 lo = v.scene->boundsMin, hi = v.scene->boundsMax, c = 0.5f * (lo + hi), e = hi - lo;
  std::vector<glm::vec3> out{v.light};
  const glm::vec3 offsets[] = {{0.3f, 0.35f, 0.2f}, {-0.3f, 0.4f, 0.1f}, {0.1f, 0.45f, -0.3f}, {-0.2f, 0.3f, -0.25f},
                               {0.0f, 0.2f, 0.0f},  {0.35f, 0.1f, 0.35f}, {-0.35f, 0.25f, 0.3f}};
  for (glm::vec3 o : offsets) out.push_back(c + o * e);
  return out;
}

}  // namespace

int main(int argc, char** argv) try {
  uint32_t size = 256;
  int frames = 5;
  std::string device, scenesArg = "builtin,museum", lightsArg = "1,2,4,8";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--size") size = uint32_t(std::stoul(bench::optionValue(argc, argv, i)));
    else if (a == "--frames") frames = std::stoi(bench::optionValue(argc, argv, i));
    else if (a == "--scenes") scenesArg = bench::optionValue(argc, argv, i);
    else if (a == "--lights") lightsArg = bench::optionValue(argc, argv, i);
    else if (a == "--device") device = bench::optionValue(argc, argv, i);
    else throw UsageError("unknown option " + a);
  }
  auto ctx = bench::benchContext(device);
  std::vector<std::unique_ptr<Scene>> scenes;
  std::vector<bench::View> views = bench::loadViews(scenesArg, scenes);
  std::printf("| view | lights | one frame of N lights, ms | N one-light frames, ms | ratio | per further light, ms |\n");
  std::printf("| --- | ---: | ---: | ---: | ---: | ---: |\n");
  const Scene* last = nullptr;
  for (const bench::View& v : views) {
    if (v.scene == last) continue;  // one view a scene: the first
    last = v.scene;
    Raster raster(*ctx, *v.scene);
    DeviceGBuffer g;
    raster.render(v.camera, v.light, size, size, g, nullptr);
    const float eps = EpsilonPolicy::forScene(*v.scene).eps;
    const std::vector<glm::vec3> all = lightsOf(v);
    auto engine = makeConeEngine(*ctx, ConeOptions{}, 1, 8);
    engine->setGeometry(*v.scene, geometryRevision(*v.scene));
    uint64_t frame = 0;
    auto run = [&](std::span<const glm::vec3> lights) {
      vk::Commands cmd(*ctx);
      engine->record(cmd, g, lights, eps, frame++, [](uint32_t, const vk::Buffer&) {});
      const auto t0 = Clock::now();
      cmd.submit();
      return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    };
    double oneLight = 0;
    for (const std::string& ns : bench::split(lightsArg)) {
      const size_t n = std::min<size_t>(std::stoul(ns), all.size());
      const std::span<const glm::vec3> lights(all.data(), n);
      std::vector<double> together, apart;
      run(lights);  // warm-up: pipelines, buffers at this size
      for (size_t l = 0; l < n; ++l) run(lights.subspan(l, 1));
      for (int f = 0; f < frames; ++f) {
        together.push_back(run(lights));
        double sum = 0;
        for (size_t l = 0; l < n; ++l) sum += run(lights.subspan(l, 1));
        apart.push_back(sum);
      }
      const double t = median(together), a = median(apart);
      if (n == 1) oneLight = t;
      std::printf("| %s | %zu | %.1f | %.1f | %.2f | %s |\n", v.name.c_str(), n, t, a, t / a,
                  n > 1 && oneLight > 0 ? std::to_string((t - oneLight) / double(n - 1)).substr(0, 6).c_str() : "");
      std::fflush(stdout);
    }
  }
  return 0;
} catch (const std::exception& e) {
  std::cerr << "lights_bench: " << e.what() << "\n";
  return 1;
}
