// The cone path as a shadow method (method/method.h), CLI name "cone": lit samples -> Hilbert ray keys ->
// radix sort (sort/) -> cone tree (conetree/) -> bounded breadth-first traversal with the precise test ->
// exact leaves. Its settings and variants. docs/ARCHITECTURE.md, "The cone path's code".
#pragma once
#include <cstdint>
#include <memory>
#include <optional>
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

// The cone path's settings. Each says what it is; why, and what each costs, is in docs/ARCHITECTURE.md,
// "The cone path's settings". Only frontFaceCulling and leafTestAuto (inside the ambiguity band) can
// change a mask; every other switch changes the work only.
struct ConeOptions {
  // Bound on the traversal's pair arena + chunk scratch (002 §4.2; --traversal-memory); past it the
  // traversal goes depth-first over subsets.
  uint64_t traversalMemoryBytes = traversal::kDefaultMemoryBytes;
  bool sorted = true;         // 002 §3.5: rays in Hilbert order of direction; off: screen order
  bool adaptiveOrder = true;  // sorted rays: screen order kept per frame when its tree is as tight (--ray-order auto)
  ConeTest test = ConeTest::Precise;
  bool frontFaceCulling = false;  // 002 §3.6: only back faces cast; exact for closed, consistently wound meshes only
  bool earlyAccept = false;       // 002 §3.3: a node every ray of which a triangle covers stops (precise test)
  // 002 §3.4, two-pass: likely blockers (at least blockerSolidAngle sr at the light, at most the largest
  // blockerMaxFraction) first, the tree rebuilt over the rays still lit unless pass one finished fewer
  // than updateMinFinished of them.
  bool twoPass = false;
  float blockerSolidAngle = 4.0f * 3.14159265f / 4096.0f;  // sr: 1/4096 of the sphere
  float blockerMaxFraction = 0.125f;
  float updateMinFinished = 0.1f;
  bool profileStages = false;       // one-pass frames submitted stage by stage (--profile-stages)
  bool clusters = true;             // triangle clusters down the tree's upper levels (--clusters)
  bool superClusters = true;        // four clusters a super cluster (--super-clusters)
  bool sphereLastExpansion = true;  // the sphere test one depth above the leaves (--last-expansion-test)
  traversal::ExpansionLanes lastExpansionLanes = traversal::ExpansionLanes::Auto;  // --last-expansion-lanes
  std::optional<uint32_t> expansionLanesMinPairs;  // tests: auto's lane choice from this many pairs (traversal.h)
  traversal::LeafRays leafRays = traversal::LeafRays::Auto;  // --leaf-rays (auto: chosen per batch from its counts on a CPU device)
  std::optional<traversal::LeafChoiceCosts> leafChoiceCosts;  // tests: auto's leaf choice with these costs (traversal.h)
  std::optional<float> leafCullTestsPerRay;  // tests: the leaves' cull from this many leaf tests a ray (traversal.h)
  bool leafTestAuto = true;  // --leaf-test auto (true: traversal.h leafTestFor, from the light or the sample) or two-ends
  // --memory-budget: device buffers and host working set together (0: none); the arena gets what the
  // rest leaves, and a budget that cannot hold the frame is refused with the bytes it needs.
  uint64_t memoryBudgetBytes = 0;
  // Triangles a triangle buffer; 0: as many as one storage binding holds (tests set a small value).
  uint32_t trianglesPerBinding = 0;
  // Tests only: when arena.pairCapacity > 0, this exact arena instead of one planned from
  // traversalMemoryBytes.
  traversal::ArenaPlan arena;
};

// name() = "cone". The mask is exactly 0.0f (shadowed) or 1.0f; the stages, the timings and the stats'
// JSON keys are listed in docs/ARCHITECTURE.md, "The cone path's code".
// Paper 002's variant names (Table 1): Precise, PreciseSorted (the default), Spheres, SpheresSorted,
// PreciseSEA, PreciseEATP, PreciseSEATP. Sets o.test, o.sorted, o.earlyAccept and o.twoPass for one of
// them and returns true; false for any other name.
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
