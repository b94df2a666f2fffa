// traversal/: push constants, workgroup shapes and counter slots of the traversal kernels, shared by
// GLSL and C++ (one layout, two languages).
#ifndef CONESHADOW_TRAVERSAL_LAYOUT_H
#define CONESHADOW_TRAVERSAL_LAYOUT_H

#include "core/shared.h"

#define TRAVERSE_THREADS 64

// Counters the kernels add to (uint each, per submit; the host reads and clears them).
#define STAT_MISSING 0     // tests short of 4 per input (1 per triangle): children or rays past a level's end
#define STAT_TOTAL 1       // survivors of the step or chunk: the test kernel's appends (traverse_test.comp)
#define STAT_ACCEPTED 2    // early accept (002 §3.3): nodes the test kernel found covered and shadowed at once
#define STAT_DROPPED 3     // early accept: input pairs dropped because their node was accepted (their tests in STAT_MISSING)
#define STAT_WORDS 4

// The device-driven frame (Traversal::record, traversal.h "One submission"): one state buffer holds the
// four step counters above, then what the advance kernel (traverse_advance.comp) keeps between steps.
#define STATE_COUNT 4          // input elements of the current step (0: the step does nothing)
#define STATE_CHILD_OFFSET 5   // the current step's TraversePush fields, from the tree's shape
#define STATE_CHILD_COUNT 6
#define STATE_INPUT_OFFSET 7
#define STATE_LEAF_SHIFT 8
#define STATE_LEAF_COUNT 9
#define STATE_OVERFLOW 10      // 1 once a step's survivors did not fit: nothing runs after it (the host redoes the frame chunked)
#define STATE_PEAK_PAIRS 11    // most pairs resident at once (a step's inputs + survivors)
#define STATE_PEAK_CHUNK 12    // most inputs of one step
#define STATE_LEAF_MISSING 13  // leaf tests short of 4 per pair (rays past the last leaf)
#define STATE_BATCHES_DONE 14  // batches whose every step and leaf fit (the host resumes after them on overflow)
#define STATE_MODE 15          // what the current step's inputs are: STEP_*
#define STATE_ACC 16           // + 8 d: depth d's inputs, tests, survivors (uint64 as lo, hi), steps that ran and
                               //   the cluster tests among the tests (uint32)
#define STATE_ACC_WORDS 8
#define STATE_LEAF_PAIRS 144   // uint64 (lo, hi): pairs sent to the leaves
#define STATE_ACCEPTED 146     // uint64: early accept, nodes found covered
#define STATE_DROPPED 148      // uint64: early accept, pairs dropped at an accepted node
#define STATE_LEAF_TESTS 150   // uint64: (pair, ray) combinations the leaves were sent, past the last ray included
#define STATE_TEST_ARGS 152    // uvec4: the current step's triangle-test dispatch (x, y, 1, inputs); 0 groups for cluster pairs
#define STATE_LEAF_ARGS 156    // + 4 k: the batch's leaves (x, y, 1, leaf pairs), k = the parity of the step that took them
                               //   (its pairs' buffer) + 2 with the cull (LEAF_CULL_*); 0 groups but the one that ran
#define STATE_MAX_STEPS 16     // steps 0 .. 15 (tree depth <= 15)
#define STATE_CLUSTER_ARGS 224 // uvec4: the current step's cluster-test dispatch (x, y, 1, inputs); 0 groups but for cluster pairs
#define STATE_EXPANDED 228     // uint64: (cluster, node) pairs expanded into their triangles
#define STATE_BATCH_TRIANGLES 230  // the current batch's triangles
#define STATE_COMMITTED 232    // the totals (STATE_LEAF_MISSING, then STATE_ACC .. STATE_TEST_ARGS) as of the last completed batch
#define STATE_COMMITTED_WORDS (1 + STATE_TEST_ARGS - STATE_ACC)
#define STATE_ROOT_CLUSTERS 369  // the clusters pass 0 kept, scaled from the batch to the whole record (the expansion rule)
#define STATE_ROOT_SUPERS 370    // the super clusters pass 0 kept, scaled likewise (the split rule)
#define STATE_SPHERE_ARGS 372  // uvec4: the current step's dispatch of the sphere-test triangle kernel a lane per
                               //   triangle pair (AdvancePush::sphereExpansion)
