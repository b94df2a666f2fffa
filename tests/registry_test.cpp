// The method registry: a method registered from the test folder alone -- no line of app/ names it -- is
// offered, checked, run and reported by every command: render, compare (its sweep, the report), compare
// --animate (its rows, its rebuild stages by kind) and compare --scaling.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "app/commands.h"
#include "method/registry.h"
#include "tests/cli_support.h"
#include "harness/harness.h"
#include "raster/gbuffer.h"
#include "raster/raster.h"
#include "tests/test_context.h"

namespace fs = std::filesystem;

namespace cs {
namespace {

// Every lit sample at one visibility level (--alllit-level, default 1): wrong exactly where the reference
// has shadow, which is what the tests read back.
class AllLit : public ShadowMethod {
 public:
  explicit AllLit(float level) : level_(level) {}
  std::string name() const override { return "alllit"; }
  MethodOutput run(const FrameInput& frame) override {
    const auto t0 = std::chrono::steady_clock::now();
    MethodOutput out;
    out.visibility.assign(frame.gbuffer->size(), 1.0f);
    size_t lit = 0;
    for (size_t i = 0; i < frame.gbuffer->size(); ++i)
      if (frame.gbuffer->isLit(i)) {
        out.visibility[i] = level_;
        ++lit;
      }
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    out.stages = {{"nothing_to_build", 0.0, StageKind::Rebuild}, {"fill", ms, StageKind::Lookup}};
    out.totalMs = ms;
    out.work = std::to_string(lit) + " samples filled";
    out.bytesAllocated = out.visibility.size() * sizeof(float);
    out.peakBytes = out.bytesAllocated;
    out.stats = {{"level", level_}};
    return out;
  }

 private:
  float level_;
};

MethodInfo allLitInfo() {
  MethodInfo m;
  m.name = "alllit";
  m.summary = "every lit sample lit (a test method)";
  m.usesDevice = false;
  m.settings = {{"alllit-level", "F", "the visibility given to every lit sample (0.5..1)", {}}};
  m.check = [](const Settings& s) { (void)s.number("alllit-level", 0.5, 1.0, 1.0); };
  m.make = [](vk::Context*, const Settings& s) -> std::unique_ptr<ShadowMethod> {
    return std::make_unique<AllLit>(float(s.number("alllit-level", 0.5, 1.0, 1.0)));
  };
  m.sweep = [](const Settings& s) {
    return std::vector<SweepPoint>{{"alllit@1", s.with("alllit-level", "1")}, {"alllit@0.75", s.with("alllit-level", "0.75")}};
  };
  return m;
}

struct Registered {
  Registered() {
    registerBuiltinMethods();
    registerMethod(allLitInfo());
  }
  ~Registered() { unregisterMethod("alllit"); }
};

int run(const std::string& args) {
  std::vector<std::string> words = {"coneshadow"};
  std::istringstream is(args);
  for (std::string w; is >> w;) words.push_back(w);
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(w.data());
  const int code = runMain(int(argv.size()), argv.data());
  if (code == 0) cs::test::expectResultsMatchTheSchema(cs::test::outFolderOf(args));
  return code;
}

fs::path outDir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("coneshadow_registry_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

std::string readText(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

nlohmann::json readJson(const fs::path& p) {
  std::ifstream f(p);
  return nlohmann::json::parse(f);
}

TEST(Registry, ABuiltinNameIsTakenOnceAndEveryBuiltinDeclaresItself) {
  registerBuiltinMethods();
  const std::vector<std::string> names = registeredMethodNames();
  for (const char* n : {"embree", "cone", "cubesm", "rmsm"})
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
  EXPECT_EQ(referenceMethod().name, "embree");
  MethodInfo again = allLitInfo();
  again.name = "cone";
  EXPECT_THROW(registerMethod(again), Error);
  EXPECT_EQ(&methodOrUsageError("RMSM"), findMethod("rmsm"));
  try {
    methodOrUsageError("cnoe");
    ADD_FAILURE() << "an unknown method was found";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean cone?"), std::string::npos) << e.what();
  }
}

TEST(Registry, AMethodRegisteredByATestRunsInRenderCompareAnimateAndScaling) {
  Registered registered;
  // render: its row on the same samples as Embree's, judged: wrong exactly where the reference is dark.
  const fs::path r = outDir("render");
  ASSERT_EQ(run("render --methods alllit --alllit-level 0.75 --view room --width 32 --height 24 --frames 1 --quiet --out " +
                r.string()),
            0);
  nlohmann::json rows = readJson(r / "results.json");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1]["method"], "alllit");
  EXPECT_EQ(rows[1]["stats"]["level"], 0.75);
  EXPECT_EQ(rows[1]["device"], "cpu (alllit)");
  const uint64_t dark = rows[0]["stats"]["lit_samples"].get<uint64_t>() > 0 ? rows[1]["error"]["false_light"].get<uint64_t>() : 0;
  EXPECT_GT(dark, 0u) << "the room has shadow, which an all-lit method gets wrong";
  EXPECT_EQ(rows[1]["error"]["false_shadow"], 0);
  EXPECT_TRUE(fs::exists(r / "alllit_shaded.png"));
  // Its setting is refused where it is not chosen, and checked where it is.
  EXPECT_EQ(run("render --methods cone --alllit-level 1 --out " + r.string()), 2);
  EXPECT_EQ(run("render --methods alllit --alllit-level 2 --out " + r.string()), 2);
  fs::remove_all(r);

  // compare: its sweep's two points, each a row of the report.
  const fs::path c = outDir("compare");
  ASSERT_EQ(run("compare --methods embree,alllit --views wall --width 24 --height 16 --frames 1 --quiet --out " + c.string()), 0);
  rows = readJson(c / "results.json");
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[1]["stats"]["setting"], "alllit@1");
  EXPECT_EQ(rows[2]["stats"]["setting"], "alllit@0.75");
  const std::string md = readText(c / "report.md");
  EXPECT_NE(md.find("| alllit@0.75 |"), std::string::npos) << md;
  EXPECT_NE(md.find("samples filled"), std::string::npos) << "the work column is the method's own";
  EXPECT_TRUE(fs::exists(c / "wall_alllit@1_shaded.png"));
  EXPECT_EQ(rows[1]["stats"]["timing"], "sequential");
  // --interleave: the same rows, the frames round-robin.
  ASSERT_EQ(run("compare --interleave --methods embree,alllit --views wall --width 24 --height 16 --frames 2 --quiet --out " +
                c.string()),
            0);
  const nlohmann::json interleaved = readJson(c / "results.json");
  ASSERT_EQ(interleaved.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(interleaved[k]["stats"]["setting"], rows[k]["stats"]["setting"]);
    EXPECT_EQ(interleaved[k]["stats"]["timing"], "interleaved");
    EXPECT_EQ(interleaved[k]["stats"]["frames"], 2);
    EXPECT_EQ(interleaved[k]["error"], rows[k]["error"]);
  }
  EXPECT_EQ(run("compare --interleave --animate 2 --methods alllit --quiet --out " + c.string()), 2);
  fs::remove_all(c);

