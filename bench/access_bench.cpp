// What a memory access costs a kernel on this device, measured before a kernel is designed around it
// (docs/ARCHITECTURE.md, "Memory access"): one kernel (access_bench.comp) makes `--per-item` accesses an
// invocation of one kind — a vec4 read as four scalar storage-buffer loads, one vec4 storage load, one
// uniform-texel-buffer texelFetch (RGBA32F), a shared-memory atomicAdd (a radix histogram's step), a
// storage-buffer atomicAdd, a vec4 storage store — at coherent elements (consecutive invocations read
// consecutive elements) or at random ones, over a source of --elements vec4. Each figure is the median
// wall time of --runs submissions of one dispatch after a warm-up (timestamps inside a submission are
// not trustworthy on lavapipe), as nanoseconds per access of one invocation and as a ratio to the vec4
// storage load in the same run, the peer every other kind is weighed against, both less a baseline
// dispatch that computes the same indices and touches no memory.
// Then what a dispatch costs apart from its work: --dispatches of one kind recorded in one submission
// (a workgroup that returns at once, an indirect dispatch of zero workgroups, each followed by a barrier,
// and a barrier alone), microseconds a dispatch against the one-workgroup dispatch in the same run. On
// lavapipe that dispatch is its thread pool's hand-off (LP_NUM_THREADS=0 runs it on the submitting thread).
//   access_bench [--device D] [--runs 5] [--invocations 1048576] [--per-item 16] [--elements 4194304]
//                [--dispatches 2000]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "bench/access_bench.comp.h"
#include "bench/bench_scenes.h"
#include "core/error.h"
#include "vk/context.h"

namespace {

using namespace cs;

struct Push {
  uint32_t mode, elements, perItem, random, invocations, pad0, pad1, pad2;
};

constexpr uint32_t kModeCount = 7, kBaseline = 6;
const char* kModes[kModeCount] = {"storage, 4 scalar loads", "storage, vec4 load", "texel buffer, texelFetch",
                                  "shared atomicAdd", "storage atomicAdd", "storage, vec4 store",
                                  "none (loop and index only)"};

double middle(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  std::string device;
  int runs = 5;
  uint32_t invocations = 1u << 20, perItem = 16, elements = 1u << 22, dispatches = 2000;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto next = [&] { return bench::optionValue(argc, argv, i); };
      if (a == "--device") device = next();
      else if (a == "--runs") runs = std::max(1, std::stoi(next()));
      else if (a == "--invocations") invocations = uint32_t(std::stoul(next()));
      else if (a == "--per-item") perItem = uint32_t(std::stoul(next()));
      else if (a == "--elements") elements = uint32_t(std::stoul(next()));
      else if (a == "--dispatches") dispatches = uint32_t(std::stoul(next()));
      else
        throw UsageError("unknown option '" + a + "' (usage: access_bench [--device D] [--runs N] [--invocations N] "
                         "[--per-item N] [--elements N] [--dispatches N])");
    }
    if (invocations == 0 || perItem == 0 || elements == 0 || dispatches == 0)
      throw UsageError("counts must be positive");
    if (elements & (elements - 1)) throw UsageError("--elements must be a power of two");
    auto ctx = bench::benchContext(device);
    const uint64_t srcBytes = uint64_t(elements) * 16, outBytes = uint64_t(std::max(elements, invocations)) * 16;
    if (srcBytes > ctx->maxStorageBufferRange() || outBytes > ctx->maxStorageBufferRange() ||
        elements > ctx->properties.limits.maxTexelBufferElements)
      throw Error("--elements " + std::to_string(elements) + " exceeds one binding of this device", ctx->deviceName(),
                  "lower --elements");
    vk::Kernel kernel = vk::createKernel(*ctx, "access_bench", spv_access_bench_comp, 5, sizeof(Push));
    vk::Buffer src = vk::createBuffer(*ctx, srcBytes), out = vk::createBuffer(*ctx, outBytes),
               atomics = vk::createBuffer(*ctx, 4096 * 4);
    {
      std::vector<float> init(size_t(elements) * 4);
      for (size_t k = 0; k < init.size(); ++k) init[k] = float(k % 1000) * 0.001f;
      vk::upload(*ctx, src, init.data(), srcBytes);
    }
    const vk::BufferRange texels = vk::texels(src, VK_FORMAT_R32G32B32A32_SFLOAT);
    const vk::Grid grid = vk::gridFor(invocations, 64, ctx->maxWorkgroups());

