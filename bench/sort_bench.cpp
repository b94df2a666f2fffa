// sort/ against the CPU in the same run: GPU radix sort of random (key, value) pairs vs std::sort and
// std::stable_sort of the same pairs, plus GPU scan and compaction vs std::exclusive_scan and a copy loop.
// GPU times come from timestamps around the recorded work only (inputs are restored by a copy before the
// first mark); every figure is the median of --runs runs after one warm-up run (lavapipe compiles shaders
// at the first dispatch). The GPU results are checked against the CPU ones before anything is printed.
//   sort_bench [--device NAME|INDEX] [--runs N] [--sizes 1048576,4194304] [--shape device|cpu|gpu]
//              [--scheme device|reduce-then-scan|look-back]
// --shape: the radix sort's tile (sort::SortShape): the one the device gets (sort::sortShapeFor, the
// default), or either shape on any device, to compare them there. --scheme likewise for the way tiles
// learn their output offsets (sort::SortScheme, sort::sortSchemeFor).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "sort/sort.h"
#include "vk/context.h"

namespace {

using namespace cs;

struct Pair {
  uint32_t key, value;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

template <class F>
double cpuMs(F&& f) {
  auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Runs `record` (restore + timed work between the marks "start" and "end") runs + 1 times; median ms.
template <class F>
double gpuMs(vk::Context& ctx, int runs, F&& record) {
  vk::Timer timer = vk::createTimer(ctx, 8);
  std::vector<double> ms;
  for (int r = 0; r <= runs; ++r) {
    timer.restart();
    vk::Commands cmd(ctx, &timer);
    record(cmd);
    cmd.submit();
    double total = 0;
    for (auto& [name, t] : timer.intervals())
      if (name == "end") total += t;
    if (r > 0) ms.push_back(total);  // run 0 is the warm-up
  }
  return median(ms);
}

std::vector<uint32_t> randomWords(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<uint32_t> v(n);
  for (auto& x : v) x = rng();
  return v;
}

double mps(size_t n, double ms) { return double(n) / (ms * 1e3); }  // millions per second

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "sort_bench: %s\n", what.c_str());
  std::exit(1);
}

}  // namespace