#define STATE_HITS_ARGS 376    // uvec4: leaf_hits.comp's dispatch (x, y, 1, sorted rays), from the tree's shape (step 0)
#define STATE_LEAF_BY_LEVEL 380  // + l - 1: leaf pairs of l levels (4, 16, 64 rays: l = 1, 2, 3), over the frame
#define STATE_LEAF_SEEN 383    // + l - 2: the survival the last batch's leaf choice of l levels (2, 3) predicted, x 2^16
                               //   (at least 1); 0: no choice was made there
#define STATE_SURVIVAL 385     // the survival of the step before the current one, x 2^16 (the leaf choice's trend)
#define STATE_LANES 386        // + 0 (1): the batches whose last expansion took a lane per cluster (triangle) pair,
                               //   over the frame (AdvancePush::wholeExpansion; traversal.h, ExpansionLanes)
#define STATE_WHOLE_ARGS 388   // uvec4: the current step's dispatch of the sphere-test kernel a lane per (super)
                               //   cluster pair (STEP_EXPAND_WHOLE, STEP_EXPAND_SUPER); 0 groups but for those
#define STATE_LANES_PAIRS 392  // + 0 (1): the (super) cluster pairs those batches' choices counted, summed
#define STATE_LEAF_CULL 394    // + 0 (1): leaf pairs whose leaves ran with (without) the cull, over the frame
#define STATE_LEAF_DEFER 396   // the current batch: depths its leaves' step moved down while clusters went on (the leaf
                               //   choice made from the cluster pairs, traverse_advance.comp deferLeaves)
#define STATE_DEFERRED 397     // the choices that so moved a batch's leaf step down, over the frame (a batch may make two)
#define STATE_ADVANCE_ARGS 400 // uvec4: the next step's advance dispatch (1, 1, 1) while the batch has a step to run,
                               //   (0, 1, 1) once it has none: the steps past the batch's last launch nothing
#define STATE_WORDS 404        // a multiple of four: traverse_test.comp reads the words as uvec4s
#if STATE_WORDS % 4 != 0
#error "STATE_WORDS must be a multiple of four"
#endif
// The leaves' dispatches a batch (STATE_LEAF_ARGS): the pairs' buffer (arena or chunk, the parity of the
// step that took them), with or without the cull (AdvancePush::leafCullTestsPerRay).
#define LEAF_SLOTS 4u
#define ADVANCE_END_OF_BATCH 0xFFFFFFFFu

