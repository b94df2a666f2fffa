// The cone frame against Embree over the generated scene family (core/scene_family.cpp; docs/ARCHITECTURE.md,
// "The scene family"): scenes no rule was tuned on. Per member, in the same run: its triangles and lit
// samples, Embree's frame (BVH build + rays, rebuilt every frame), the cone frame, their ratio, pairs
// tested and leaf tests per lit sample, what the automatic choices chose (rays a leaf pair, the last
// expansion's lanes -- and why, where a batch reached that expansion -- the ray order) and the samples
// misclassified outside the band (0: exact); then the WORST ratio, naming its member, and the MEDIAN.
//   family_bench [--members N] [--first S] [--members-list LIST] [--size 1024] [--frames 3] [--big] [--detail]
//                [--device D] [--CONE-SETTING V ...]
// Members family:S .. family:S+N-1 (default 1..12), or those of LIST (e.g. 3,9:tris=1M), at size² (default
// 1024). --big adds, at 512², members 1..12 at 1 M triangles and 1..4 at 10 M (slow: two minutes on
// lavapipe with --frames 1), reported apart with their own worst and median (--members 0 --big: those alone). --detail: per member the pairs per depth, the leaf pairs and tests, and with
// --profile-stages on the stages' times. Frames: the median of N after a warm-up frame.
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "bench/bench_scenes.h"
#include "harness/harness.h"
#include "method/registry.h"
#include "vk/context.h"

