// traversal/: every triangle pushed through the cone tree, breadth-first with bounded memory (002 §3.1,
// §3.2, §4.2), down to an exact ray/triangle test per leaf that shadows the sample.
//
// ---- How it works ---------------------------------------------------------------------------------
// Pairs. A pair is (triangle, node index within its depth). Pass 0 tests every triangle against the root
// (depth 0); pass k takes the pairs of depth k-1 and tests each against its node's (up to) four children
// at depth k with the precise cone/triangle test (precise_test.h) ANDed with the bounding-sphere test
// (both conservative: the sphere's tighter margins reject small triangles the edge planes keep), or per
// frame the sphere test alone (sphere_test.h; TraversalInput::test); with front-face culling, pass 0 drops the triangles that face the
// light (002 §3.6; TraversalInput::frontFaceCulling). The survivors are appended by the test
// kernel itself: each subgroup sums its survivors, reserves that many output slots with one atomicAdd on
// the step's survivor count, and each invocation writes its pairs at its prefix within the reservation
// (no per-input masks, no scan, no second pass over the inputs; the order of the pairs across subgroups
// is the order the reservations were taken, and nothing depends on it). The pairs of
// depth D-1 (parents of leaves) go to traverse_leaves.comp -- or those of D-2 or D-3, with 16 or 64 rays a
// leaf pair (LeafRays below) -- one invocation per pair, reading the triangle once for the (up to) four,
// 16 or 64 rays under the node; it rebuilds each ray from the light and the sample's
// position (conetree/cone_math.h) and runs the watertight ray/triangle test with hits counted at distances in (eps, L - eps) from the light
// (the reference's interval, measured from the other end). A hit sets the ray's bit in the shadowed words
// (atomicOr); once the traversal's leaves have all run, leaf_hits.comp stores 0 into the visibility word
// of each marked ray's pixel. Both are idempotent, so the mask does not depend on order, races or how the
// work was split.
//
// Bounded memory (002 §4.2). All pairs live in one fixed arena of `pairCapacity` pairs, used as a stack of
// depths: depth d+1's pairs sit right after what is left of depth d's. Depth d is processed from its tail:
// a chunk of its last m pairs is copied to the chunk buffer, tested, and its survivors written into depth
// d+1 starting at the chunk's own first slot (the slots it frees); depth d+1 is then finished,
// recursively, before the next chunk of depth d. Depth d+1 may reach the arena's end minus a reserve of 4
// slots for each deeper depth (reserveBelow), so one pair (at most 4 survivors) always fits and the
// traversal needs no more than 4 (D - 1) + 1 pairs (one node's children per depth) to make progress. The
// chunk is sized from the survivors per input seen so far at that depth; a chunk whose survivors would
// pass the limit is retried smaller (the kernel counts every survivor but writes only those below the
// limit, into slots the retry overwrites). So
// the traversal is breadth-first, a whole depth per pass, while the arena holds two consecutive depths,
// and degrades smoothly to depth-first over chunks when it does not; the mask is bit-identical at every
// arena size (tests/traversal_test.cpp): visibility only ever goes from 1 to 0, and every (triangle,
// leaf) pair that survives is tested exactly once whatever the chunking.
// Scratch per chunk: the copied inputs, sized for `chunkCapacity` inputs. The host reads back one word per chunk (the survivor count) to place the next
// chunk; each chunk is one submit, and so is each batch of leaf tests.
//
// Far-light frame (conetree/cone_layout.h ConeFrame, conetree.h chooseFrame). The tests' rounding margins
// are relative to the magnitudes they compare: 2^-16 (256 ulp) of |P - light| for a distance across a
// cone, an angle of 2^-16 rad added to each parent. In world coordinates a direction's components are all
// of its length, so those are what the rounding really is -- but a light 10^3 scene diagonals away sends
// cones narrower than 2^-16 rad, every margin passes and every triangle reaches every leaf. When the light
// is at least 8 half-diagonals from the centre C of the triangles' bounds (the bounds within Θ <= 7.2
// degrees of the direction to C), the cone path works in a rotated frame instead: z from the light to C,
// x_f = S R (x - C), the light at S R (light - C) computed in double, S the shear that takes the light's
// lateral offset under the fp32 rows (up to D 2^-24) off it (cone_layout.h, ConeFrame). There every vertex and every ray is
// within Θ of z, their components across z are <= |v| tan Θ, and the rounding of the tests' cross and dot
// products is that much smaller: the margins of the quantities measured across the cones -- the edge
// planes' orientation and normal error, the bounding sphere's radius and its distance across the cone,
// the parents' padding -- are multiplied by the frame's angular scale min(1, 4 tan Θ) (precise_test.h
// edgePlane, sphere_test.h, cone_math.h coneEnclose), those along the rays (Lmax, eps, the plane slab)
// keep theirs. Parent axes come from merging the children as discs on z = 1 (coneParentFar), near the rays
// below, never steered off by a GPU's approximate sin/cos. The ray keys cover the bounds' projection
// (rays/hilbert.h frameRayKey) instead of six cube faces. The frame's geometry is the world's through an
// fp32 rotation: the leaves stay in world coordinates (leafHit, as the reference), and the difference --
// the transform's rounding, a few ulp of |x - C| and of the light's lateral coordinates the shear leaves,
// and the leaf test's, a few ulp of a triangle's distance to the sample -- is covered by widening every
// leaf cone by sigma = 2^-16 of the bounds' diagonal plus those lateral coordinates across
// (as the angle beta = sigma / (nearest distance to the bounds)) and along (Lmin - sigma, Lmax + sigma).
// Bit-identical masks across variants and arena sizes hold in both frames (tests/cone_exactness_test.cpp,
// far lights from 10 to 10^16 diagonals); the margins' conservativeness in the far frame is checked by
// tests/traversal_test.cpp (FarFrame*) and, under the arithmetic a GPU is allowed, tests/gpu_arithmetic.
// The pass tests read the triangles relative to the light in the frame from a copy frame_triangles.comp
// writes once per frame (48 bytes a triangle, counted in the method's bytes).
//
// Memory budget. `memoryBytes` (ConeOptions::traversalMemoryBytes, --traversal-memory) bounds the arena
// plus the chunk scratch: planArena() splits it (arena 2/3, chunk capacity = arena / 4), caps each array
// at one storage binding (maxStorageBufferRange) and one texel buffer (the kernels read pairs as RGBA32UI
// texels, two a texel; pair buffers are whole texels) and reports what it allocates. peakBytes in the stats is
// the high-water mark of the arena slots in use plus the scratch of the largest chunk: always <= the bound.
//
// Early accept (002 §3.3; TraversalInput::earlyAccept, precise test only). The test kernel also checks
// each surviving child with preciseConeCovered (precise_test.h: every ray under the node hits the
// triangle within (eps, L - eps), conservatively): a covered child shadows its leaf range at once (an
// atomicAnd of each ray's visibility word with 0, not the leaves' bits; degenerate rays skipped as
// there) and writes no pair;
// the node is flagged (one word per interior node, cleared per frame) and every later pair at a flagged
// node is dropped when it is next tested. The mask is unchanged (tests/early_accept_test.cpp): an accepted
// node's samples are exactly what its leaves would shadow, and a dropped pair's samples are all 0 already.
// A chunk retried after an overflow accepts again: idempotent. The flags are outside the memory bound
// (flagBytes(): 4 bytes per interior node, like the tree's own nodes).
//
// One submission (the device path; record()). For a tree built on the GPU from the GPU's ray count
// (ConeTree::recordDevice), the whole traversal goes into the caller's command buffer with no count from
// the host. The triangles are taken in batches of chunkCapacity (a host count); each batch goes down the
// tree breadth-first, one step per depth: step c tests the pairs of depth c - 1 (step 0: the batch's
// triangles) against their children at depth c and appends the survivors, the
// steps ping-ponging between the arena and the chunk buffer; at c = D, the tree's depth on the GPU, the
// pairs go to the leaves instead. Between steps a one-invocation kernel (traverse_advance.comp) adds the
// step's counts to per-depth totals and writes the next step's count, shape fields and indirect dispatch
// arguments; steps past the tree's depth are dispatches of zero workgroups. Every step may write at most
// chunkCapacity pairs (either buffer holds that many): a step whose survivors do not fit is discarded
// (whatever of it was written is never read) and sets the overflow word, after which nothing more runs,
// and the caller redoes the traversal with run() (chunked, several submits) -- the mask is the same either way: the hits already
// written are hits, and the chunked run decides every pair from the first batch that did not complete).
// The batch size adapts from frame to frame (learnBatch). The counters stay on the GPU (stateBuffer())
// and come back once with the mask (statsFromState).
//
// Clusters (device path, TraversalInput::clusterSpheres). The triangle buffer is laid out so that every
// CLUSTER_SIZE consecutive triangles are close in space (cone_method.cpp: Hilbert order of their
// centroids on a grid of cubes, once per upload), each group bounded by a sphere the host computes per frame in double,
// relative to the light in the pass tests' coordinates and padded by 2^-16 of the magnitudes (so it holds
// the fp32 vertices the GPU sees). With a tree at least 3 deep, a batch starts as (cluster, node) pairs
// tested with the sphere test (sphere_test.h: false only when no ray of the cone meets the sphere, so
// never for a cluster holding a triangle that any ray of the cone hits, tests/traversal_test.cpp
// ClusterSphere*); the advance kernel expands the surviving cluster pairs into their triangles' pairs
// at the first depth with more than 1/EXPAND_NODES_PER_CLUSTER as many nodes as pass 0 kept clusters
// (scaled from the batch to the record's triangles), where a node covers fewer rays than 16 clusters'
// share of them and clusters stop being culled as a whole (docs/ARCHITECTURE.md, "Clusters"), and at the
// latest one depth above the leaves; the triangle pairs then continue as without clusters. The mask is
// the same (tested): a triangle's pair is dropped only where its cluster's conservative test, or its
// own, rejects it. An expansion's inputs count against the step's capacity like any pairs (learnBatch).
// An expansion one depth above the leaves (the clusters stayed small against every depth's nodes: the
// scene's triangles outnumber the leaf-level nodes by 64 or more, so they are a fraction of a leaf
// cone's width) runs the sphere-test kernel, not the precise one (sphereLastExpansion): a pair that only
// the precise test would reject costs one leaf invocation, while the precise test's code costs every
// input of the step on lavapipe, and those steps hold millions (the 1 M height field at 512²: 6 M inputs,
// leaf pairs 1.45 M -> 1.56 M, the frame 461 -> 370 ms). Higher expansions, and every step of triangle
// pairs, keep the precise test: there a pair it rejects spares a subtree, and bigger triangles fit their
// spheres worse (measured on the built-in views, 2CylinderEngine and the museum with the sphere test on
// every last step: leaf pairs +18-60 %, the frames slower). That expansion takes a lane per cluster pair,
// not per triangle pair (STEP_EXPAND_WHOLE): the lane tests the cluster's sphere, then its four groups'
// (ClusterWorld), then its sixteen triangles against the node's children, read once, each against the
// children the one before kept, on a CPU device: on lavapipe a lane of the test kernel costs ~20 ns before any
// work, and the step held most of the frame's lanes (docs/ARCHITECTURE.md, "Clusters"). A GPU keeps a lane
// per triangle pair (ExpansionLanes).
//
// Super clusters (TraversalInput::superClusters): every SUPER_CLUSTERS consecutive clusters have one
// more sphere, holding theirs. A batch then starts as (super cluster, root) pairs, which split into their
// clusters' pairs (STEP_SPLIT) one depth above the one where the clusters expand by the rule above, and
// at the latest two depths above the leaves; with a lane per cluster pair for the last expansion they
// reach one depth above the leaves unsplit and expand there a super cluster a lane (STEP_EXPAND_SUPER).
// The same mask (tested); the 1 M height field at 512² tests 5.75 M pairs where clusters alone test
// 8.08 M, the 10 M one 31.1 M where they test 57.8 M (docs/ARCHITECTURE.md, "Clusters").
//
// Stats per frame: for each pass (depth), the (triangle, node) pairs tested, the survivors and the chunks;
// the leaf tests; the submits; the time of the passes ("traversal") and of the leaf tests
// ("leaves"), as the wall time of their submits (host waits included) and from timestamps.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "conetree/conetree.h"
#include "traversal/traversal_layout.h"
#include "vk/context.h"