// Triangle clusters (traversal.h, "Clusters"): CLUSTER_SIZE consecutive triangles of a triangle buffer
// (the last may hold fewer), bounded by one sphere relative to the light (triangle_layout.cpp).
#define CLUSTER_SIZE 16u
#define CLUSTER_SHIFT 4u
// Each cluster's four runs of four triangles (its groups) have spheres too, read by the whole-cluster
// expansion only: a cluster's spheres are CLUSTER_SPHERES consecutive vec4s, the cluster's first, then its
// groups' (a group past the buffer's triangles: the cluster's, never read).
#define CLUSTER_GROUPS 4u
#define GROUP_SIZE 4u
#define CLUSTER_SPHERES 5u
// Every SUPER_CLUSTERS consecutive clusters (SUPER_SIZE triangles; the last may hold fewer) form a super
// cluster, which goes down the top of the tree before its clusters do (STEP_SUPER, STEP_SPLIT). The
// sphere buffer holds SUPER_SPHERES vec4s a super cluster: its own sphere, then each of its clusters'
// CLUSTER_SPHERES (a cluster past the buffer's triangles: never read). clusterSphereAt(c): cluster c's.
#define SUPER_CLUSTERS 4u
#define SUPER_SIZE 64u
#define SUPER_SHIFT 6u
#define SUPER_SPHERES 21u
#define clusterSphereAt(c) (SUPER_SPHERES * ((c) >> 2u) + 1u + CLUSTER_SPHERES * ((c) & 3u))
// A step's inputs (STATE_MODE): (triangle, node) pairs; (cluster, node) pairs, tested with the cluster's
// sphere; or the expansion of (cluster, node) pairs, input i being triangle CLUSTER_SIZE * cluster + i % CLUSTER_SIZE
// of pair i / CLUSTER_SIZE (tested as a triangle pair; past the buffer's triangles: nothing).
#define STEP_TRIANGLES 0u
#define STEP_CLUSTERS 1u
#define STEP_EXPAND 2u
// The last depth's expansion in the sphere-test kernel (AdvancePush::sphereExpansion) as a lane per
// cluster pair (AdvancePush::wholeExpansion, traversal.h ExpansionLanes): input i is (cluster, node) pair i
// itself, and one invocation tests the cluster's sphere against the node's children, then its groups'
// spheres against the children the cluster kept, then every triangle against the children its group kept
// (the step's inputs are still counted per triangle pair, its tests as made: the cluster's, the groups'
// and the triangles'). On lavapipe a lane of the test kernel costs more before it does anything than the
// tests it makes (docs/ARCHITECTURE.md, "Clusters", has the measurement), so sixteen triangles a lane,
// with the node's children read once, cost a fraction of sixteen lanes once the pairs fill the device;
// with fewer pairs a lane per triangle pair fills more of it (EXPANSION_CHOSEN).
#define STEP_EXPAND_WHOLE 3u
// (super cluster, node) pairs, tested with the super cluster's sphere in the cluster kernel; pass 0 of a
// batch that starts from super clusters (AdvancePush::clusters = 2).
#define STEP_SUPER 4u
// The split of (super cluster, node) pairs into their clusters: input i is cluster SUPER_CLUSTERS * s +
// i % SUPER_CLUSTERS of pair i / SUPER_CLUSTERS, tested as a cluster pair (past the buffer's triangles:
// nothing); its survivors are (cluster, child) pairs. One depth above the one where the clusters expand
// by the expansion rule, and at the latest two depths above the leaves (traverse_advance.comp).
#define STEP_SPLIT 5u
// The last depth's expansion of (super cluster, node) pairs with a lane per pair (AdvancePush::wholeExpansion):
// a lane per super cluster pair, as STEP_EXPAND_WHOLE's per cluster pair, the super cluster's sphere
// tested first (its inputs counted per triangle pair: SUPER_SIZE a pair). With it super clusters that
// reach one depth above the leaves are not split two depths above: they expand there whole.
#define STEP_EXPAND_SUPER 6u
// AdvancePush::wholeExpansion: the last expansion's lanes, chosen per batch from its pairs -- a lane per
// (super) cluster pair where they are at least AdvancePush::wholeMinPairs, a lane per triangle pair below
// (traverse_advance.comp, wholeLanes; docs/ARCHITECTURE.md, "The last expansion's lanes chosen per batch").
#define EXPANSION_PER_TRIANGLE 0u
#define EXPANSION_PER_CLUSTER 1u
#define EXPANSION_CHOSEN 2u
// The expansion rule's K (traverse_advance.comp): cluster pairs expand at the first depth with more than
// 1/K as many nodes as pass 0 kept clusters. 16 because it tests the fewest pairs over the scenes
// bench/scale_bench measures (docs/ARCHITECTURE.md, "Clusters": K = 4, 8, 16, 32).
#define EXPAND_NODES_PER_CLUSTER 16u

// The cone method's choice of ray order (cone_method.h, ConeOptions::adaptiveOrder; order_choice.comp):
// words of its order buffer.
#define ORDER_SORT_COUNT 0  // rays the Hilbert keys, sort and rebuild cover: the lit count, or 0 (screen order kept)
#define ORDER_SORTED 1      // 1: the frame's rays were sorted; 0: the screen-order tree was kept
#define ORDER_SPREAD 2      // + 2 d: uint64, depth d's spread in the screen-order tree (conetree's tree_spread.comp)
#define ORDER_TOP_DEPTHS 3  // the top of the tree, against which the deeper depths' spread is compared
#define ORDER_LOOSE_RATIO 1.5  // loose when a deeper depth covers more than this times the top's widest
// A loose screen order is sorted only where the triangles make its looseness cost more than the sort:
// triangles x (looseness - 1) > ORDER_SORT_PAYS x sqrt(lit samples) (order_choice.comp; the measurements
// behind 8: docs/ARCHITECTURE.md, "The ray order, chosen per frame on the GPU").
#define ORDER_SORT_PAYS 8.0
#define ORDER_LOOSE 34       // 1: the screen-order tree was loose (sorted or not: the stats say which verdict)
#define ORDER_GATE_ARGS 36   // uvec4: (1, 1, 1) where the frame sorts, (0, 1, 1) where it keeps screen order: the
                             //   indirect arguments the keys', sort's and rebuild's sizing kernels launch through
#define ORDER_WORDS 40
// order_choice.comp's push constant: the triangles the frame traverses.
struct OrderPush {
  uint triangles;
};

// TraversePush::test: the cone/triangle test of the passes (cone_method.h, ConeOptions::test).
#define TRAVERSE_TEST_PRECISE 0u  // precise_test.h (002 §3.2)
#define TRAVERSE_TEST_SPHERE 1u   // sphere_test.h: the triangle's bounding sphere (the ray-space-hierarchy baseline)

