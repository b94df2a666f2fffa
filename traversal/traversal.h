// traversal/: every triangle pushed through the cone tree, breadth-first in one bounded pair arena
// (002 §3.1, §3.2, §4.2), down to an exact ray/triangle test per leaf pair that shadows the sample.
// How it works -- pairs, bounded memory, the far-light frame, the memory budget, early accept, one
// submission, clusters and super clusters -- is docs/ARCHITECTURE.md, "The traversal
// (traversal/traversal.h)". The mask never depends on order, races, the arena's size or how the work was
// split: visibility only goes from lit to shadowed, and every (triangle, leaf) pair that survives is
// tested.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "conetree/conetree.h"
#include "core/function_ref.h"
#include "traversal/traversal_layout.h"
#include "vk/context.h"

namespace cs::traversal {

// ---- sizing (pure, unit-tested) ---------------------------------------------------------------------
// Bounded memory: the arena holds the pairs of every depth as a stack; a depth is processed from its
// tail in chunks whose survivors overwrite the slots they free, so the traversal is breadth-first while
// two depths fit and degrades to depth-first over chunks when they do not, with the same mask.
struct ArenaPlan {
  uint64_t pairCapacity = 0;   // pairs the arena holds
  uint32_t chunkCapacity = 0;  // input pairs one chunk may have (the chunk buffer sized for it)
  uint64_t bytes = 0;          // arena + chunk scratch, <= the budget
};
// Bytes the chunk scratch of `chunkCapacity` inputs takes: the chunk buffer, the counters, the state words.
uint64_t chunkScratchBytes(uint32_t chunkCapacity);
// Splits `memoryBytes` into the arena and the chunk scratch; each array stays within `maxBinding` bytes.
// Throws a cs::Error when the budget cannot hold even a minimal arena (kMinPairs pairs + one chunk).
ArenaPlan planArena(uint64_t memoryBytes, uint64_t maxBinding);
// The bytes one pair buffer may take on this device: one storage binding and one texel buffer (the kernels
// read pairs as RGBA32UI texels). Traversal plans its arena with it; so must anyone predicting that plan.
uint64_t maxPairBufferBytes(const vk::Context& ctx);
// Arena slots reserved beyond depth d's pairs for the deeper depths (4 per interior depth below d).
uint64_t reserveBelow(uint32_t treeDepth, uint32_t d);
// The smallest arena that can traverse a tree of this depth: one node's children per depth.
uint64_t minimumPairs(uint32_t treeDepth);
constexpr uint64_t kMinPairs = 4;
constexpr uint64_t kDefaultMemoryBytes = uint64_t(64) << 20;

// ---- cluster spheres (pure, unit-tested; "Clusters") ------------------------------------------------
// Clusters (the device path): every CLUSTER_SIZE consecutive triangles (in Hilbert order, triangle_layout.cpp)
// are bounded by one sphere and every SUPER_CLUSTERS clusters by another; a batch goes down the upper
// depths as (super cluster or cluster, node) pairs under the conservative sphere test and is expanded into
// its triangles' pairs where the nodes stop being wide against the clusters (docs/ARCHITECTURE.md, "The
// traversal": "Clusters", "Super clusters"). The same mask.
// The world bound of `count` fp32 vertices, in double: xyz the centre of their box, w the largest
// distance from it to a vertex.
glm::dvec4 clusterBounds(const glm::vec4* vertices, size_t count);
// A cluster's world bounds: its own (clusterBounds of all its vertices) and its groups', each group's
// CLUSTER_GROUPS-th share of the triangles (GROUP_SIZE each, in order) bounded by clusterBounds and
// rounded outward to fp32 (the centre rounded, the radius grown by that rounding, then rounded up): 80
// bytes a cluster where five double bounds would take 160. A group with no triangles gets the
// cluster's bound. `triangles`: 1 to CLUSTER_SIZE, three vertices each.
struct ClusterWorld {
  glm::dvec4 whole;
  glm::vec4 groups[CLUSTER_GROUPS];
};
ClusterWorld clusterWorld(const glm::vec4* vertices, size_t triangles);
// A super cluster's world bound: a sphere holding the `count` (1 to SUPER_CLUSTERS) clusters' own spheres
// (centred on their box), in double.
glm::dvec4 superBounds(const ClusterWorld* clusters, size_t count);
// The sphere a pass test reads: centre `rel` (the bound's centre relative to the light in the tests'
// coordinates, exact), radius `radius`, padded by 2^-16 of |rel| + radius + `operands` (the magnitudes
// of the fp32 values the GPU's vertices are differences of) so it holds the vertices as the GPU
// rounds them.
glm::vec4 clusterSphere(glm::dvec3 rel, double radius, double operands);
// The same in the far-light frame, where rel.z is about the light's distance D and rounds to an ulp of
// D: the pass tests' own margins cover a centre that far off along z (2^-16 of |c| along the rays, and
// across them 2^-16 |c| times the frame's angular scale, which bounds how far a shift along z moves a
// point across any cone of the frame), so the radius is padded by 2^-16 of what lies across z only:
// |rel.xy| + radius + `lateralOperands` (|x - C| and the light's lateral coordinates in the frame).
// (Padding by 2^-16 of D would make every cluster as wide as the scene from ~10^3 diagonals on.)
glm::vec4 clusterSphereFar(glm::dvec3 rel, double radius, double lateralOperands);
// The position of cell (x, y, z) of a 2^bits-a-side grid (bits 1 to 21) along a 3D Hilbert curve:
// consecutive positions are cells that share a face, so the triangles of any run of them are one
// connected piece of space (the cluster order; a Morton order jumps, and a cluster across a jump is two
// pieces under one sphere).
uint64_t hilbertIndex3(uint32_t x, uint32_t y, uint32_t z, int bits);

// Which leaf test the leaves run (precise_test.h): TwoEnds, leafHit -- each ray measured from the end of
// it the triangle is nearer, right at any light distance and coordinate range -- or FromLight,
// leafHitFromLight: the triangle's share of the test (its edge normals through the light, its plane)
// computed once for the pair's rays, which share the light as their origin, and three dot products a
// ray -- or FromSample, leafHitFromSample: the same with each edge's normal through the ray's sample
// (through the light where that end is the nearer to the edge: three differences, cross and dot
// products a ray; no shear or division). FromLight is
// for a light among the geometry: its edge functions round to an ulp of the triangle's distance from the
// light, which a light 10^3 diagonals away makes wider than the band. FromSample is for a far light:
// its edge functions round to an ulp of the triangle's distance from the sample, as TwoEnds does from
// the end it takes there. leafTestFor() says which may run.
// All three are exact outside the ambiguity band and watertight, but they round differently at the edges
// and the ends of the interval, so the masks may differ within the band; every variant and every arena
// size of one frame runs the same test and gives the same mask.
enum class LeafTest { TwoEnds, FromLight, FromSample };
const char* leafTestName(LeafTest test);
// Where the products of three coordinates neither overflow nor go subnormal (half-diagonal of the
// triangles' bounds [lo, hi] >= 2^-12, every coordinate of the bounds and the light <= 2^40): FromLight
// in the world frame (a light within kFarFrameRatio half-diagonals of the centre of the bounds, so rays
// are at most ~4.5 diagonals long), FromSample in the far frame. TwoEnds otherwise.
LeafTest leafTestFor(bool farFrame, glm::vec3 lo, glm::vec3 hi, glm::vec3 light);

// ---- per-frame statistics -----------------------------------------------------------------------------
struct PassStats {
  uint64_t inputs = 0;    // pairs (or triangles, pass 0) fed to the pass
  uint64_t tested = 0;    // (triangle, node) tests: inputs x children
  uint64_t survived = 0;  // pairs written for the next depth
  uint64_t chunks = 0;    // chunks the pass was split into
  uint64_t overflows = 0; // chunks tested but dropped because their survivors did not fit (retried)
  uint64_t clusterTests = 0;  // of `tested`: (cluster, node) tests (device path with clusters)
};
struct TraversalStats {
  std::vector<PassStats> passes;  // passes[d]: the tests against the nodes of depth d (0 = root)
  uint64_t expandedClusters = 0;  // (cluster, node) pairs expanded into their triangles' pairs
  uint64_t leafPairs = 0;         // pairs sent to the leaves (of depth D-1, or D-2 / D-3 with 16 / 64 rays a pair)
  uint64_t leafTests = 0;         // (pair, ray) combinations at the leaves: 4 (16, 64) per pair but under a last node
  uint32_t leafRays = 4;          // rays a leaf pair covers (LeafRays; 4 in a tree of depth 1 whatever was asked);
                                  // chosen per batch: the span that took the most leaf pairs
  uint64_t leafPairsByRays[3] = {0, 0, 0};  // leaf pairs of 4, 16 and 64 rays
  std::string leafChoice;         // chosen per batch: what was chosen and why; "" when the span was given
  uint64_t leafChoicesByClusters = 0;  // chosen per batch: the choices made from cluster pairs' survival that
                                       // kept them clusters one depth further (a batch may make two)
  uint64_t leafPairsByCull[2] = {0, 0};  // leaf pairs whose leaves ran with the cull, without (leafCullTestsPerRay)
  std::string leafCull;                  // the cull's rule (device path); "" on the chunked path (never)
  LeafTest leafTest = LeafTest::TwoEnds;  // the leaves' test
  // The last expansion's lanes (ExpansionLanes): "cluster" or "triangle" -- given, or chosen per batch: the
  // form that took the most pairs ("none" when no batch reached that expansion).
  std::string expansionLanes;
  uint64_t expansionsByLanes[2] = {0, 0};      // batches that took a lane per (super) cluster pair, per triangle pair
  uint64_t expansionPairsByLanes[2] = {0, 0};  // the (super) cluster pairs those batches' choices counted
  std::string expansionLanesChoice;            // chosen per batch: what and why; "" when given
  uint64_t submits = 0;
  uint64_t earlyAccepted = 0;     // early accept: distinct nodes found covered (and shadowed at once)
  uint64_t droppedPairs = 0;      // early accept: pairs dropped because their node had been accepted
  uint64_t peakPairs = 0;         // arena high-water mark, in pairs
  uint32_t peakChunk = 0;         // largest chunk, in input pairs
  uint64_t peakBytes = 0;         // peakPairs * 8 + the scratch of the largest chunk (<= what is allocated)
  double traversalMs = 0;         // wall time of the passes' submits (test and append), waits included
  double leavesMs = 0;            // wall time of the leaf tests' submits
  double traversalGpuMs = 0;      // the same from timestamps (docs/ARCHITECTURE.md, "Timing on lavapipe")
  double leavesGpuMs = 0;
  uint64_t pairsTested() const;
  uint64_t pairsSurvived() const;
  nlohmann::json toJson() const;
};

// How the sphere-test kernel's last-depth expansion spreads over lanes (see "Clusters"): a lane per cluster
// (or super cluster) pair, testing its triangles (STEP_EXPAND_WHOLE, STEP_EXPAND_SUPER), or a lane per
// triangle pair. The same mask either way; a cluster's lane tests the cluster's and groups' spheres against
// the children first (each of sixteen lanes would repeat them), so it tests fewer pairs, and a lane of the
// test kernel costs more before any work than its tests do on lavapipe. Auto, where the threshold is known
// (expansionLanesMinPairs: a CPU device), chosen per batch on the device from the (super) cluster pairs
// where the two forms part: a lane per pair where they fill the lanes the device runs at once, a lane per
// triangle pair where they are fewer (traverse_advance.comp, wholeLanes; docs/ARCHITECTURE.md, "The last
// expansion's lanes chosen per batch"). On a GPU, where the threshold has not been measured, a lane per
// triangle pair.
enum class ExpansionLanes { Auto, PerCluster, PerTriangle };
// Auto's threshold on this device, in (super) cluster pairs: the workgroups it runs at once (lavapipe: a
// worker thread a core) times TRAVERSE_THREADS lanes; none on a GPU (unmeasured: a lane per triangle pair).
std::optional<uint32_t> expansionLanesMinPairs(const vk::Context& ctx);
const char* expansionLanesName(ExpansionLanes lanes);

// How many rays a leaf pair covers: Four, paper 002's leaves -- the pairs of the deepest interior depth,
// D - 1, each tested against its node's four rays -- or Sixteen or SixtyFour: the traversal stops one or
// two depths earlier and the pairs of depth D - 2 (D - 3) go to the leaves, each against the 16 (64) rays
// under its node (a tree gives the levels it has: depth 2 sixteen, depth 1 four). The same mask either
// way: a pair a skipped test would have rejected holds no ray the leaf test hits (precise_test.h: the
// test's margins cover the leaf test's rounding), so its extra leaf tests find nothing. What it trades:
// the last depths' tests, the most numerous of the traversal, with their appends, against more leaf tests
// (the measurements: docs/ARCHITECTURE.md, "Leaf pairs of sixteen or 64 rays"). Auto on a CPU device
// (lavapipe), the device path: chosen per batch on the device from the batch's own counts -- at the 64-ray
// step and again at the 16-ray one, the leaves now or one more depth, whichever the step's pairs, the rays
// under them and the survival of the step above say is cheaper (leafChoiceCosts; docs/ARCHITECTURE.md,
// "Leaf pairs chosen per frame"); the chunked fallback takes 64. Four on a GPU, where the costs have not
// been measured yet.
enum class LeafRays { Auto, Four, Sixteen, SixtyFour };
// The leaf choice's costs on this kind of device, in leaf tests (one ray against one triangle): a pair's
// step (its four child tests and appends) and a leaf pair's lane before its rays. The survival below which
// one more depth wins at a step of `rays` rays a pair: (lane + rays - step) / (4 lane + rays).
struct LeafChoiceCosts {
  float step = 0, lane = 0;
  // One more depth when the survival predicted there is below this, for `rays` under a pair's node; with
  // `shared` triangles sharing a step (the choice asked from (super) cluster pairs, deferLeaves in
  // traverse_advance.comp), 1 for triangle pairs.
  double threshold(double rays, double shared = 1.0) const { return (lane + rays - step / shared) / (4.0 * lane + rays); }
};
LeafChoiceCosts leafChoiceCosts(bool cpuDevice);
// The leaves' cull (traverse_leaves.comp): each pair's rays tested against the triangle's sphere first,
// the exact test run on those it keeps. The same mask; it pays where nearly every leaf test misses, which
// a batch's leaf tests per ray say (a ray is hit by few triangles): on the device path each batch takes
// it where its leaf tests per ray, scaled to the record, reach this many (docs/ARCHITECTURE.md, "The
// leaves' cull"). +inf on a GPU (unmeasured: never); the chunked fallback never culls.
float leafCullTestsPerRay(bool cpuDevice);

// What one traversal reads. Buffers stay owned by the caller.
struct TraversalInput {
  const vk::Buffer* triangles = nullptr;  // vec4 x 3 per triangle, world space (w ignored)
  // Far-light frame: for a light 8+ half-diagonals from the scene the tree and the pass tests work in a
  // frame rotated (and sheared) so z points from the light at the scene, where the margins across the
  // cones shrink with its angular size (coneScale); the leaves stay in world coordinates
  // (docs/ARCHITECTURE.md, "The traversal": "Far-light frame"). These are the triangles relative to the
  // light in that frame (frame_triangles.comp), for the pass tests. Null: world.
  const vk::Buffer* frameTriangles = nullptr;
  float coneScale = 1.0f;                 // the frame's angular scale (1 in the world frame)
  uint32_t triangleCount = 0;
  uint32_t firstTriangle = 0;             // the triangles traversed: [firstTriangle, firstTriangle + triangleCount)
  const cone::ConeTree* tree = nullptr;   // built over the rays below
  const vk::Buffer* visibility = nullptr; // uint per pixel: float bits, 1.0f lit; hits write 0
  glm::vec3 light{0};
  float eps = 0;                          // hits count in (eps, L - eps)
  uint32_t test = TRAVERSE_TEST_PRECISE;  // the passes' cone/triangle test (traversal_layout.h)
  bool frontFaceCulling = false;          // pass 0 drops triangles facing the light (cone_method.h)
  // Early accept (002 §3.3, the precise test only): a child every ray of which the triangle covers is
  // shadowed at once and its node's later pairs dropped (docs/ARCHITECTURE.md, "The traversal").
  bool earlyAccept = false;
  // Device path, one-pass frames: the sphere of each CLUSTER_SIZE triangles of `triangles` (see
  // "Clusters"), relative to the light as the pass tests' vertices. Null: no clusters.
  const vk::Buffer* clusterSpheres = nullptr;
  // With clusters and the precise test: cluster pairs expanded one depth above the leaves are tested with
  // the sphere test alone (see "Clusters"); off: the precise test, as every other triangle step. The same
  // mask either way.
  bool sphereLastExpansion = true;
  ExpansionLanes lastExpansionLanes = ExpansionLanes::Auto;  // that expansion's lanes (see ExpansionLanes)
  // Auto's choice from this many pairs instead of the device's threshold (tests: either outcome on any
  // device); unset: expansionLanesMinPairs(device), and no choice on a GPU.
  std::optional<uint32_t> expansionLanesMinPairs;
  LeafRays leafRays = LeafRays::Auto;     // rays a leaf pair covers (see LeafRays)
  // Auto's choice with these costs instead of the device's (tests: every outcome of the choice on any
  // device); unset: leafChoiceCosts(device), and no choice on a GPU.
  std::optional<LeafChoiceCosts> leafChoiceCosts;
  // The leaves' cull from this many leaf tests a ray instead of the device's (tests: 0 always, +inf never);
  // unset: leafCullTestsPerRay(device).
  std::optional<float> leafCullTestsPerRay;
  LeafTest leafTest = LeafTest::TwoEnds;  // the leaves' test (see LeafTest; leafTestFor says when FromLight is exact)
  // With clusters: batches start as super clusters, which split into their clusters further down
  // ("Clusters"). The same mask.
  bool superClusters = true;
};

class Traversal {
 public:
  // Allocates the arena and the chunk scratch for `memoryBytes` (see planArena) once.
  Traversal(vk::Context& ctx, uint64_t memoryBytes);
  // With an explicit plan (tests: down to minimumPairs(depth) pairs and chunks of one pair).
  Traversal(vk::Context& ctx, const ArenaPlan& plan);
  ~Traversal();
  Traversal(const Traversal&) = delete;
  Traversal& operator=(const Traversal&) = delete;

