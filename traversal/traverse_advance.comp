#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
// The device path's bookkeeping between two steps (one invocation; traversal.h, "One submission"). Step c
// expands the pairs of depth c - 1 into depth c (step 0: the batch's triangles into the root); at c = D,
// the depth whose pairs the leaves take plus one (the tree's depth, or one or two less with 16 or 64 rays a
// leaf pair: traversal.h, LeafRays), the pairs go to the leaves instead. Before step c this kernel
//  - adds what step c - 1 did to its depth's totals (inputs, tests, survivors, steps run, early accept),
//  - flags an overflow when step c - 1's survivors passed the capacity (what the step wrote is never read, and
//    every later step of the frame is a dispatch of zero workgroups: the host redoes it chunked),
//  - at step 0, writes the indirect arguments of leaf_hits.comp (a lane per LEAF_HITS_RAYS sorted rays),
//  - writes step c's count, its TraversePush fields from the tree's shape, and the indirect arguments of
//    its test (the cluster or the triangle kernel), or at c = D of the batch's leaves: one of LEAF_SLOTS
//    dispatches, by the buffer step c - 1 wrote and the leaves' cull (leafCullTestsPerRay), and clears the
//    step counters;
//  - with the leaf choice (AdvancePush::leafChoice), from c = D on to the tree's depth, chooses from the
//    step's own counts between the leaves now and one more depth first (leafChoice below); where cluster
//    pairs reach the depth at which they would have to expand for the leaves at D, it makes that choice
//    from the clusters' survival first, and a "one more depth" moves D down and keeps them clusters
//    (deferLeaves below);
//  - with the lanes chosen (AdvancePush::wholeExpansion), where the last expansion's two forms part,
//    chooses its lanes from the pairs there (wholeLanes below).
// bindings: 0 = shape words (SHAPE_*, conetree/tree_shape.comp), 1 = state words (STAT_*, STATE_*)
#include "conetree/cone_layout.h"
#include "traversal/traversal_layout.h"

layout(local_size_x = 1) in;
layout(std430, binding = 0) readonly buffer Shape { uint shape[]; };
layout(std430, binding = 1) buffer State { uint state[]; };
layout(push_constant) uniform Push { AdvancePush p; };

void add64(uint at, uint value) {
  uint lo = state[at] + value;
  if (lo < value) state[at + 1u] += 1u;
  state[at] = lo;
}

void add64v(uint at, uint64_t value) {
  uint64_t sum = (uint64_t(state[at + 1u]) << 32) + uint64_t(state[at]) + value;
  state[at] = uint(sum & 0xFFFFFFFFul);
  state[at + 1u] = uint(sum >> 32);
}

// The leaf choice (traversal.h, LeafRays::Auto; docs/ARCHITECTURE.md, "Leaf pairs chosen per frame"): n
// triangle pairs at step c of a tree of depth D, each with 4^(D - c + 1) rays under its node; `survival` is
// the step's own survival as the steps above predict it (survival grows with depth: the last one's,
// times its growth over the one before when both tested triangle pairs, at most 1). The leaves now cost n (leafLaneCost + rays) leaf
// tests; one more depth costs n stepCost, then 4 survival n pairs with a quarter of the rays each. One
// more depth when that is cheaper and its pairs, so estimated, fill at most 3/4 of the capacity (an
// overflow redoes the frame on the host).
// (One more depth is cheaper at step c for a step of `stepCost` leaf tests.)
bool deeperIsCheaper(uint c, uint treeDepth, float survival, float stepCost) {
  float rays = float(1u << (2u * (treeDepth - c + 1u)));
  float now = p.leafLaneCost + rays;
  float deeper = stepCost + 4.0 * survival * (p.leafLaneCost + 0.25 * rays);
  return deeper < now;
}

bool leavesNow(uint c, uint treeDepth, uint n, float survival) {
  return !deeperIsCheaper(c, treeDepth, survival, p.stepCost) || 4.0 * survival * float(n) > 0.75 * float(p.capacity);
}