namespace cs::traversal {

// ---- sizing (pure, unit-tested) ---------------------------------------------------------------------
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
// Padding by 2^-16 of D instead made every cluster as wide as the scene from ~10^3 diagonals on.
glm::vec4 clusterSphereFar(glm::dvec3 rel, double radius, double lateralOperands);
// The position of cell (x, y, z) of a 2^bits-a-side grid (bits 1 to 21) along a 3D Hilbert curve:
// consecutive positions are cells that share a face, so the triangles of any run of them are one
// connected piece of space (the cluster order; a Morton order jumps, and a cluster across a jump is two
// pieces under one sphere).
uint64_t hilbertIndex3(uint32_t x, uint32_t y, uint32_t z, int bits);

// Which leaf test the leaves run (precise_test.h): TwoEnds, leafHit -- each ray measured from the end of
// it the triangle is nearer, right at any light distance -- or FromLight, leafHitFromLight: the
// triangle's share of the test (its edge normals through the light, its plane) computed once for the
// pair's rays, which share the light as their origin, and three dot products a ray. FromLight is for a
// light among the geometry: its edge functions round to an ulp of the triangle's distance from the light,
// which a light 10^3 diagonals away makes wider than the band. leafTestFor() says when it may run.
// Both are exact outside the ambiguity band and watertight, but they round differently at the edges and
// the ends of the interval, so the masks may differ within the band; every variant and every arena size
// of one frame runs the same test and gives the same mask.
enum class LeafTest { TwoEnds, FromLight };
const char* leafTestName(LeafTest test);
// FromLight where it is exact: the world frame (a light within kFarFrameRatio half-diagonals of the
// centre of the triangles' bounds [lo, hi], so rays are at most ~4.5 diagonals long) and coordinates
// whose cubes neither overflow nor go subnormal in the test's products (half-diagonal >= 2^-12, every
// coordinate of the bounds and the light <= 2^40). TwoEnds otherwise.
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
  uint64_t leafPairs = 0;         // pairs sent to the leaves (of depth D-1, or D-2 with sixteen rays a pair)
  uint64_t leafTests = 0;         // (pair, ray) combinations at the leaves: 4 (16) per pair but under a last node
  uint32_t leafRays = 4;          // rays a leaf pair covers (LeafRays; 4 in a tree of depth 1 whatever was asked)
  LeafTest leafTest = LeafTest::TwoEnds;  // the leaves' test
  uint64_t submits = 0;
  uint64_t earlyAccepted = 0;     // early accept: distinct nodes found covered (and shadowed at once)
  uint64_t droppedPairs = 0;      // early accept: pairs dropped because their node had been accepted
  uint64_t peakPairs = 0;         // arena high-water mark, in pairs
  uint32_t peakChunk = 0;         // largest chunk, in input pairs
  uint64_t peakBytes = 0;         // peakPairs * 8 + the scratch of the largest chunk (<= what is allocated)
  double traversalMs = 0;         // wall time of the passes' submits (test and append), waits included
  double leavesMs = 0;            // wall time of the leaf tests' submits
  double traversalGpuMs = 0;      // the same from timestamps (see cone_method.h on lavapipe's timestamps)
  double leavesGpuMs = 0;
  uint64_t pairsTested() const;
  uint64_t pairsSurvived() const;
  nlohmann::json toJson() const;
};