  // Runs every pass and the leaves (several submits; waits for the last). `timer`, when given, is
  // restarted per submit and its "traversal" / "leaves" timestamp intervals summed into the stats.
  TraversalStats run(const TraversalInput& in, vk::Timer* timer = nullptr);

  // One submission, the device path: the whole traversal in the caller's command buffer, every step sized
  // on the GPU by traverse_advance.comp (indirect dispatch), no count from the host; a step whose pairs
  // overflow its buffer sets the overflow word and the caller redoes the frame with run(), with the same
  // mask (docs/ARCHITECTURE.md, "The traversal"). recordBegin() once per frame clears the counters (and the
  // early-accept flags, sized for the deepest tree the recording allows); record() once per triangle
  // buffer; recordEnd() once after them puts the leaves' hits into the visibility (leaf_hits.comp; run()
  // does so itself). `boundary`, when given, is called after each batch's passes with "traversal" and
  // after its leaves with "leaves" (a caller may end a submission there to time them).
  void recordBegin(vk::Commands& cmd, const TraversalInput& in);
  void recordEnd(vk::Commands& cmd, const TraversalInput& in);
  // Appends the first triangle of each batch to `batchStarts`, in order (STATE_BATCHES_DONE of them
  // completed): the caller's vector, so a recording with room in it allocates nothing.
  void record(vk::Commands& cmd, const TraversalInput& in, std::vector<uint32_t>& batchStarts,
              FunctionRef<void(const char*)> boundary = nullptr);
  // After a device frame, from its state words and the frame's whole traversal stats (`triangles`
  // traversed): a frame that overflowed sizes the next frame's batches so that its busiest depth's pairs
  // per triangle fill half the capacity (at most half the batch it used; a step's pairs grow with its
  // batch's triangles), one that used less than 1/8 of the capacity at its peak doubles them, up to
  // chunkCapacity. So a scene whose full batch overflows pays the chunked fallback on its first frame.
  void learnBatch(const uint32_t* words, const TraversalStats& frame, uint64_t triangles);
  // The same from the state words alone (the engine's frames, whose stats are the words): `mostSurvived`,
  // the most pairs any depth held (mostSurvived() of the words).
  void learnBatch(const uint32_t* words, uint64_t mostSurvived, uint64_t triangles);
  // The most survivors of any depth in statsFromState(words, depth, committed).passes, read without
  // building the stats (nothing allocated).
  uint64_t mostSurvived(const uint32_t* words, uint32_t depth, bool committed = false) const;
  uint32_t batchTriangles() const { return batchTriangles_; }
  // Whether the device path may start its batches as clusters (an arena too small for one cluster's
  // expansion turns them off for good).
  bool clustersFit() const { return clustersFit_; }
  // The last frame's rays a leaf pair (Four, Sixteen or SixtyFour: Auto resolved for the device; a tree
  // shallower than the levels asked gives what it has, a tree of depth 1 four); with leafChoice(), the
  // most the choice could take (the stats say what it took).
  LeafRays leafRays() const { return leafRays_; }
  bool leafChoice() const { return leafChoice_; }
  const vk::Buffer& stateBuffer() const { return state_; }
  // The counters of the device path from the state words read back (STATE_WORDS of them), for a tree
  // of `depth` (the shape's SHAPE_DEPTH).
  // With `committed`, as of the last batch that completed (what an overflowed frame's fallback adds to).
  TraversalStats statsFromState(const uint32_t* words, uint32_t depth, bool committed = false) const;
  static uint32_t batchesDone(const uint32_t* words) { return words[STATE_BATCHES_DONE]; }
  static bool overflowed(const uint32_t* words) { return words[STATE_OVERFLOW] != 0; }