#ifdef __cplusplus
#include <cstddef>
namespace cs::traversal {
CS_GLSL_TYPES
#endif

// traverse_test.comp, traverse_leaves.comp. A pair is uvec2(triangle, node index
// within its depth); the arena holds the pairs of every depth on a stack (traversal.h).
struct TraversePush {
  vec4 light;         // xyz: the point light (the cones' apex)
  uint first;         // first input pair in the arena, or first triangle when fromTriangles
  uint count;         // input elements of this dispatch
  uint fromTriangles; // 1: input i is triangle first + i, tested against the root (pass 0)
  uint childOffset;   // node-array offset of the child depth (test); unused by the leaves
  uint childCount;    // elements at the child depth (nodes, or the rays at the leaves)
  uint outFirst;      // the test's appends: arena slot of the first output pair
  float eps;          // leaves: hits count at distances in (eps, L - eps) from the light
  float minLength;    // leaves: rays not longer than this are degenerate (2 eps), never tested
  uint outLimit;      // the test's appends: no pair is written at or past this slot (the chunk overflowed)
  uint test;          // test: TRAVERSE_TEST_PRECISE or TRAVERSE_TEST_SPHERE
  uint frontFaceCulling; // test, pass 0: 1 drops the triangles that face the light (002 §3.6, cone_method.h)
  uint earlyAccept;   // test: 1 shadows the leaves of a covered child at once (002 §3.3) and marks it
  uint leafCount;     // test, early accept: the tree's leaves (sorted rays)
  uint leafShift;     // test, early accept: 2 (D - d) for the child depth d: leaves under a child = 4^(D-d);
                      // leaves (host path): a pair's rays are [node << leafShift, (node + 1) << leafShift)
  uint inputOffset;   // test, early accept: node-array offset of the input pairs' depth (their flags)
  uint frameVertices; // test: 1 = binding 0 holds the vertices relative to the light in the far-light frame
                      // (frame_triangles.comp), used as they are; 0 = world positions, the light subtracted
  float coneScale;    // test: the frame's angular scale (1 in the world frame; precise_test.h)
  uint countWord;     // device path: the stats word holding the input count (0: `count` above)
  uint deviceParams;  // device path, test: 1 = childOffset .. leafCount and inputOffset from the STATE_* words
  uint missingWord;   // leaves: the stats word their missing tests go to (STAT_MISSING, or STATE_LEAF_MISSING)
  uint triangleEnd;   // device path: the triangle buffer's triangle count (an expansion's last cluster ends there)
  uint pad0, pad1, pad2;
};

// The step whose pairs go to the leaves instead of a test (traversal.h, LeafRays): with one level of
// leaves (four rays a leaf pair) the tree's depth D, the pairs of depth D - 1; with two (sixteen rays a
// pair) D - 1, the pairs of depth D - 2; with three (sixty-four) D - 2, the pairs of depth D - 3 -- as many
// levels as the tree has to give (a tree of depth 2 gives two, of depth 1 one). A leaf pair's rays are
// then [node << 2 (D - step + 1), (node + 1) << 2 (D - step + 1)).
CS_FN uint leafStepOf(uint treeDepth, uint leafLevels) {
  uint levels = leafLevels < treeDepth ? leafLevels : treeDepth;
  return levels > 1u ? treeDepth - (levels - 1u) : treeDepth;
}

// traverse_advance.comp: between two steps of the device path (one invocation).
struct AdvancePush {
  uint step;          // 0: a batch starts (pass 0 next); c >= 1: step c - 1 just ran, step c is next;
                      // ADVANCE_END_OF_BATCH: the batch's leaves ran (counts it done unless it overflowed)
  uint triangles;     // step 0: the batch's triangles (pass 0's inputs)
  uint capacity;      // pairs a step may write (its output buffer and the next step's scratch)
  uint maxPerDim;     // workgroups per grid dimension
  uint clusters;      // step 0: 1 = the batch starts as (cluster, root) tests when the tree is deep enough,
                      // 2 = as (super cluster, root) tests
  uint frameTriangles;  // the triangles of the whole record() the batch is one of (the expansion rule's scale)
  uint sphereExpansion;  // 1: an expansion step's triangle pairs go to the sphere-test kernel (STATE_SPHERE_ARGS)
  uint wholeExpansion;   // with sphereExpansion: EXPANSION_PER_CLUSTER = that step is STEP_EXPAND_WHOLE or
                         // STEP_EXPAND_SUPER (a lane per pair), EXPANSION_PER_TRIANGLE = a lane per triangle pair,
                         // EXPANSION_CHOSEN = per batch from its pairs against wholeMinPairs
  uint leafLevels;       // 1: the pairs of depth D - 1 go to the leaves (four rays each); 2 (3): those of
                         // depth D - 2 (D - 3), 16 (64) rays each, as deep as the tree goes (leafStepOf);
                         // with leafChoice, the most levels the leaves may take
  uint leafChoice;       // 1: each step from that one on chooses between the leaves and one more depth from
                         // its counts (traversal.h, LeafRays::Auto; the costs below); 0: the leaves there
  float stepCost;        // the leaf choice's costs, in leaf tests (one ray against one triangle): a pair's
  float leafLaneCost;    // step (four child tests and the appends) and a leaf pair's lane before its rays
  uint wholeMinPairs;    // EXPANSION_CHOSEN: the fewest (super) cluster pairs that take a lane a pair
  // The leaves' cull (traverse_leaves.comp, SPEC_CULL), chosen per batch: where its leaf tests, scaled from
  // the batch to the record's triangles, come to at least this many a ray (0: always; +inf: never).
  float leafCullTestsPerRay;
};

// leaf_hits.comp: the leaves' hits into the visibility, LEAF_HITS_RAYS sorted rays an invocation (a
// power of two, at most 32: the bits of one word). 16, the fastest of 4, 16 and 32 on lavapipe
// (docs/ARCHITECTURE.md, "The leaves' hits as bits, a hint to the leaves too").
#define LEAF_HITS_SHIFT 4u
#define LEAF_HITS_RAYS (1u << LEAF_HITS_SHIFT)
#define LEAF_HITS_MASK (LEAF_HITS_RAYS == 32u ? 0xFFFFFFFFu : (1u << LEAF_HITS_RAYS) - 1u)
struct LeafHitsPush {
  uint count;      // sorted rays (when fromShape is 0)
  uint fromShape;  // 1: the count is the tree's shape word SHAPE_LEAVES (the device path)
  uint pad0, pad1;
};

// frame_triangles.comp: the triangles' vertices relative to the light in the far-light frame.
struct FrameTrianglesPush {
  vec4 rowX, rowY, rowZ;  // the rotation's rows (conetree/cone_layout.h, ConeFrame)
  vec4 centre;            // xyz: its origin C
  vec4 lightFrame;        // xyz: the light in the frame
  uint count;             // triangles
  uint pad0, pad1, pad2;
};

// sample_light.comp (the engine's samples): the mask's undecided samples after a frame whose pairs passed
// the arena, or each sample's light term written out for one light.
struct SampleLightPush {
  vec4 light;  // xyz: the light
  uint count;  // pixels
  uint mode;   // SAMPLE_UNDECIDED or SAMPLE_LIGHT_TERM
  uint pad0, pad1;
};
#define SAMPLE_LIGHT_TERM 0u
#define SAMPLE_UNDECIDED 1u

#ifdef __cplusplus
static_assert(sizeof(SampleLightPush) == 32, "SampleLightPush layout");
static_assert(sizeof(FrameTrianglesPush) == 96, "FrameTrianglesPush layout");
static_assert(sizeof(AdvancePush) == 56, "AdvancePush layout");
static_assert(sizeof(LeafHitsPush) == 16, "LeafHitsPush layout");
static_assert(STATE_ACC + STATE_ACC_WORDS * STATE_MAX_STEPS <= STATE_LEAF_PAIRS && STATE_TEST_ARGS % 4 == 0 &&
                  STATE_LEAF_ARGS % 4 == 0 && STATE_LEAF_ARGS + 4 * LEAF_SLOTS <= STATE_CLUSTER_ARGS,
              "state words");
static_assert(STATE_ADVANCE_ARGS % 4 == 0 && STATE_ADVANCE_ARGS >= STATE_DEFERRED + 1 && STATE_ADVANCE_ARGS + 4 <= STATE_WORDS,
              "the advance's dispatch words");
static_assert(STATE_COMMITTED >= STATE_EXPANDED + 2 && STATE_EXPANDED >= STATE_CLUSTER_ARGS + 4 && STATE_COMMITTED + STATE_COMMITTED_WORDS <= STATE_WORDS, "committed words");
static_assert(sizeof(TraversePush) == 112 && offsetof(TraversePush, frameVertices) == 76 && offsetof(TraversePush, first) == 16 &&
                  offsetof(TraversePush, minLength) == 44 && offsetof(TraversePush, outLimit) == 48 &&
                  offsetof(TraversePush, test) == 52 && offsetof(TraversePush, frontFaceCulling) == 56,
              "TraversePush layout");
}  // namespace cs::traversal
#endif
#endif