namespace {

using namespace cs;

struct Row {
  std::string name;
  double ratio = 0;
};

uint64_t u64(const nlohmann::json& s, const char* key) { return s.contains(key) ? s[key].get<uint64_t>() : 0; }
std::string text(const nlohmann::json& s, const char* key) {
  if (!s.contains(key)) return "-";
  return s[key].is_string() ? s[key].get<std::string>() : s[key].dump();
}

// Prints the worst and the median ratio of `rows` under `title`.
void summary(const char* title, std::vector<Row> rows) {
  if (rows.empty()) return;
  const auto worst = std::max_element(rows.begin(), rows.end(), [](const Row& a, const Row& b) { return a.ratio < b.ratio; });
  std::printf("%s: WORST %.2fx Embree (%s), ", title, worst->ratio, worst->name.c_str());
  std::sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) { return a.ratio < b.ratio; });
  const size_t n = rows.size();
  const double median = n % 2 ? rows[n / 2].ratio : 0.5 * (rows[n / 2 - 1].ratio + rows[n / 2].ratio);
  std::printf("MEDIAN %.2fx over %zu members\n", median, n);
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t count = 12, first = 1, size = 1024;
  int frames = 3;
  bool big = false, detail = false;
  std::vector<std::string> list;
  std::string device;
  std::vector<std::pair<std::string, std::string>> given;
  try {
    registerBuiltinMethods();
    const MethodInfo& cone = methodOrUsageError("cone");
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto next = [&] { return bench::optionValue(argc, argv, i); };
      if (a == "--members") count = uint32_t(std::max(0, std::stoi(next())));
      else if (a == "--first") first = uint32_t(std::max(0, std::stoi(next())));
      else if (a == "--size") size = uint32_t(std::max(16, std::stoi(next())));
      else if (a == "--frames") frames = std::max(1, std::stoi(next()));
      else if (a == "--big") big = true;
      else if (a == "--detail") detail = true;
      else if (a == "--members-list") list = bench::split(next());
      else if (a == "--device") device = next();
      else if (const SettingSpec* setting = bench::settingOption(cone, a)) given.emplace_back(setting->name, next());
      else
        throw UsageError("unknown option '" + a + "' (usage: family_bench [--members N] [--first S] [--members-list "
                         "S[:k=v...],...] [--size 1024] [--frames N] [--big] [--detail] [--device D] [--CONE-SETTING VALUE ...])");
    }
    if (count == 0 && list.empty() && !big) throw UsageError("--members 0 leaves nothing to run (add --big, or a --members-list)");
    std::string settingsText;
    const Settings settings = bench::settingsOf(cone, given, settingsText);

    auto ctx = bench::benchContext(device);
    std::printf("device: %s\nmedian of %d frame(s) after a warm-up; cone settings:%s\n"
                "embree = BVH build + rays every frame; pairs = (triangle or cluster, node) tests; per lit sample\n\n",
                ctx->driverDescription().c_str(), frames, settingsText.empty() ? " the defaults" : settingsText.c_str());
    struct Member {
      std::string arg;
      uint32_t size;
      bool big;
    };
    std::vector<Member> members;
    if (!list.empty()) {
      for (const std::string& m : list) members.push_back({"family:" + m, size, false});
    } else {
      for (uint32_t s = first; s < first + count; ++s) members.push_back({"family:" + std::to_string(s), size, false});
    }
    if (big) {
      for (uint32_t s = 1; s <= 12; ++s) members.push_back({"family:" + std::to_string(s) + ":tris=1M", 512, true});
      for (uint32_t s = 1; s <= 4; ++s) members.push_back({"family:" + std::to_string(s) + ":tris=10M", 512, true});
    }
    std::printf("%-10s %5s %9s %8s %9s %9s %7s %9s %11s %5s %-8s %-6s %5s  %s\n", "member", "size", "triangles", "lit",
                "embree ms", "cone ms", "x emb", "pairs/lit", "leaftst/lit", "leaf", "lanes", "order", "wrong", "parameters");
    std::vector<Row> small, large;
    for (const Member& m : members) {
      std::vector<std::unique_ptr<Scene>> scenes;
      const std::vector<bench::View> views = bench::loadViews(m.arg, scenes);
      const bench::View& v = views.front();
      harness::RunSpec spec = bench::viewRun(v, m.size, uint32_t(frames));
      spec.methods = {{&cone, cone.name, settings}};
      const harness::Results ran = harness::run(*ctx, spec);
      const PreparedFrame& frame = *ran.frames.front().prepared;
      const Judged& j = ran.frames.front().rows.front().judged;
      const nlohmann::json& s = j.runs.output.stats;
      const double lit = double(std::max<uint64_t>(1, u64(s, "lit_samples")));
      const double ratio = j.runs.medianMs / frame.reference.medianMs;
      const std::string label = m.arg.substr(std::string("family:").size());
      std::printf("%-10s %5u %9zu %8llu %9.1f %9.1f %7.2f %9.2f %11.1f %5s %-8s %-6s %5llu  %s\n", label.c_str(), m.size,
                  v.scene->triangleCount(), (unsigned long long)u64(s, "lit_samples"), frame.reference.medianMs,
                  j.runs.medianMs, ratio, double(u64(s, "pairs_tested")) / lit, double(u64(s, "leaf_tests")) / lit,
                  text(s, "leaf_rays").c_str(), text(s, "last_expansion_lanes").c_str(), text(s, "ray_order").c_str(),
                  (unsigned long long)j.error.misclassifiedOutsideBand, familyDescription(parseFamilyArg(m.arg)).c_str());
      const nlohmann::json& t = s["traversal"];
      std::printf("%-10s   leaf rays: %s\n", "", text(t, "leaf_rays_choice").c_str());
      if (t.contains("expansion_lanes_by_batch") && (u64(t["expansion_lanes_by_batch"], "cluster") > 0 ||
                                                     u64(t["expansion_lanes_by_batch"], "triangle") > 0))
        std::printf("%-10s   last expansion's lanes: %s\n", "", text(t, "expansion_lanes_choice").c_str());
      if (detail) {  // what the leaf choice's costs are fitted to (docs/ARCHITECTURE.md, "Leaf pairs chosen per frame")
        std::printf("%-10s   per depth (tested/survived, k):", "");
        for (const nlohmann::json& p : t["passes"])
          std::printf(" %.4g/%.4g", double(u64(p, "pairs_tested")) / 1e3, double(u64(p, "pairs_survived")) / 1e3);
        std::printf("; leaf pairs %.4gk, leaf tests %.4gk\n", double(u64(t, "leaf_pairs")) / 1e3, double(u64(t, "leaf_tests")) / 1e3);
        if (j.runs.output.stages.size() > 1) {  // --profile-stages on: the frame's stages timed one by one
          std::printf("%-10s   stages (ms):", "");
          for (const StageTime& st : j.runs.output.stages) std::printf(" %s %.1f", st.name.c_str(), st.ms);
          std::printf("\n");
        }
      }
      std::fflush(stdout);
      (m.big ? large : small).push_back({label, ratio});
    }
    std::printf("\n");
    summary(("family at " + std::to_string(size) + "²").c_str(), small);
    summary("big members at 512²", large);
  } catch (const UsageError& e) {
    std::cerr << "family_bench: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "family_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