  // compare --animate: one row per frame; the rebuild column from the stage kinds.
  const fs::path a = outDir("animate");
  ASSERT_EQ(run("compare --animate 2 --methods alllit,embree --views wall --width 24 --height 16 --quiet --out " + a.string()), 0);
  rows = readJson(a / "results.json");
  size_t allLitRows = 0;
  for (const auto& row : rows) allLitRows += row["method"] == "alllit";
  EXPECT_EQ(allLitRows, 2u);
  const std::string dyn = readText(a / "dynamic.md");
  EXPECT_NE(dyn.find("| alllit | "), std::string::npos) << dyn;
  EXPECT_NE(dyn.find("nothing_to_build"), std::string::npos) << "its Rebuild stage is in the rebuild column\n" << dyn;
  fs::remove_all(a);

  // compare --scaling: a row at every point.
  const fs::path s = outDir("scaling");
  ASSERT_EQ(run("compare --scaling --scaling-sizes 16,24 --scaling-max-triangles 8000 --methods alllit --views wall --width 16 "
                "--height 16 --frames 1 --quiet --out " + s.string()),
            0);
  const std::string scaling = readText(s / "scaling.md");
  size_t at = 0, count = 0;
  while ((at = scaling.find("| alllit |", at)) != std::string::npos) ++count, ++at;
  EXPECT_GE(count, 3u) << scaling;
  fs::remove_all(s);
}

}  // namespace
}  // namespace cs

namespace cs {
namespace {

// A method that logs its runs into a shared list (its name, each run) and otherwise fills like AllLit.
class Logged : public AllLit {
 public:
  Logged(float level, std::string tag, std::vector<std::string>& log) : AllLit(level), tag_(std::move(tag)), log_(log) {}
  MethodOutput run(const FrameInput& frame) override {
    log_.push_back(tag_);
    return AllLit::run(frame);
  }