// How the sphere-test kernel's last-depth expansion spreads over lanes (see "Clusters"): a lane per cluster
// pair, testing its sixteen triangles (STEP_EXPAND_WHOLE), or a lane per triangle pair. Auto: per cluster
// pair on a CPU device, where a lane costs ~20 ns before any work; per triangle pair on a GPU, where lanes
// are cheap and sixteen run side by side. The same mask either way; a cluster's lane tests the cluster's
// and groups' spheres against the children first (each of sixteen lanes would repeat them), so it tests
// fewer pairs.
enum class ExpansionLanes { Auto, PerCluster, PerTriangle };
const char* expansionLanesName(ExpansionLanes lanes);

// How many rays a leaf pair covers: Four, paper 002's leaves -- the pairs of the deepest interior depth,
// D - 1, each tested against its node's four rays -- or Sixteen or SixtyFour: the traversal stops one or
// two depths earlier and the pairs of depth D - 2 (D - 3) go to the leaves, each against the 16 (64) rays
// under its node (a tree gives the levels it has: depth 2 sixteen, depth 1 four). The same mask either
// way: a pair a skipped test would have rejected holds no ray the leaf test hits (precise_test.h: the
// test's margins cover the leaf test's rounding), so its extra leaf tests find nothing. What it trades:
// the last depths' tests, the most numerous of the traversal, with their appends, against more leaf tests
// (measured on lavapipe at 1024², docs/ARCHITECTURE.md: sixteen halved the traversal on the room, the fur
// and 2CylinderEngine with the leaves about level; with the leaf test from the light, LeafTest, 64 takes
// a further third off the traversal for fewer added to the leaves).
// Auto: SixtyFour on a CPU device (lavapipe), whose lanes pay for every step's bookkeeping; Four on a GPU,
// where neither has been measured against it yet.
enum class LeafRays { Auto, Four, Sixteen, SixtyFour };

