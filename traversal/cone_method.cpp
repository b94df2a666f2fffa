// The cone path as the bench's shadow method "cone" (cone_method.h): a frame of the recorder
// (cone_recorder.h) and its typed statistics turned into the method's output and JSON row.
// docs/ARCHITECTURE.md, "The cone path's code".
#include "traversal/cone_method.h"

#include <algorithm>
#include <string>

#include "core/error.h"
#include "traversal/cone_recorder.h"

namespace cs {
namespace {

// The frame's statistics as the bench's JSON row (its keys: docs/ARCHITECTURE.md, "The cone path's settings").
nlohmann::json statsJson(const ConeFrameStats& s) {
  nlohmann::json j = {{"triangles", s.triangles},
                      {"triangles_dropped", s.trianglesDropped},
                      {"triangle_buffers", s.triangleBuffers},
                      {"sorted", s.sorted},
                      {"variant", s.variant},
                      {"test", s.test},
                      {"front_face_culling", s.frontFaceCulling},
                      {"early_accept", s.earlyAccept},
                      {"two_pass", s.twoPass},
                      {"epsilon", s.epsilon},
                      {"frame", s.far ? "far" : "world"},
                      {"frame_scale", s.frameScale}};
  if (s.far) {
    j["frame_sigma"] = s.frameSigma;
    j["frame_beta"] = s.frameBeta;
    j["light_distance_half_diagonals"] = s.lightDistanceHalfDiagonals;
  }
  if (s.oneSubmission) {
    j["clusters"] = s.clusters;
    j["last_expansion_test"] = s.lastExpansionTest;
    j["last_expansion_lanes"] = s.traversal.expansionLanes;
    j["traversal_batch_triangles"] = s.traversalBatchTriangles;
  }
  j["lit_samples"] = s.litSamples;
  j["ray_sort"] = s.raySort;
  if (s.rayKeyBits) j["ray_key_bits"] = *s.rayKeyBits;
  j["tree_depth"] = s.treeDepth;
  j["tree_nodes"] = s.treeNodes;
  if (s.rayOrder) j["ray_order"] = *s.rayOrder;
  if (s.rayOrderChoice) j["ray_order_choice"] = *s.rayOrderChoice;
  if (s.screenTreeLooseness) {
    j["screen_tree_solid_angle_sr"] = s.screenTreeSolidAngleSr;  // per depth, the sum over its cones
    j["screen_tree_looseness"] = *s.screenTreeLooseness;
  }
  j["traversal_path"] = s.traversalPath;
  j["stage_timing"] = s.stageTiming;
  if (s.twoPassDetail) {
    const ConeFrameStats::TwoPass& t = *s.twoPassDetail;
    nlohmann::json tp = {{"blockers", t.blockers},
                         {"blocker_solid_angle_sr", t.blockerSolidAngle},
                         {"blocker_max_fraction", t.blockerMaxFraction},
                         {"update_min_finished", t.updateMinFinished},
                         {"update", t.update},
                         {"rays_finished_pass_one", t.raysFinishedPassOne}};
    if (t.raysRemaining) tp["rays_remaining"] = *t.raysRemaining;
    if (t.passOne) tp["pass_one"] = t.passOne->toJson();
    if (t.passTwo) tp["pass_two"] = t.passTwo->toJson();
    if (t.treeDepthPassTwo) tp["tree_depth_pass_two"] = *t.treeDepthPassTwo;
    if (t.treeNodesPassTwo) tp["tree_nodes_pass_two"] = *t.treeNodesPassTwo;
    j["two_pass"] = tp;
  }
  if (s.hostSplit)
    j["host_split_ms"] = {{"prepare_and_record", s.hostSplit->prepareAndRecord},
                          {"submit_and_wait", s.hostSplit->submitAndWait},
                          {"after", s.hostSplit->after}};
  j["readback_ms"] = s.readbackMs;
  nlohmann::json timestamps = nlohmann::json::object();
  for (const auto& [n, ms] : s.timestampMs) timestamps[n] = ms;
  j["timestamp_ms"] = timestamps;
  const traversal::TraversalStats& ts = s.traversal;
  j["traversal"] = ts.toJson();
  j["pairs_tested"] = ts.pairsTested();
  j["pairs_survived"] = ts.pairsSurvived();
  j["leaf_tests"] = ts.leafTests;
  j["leaf_rays"] = ts.leafRays;
  j["leaf_test"] = traversal::leafTestName(ts.leafTest);
  j["early_accepted_nodes"] = ts.earlyAccepted;
  j["traversal_peak_bytes"] = ts.peakBytes;
  if (s.traversalMade) {
    j["traversal_memory_bytes"] = s.traversalMemoryBytes;
    j["pair_capacity"] = s.pairCapacity;
    j["chunk_capacity"] = s.chunkCapacity;
    j["traversal_bytes"] = s.traversalBytes;
  }
  j["host_peak_bytes"] = s.hostPeakBytes;
  if (s.memoryBudgetBytes) {
    j["memory_budget_bytes"] = s.memoryBudgetBytes;
    j["memory_budget_used_bytes"] = s.memoryBudgetUsedBytes;
  }
  if (s.lights) {
    const ConeFrameStats::Lights& l = *s.lights;
    j["lights_frame"] = {{"lights", l.count}, {"together", l.together}, {"frame_ms", l.frameMs}, {"total_ms", l.share}};
    if (!l.why.empty()) j["lights_frame"]["why"] = l.why;
    if (!l.alone.empty()) j["lights_frame"]["alone"] = l.alone;
  }
  return j;
}

class ConeMethod : public ShadowMethod {
 public:
  ConeMethod(vk::Context& ctx, const ConeOptions& options) : recorder_(ctx, options) {}
  std::string name() const override { return "cone"; }