// The leaf choice made while clusters still go down (docs/ARCHITECTURE.md, "Leaf pairs chosen per
// frame"): n (super) cluster pairs that survived step c - 1 with `survival` per test, at the last depth
// where they may stay cluster pairs for the leaves at `depth` (ahead: two depths above it for super
// clusters, which split there, one for clusters, which expand there), and only where the expansion rule
// would keep them whole (else moving the leaves would change nothing). The leaves' step moves one depth
// down when the leaf choice at `depth` says one more depth, asked for each triangle of a pair (`size`
// of them) with the clusters' survival and the cost of a depth of cluster pairs: a step's cost shared by
// the pair's triangles. The clusters then go on one depth as clusters and expand a depth later, where the
// choice made after the expansion could only have tested every triangle pair once more. Not where the
// deferred step's clusters, so estimated, would not fit their expansion (`limit` pairs).
bool deferLeaves(uint c, uint ahead, uint depth, uint treeDepth, uint n, float survival, uint size, uint limit) {
  if (p.leafChoice == 0u || n == 0u || c + ahead < depth || depth >= treeDepth) return false;
  return deeperIsCheaper(depth, treeDepth, survival, p.stepCost / float(size)) &&
         4.0 * survival * float(n) <= 0.75 * float(limit);
}

// deferLeaves said so: the leaves' step one depth down, for this batch's later steps too; the survival
// it saw is the stats' prediction at that step.
uint deferredDepth(uint depth, uint treeDepth, float survival) {
  state[STATE_LEAF_SEEN + treeDepth - depth - 1u] = max(1u, uint(min(survival, 1.0) * 65536.0));
  state[STATE_LEAF_DEFER] += 1u;
  state[STATE_DEFERRED] += 1u;
  return depth + 1u;
}

// The last expansion's lanes (traversal.h, ExpansionLanes; docs/ARCHITECTURE.md, "The last expansion's
// lanes chosen per batch"), decided once a batch where the two forms part, from the n (super) cluster pairs
// there: a lane per pair (the cluster's and groups' spheres tested once for their triangles) where the
// pairs alone fill the device's lanes, a lane per triangle pair (sixteen times the lanes) where they do
// not. Counted per frame for the stats.
bool wholeLanes(uint n) {
  bool whole = p.wholeExpansion == EXPANSION_PER_CLUSTER || (p.wholeExpansion == EXPANSION_CHOSEN && n >= p.wholeMinPairs);
  uint form = whole ? 0u : 1u;
  state[STATE_LANES + form] += 1u;
  state[STATE_LANES_PAIRS + form] += n;
  return whole;
}

void writeArgs(uint at, uint items, uint count, uint groupSize) {
  uvec2 grid = indirectGrid(items, groupSize, p.maxPerDim);
  state[at] = grid.x;
  state[at + 1u] = grid.y;
  state[at + 2u] = 1u;
  state[at + 3u] = count;
}

