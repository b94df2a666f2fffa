// One frame of every registered method per scene, view and size, measured by the tool itself: for each
// size and scene it runs `coneshadow compare` in this process (the frame harness: one raster, one
// Embree reference and one ambiguity band per view; every method's sweep on the same samples; one
// warm-up, medians of --frames; the view's methods a frame each in turn, `compare --interleave`, so the
// ratios below are of times taken side by side) into OUT/<scene>_<size>/, then prints, from those
// results.json files,
//   1. per size, every method setting's median ms and misclassified % outside the band (docs/RESULTS.md's
//      table: `coneshadow results-table`);
//   2. the cone path's time over Embree's build + rays, the 2048² cube map's and rmsm@16M's from the same
//      run, and what each method's default setting cost the host a frame (submissions, host syncs, KiB
//      read back, allocations, dispatches: `coneshadow results-table --host-cost`).
// No figure is printed twice: the ratios come from the times of table 1.
//   frame_bench [--sizes 512,1024] [--frames 3] [--scenes builtin,engine,museum] [--out DIR] [--device D]
// "builtin" is every view of the built-in scene, "engine" assimp's 2CylinderEngine (automatic camera and
// light), "museum" the BART museum (its view and camera track at t = 2.5); any other entry is a scene
// path as `compare` takes it. Anything after "--" goes to every compare (e.g. -- --methods cone,cubesm).
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "app/commands.h"
#include "app/results_table.h"
#include "bench/bench_scenes.h"
#include "core/error.h"
#include "vk/context.h"

namespace {

using namespace cs;
namespace fs = std::filesystem;

constexpr const char* kEngine = "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";

// The compare arguments of a scene-list entry, and a folder name for it.
std::pair<std::vector<std::string>, std::string> sceneArgs(const std::string& entry) {
  if (entry == "builtin") return {{}, "builtin"};
  if (entry == "engine") return {{kEngine}, "engine"};
  if (entry == "museum") return {{std::string(CONESHADOW_BART_SCENES) + "/museum/museum5.aff", "--time", "2.5"}, "museum"};
  return {{entry}, fs::path(entry).stem().string()};
}

}  // namespace

int main(int argc, char** argv) {
  std::string sizesArg = "512,1024", scenesArg = "builtin,engine,museum", out = "build/frame-bench", device;
  int frames = 3;
  std::vector<std::string> extra;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto next = [&] { return bench::optionValue(argc, argv, i); };
      if (a == "--sizes") sizesArg = next();
      else if (a == "--frames") frames = std::max(1, std::stoi(next()));
      else if (a == "--scenes") scenesArg = next();
      else if (a == "--out") out = next();
      else if (a == "--device") device = next();
      else if (a == "--") extra.assign(argv + i + 1, argv + argc), i = argc;
      else
        throw UsageError("unknown option '" + a + "' (usage: frame_bench [--sizes 512,1024] [--frames N] "
                         "[--scenes builtin,engine,museum] [--out DIR] [--device D] [-- COMPARE OPTIONS])");
    }
    std::string deviceName;
    {
      auto ctx = bench::benchContext(device);
      deviceName = ctx->driverDescription();
    }
    std::printf("device: %s\ncommands (each a `coneshadow compare` run in this process):\n", deviceName.c_str());
    std::vector<std::vector<std::string>> dirsBySize;
    std::vector<std::string> allDirs;
    for (const std::string& size : bench::split(sizesArg)) {
      dirsBySize.emplace_back();
      for (const std::string& entry : bench::split(scenesArg)) {
        auto [args, name] = sceneArgs(entry);
        const std::string dir = (fs::path(out) / (name + "_" + size)).string();
        std::vector<std::string> cmd = {"coneshadow", "compare"};
        cmd.insert(cmd.end(), args.begin(), args.end());
        for (const std::string& s : {std::string("--width"), size, std::string("--height"), size, std::string("--frames"),
                                     std::to_string(frames), std::string("--interleave"), std::string("--out"), dir,
                                     std::string("--quiet")})
          cmd.push_back(s);
        if (!device.empty()) cmd.insert(cmd.end(), {"--device", device});
        cmd.insert(cmd.end(), extra.begin(), extra.end());
        std::string line;
        for (size_t k = 0; k < cmd.size(); ++k) line += (k ? " " : "") + cmd[k];
        std::printf("  %s\n", line.c_str());
        std::fflush(stdout);
        std::vector<char*> cargv;
        for (std::string& s : cmd) cargv.push_back(s.data());
        cargv.push_back(nullptr);
        const int code = runMain(int(cmd.size()), cargv.data());
        if (code != 0) {
          std::fprintf(stderr, "frame_bench: `%s` exited with %d\n", line.c_str(), code);
          return code;
        }
        dirsBySize.back().push_back(dir);
        allDirs.push_back(dir);
      }
    }
    const std::vector<std::string> sizes = bench::split(sizesArg);
    for (size_t k = 0; k < sizes.size(); ++k) {
      std::printf("\n### every method setting at %s², median ms / misclassified outside the band\n\n", sizes[k].c_str());
      std::printf("%s", resultsTable(readResults(dirsBySize[k])).c_str());
    }
    std::printf("\n### the cone path against its peers (same run) and each method's host cost a frame\n"
                "(submissions / host syncs / KiB read back / allocations / dispatches, the method's default setting)\n\n");
    std::printf("%s", hostCostTable(readResults(allDirs)).c_str());
    return 0;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "frame_bench: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "frame_bench: %s\n", e.what());
    return 1;
  }
}