  MethodOutput run(const FrameInput& frame) override { return outputOf(recorder_.runFrame(frame)); }

  // The view's lights in one submission (ConeRecorder::runLights), kConeMaxLightsTogether at a time.
  bool sharesLights() const override { return true; }
  std::vector<MethodOutput> runLights(std::span<const FrameInput> frames) override {
    std::vector<MethodOutput> out;
    out.reserve(frames.size());
    for (size_t at = 0; at < frames.size(); at += kConeMaxLightsTogether)
      for (ConeRecorder::Frame& f : recorder_.runLights(frames.subspan(at, std::min(kConeMaxLightsTogether, frames.size() - at))))
        out.push_back(outputOf(std::move(f)));
    return out;
  }

 private:
  MethodOutput outputOf(ConeRecorder::Frame f) {
    MethodOutput out;
    out.visibility = std::move(f.mask);  // 1.0f or 0.0f bits only: no NaN or inf can appear
    out.totalMs = f.totalMs;
    out.stages = std::move(f.stages);
    const traversal::TraversalStats& ts = f.stats.traversal;
    out.work = std::to_string(ts.pairsTested()) + " nodes visited, " + std::to_string(ts.leafTests) + " leaf tests";
    out.bytesAllocated = recorder_.heldBytes();
    // Working set: everything resident for the frame, with the traversal's share at its measured peak.
    out.peakBytes = out.bytesAllocated - f.stats.traversalBytes + ts.peakBytes;
    // The budget (--memory-budget) holds the device buffers as allocated (the arena whole, not its peak)
    // and the host working set of the upload; ensureTraversal() planned the arena to make it hold.
    if (const uint64_t budget = recorder_.options().memoryBudgetBytes) {
      const uint64_t used = out.bytesAllocated + f.stats.hostPeakBytes;
      f.stats.memoryBudgetBytes = budget;
      f.stats.memoryBudgetUsedBytes = used;
      CS_CHECK(used <= budget, "cone: the frame held " << used << " bytes, over its --memory-budget of " << budget);
    }
    out.stats = statsJson(f.stats);
    double stageMs = 0;
    for (const StageTime& st : out.stages) stageMs += st.ms;
    out.stats["stages_ms"] = stageMs;
    return out;
  }

  ConeRecorder recorder_;
};

}  // namespace

bool applyConeVariant(const std::string& name, ConeOptions& o) {
  struct Row {
    const char* name;
    ConeTest test;
    bool sorted, earlyAccept, twoPass;
  };
  static const Row rows[] = {{"Precise", ConeTest::Precise, false, false, false},
                             {"PreciseSorted", ConeTest::Precise, true, false, false},
                             {"Spheres", ConeTest::Sphere, false, false, false},
                             {"SpheresSorted", ConeTest::Sphere, true, false, false},
                             {"PreciseSEA", ConeTest::Precise, true, true, false},
                             {"PreciseEATP", ConeTest::Precise, false, true, true},
                             {"PreciseSEATP", ConeTest::Precise, true, true, true}};
  for (const Row& r : rows)
    if (name == r.name) {
      o.test = r.test;
      o.sorted = r.sorted;
      o.earlyAccept = r.earlyAccept;
      o.twoPass = r.twoPass;
      return true;
    }
  return false;
}

const std::vector<std::string>& coneVariantNames() {
  static const std::vector<std::string> names = {"Precise",    "PreciseSorted", "Spheres",     "SpheresSorted",
                                                 "PreciseSEA", "PreciseEATP",   "PreciseSEATP"};
  return names;
}

std::string coneVariantName(const ConeOptions& o) {
  const bool early = o.earlyAccept && o.test == ConeTest::Precise;
  std::string name = o.test == ConeTest::Sphere ? "Spheres" : "Precise";
  if (!early && !o.twoPass) return name + (o.sorted ? "Sorted" : "");
  return name + (o.sorted ? "S" : "") + (early ? "EA" : "") + (o.twoPass ? "TP" : "");
}

std::unique_ptr<ShadowMethod> makeConeMethod(vk::Context& ctx, const ConeOptions& options) {
  return std::make_unique<ConeMethod>(ctx, options);
}

}  // namespace cs