void main() {
  if (p.step == ADVANCE_END_OF_BATCH) {
    if (state[STATE_OVERFLOW] != 0u) return;
    state[STATE_BATCHES_DONE] += 1u;
    state[STATE_COMMITTED] = state[STATE_LEAF_MISSING];
    for (uint k = 0u; k + 1u < STATE_COMMITTED_WORDS; k++) state[STATE_COMMITTED + 1u + k] = state[STATE_ACC + k];
    return;
  }
  uint treeDepth = shape[SHAPE_DEPTH];
  uint c = p.step;
  if (c == 0u) state[STATE_LEAF_DEFER] = 0u;
  // (the tree's depth with four rays a leaf pair; moved down by deferLeaves)
  uint depth = min(leafStepOf(treeDepth, p.leafLevels) + state[STATE_LEAF_DEFER], treeDepth);
  uint n = 0u;
  uint mode = STEP_TRIANGLES;
  uint count = 0u;  // the next step's inputs (an expansion: CLUSTER_SIZE per cluster pair)
  float survival = 1.0;  // survivors per test of step c - 1 (the leaf choice's estimate of step c's)
  if (c == 0u) {
    n = state[STATE_OVERFLOW] != 0u || depth == 0u ? 0u : p.triangles;
    state[STATE_BATCH_TRIANGLES] = p.triangles;
    state[STATE_SURVIVAL] = 0u;
    writeArgs(STATE_HITS_ARGS, (shape[SHAPE_LEAVES] + LEAF_HITS_RAYS - 1u) / LEAF_HITS_RAYS, shape[SHAPE_LEAVES], CONE_BUILD_THREADS);
    // Clusters go down the upper levels when there are levels to spare before the leaves (see below),
    // super clusters first where the host asks.
    if (p.clusters == 2u && depth >= 3u) {
      mode = STEP_SUPER;
      n = (n + SUPER_SIZE - 1u) >> SUPER_SHIFT;
    } else if (p.clusters != 0u && depth >= 3u) {
      mode = STEP_CLUSTERS;
      n = (n + CLUSTER_SIZE - 1u) >> CLUSTER_SHIFT;
    }
    count = n;
  } else {
    uint was = state[STATE_MODE];
    // Triangle pairs: an invocation of a whole-cluster expansion stands for CLUSTER_SIZE of them.
    uint inputs = state[STATE_COUNT] << (was == STEP_EXPAND_WHOLE ? CLUSTER_SHIFT : (was == STEP_EXPAND_SUPER ? SUPER_SHIFT : 0u));
    if (inputs > 0u) {
      uint survivors = state[STAT_TOTAL];
      uint acc = STATE_ACC + STATE_ACC_WORDS * (c - 1u);
      uint tests = inputs * (c == 1u ? 1u : 4u) - state[STAT_MISSING];
      add64(acc, inputs);
      add64(acc + 2u, tests);
      add64(acc + 4u, survivors);
      state[acc + 6u] += 1u;
      if (was == STEP_CLUSTERS || was == STEP_SUPER || was == STEP_SPLIT) state[acc + 7u] += tests;
      add64(STATE_ACCEPTED, state[STAT_ACCEPTED]);
      add64(STATE_DROPPED, state[STAT_DROPPED]);
      state[STATE_PEAK_CHUNK] = max(state[STATE_PEAK_CHUNK], inputs);
      state[STATE_PEAK_PAIRS] = max(state[STATE_PEAK_PAIRS], (c == 1u ? 0u : inputs) + min(survivors, p.capacity));
      if (survivors > p.capacity) state[STATE_OVERFLOW] = 1u;
      else n = survivors;
      // Of every (pair, child) of the step, those a whole-cluster lane never tested included; the trend
      // only from one triangle step to the next (a cluster step's survival is another quantity).
      float last = float(survivors) / max(1.0, float(inputs) * (c == 1u ? 1.0 : 4.0));
      float before = float(state[STATE_SURVIVAL]) / 65536.0;
      survival = was == STEP_TRIANGLES && before > 0.0 ? min(1.0, last * max(1.0, last / before)) : last;
      state[STATE_SURVIVAL] = was == STEP_TRIANGLES ? max(1u, uint(min(last, 1.0) * 65536.0)) : 0u;
      // Expansion rule (traversal.h, "Clusters"): cluster pairs go on while the nodes are wide against the
      // clusters, and expand into their triangles' pairs at the first depth with more than 1/K as many
      // nodes as the clusters pass 0 kept (scaled from the batch to the whole record: the batches are
      // contiguous runs of the Hilbert order, each a part of the scene's footprint) -- there a node covers
      // fewer rays than K clusters' share of them -- and at the latest one depth above the leaves.
      // Triangle pairs stay triangle pairs.
      // Super cluster pairs split into their clusters' pairs one step before the clusters would expand by
      // the rule below (so clusters expand where they would have without super clusters), and otherwise
      // at the latest two depths above the leaves -- but where the last expansion takes a lane per pair
      // (wholeLanes), which takes the super cluster pairs that reach one depth above the leaves as they
      // are (STEP_EXPAND_SUPER).
      if (was == STEP_SUPER && n > 0u) {
        if (c == 1u) {
          uint batchSupers = (state[STATE_BATCH_TRIANGLES] + SUPER_SIZE - 1u) >> SUPER_SHIFT;
          uint frameSupers = (p.frameTriangles + SUPER_SIZE - 1u) >> SUPER_SHIFT;
          uint64_t kept = min(uint64_t(n) * frameSupers / max(batchSupers, 1u), uint64_t(0xFFFFFFFFu));
          state[STATE_ROOT_SUPERS] = uint(kept);
          // (the expansion rule's count: at most SUPER_CLUSTERS clusters a super cluster kept)
          state[STATE_ROOT_CLUSTERS] = uint(min(kept * SUPER_CLUSTERS, uint64_t(0xFFFFFFFFu)));
        }
        bool expandNext = uint64_t(shape[SHAPE_COUNTS + c + 1u]) * EXPAND_NODES_PER_CLUSTER > uint64_t(state[STATE_ROOT_CLUSTERS]);
        // Where only the leaves' depth would split them (the rule keeps them whole), the leaf choice from
        // their survival may move the leaves down a depth.
        if (!expandNext && deferLeaves(c, 2u, depth, treeDepth, n, survival, SUPER_SIZE, p.capacity >> SUPER_SHIFT)) depth = deferredDepth(depth, treeDepth, survival);
        // Super cluster pairs reach the last depth unsplit only where their lanes were chosen below.
        if (p.sphereExpansion != 0u && p.wholeExpansion != EXPANSION_PER_TRIANGLE && c + 1u >= depth) {
          mode = STEP_EXPAND_SUPER;
          add64(STATE_EXPANDED, n * SUPER_CLUSTERS);
          // A lane a pair, read from the arena where they were written: only the step's 32-bit count of
          // tests (four per triangle pair) bounds it.
          if (n > (0xFFFFFFFFu >> (SUPER_SHIFT + 2u))) {
            state[STATE_OVERFLOW] = 1u;
            n = 0u;
          }
        } else {
          // Two depths above the leaves the lanes part: a lane per triangle pair splits the pairs here, a
          // lane per pair keeps them whole for one more depth (the choice, from these pairs).
          bool split = c + 2u >= depth ? !(p.sphereExpansion != 0u && wholeLanes(n)) : expandNext;
          mode = split ? STEP_SPLIT : STEP_SUPER;
          if (split && n > (p.capacity >> 2u)) {  // (SUPER_CLUSTERS inputs a pair)
            state[STATE_OVERFLOW] = 1u;
            n = 0u;
          }
        }
      } else if ((was == STEP_CLUSTERS || was == STEP_SPLIT) && n > 0u) {
        if (c == 1u && was == STEP_CLUSTERS) {
          uint batchClusters = (state[STATE_BATCH_TRIANGLES] + CLUSTER_SIZE - 1u) >> CLUSTER_SHIFT;
          uint frameClusters = (p.frameTriangles + CLUSTER_SIZE - 1u) >> CLUSTER_SHIFT;
          state[STATE_ROOT_CLUSTERS] =
              uint(min(uint64_t(n) * frameClusters / max(batchClusters, 1u), uint64_t(0xFFFFFFFFu)));
        }
        bool byRule = uint64_t(shape[SHAPE_COUNTS + c]) * EXPAND_NODES_PER_CLUSTER > uint64_t(state[STATE_ROOT_CLUSTERS]);
        if (!byRule && deferLeaves(c, 1u, depth, treeDepth, n, survival, CLUSTER_SIZE, p.capacity >> CLUSTER_SHIFT)) depth = deferredDepth(depth, treeDepth, survival);
        bool expand = c + 1u >= depth || byRule;
        mode = expand ? STEP_EXPAND : STEP_CLUSTERS;
        if (expand) {
          add64(STATE_EXPANDED, n);
          if (n > (p.capacity >> CLUSTER_SHIFT)) {
            state[STATE_OVERFLOW] = 1u;
            n = 0u;
          }
        }
      }
      // The last depth's expansion in the sphere-test kernel: a lane per cluster pair where chosen. Split
      // super cluster pairs chose a lane per triangle pair a depth above.
      if (mode == STEP_EXPAND && p.sphereExpansion != 0u && c + 1u >= depth && was == STEP_CLUSTERS && n > 0u &&
          wholeLanes(n))
        mode = STEP_EXPAND_WHOLE;
      count = mode == STEP_EXPAND ? n << CLUSTER_SHIFT : (mode == STEP_SPLIT ? n << 2u : n);
    }
  }
  state[STATE_MODE] = mode;
  writeArgs(STATE_TEST_ARGS, 0u, 0u, TRAVERSE_THREADS);
  writeArgs(STATE_CLUSTER_ARGS, 0u, 0u, TRAVERSE_THREADS);
  writeArgs(STATE_SPHERE_ARGS, 0u, 0u, TRAVERSE_THREADS);
  writeArgs(STATE_WHOLE_ARGS, 0u, 0u, TRAVERSE_THREADS);
  if (c == 0u)
    for (uint k = 0u; k < LEAF_SLOTS; k++) writeArgs(STATE_LEAF_ARGS + 4u * k, 0u, 0u, TRAVERSE_THREADS);
  state[STATE_COUNT] = 0u;
  // The leaves take the pairs at step D, or with the choice at the first step from D on where it says so
  // (at the tree's depth at the latest). Expansions are done by D (the rules above count from it), so
  // the pairs there and below are triangle pairs.
  bool choosing = p.leafChoice != 0u && c >= depth && c < treeDepth && mode == STEP_TRIANGLES;
  bool leaves = n > 0u && c >= depth && (!choosing || leavesNow(c, treeDepth, n, survival));
  if (choosing && n > 0u && treeDepth - c + 1u <= 3u)
    state[STATE_LEAF_SEEN + treeDepth - c - 1u] = max(1u, uint(min(survival, 1.0) * 65536.0));
  if (leaves) {
    uint levels = treeDepth - c + 1u;
    // The cull where the batch's leaf tests per ray, scaled to the record, say most tests miss (a ray is
    // hit by few triangles, so thousands of tests a ray are nearly all misses the cull removes;
    // docs/ARCHITECTURE.md, "The leaves' cull").
    float perRay = float(n) * float(1u << (2u * levels)) * (float(p.frameTriangles) / float(max(state[STATE_BATCH_TRIANGLES], 1u))) /
                   float(max(shape[SHAPE_LEAVES], 1u));
    uint cull = perRay >= p.leafCullTestsPerRay ? 1u : 0u;
    state[STATE_LEAF_CULL + 1u - cull] += n;
    writeArgs(STATE_LEAF_ARGS + 4u * (((c - 1u) & 1u) + 2u * cull), n, n, TRAVERSE_THREADS);
    add64(STATE_LEAF_PAIRS, n);
    add64v(STATE_LEAF_TESTS, uint64_t(n) << (2u * levels));
    state[STATE_LEAF_BY_LEVEL + min(levels, 3u) - 1u] += n;
    state[STATE_LEAF_SHIFT] = 2u * levels;  // a pair's rays: [node << shift, (node + 1) << shift)
  } else if (n > 0u) {
    state[STATE_COUNT] = count;
    // The step's test: the cluster kernel for cluster pairs, the triangle kernel otherwise, or the
    // sphere-test triangle kernel for an expansion one depth above the leaves when the host asks for it
    // (traversal.h, "Clusters"), a lane per triangle pair or a lane per (super) cluster pair. All are
    // recorded; the others get zero workgroups.
    bool whole = mode == STEP_EXPAND_WHOLE || mode == STEP_EXPAND_SUPER;
    uint args = mode == STEP_CLUSTERS || mode == STEP_SUPER || mode == STEP_SPLIT ? STATE_CLUSTER_ARGS
                : whole ? STATE_WHOLE_ARGS
                : (mode != STEP_TRIANGLES && p.sphereExpansion != 0u && c + 1u >= depth ? STATE_SPHERE_ARGS : STATE_TEST_ARGS);
    writeArgs(args, count, count, TRAVERSE_THREADS);
    state[STATE_CHILD_OFFSET] = shape[SHAPE_OFFSETS + c];
    state[STATE_CHILD_COUNT] = shape[SHAPE_COUNTS + c];
    state[STATE_INPUT_OFFSET] = c == 0u ? 0u : shape[SHAPE_OFFSETS + c - 1u];
    state[STATE_LEAF_SHIFT] = 2u * (treeDepth - c);  // the rays under a node of depth c (early accept)
  }
  // The next step's advance runs only where this one left that step inputs: a step with none leaves the
  // words as they are (its advance would only write them again), and lavapipe hands every dispatch with a
  // workgroup to its worker threads, tens of microseconds each whatever the work.
  state[STATE_ADVANCE_ARGS] = state[STATE_COUNT] != 0u ? 1u : 0u;
  state[STATE_ADVANCE_ARGS + 1u] = 1u;
  state[STATE_ADVANCE_ARGS + 2u] = 1u;
  state[STATE_LEAF_COUNT] = shape[SHAPE_LEAVES];
  state[STAT_MISSING] = 0u;
  state[STAT_TOTAL] = 0u;
  state[STAT_ACCEPTED] = 0u;
  state[STAT_DROPPED] = 0u;
}
