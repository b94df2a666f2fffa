// The cone path's statistics of one bench frame, typed: the recorder fills them, and only the bench's
// method turns them into its JSON row (cone_method.cpp, statsJson). docs/ARCHITECTURE.md, "The cone path's
// code"; the JSON keys are listed under "The cone path's settings".
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "traversal/traversal.h"

namespace cs {

struct ConeFrameStats {
  // The settings and the geometry.
  uint32_t triangles = 0;
  uint64_t trianglesDropped = 0;
  uint64_t triangleBuffers = 0;
  bool sorted = false, twoPass = false, frontFaceCulling = false, earlyAccept = false;
  std::string variant, test;  // test: "precise" | "sphere"
  float epsilon = 0;
  // The cones' frame: world, or far (with its slack and the light's distance in half diagonals).
  bool far = false;
  float frameScale = 1, frameSigma = 0, frameBeta = 0;
  double lightDistanceHalfDiagonals = 0;

  // The frame's recording.
  uint32_t litSamples = 0;
  std::string raySort;
  std::optional<uint32_t> rayKeyBits;  // sorted frames
  uint32_t treeDepth = 0, treeNodes = 0;
  std::optional<std::string> rayOrder, rayOrderChoice;
  std::vector<double> screenTreeSolidAngleSr;  // with a measured order choice: per depth
  std::optional<double> screenTreeLooseness;
  std::string traversalPath, stageTiming;
  // One-submission frames: the clusters, the last expansion's test and lanes, the batch.
  bool oneSubmission = false;
  bool clusters = false;
  std::string lastExpansionTest;  // (the lanes, given or chosen per batch: traversal.expansionLanes)
  uint32_t traversalBatchTriangles = 0;
  struct HostSplit {
    double prepareAndRecord = 0, submitAndWait = 0, after = 0;
  };
  std::optional<HostSplit> hostSplit;

  // Two-pass frames (002 §3.4), when the tree was built.
  struct TwoPass {
    uint32_t blockers = 0;
    float blockerSolidAngle = 0, blockerMaxFraction = 0, updateMinFinished = 0;
    std::string update;
    uint32_t raysFinishedPassOne = 0;
    std::optional<uint32_t> raysRemaining;
    std::optional<traversal::TraversalStats> passOne, passTwo;
    std::optional<uint32_t> treeDepthPassTwo, treeNodesPassTwo;
  };
  std::optional<TwoPass> twoPassDetail;

  // Times and the traversal's counters.
  double readbackMs = 0;
  std::vector<std::pair<std::string, double>> timestampMs;  // per named interval
  traversal::TraversalStats traversal;
  // The traversal's memory (when one is made) and the budget.
  bool traversalMade = false;
  uint64_t traversalMemoryBytes = 0, pairCapacity = 0, traversalBytes = 0;
  uint32_t chunkCapacity = 0;
  uint64_t hostPeakBytes = 0;
  uint64_t memoryBudgetBytes = 0, memoryBudgetUsedBytes = 0;  // under a budget

  // A frame of several lights of one view (ConeRecorder::runLights): how many, whether one submission
  // recorded them all (else a frame a light, and why), the frame's wall time and how this light's totalMs
  // is its share of it, and why this light was run again alone after the shared submission (if it was).
  struct Lights {
    uint32_t count = 0;
    bool together = false;
    std::string why;
    double frameMs = 0;
    std::string share, alone;
  };
  std::optional<Lights> lights;

  // Adds ms to the named interval (a new name goes last).
  void addTimestamp(const std::string& name, double ms) {
    for (auto& [n, v] : timestampMs)
      if (n == name) return void(v += ms);
    timestampMs.push_back({name, ms});
  }
  void setTimestamp(const std::string& name, double ms) {
    for (auto& [n, v] : timestampMs)
      if (n == name) return void(v = ms);
    timestampMs.push_back({name, ms});
  }
  const double* timestamp(const std::string& name) const {
    for (const auto& [n, v] : timestampMs)
      if (n == name) return &v;
    return nullptr;
  }
};

}  // namespace cs
