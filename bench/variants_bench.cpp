// Paper 002's Table 1 variants of the cone path on the same frame: for every view, each variant's nodes
// visited ((triangle, node) pairs tested, the measure paper 002 plots), early-accepted nodes, rays
// finished in two-pass's first pass, the median time of its whole shadow frame over PreciseSorted's
// (the default; same frames, same run), and the misclassified samples outside the band against Embree
// (0: every variant is exact). Prints a markdown table (docs/RESULTS.md's variants table); the absolute times
// of the default and of Embree are the frame bench's (bench/frame_bench.cpp), not printed twice.
//   variants_bench [--size 1024] [--frames 3] [--scenes builtin,engine,museum] [--variants A,B,...] [--device D]
//                  [--slow-ms 5000]
// "builtin" is every named view of the built-in scene; "engine" is assimp's 2CylinderEngine (121,496
// triangles flattened) with the automatic camera and light; "museum" is the BART museum paper 002's
// Table 2 measured (bench_scenes.h); or a .gltf/.glb/.aff path. Each configuration
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

#include "bench/bench_scenes.h"
#include "judge/metrics.h"
#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "method/epsilon.h"
#include "traversal/cone_method.h"
#include "vk/context.h"

namespace {

using namespace cs;
using bench::split;

std::string millions(uint64_t n) {
  char buf[32];
  if (n >= 100000) std::snprintf(buf, sizeof buf, "%.2f M", double(n) / 1e6);
  else std::snprintf(buf, sizeof buf, "%llu", (unsigned long long)n);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t size = 1024;
  int frames = 3;
  double slowMs = 5000;
  std::string device, scenesArg = "builtin,engine,museum", variantsArg;
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
      std::cerr << "usage: variants_bench [--size N] [--frames N] [--scenes builtin,engine,museum] [--variants A,B]"
                   " [--device D] [--slow-ms MS]\n";
      return 2;
    }
  }
  try {
    registerBuiltinMethods();
    const MethodInfo& cone = methodOrUsageError("cone");
    std::vector<std::string> variants = variantsArg.empty() ? coneVariantNames() : split(variantsArg);
    for (const std::string& v : variants) cone.check(Settings("cone").with("variant", v));  // before any work
    std::vector<std::unique_ptr<Scene>> scenes;
    std::vector<bench::View> views = bench::loadViews(scenesArg, scenes);
    auto ctx = bench::benchContext(device);
    std::printf("device: %s; Embree on the host CPU\n%ux%u, median of %d frames after a warm-up (a warm-up over "
                "%.0f ms is the one timed frame); nodes visited = (triangle, node) pairs tested\n\n",
                ctx->driverDescription().c_str(), size, size, frames, slowMs);
    // Times as ratios to PreciseSorted's (the cone path's default) from the same frames: its own time, and
    // Embree's, are the frame bench's figures (docs/RESULTS.md), not printed twice.
    std::printf("| view | variant | nodes visited | early accepted | finished in pass one | time / PreciseSorted | "
                "misclassified outside band |\n|---|---|---:|---:|---:|---:|---:|\n");
    std::fflush(stdout);
    for (const bench::View& v : views) {
      harness::RunSpec spec = bench::viewRun(v, size, uint32_t(frames), slowMs);
      for (const std::string& name : variants) spec.methods.push_back({&cone, name, Settings("cone").with("variant", name), false});
      const harness::Results ran = harness::run(*ctx, spec);
      const PreparedFrame& frame = *ran.frames.front().prepared;
      struct Line {
        std::string name, finished;
        nlohmann::json stats;
        double ms;
        bool oneFrame;
        uint64_t wrong;
      };
      std::vector<Line> lines;
      double sortedMs = 0;
      for (const harness::Row& row : ran.frames.front().rows) {
        const std::string& name = spec.methods[row.method].label;
        const Judged& j = row.judged;
        const nlohmann::json& s = j.runs.output.stats;
        std::string finished = "–";
        if (s.contains("two_pass") && s["two_pass"].is_object()) {
          const nlohmann::json& tp = s["two_pass"];
          const std::string update = tp["update"].get<std::string>();
          finished = millions(tp["rays_finished_pass_one"].get<uint64_t>()) + " (" +
                     (update == "rebuilt" ? "rebuilt" : update.substr(0, update.find(':'))) + ")";
        }
        if (name == "PreciseSorted") sortedMs = j.runs.medianMs;
        lines.push_back({name, finished, s, j.runs.medianMs, j.runs.totals.size() == 1 && frames > 1,
                         j.error.misclassifiedOutsideBand});
      }
      for (const Line& l : lines) {
        char ratio[32] = "-";
        if (sortedMs > 0) std::snprintf(ratio, sizeof(ratio), "%.2f×", l.ms / sortedMs);
        std::printf("| %s (%zu lit samples) | %s | %s | %s | %s | %s%s | %llu |\n", v.name.c_str(), frame.litSamples,
                    l.name.c_str(), millions(l.stats["pairs_tested"].get<uint64_t>()).c_str(),
                    millions(l.stats["early_accepted_nodes"].get<uint64_t>()).c_str(), l.finished.c_str(), ratio,
                    l.oneFrame ? "¹" : "", (unsigned long long)l.wrong);
      }
      std::fflush(stdout);
    }
    std::printf("\n¹ one frame: its warm-up was over %.0f ms.\n", slowMs);
  } catch (const std::exception& e) {
    std::cerr << "variants_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