  const ArenaPlan& plan() const { return plan_; }
  uint64_t bytesAllocated() const;
  // The early-accept flags (allocated on the first frame that uses them; not in bytesAllocated()).
  uint64_t flagBytes() const { return flags_.size; }
  // The leaves' hits (traverse_leaves.comp, leaf_hits.comp): a bit a sorted ray, shadowedBytes(rays).
  uint64_t shadowedBytes() const { return shadowed_.size; }
  static uint64_t shadowedBytes(uint64_t rays) { return ((rays / 32 + 2) * 4 + 15) / 16 * 16; }  // whole vec4s

 private:
  struct Frame;
  void processDepth(Frame& f, uint32_t d);
  bool expandChunk(Frame& f, uint32_t child, bool fromTriangles, uint64_t first, uint32_t count, uint64_t outFirst,
                   uint64_t limit);
  uint64_t chunkSize(uint64_t available, uint64_t end, uint64_t limit, double ratio) const;
  void leaves(Frame& f, uint32_t d);
  void submit(Frame& f, vk::Commands& cmd, double& wallMs);

  vk::Context& ctx_;
  ArenaPlan plan_;
  void ensureFlags(uint64_t nodes);
  void ensureShadowed(uint64_t rays);
  void recordLeafHits(vk::Commands& cmd, const cone::ConeTree& tree, const vk::Buffer& visibility, const LeafHitsPush& p);

