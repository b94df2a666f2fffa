// The cone path as a shadow method (method/method.h): lit samples -> Hilbert ray keys -> radix sort (sort/)
// -> cone tree (conetree/) -> bounded breadth-first traversal with the precise test -> exact leaves
// (traversal/). CLI name "cone". See traversal/traversal.h for the traversal and its memory bound.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "method/method.h"
#include "traversal/traversal.h"

namespace cs {
namespace vk { struct Context; }

// The passes' cone/triangle test.
enum class ConeTest {
  Precise,  // precise_test.h (002 §3.2)
  Sphere,   // sphere_test.h: the triangle's bounding sphere, the ray-space-hierarchy baseline (002 §3.2)
};

struct ConeOptions {
  // Bound on the traversal's pair arena + chunk scratch (002 §4.2; --traversal-memory). Past it the
  // traversal goes depth-first over subsets: slower, never different.
  uint64_t traversalMemoryBytes = traversal::kDefaultMemoryBytes;
  // 002 §3.5: sort the rays by Hilbert key of their direction before building the tree. Off: screen
  // order (Morton inside 64x64 tiles: four consecutive leaves are a 2x2 pixel block), as without sorting.
  bool sorted = true;
  // With sorted rays, the order is chosen per frame on the GPU (order_choice.comp; --ray-order auto, the
  // default): the tree is first built in screen order, and kept when no depth below its top three covers
  // more than 3/2 the solid angle of the widest of them (its cones partition their parents, as a sorted
  // tree's do);
  // otherwise the keys, the sort and the rebuild run. Either way in the one submission, by indirect
  // dispatches that launch nothing when not needed; the mask is the same, only the work differs. Off
  // (--ray-order hilbert): always sorted, paper 002's PreciseSorted as written. Two-pass frames sort always.
  bool adaptiveOrder = true;
  ConeTest test = ConeTest::Precise;
  // 002 §3.6, front-face culling (off by default): only triangles facing away from the light cast. With
  // glTF's counter-clockwise front faces, N = (v1 - v0) x (v2 - v0) points out of a closed mesh; a triangle
  // faces the light when the light is on N's side, N.(light - v0) > 0, and is then dropped in pass 0 on
  // the GPU (edge-on ones, within rounding, are kept). Exact only for closed, consistently wound meshes:
  // a shadow ray that enters a closed mesh through a front face leaves it through a back face before the
  // sample (which lies on a lit, front surface), so the back face alone decides the shadow. It is WRONG
  // for open meshes and one-sided geometry (a single quad, a leaf card, a terrain sheet, a mesh with holes
  // or inconsistent winding): there the face towards the light may be the only one the ray crosses, and
  // dropping it lights samples that are in shadow. Also wrong with the light inside a closed caster.
  bool frontFaceCulling = false;
  // 002 §3.3, early accept (off by default; precise test only): a node whose every ray provably hits a
  // triangle (precise_test.h: preciseConeCovered) shadows all its samples at once and stops there, and the
  // other triangles' pairs at that node are dropped (traversal.h). The mask is unchanged; fewer pairs are
  // tested where large occluders cover whole cones. Variant "PreciseSEA" = precise, sorted, early accept.
  bool earlyAccept = false;
  // 002 §3.4, two-pass traversal (off by default). Pass one pushes only the likely blockers through the
  // tree; the rays they shadowed are dropped (the unfinished rays are compacted in their order, so still
  // sorted) and the tree is rebuilt over the rest; pass two pushes the remaining triangles through the
  // smaller tree. Exact either way: every (triangle, ray) pair is still decided, a dropped ray is shadowed.
  // The blocker heuristic: a triangle is a likely blocker when the solid angle it subtends at the light
  // (exact, Van Oosterom-Strackee) is at least blockerSolidAngle steradians -- large walls and floors near
  // the light, what paper 002 names as good occluders in architectural scenes -- keeping only the
  // largest blockerMaxFraction of the triangles when more qualify (pass one should stay cheap). Chosen
  // on the host per frame (the light or the triangles changed), the triangle buffer ordered blockers
  // first. The update (compaction + rebuild) is skipped, as the paper allows, when pass one finished
  // fewer than updateMinFinished of the lit rays: pass two then reuses the first tree (stats say so).
  bool twoPass = false;
  float blockerSolidAngle = 4.0f * 3.14159265f / 4096.0f;  // sr: 1/4096 of the sphere
  float blockerMaxFraction = 0.125f;
  float updateMinFinished = 0.1f;
  // The frame is one submission (traversal.h, "One submission"): every count that sizes later work stays
  // on the GPU and the host waits once. With profileStages (--profile-stages) the same recording is
  // submitted stage by stage, so each stage's wall clock can be measured where timestamps are not to be
  // trusted (lavapipe). Two-pass frames are always submitted per stage: their update is decided on the host.
  bool profileStages = false;
  // Triangle clusters down the upper levels of the tree (traversal.h, "Clusters"; --clusters): the same
  // mask, fewer pairs tested on large scenes. One-pass frames in one submission only.
  bool clusters = true;
  // With clusters: every 4 consecutive clusters form a super cluster, which goes down the top of the tree
  // before they do (traversal.h, "Clusters"; --super-clusters). The same mask.
  bool superClusters = true;
  // With clusters: expansions one depth above the leaves take the sphere test, not the precise one
  // (traversal.h, "Clusters"; --last-expansion-test). The same mask.
  bool sphereLastExpansion = true;
  // Those expansions' lanes (traversal.h ExpansionLanes; --last-expansion-lanes): auto (a lane per cluster
  // pair on a CPU device, per triangle pair on a GPU), cluster or triangle. The same mask.
  traversal::ExpansionLanes lastExpansionLanes = traversal::ExpansionLanes::Auto;
  // Rays a leaf pair covers (traversal.h LeafRays; --leaf-rays): auto (chosen per batch from its counts
  // on a CPU device, four on a GPU), 4 (paper 002's leaves), 16 or 64. The same mask.
  traversal::LeafRays leafRays = traversal::LeafRays::Auto;
  std::optional<traversal::LeafChoiceCosts> leafChoiceCosts;  // tests: auto's choice with these costs (traversal.h)
  // The leaves' test (traversal.h LeafTest; --leaf-test): true (auto), the test from the light wherever it
  // is exact (traversal::leafTestFor: a light among the geometry), else the two ends'; false, the two ends'
  // always. Exact outside the ambiguity band either way; within it the masks may differ.
  bool leafTestFromLight = true;
  // --memory-budget: a cap on everything the cone path holds for a frame, device buffers and host working
  // set together (0: none). The traversal's arena is what the other buffers leave, at most
  // traversalMemoryBytes (a smaller arena is slower, never different); a budget that cannot hold the
  // triangles, the frame's rays and tree and the smallest arena is refused with the bytes it needs.
  // The device bytes count the arena whole; the host bytes are the upload's working set (cone_method.cpp).
  uint64_t memoryBudgetBytes = 0;
  // Triangles per triangle buffer; 0 = as many as one storage binding of the device holds (48 bytes each:
  // 2.8 M on lavapipe's 128 MiB). A larger scene is traversed buffer by buffer, the same tree and mask
  // (tests set a small value to prove it).
  uint32_t trianglesPerBinding = 0;
  // Tests only: when arena.pairCapacity > 0, this exact arena (down to traversal::minimumPairs pairs and
  // chunks of one pair) instead of one planned from traversalMemoryBytes.
  traversal::ArenaPlan arena;
};

// name() = "cone". MethodOutput:
//   visibility  0/1 per pixel (1 where the sample is not lit); exactly 0.0f or 1.0f, never NaN.
//   stages      "upload" on frames whose triangles changed, then: with one submission on a device whose
//               timestamps are trusted (not a CPU device), "compact", "keys", "sort", "build",
//               "traversal", "leaves" from timestamps; with one submission on lavapipe, one "frame"
//               stage (the wall clock of the submission): a timestamp written after a barrier there can
//               take the time of the dispatch *after* it (measured: a 30 ms leaf dispatch reported as
//               0.05 ms), so per-stage timestamps are misattributed; with profileStages or two-pass, the
//               six stages -- five in a sorted frame that does not measure the ray order, whose
//               compaction and keys are one stage, "compact + keys", where the device's sort takes pairs
//               (rays::LitRays::recordCompactionWithKeys), and also with timestamps --
//               (two-pass adds "update", the unfinished rays' compaction, and "rebuild", the second tree;
//               a frame that measures the screen order adds "order", its tree and the choice, before
//               "keys"), each the host's wall clock around its own submit(s), waits included.
//               stats.stage_timing says which; the timestamp intervals are in stats.timestamp_ms.
//   totalMs     wall clock of the frame's shadow work up to the mask on the GPU; the readback of the mask
//               to the host is stats.readback_ms.
//   stats       variant ("PreciseSorted", ...), test ("precise" | "sphere"), front_face_culling, early_accept,
//               ray_order ("hilbert" | "screen": the order this frame used), ray_sort (the radix sort's
//               scheme and tile on this device, sort::sortSchemeFor / sortShapeFor); with adaptiveOrder
//               ray_order_choice (measured this frame, or sorted on a recent loose verdict) and, when
//               measured, screen_tree_solid_angle_sr (per depth) and screen_tree_looseness,
//               two_pass (when on: blockers, rays finished in pass one, update rebuilt or skipped and why,
//               each pass's traversal stats; the top-level counts are the two passes' sums),
//               early_accepted_nodes, lit_samples, triangles, tree_depth, tree_nodes, pairs_tested, pairs_survived, leaf_tests,
//               leaf_rays (4 or 16: rays a leaf pair covered),
//               traversal (per pass: inputs, pairs tested, survivors, chunks; leaf pairs/tests/hits;
//               submits; peak_bytes), traversal_memory_bytes, pair_capacity, chunk_capacity, epsilon.
//               host_peak_bytes (the upload's host working set); under a budget memory_budget_bytes and
//               memory_budget_used_bytes (device bytes allocated + host_peak_bytes, <= the budget).
//   bytesAllocated / peakBytes: every buffer the method holds for the frame / the same with the
//               traversal's share at its measured peak (<= traversalMemoryBytes).
// Paper 002's variant names (Table 1): "Precise" (precise test, unsorted), "PreciseSorted" (precise,
// sorted: the default), "Spheres" (sphere test, unsorted), "SpheresSorted" (sphere, sorted), "PreciseSEA"
// (precise, sorted, early accept), "PreciseEATP" (precise, unsorted, early accept, two-pass),
// "PreciseSEATP" (precise, sorted, early accept, two-pass). Sets o.test, o.sorted, o.earlyAccept and
// o.twoPass for one of those names and returns true; false for any other name.
bool applyConeVariant(const std::string& name, ConeOptions& o);
// Triangles the upload writes into the triangle buffers at a time (16 MiB of vertices, whole clusters of
// 64): the host chunk and, on a discrete GPU, the staging buffer hold no more.
inline constexpr uint64_t kConeUploadTriangles = uint64_t(64) * 5461;
// The seven names above, in Table 1's order.
const std::vector<std::string>& coneVariantNames();
// The variant name of these options: a Table 1 name, or for other combinations of the switches the same
// scheme -- Precise|Spheres, then "Sorted" alone, or S (sorted), EA (early accept), TP (two-pass): e.g.
// "PreciseEA", "PreciseSTP", "SpheresSTP".
std::string coneVariantName(const ConeOptions& o);

std::unique_ptr<ShadowMethod> makeConeMethod(vk::Context& ctx, const ConeOptions& options = {});

}  // namespace cs