    std::printf("device: %s\n%u invocations x %u accesses, over %u vec4 (%.0f MiB); median of %d submissions after a "
                "warm-up, wall clock\n\n",
                ctx->driverDescription().c_str(), invocations, perItem, elements, double(srcBytes) / (1 << 20), runs);
    std::printf("| access | pattern | ms | ns per access | ns less the baseline | × vec4 storage load |\n"
                "| --- | --- | ---: | ---: | ---: | ---: |\n");
    for (uint32_t random : {0u, 1u}) {
      double ms[kModeCount], ns[kModeCount];
      for (uint32_t mode = 0; mode < kModeCount; ++mode) {
        const Push push{mode, elements, perItem, random, invocations, 0, 0, 0};
        std::vector<double> times;
        for (int r = 0; r <= runs; ++r) {
          vk::Commands cmd(*ctx);
          const auto t0 = std::chrono::steady_clock::now();
          cmd.dispatch(kernel, {src, src, texels, out, atomics}, push, grid.x, grid.y);
          cmd.submit();
          const double t = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
          if (r > 0) times.push_back(t);  // run 0: the warm-up (lavapipe compiles at the first dispatch)
        }
        ms[mode] = middle(times);
        ns[mode] = ms[mode] * 1e6 / (double(invocations) * perItem);
      }
      // The access's own cost: its row less the baseline's (the loop, the index, the hash when random).
      const double peer = ns[1] - ns[kBaseline];
      for (uint32_t mode = 0; mode < kModeCount; ++mode) {
        const double own = ns[mode] - ns[kBaseline];
        std::printf("| %s | %s | %.1f | %.2f | %s | %s |\n", kModes[mode], random ? "random" : "coherent", ms[mode],
                    ns[mode], mode == kBaseline ? "-" : (std::to_string(own).substr(0, 5)).c_str(),
                    mode == kBaseline || peer <= 0 ? "-" : (std::to_string(own / peer).substr(0, 4) + "×").c_str());
      }
      std::fflush(stdout);
    }
    std::printf("\nns per access: the wall time over invocations × accesses (a scalar-load row's access is a vec4\n"
                "read as four floats); less the baseline: what the access adds to the loop that computes its index;\n"
                "× vec4 storage load: that, over the vec4 load's, same pattern, same run.\n");

    // What a dispatch costs apart from its work: `dispatches` of one kind in one submission.
    const char* kinds[3] = {"one workgroup that returns at once, then a barrier",
                            "indirect, zero workgroups, then a barrier", "a barrier alone"};
    vk::Buffer args = vk::createBuffer(*ctx, 16, vk::Memory::Device, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
    {
      const uint32_t zero[4] = {0, 1, 1, 0};
      vk::upload(*ctx, args, zero, sizeof(zero));
    }
    const Push none{kBaseline, elements, 1, 0, 0, 0, 0, 0};  // no invocation passes its first test
    double us[3];
    for (uint32_t kind = 0; kind < 3; ++kind) {
      std::vector<double> times;
      for (int r = 0; r <= runs; ++r) {
        vk::Commands cmd(*ctx);
        for (uint32_t d = 0; d < dispatches; ++d) {
          if (kind == 0) cmd.dispatch(kernel, {src, src, texels, out, atomics}, none, 1);
          if (kind == 1) cmd.dispatchIndirect(kernel, {src, src, texels, out, atomics}, &none, sizeof(none), args);
          cmd.barrier();
        }
        const auto t0 = std::chrono::steady_clock::now();
        cmd.submit();
        const double t = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
        if (r > 0) times.push_back(t / dispatches);
      }
      us[kind] = middle(times);
    }
    std::printf("\n%u dispatches of a kind in one submission, median of %d submissions after a warm-up:\n\n"
                "| dispatch | µs each | × one workgroup |\n| --- | ---: | ---: |\n",
                dispatches, runs);
    for (uint32_t kind = 0; kind < 3; ++kind)
      std::printf("| %s | %.2f | %.3f× |\n", kinds[kind], us[kind], us[0] > 0 ? us[kind] / us[0] : 0.0);
    return 0;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "access_bench: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "access_bench: %s\n", e.what());
    return 1;
  }
}