 private:
  std::string tag_;
  std::vector<std::string>& log_;
};

// compare --interleave (judgeInterleaved): every method's warm-up, then frame k of each in turn; each
// method judged as judge() judges it alone (mask, error, frames), the reference rerun for its times.
TEST(Registry, InterleavedJudgingRunsTheMethodsRoundRobinAndJudgesEachAsAlone) {
  registerBuiltinMethods();
  auto& ctx = test::context();
  Scene scene = builtinScene();
  Raster raster(ctx, scene);
  FrameSpec spec;
  spec.camera = *scene.findCamera("room");
  spec.view = "room";
  spec.light = scene.lights.front().position;
  spec.width = 40;
  spec.height = 32;
  spec.frames = 1;
  std::unique_ptr<PreparedFrame> frame = prepareFrame(ctx, raster, scene, spec);
  std::vector<std::string> log;
  Logged a(1.0f, "a", log), b(0.75f, "b", log);
  const MethodInfo info = allLitInfo();
  const MethodInfo& reference = referenceMethod();
  const std::vector<Judged> j = judgeInterleaved({&info, &reference, &info}, {&a, nullptr, &b}, *frame, 3);
  EXPECT_EQ(log, (std::vector<std::string>{"a", "b", "a", "b", "a", "b", "a", "b"}));
  ASSERT_EQ(j.size(), 3u);
  std::vector<std::string> alone;
  Logged a2(1.0f, "a", alone), b2(0.75f, "b", alone);
  const Judged ja = judge(info, &a2, *frame, 3), jb = judge(info, &b2, *frame, 3);
  for (auto [got, want] : {std::pair{&j[0], &ja}, std::pair{&j[2], &jb}}) {
    EXPECT_EQ(got->runs.output.visibility, want->runs.output.visibility);
    EXPECT_EQ(got->runs.totals.size(), 3u);
    EXPECT_TRUE(got->runs.deterministic);
    EXPECT_EQ(got->error.misclassifiedFraction, want->error.misclassifiedFraction);
    EXPECT_EQ(got->error.misclassifiedOutsideBand, want->error.misclassifiedOutsideBand);
    EXPECT_EQ(got->perFrame.size(), 4u);  // the warm-up and three frames
  }
  EXPECT_GT(j[0].error.misclassifiedOutsideBand, 0u) << "the room has shadow, which an all-lit method gets wrong";
  EXPECT_EQ(j[1].runs.output.visibility, frame->reference.output.visibility);
  EXPECT_EQ(j[1].runs.totals.size(), 3u);
  EXPECT_EQ(j[1].error.misclassifiedFraction, 0.0);
  EXPECT_THROW(judgeInterleaved({&info}, {nullptr}, *frame, 1), Error) << "a method entry with no object";
}

// What every registered method owes, checked on every one of them without naming any: one visibility in
// [0, 1] per pixel and 1 where the sample is not lit, stages with kinds and a work summary, the same mask
// frame after frame (unless it is progressive), 0 misclassified outside the band when it claims to be exact; and its enumerated
// settings refuse a value outside their choices, naming the method.
TEST(Registry, EveryRegisteredMethodKeepsTheMethodContract) {
  registerBuiltinMethods();
  auto& ctx = test::context();
  Scene scene = builtinScene();
  Raster raster(ctx, scene);
  for (const char* view : {"wall", "fur"}) {
    FrameSpec spec;
    spec.camera = *scene.findCamera(view);
    spec.view = view;
    spec.light = scene.lights.front().position;
    spec.width = 40;
    spec.height = 32;
    spec.frames = 1;
    std::unique_ptr<PreparedFrame> frame = prepareFrame(ctx, raster, scene, spec);
    for (const MethodInfo& m : registeredMethods()) {
      const std::string what = m.name + " on " + view;
      Settings defaults(m.name);
      if (m.check) {
        EXPECT_NO_THROW(m.check(defaults)) << what;
      }
      const Judged j = judge(m, defaults, ctx, *frame, 2);
      const MethodOutput& out = j.runs.output;
      ASSERT_EQ(out.visibility.size(), frame->gbuffer.size()) << what;
      for (size_t i = 0; i < out.visibility.size(); ++i) {
        ASSERT_TRUE(out.visibility[i] >= 0.0f && out.visibility[i] <= 1.0f) << what << " pixel " << i;
        if (!frame->gbuffer.isLit(i)) {
          ASSERT_EQ(out.visibility[i], 1.0f) << what << ": pixel " << i << " is not lit";
        }
      }
      EXPECT_FALSE(out.stages.empty()) << what;
      EXPECT_FALSE(out.work.empty()) << what;
      if (!m.progressive) {
        EXPECT_TRUE(j.runs.deterministic) << what;
      } else {  // refined frame by frame: each frame judged, the warm-up first
        EXPECT_EQ(j.perFrame.size(), 3u) << what;
      }
      EXPECT_EQ(j.error.litSamples, frame->litSamples) << what;
      if (m.exact) {
        EXPECT_EQ(j.error.misclassifiedOutsideBand, 0u) << what;
      }
    }
  }
  for (const MethodInfo& m : registeredMethods())
    for (const SettingSpec& s : m.settings) {
      if (s.choices.empty() || !m.check) continue;
      try {
        m.check(Settings(m.name).with(s.name, "no-such-choice"));
        ADD_FAILURE() << m.name << " --" << s.name << " took a value outside its choices";
      } catch (const UsageError& e) {
        EXPECT_EQ(std::string(e.what()).rfind(m.name + ": --" + s.name, 0), 0u) << e.what();
      }
    }
}

}  // namespace
}  // namespace cs