// What one traversal reads. Buffers stay owned by the caller.
struct TraversalInput {
  const vk::Buffer* triangles = nullptr;  // vec4 x 3 per triangle, world space (w ignored)
  // The far-light frame (see "Far-light frame" above): the same triangles relative to the light in the
  // frame (frame_triangles.comp), for the pass tests; the tree is built in the frame too. Null: world.
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
  bool earlyAccept = false;               // 002 §3.3, with the precise test only (see above)
  // Device path, one-pass frames: the sphere of each CLUSTER_SIZE triangles of `triangles` (see
  // "Clusters"), relative to the light as the pass tests' vertices. Null: no clusters.
  const vk::Buffer* clusterSpheres = nullptr;
  // With clusters and the precise test: cluster pairs expanded one depth above the leaves are tested with
  // the sphere test alone (see "Clusters"); off: the precise test, as every other triangle step. The same
  // mask either way.
  bool sphereLastExpansion = true;
  ExpansionLanes lastExpansionLanes = ExpansionLanes::Auto;  // that expansion's lanes (see ExpansionLanes)
  LeafRays leafRays = LeafRays::Auto;     // rays a leaf pair covers (see LeafRays)
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

  // The device path (see "One submission"). recordBegin() once per frame clears the counters (and the
  // early-accept flags, sized for the deepest tree the recording allows); record() once per triangle
  // buffer; recordEnd() once after them puts the leaves' hits into the visibility (leaf_hits.comp; run()
  // does so itself). `boundary`, when given, is called after each batch's passes with "traversal" and
  // after its leaves with "leaves" (a caller may end a submission there to time them).
  void recordBegin(vk::Commands& cmd, const TraversalInput& in);
  void recordEnd(vk::Commands& cmd, const TraversalInput& in);
  // Returns the first triangle of each batch, in order (STATE_BATCHES_DONE of them completed).
  std::vector<uint32_t> record(vk::Commands& cmd, const TraversalInput& in,
                               const std::function<void(const char*)>& boundary = {});
  // After a device frame, from its state words and the frame's whole traversal stats (`triangles`
  // traversed): a frame that overflowed sizes the next frame's batches so that its busiest depth's pairs
  // per triangle fill half the capacity (at most half the batch it used; a step's pairs grow with its
  // batch's triangles), one that used less than 1/8 of the capacity at its peak doubles them, up to
  // chunkCapacity. So a scene whose full batch overflows pays the chunked fallback on its first frame.
  void learnBatch(const uint32_t* words, const TraversalStats& frame, uint64_t triangles);
  uint32_t batchTriangles() const { return batchTriangles_; }
  // Whether the device path may start its batches as clusters (an arena too small for one cluster's
  // expansion turns them off for good).
  bool clustersFit() const { return clustersFit_; }
  // What the last record() gave the sphere-test kernel's last-depth expansion: PerCluster or PerTriangle
  // (ExpansionLanes::Auto resolved for this device).
  ExpansionLanes lastExpansionLanes() const { return lastExpansionLanes_; }
  // The last frame's rays a leaf pair (Four, Sixteen or SixtyFour: Auto resolved for the device; a tree
  // shallower than the levels asked gives what it has, a tree of depth 1 four).
  LeafRays leafRays() const { return leafRays_; }
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
  vk::Kernel leaves_, leavesFromLight_, advance_, leafHits_;
  const vk::Kernel& leafKernel(LeafTest test) const { return test == LeafTest::FromLight ? leavesFromLight_ : leaves_; }
  vk::Buffer arena_, chunk_, stats_, flags_, state_;
  vk::Buffer shadowed_;  // the leaves' hits: a bit per sorted ray (traverse_leaves.comp, leaf_hits.comp)
  uint32_t batchTriangles_ = 1;  // triangles per batch of the device path (learnBatch)
  bool clustersFit_ = true;      // false once a one-cluster batch overflowed: triangles only from then on
  bool usedClusters_ = false;    // the last record() started its batches as clusters
  bool supersFit_ = true;        // false once a one-super-cluster batch overflowed: clusters only from then on
  bool usedSupers_ = false;      // the last record() started its batches as super clusters
  ExpansionLanes lastExpansionLanes_ = ExpansionLanes::PerTriangle;
  LeafRays leafRays_ = LeafRays::Four;
  LeafTest leafTest_ = LeafTest::TwoEnds;  // the last frame's (statsFromState)
  LeafRays resolveLeafRays(LeafRays wanted) const;
};

}  // namespace cs::traversal