  const vk::Kernel& testKernel(const TraversePush& p, bool clusters, bool whole = false);
  std::unique_ptr<vk::Kernel> tests_[22];  // the test kernels per switches, the cluster kernel, the whole-cluster ones;
                                           // each with the scale a constant 1 and from the push constants
  vk::Kernel leaves_, leavesFromLight_, leavesCull_, leavesFromLightCull_, leavesFromSample_, leavesFromSampleCull_;
  vk::Kernel advance_, leafHits_;
  // The leaves' kernel for the test, with the cull (SPEC_CULL) or without.
  const vk::Kernel& leafKernel(LeafTest test, bool cull) const {
    if (test == LeafTest::FromLight) return cull ? leavesFromLightCull_ : leavesFromLight_;
    if (test == LeafTest::FromSample) return cull ? leavesFromSampleCull_ : leavesFromSample_;
    return cull ? leavesCull_ : leaves_;
  }
  float leafCullTestsPerRay_ = 0;  // the last record()'s AdvancePush::leafCullTestsPerRay
  vk::Buffer arena_, chunk_, stats_, flags_, state_;
  vk::Buffer shadowed_;  // the leaves' hits: a bit per sorted ray (traverse_leaves.comp, leaf_hits.comp)
  uint32_t batchTriangles_ = 1;  // triangles per batch of the device path (learnBatch)
  bool clustersFit_ = true;      // false once a one-cluster batch overflowed: triangles only from then on
  bool usedClusters_ = false;    // the last record() started its batches as clusters
  bool supersFit_ = true;        // false once a one-super-cluster batch overflowed: clusters only from then on
  bool usedSupers_ = false;      // the last record() started its batches as super clusters
  uint32_t expansionLanes_ = EXPANSION_PER_TRIANGLE;  // the last record()'s AdvancePush::wholeExpansion
  bool expansionAuto_ = false;                         // ... asked for Auto
  uint32_t expansionMinPairs_ = 0;                     // ... with EXPANSION_CHOSEN, the threshold
  LeafRays leafRays_ = LeafRays::Four;  // the fixed span, or with leafChoice_ the earliest the choice may take
  bool leafChoice_ = false;              // the last record() chose the span per batch (AdvancePush::leafChoice)
  bool leafAuto_ = false;                // the last record() was asked for Auto
  LeafChoiceCosts leafCosts_;            // with the costs (statsFromState says why)
  LeafTest leafTest_ = LeafTest::TwoEnds;  // the last frame's (statsFromState)
  LeafRays resolveLeafRays(LeafRays wanted) const;
  // The depths statsFromState reports passes for (at most STATE_MAX_STEPS of them), from the live words:
  // those above the pairs the leaves take in a tree of `depth`; with the leaf choice, down to the deepest
  // step that ran.
  uint32_t passesInState(const uint32_t* live, uint32_t depth) const;
};

}  // namespace cs::traversal