int main(int argc, char** argv) {
  vk::ContextOptions options;
  options.quiet = true;
  int runs = 7;
  std::vector<uint32_t> sizes = {1u << 20, 1u << 22};
  std::string shapeName = "device", schemeName = "device";
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) fail(a + " needs a value");
      return argv[++i];
    };
    if (a == "--device") {
      options.device = value();
    } else if (a == "--runs") {
      runs = std::max(5, std::atoi(value().c_str()));
    } else if (a == "--sizes") {
      sizes.clear();
      std::string s = value();
      for (size_t p = 0; p < s.size();) {
        size_t q = s.find(',', p);
        sizes.push_back(uint32_t(std::stoul(s.substr(p, q - p))));
        p = q == std::string::npos ? s.size() : q + 1;
      }
    } else if (a == "--shape") {
      shapeName = value();
      if (shapeName != "device" && shapeName != "cpu" && shapeName != "gpu") fail("--shape takes device, cpu or gpu");
    } else if (a == "--scheme") {
      schemeName = value();
      if (schemeName != "device" && schemeName != "reduce-then-scan" && schemeName != "look-back")
        fail("--scheme takes device, reduce-then-scan or look-back");
    } else {
      fail("unknown argument " + a +
           " (--device NAME|INDEX, --runs N >= 5, --sizes N,N,..., --shape device|cpu|gpu, --scheme "
           "device|reduce-then-scan|look-back)");
    }
  }
  try {
    auto ctxPtr = vk::createContext(options);
    vk::Context& ctx = *ctxPtr;
    std::printf("device: %s\n", ctx.driverDescription().c_str());
    std::printf("median of %d runs after a warm-up; GPU: timestamps; CPU: one thread; speedup = CPU ms / GPU ms\n\n",
                runs);
    const sort::SortShape shape = shapeName == "cpu"   ? sort::kCpuSortShape
                                  : shapeName == "gpu" ? sort::kGpuSortShape
                                                       : sort::sortShapeFor(ctx);
    const sort::SortScheme scheme = schemeName == "reduce-then-scan" ? sort::SortScheme::ReduceThenScan
                                    : schemeName == "look-back"      ? sort::SortScheme::LookBack
                                                                     : sort::sortSchemeFor(ctx);
    std::printf("radix sort of random (uint32 key, uint32 value) pairs, 32 key bits; tiles of %u invocations x %u keys (%s); %s (%s)\n",
                shape.threads, shape.items, shapeName == "device" ? "the device's shape" : (shapeName + " shape").c_str(),
                sort::sortSchemeName(scheme), schemeName == "device" ? "the device's scheme" : "chosen");
    std::printf("%-9s | %9s %8s | %-23s %7s | %-23s %7s\n", "pairs", "GPU ms", "Mkeys/s", "std::sort ms   Mkeys/s",
                "speedup", "std::stable_sort ms  Mk/s", "speedup");

    for (uint32_t n : sizes) {
      const size_t bytes = size_t(n) * 4;
      std::vector<uint32_t> keys = randomWords(n, n), values(n);
      std::iota(values.begin(), values.end(), 0u);

      // GPU: restore the input, then sort between the marks.
      sort::RadixSort sorter(ctx, n, shape, scheme);
      vk::Buffer k0 = vk::createBuffer(ctx, bytes), v0 = vk::createBuffer(ctx, bytes);
      vk::Buffer k = vk::createBuffer(ctx, bytes), v = vk::createBuffer(ctx, bytes);
      vk::upload(ctx, k0, keys.data(), bytes);
      vk::upload(ctx, v0, values.data(), bytes);
      double gpu = gpuMs(ctx, runs, [&](vk::Commands& cmd) {
        cmd.copy(k0, k, bytes);
        cmd.copy(v0, v, bytes);
        cmd.barrier();
        cmd.mark("start");
        sorter.record(cmd, k, v, n);
        cmd.mark("end");
      });

      // CPU: the same pairs, by key.
      std::vector<Pair> pairs(n), work;
      for (uint32_t i = 0; i < n; ++i) pairs[i] = {keys[i], values[i]};
      auto byKey = [](const Pair& a, const Pair& b) { return a.key < b.key; };
      std::vector<double> sortMs, stableMs;
      for (int r = 0; r <= runs; ++r) {
        work = pairs;
        double t = cpuMs([&] { std::sort(work.begin(), work.end(), byKey); });
        if (r > 0) sortMs.push_back(t);
        work = pairs;
        t = cpuMs([&] { std::stable_sort(work.begin(), work.end(), byKey); });
        if (r > 0) stableMs.push_back(t);
      }
      // The GPU result must be the stable one, bit for bit.
      std::vector<uint32_t> gk = vk::download<uint32_t>(ctx, k, n), gv = vk::download<uint32_t>(ctx, v, n);
      for (uint32_t i = 0; i < n; ++i)
        if (gk[i] != work[i].key || gv[i] != work[i].value) fail("GPU sort differs from std::stable_sort at " + std::to_string(i));

      double s = median(sortMs), st = median(stableMs);
      std::printf("%-9u | %9.1f %8.2f | %12.1f %10.2f %7.2fx | %12.1f %10.2f %7.2fx\n", n, gpu, mps(n, gpu), s, mps(n, s),
                  s / gpu, st, mps(n, st), st / gpu);
    }

    std::printf("\nscan and compaction of uint32 (CPU peers: std::exclusive_scan, a copy-if loop; 50%% kept)\n");
    std::printf("%-9s | %-10s | %9s %8s | %9s %8s | %7s\n", "elements", "primitive", "GPU ms", "Melem/s", "CPU ms",
                "Melem/s", "speedup");
    for (uint32_t n : sizes) {
      const size_t bytes = size_t(n) * 4;
      std::vector<uint32_t> in = randomWords(n, n + 1), flags(n);
      for (uint32_t i = 0; i < n; ++i) flags[i] = in[i] & 1u;  // half kept
      vk::Buffer a = vk::createBuffer(ctx, bytes), b = vk::createBuffer(ctx, bytes), word = vk::createBuffer(ctx, 16);
      vk::upload(ctx, a, in.data(), bytes);

      sort::Scan scan(ctx, n);
      double gpuScan = gpuMs(ctx, runs, [&](vk::Commands& cmd) {
        cmd.mark("start");
        scan.record(cmd, a, b, n, sort::GpuWord(word, 0));
        cmd.mark("end");
      });
      std::vector<uint32_t> out(n);
      std::vector<double> cpu;
      for (int r = 0; r <= runs; ++r) {
        double t = cpuMs([&] { std::exclusive_scan(in.begin(), in.end(), out.begin(), 0u); });
        if (r > 0) cpu.push_back(t);
      }
      if (vk::download<uint32_t>(ctx, b, n) != out) fail("GPU scan differs from std::exclusive_scan");
      double c = median(cpu);
      std::printf("%-9u | %-10s | %9.2f %8.1f | %9.2f %8.1f | %6.2fx\n", n, "scan", gpuScan, mps(n, gpuScan), c,
                  mps(n, c), c / gpuScan);

      vk::upload(ctx, a, flags.data(), bytes);
      sort::Compact compact(ctx, n);
      double gpuCompact = gpuMs(ctx, runs, [&](vk::Commands& cmd) {
        cmd.mark("start");
        compact.record(cmd, a, n, b, sort::GpuWord(word, 0));
        cmd.mark("end");
      });
      cpu.clear();
      size_t kept = 0;
      for (int r = 0; r <= runs; ++r) {
        double t = cpuMs([&] {
          kept = 0;
          for (uint32_t i = 0; i < n; ++i)
            if (flags[i]) out[kept++] = i;
        });
        if (r > 0) cpu.push_back(t);
      }
      out.resize(kept);
      if (vk::download<uint32_t>(ctx, word, 1)[0] != kept || vk::download<uint32_t>(ctx, b, kept) != out)
        fail("GPU compaction differs from the CPU loop");
      c = median(cpu);
      std::printf("%-9u | %-10s | %9.2f %8.1f | %9.2f %8.1f | %6.2fx\n", n, "compaction", gpuCompact,
                  mps(n, gpuCompact), c, mps(n, c), c / gpuCompact);
      out.resize(n);
    }
  } catch (const Error& e) {
    fail(e.what());
  }
  return 0;
}
