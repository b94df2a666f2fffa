// The cone path in the method registry: its settings (paper 002's variants and switches, the traversal's
// memory bound, the ray order), compare's sweep over the memory bound, and the factory.
#include <algorithm>

#include "method/registry.h"
#include "traversal/cone_method.h"
#include "traversal/traversal.h"

namespace cs {

namespace {

const char* kMethod = "cone";

// --variant is applied first, then the switches, whatever their order on the command line, so a switch
// amends a variant: --variant PreciseSorted --two-pass on is PreciseSTP.
ConeOptions coneOptions(const Settings& s) {
  ConeOptions cone;
  const uint64_t least = traversal::kMinPairs * sizeof(glm::uvec2) + traversal::chunkScratchBytes(1);
  cone.traversalMemoryBytes = s.bytes("traversal-memory", traversal::kDefaultMemoryBytes);
  if (cone.traversalMemoryBytes < least)
    throw UsageError("cone: --traversal-memory " + std::to_string(cone.traversalMemoryBytes) +
                     " is too small: the traversal needs at least " + std::to_string(least) +
                     " bytes (4 pairs and one chunk's scratch)");
  cone.memoryBudgetBytes = s.bytes("memory-budget", 0);
  if (s.has("memory-budget") && cone.memoryBudgetBytes < (uint64_t(1) << 20))
    throw UsageError("cone: --memory-budget " + std::to_string(cone.memoryBudgetBytes) +
                     " is too small: give at least 1M (the scene's triangles take 48 bytes each, the rays about "
                     "100 bytes a pixel)");
  const std::string order = s.choice("ray-order", {"auto", "hilbert", "screen"}, "auto");
  const bool unsorted = order == "screen";
  if (s.has("variant")) {
    applyConeVariant(s.choice("variant", coneVariantNames(), ""), cone);
    if (unsorted && cone.sorted)
      throw UsageError("cone: variant '" + coneVariantName(cone) +
                       "' is sorted, but --ray-order screen asks for unsorted rays");
  }
  if (unsorted) cone.sorted = false;
  // A Table 1 variant named on its own is the paper's: sorted means always sorted (--ray-order auto amends it).
  if (order == "hilbert" || (s.has("variant") && !s.has("ray-order"))) cone.adaptiveOrder = false;
  if (order == "auto" && s.has("ray-order") && !cone.sorted)
    throw UsageError("cone: variant '" + coneVariantName(cone) +
                     "' is unsorted (screen order), but --ray-order auto chooses between sorted and screen order");
  cone.frontFaceCulling = s.onOff("front-face-culling", cone.frontFaceCulling);
  cone.earlyAccept = s.onOff("early-accept", cone.earlyAccept);
  cone.twoPass = s.onOff("two-pass", cone.twoPass);
  cone.profileStages = s.onOff("profile-stages", cone.profileStages);
  cone.clusters = s.onOff("clusters", cone.clusters);
  cone.superClusters = s.onOff("super-clusters", cone.superClusters);
  if (s.has("last-expansion-test"))
    cone.sphereLastExpansion = s.choice("last-expansion-test", {"sphere", "precise"}, "sphere") == "sphere";
  if (s.has("last-expansion-lanes")) {
    const std::string lanes = s.choice("last-expansion-lanes", {"auto", "cluster", "triangle"}, "auto");
    cone.lastExpansionLanes = lanes == "cluster"    ? traversal::ExpansionLanes::PerCluster
                              : lanes == "triangle" ? traversal::ExpansionLanes::PerTriangle
                                                    : traversal::ExpansionLanes::Auto;
  }
  if (s.has("variant")) cone.leafRays = traversal::LeafRays::Four;  // paper 002's leaves, unless named below
  if (s.has("leaf-rays")) {
    const std::string rays = s.choice("leaf-rays", {"auto", "4", "16", "64"}, "auto");
    cone.leafRays = rays == "4"    ? traversal::LeafRays::Four
                    : rays == "16" ? traversal::LeafRays::Sixteen
                    : rays == "64" ? traversal::LeafRays::SixtyFour
                                   : traversal::LeafRays::Auto;
  }
  if (s.has("leaf-test")) cone.leafTestAuto = s.choice("leaf-test", {"auto", "two-ends"}, "auto") == "auto";
  if (s.has("test"))
    cone.test = s.choice("test", {"precise", "sphere"}, "precise") == "sphere" ? ConeTest::Sphere : ConeTest::Precise;
  cone.blockerSolidAngle = float(s.number("blocker-solid-angle", 0.0, 12.5664, cone.blockerSolidAngle));
  cone.blockerMaxFraction = float(s.number("blocker-max-fraction", 0.0, 1.0, cone.blockerMaxFraction));
  cone.updateMinFinished = float(s.number("update-min-finished", 0.0, 1.0, cone.updateMinFinished));
  if (cone.earlyAccept && cone.test == ConeTest::Sphere)
    throw UsageError("cone: early accept needs the precise test (the sphere test cannot prove a cone covered)");
  return cone;
}

}  // namespace

MethodInfo coneMethodInfo() {
  MethodInfo m;
  m.name = kMethod;
  m.summary = "the cone hierarchy over the light buffer's rays (exact)";
  m.exact = true;
  m.settings = {
      {"variant", "NAME",
       "paper 002 Table 1, applied before the switches (default PreciseSorted with --ray-order auto; a variant "
       "named here sorts as the paper does unless --ray-order says otherwise)",
       coneVariantNames()},
      {"test", "T", "the node test: precise or sphere", {"precise", "sphere"}},
      {"early-accept", "on|off", "accept a cone every ray of which provably hits a triangle (precise test only)", {}},
      {"two-pass", "on|off", "likely blockers first, then the tree rebuilt over the rays still lit", {}},
      {"blocker-solid-angle", "SR", "two-pass: blockers subtend >= SR at the light (default 1/4096 of the sphere)", {}},
      {"blocker-max-fraction", "F", "two-pass: at most the largest F of all triangles are blockers (0.125)", {}},
      {"update-min-finished", "F", "two-pass: the update is skipped below F finished rays (0.1)", {}},
      {"front-face-culling", "on|off",
       "only triangles facing away from the light cast; exact only when every caster is a closed, consistently "
       "wound mesh (wrong on the built-in fur)",
       {}},
      {"ray-order", "O",
       "auto (default: screen order when its tree is as tight as a sorted one, or looser but over too few "
       "triangles for the sort to pay, else sorted; chosen per frame on the GPU, `ray_order_choice` says why), "
       "hilbert (always sorted) or screen (2x2 Morton screen order)",
       {"auto", "hilbert", "screen"}},
      {"traversal-memory", "BYTES", "bound on the traversal's pair buffers (default 64M; e.g. 256K)", {}},
      {"memory-budget", "BYTES",
       "cap on the cone path's device buffers and host working set together (e.g. 1G); the traversal gets what "
       "the rest leaves, at most --traversal-memory; too small for the scene: an error with the bytes it needs",
       {}},
      {"clusters", "on|off", "clusters of 16 triangles go down the tree's upper levels first (default on; the same mask)", {}},
      {"super-clusters", "on|off",
       "with clusters: runs of 4 clusters go down the top of the tree before their clusters do (default on; the same mask)", {}},
      {"last-expansion-test", "T",
       "with clusters and the precise test: the test of cluster pairs expanded one depth above the leaves, "
       "sphere or precise (default sphere: cheaper where clusters stay small down to there; the same mask)",
       {"sphere", "precise"}},
      {"last-expansion-lanes", "L",
       "with the sphere test there: a lane per cluster pair (its sixteen triangles) or per triangle pair; "
       "auto (default): on a CPU device (lavapipe) chosen per batch on the device, a lane per cluster pair "
       "where the pairs fill the lanes it runs at once, per triangle pair below; triangle on a GPU (the same "
       "mask; a cluster lane tests its cluster first, so fewer pairs)",
       {"auto", "cluster", "triangle"}},
      {"leaf-rays", "N",
       "rays a leaf pair covers: 4 (paper 002's leaves: the pairs of the deepest interior depth), 16 or 64 (the "
       "traversal stops one or two depths earlier, its most numerous steps, and the leaves test the 16 or 64 "
       "rays under a pair's node); auto (default): on a CPU device (lavapipe) chosen per batch on the device from "
       "its counts (4, 16 or 64; leaf_rays_choice in the stats says why), 4 on a GPU; a --variant "
       "named without it takes 4, as the paper does (the same mask)",
       {"auto", "4", "16", "64"}},
      {"leaf-test", "T",
       "the leaves' ray/triangle test: auto (default) tests from the light for a light within 8 half-diagonals "
       "of the scene (the triangle's edge planes through the light made once for a leaf pair's rays) and from "
       "the sample for a farther one (the edge planes through each ray's sample, no division), where "
       "coordinates stay within 2^40; two-ends measures every ray from the end the triangle is nearer, with a "
       "shear and divisions, right at any distance (exact outside the ambiguity band every way)",
       {"auto", "two-ends"}},
      {"profile-stages", "on|off",
       "one submission per stage (compact, keys, sort, build, traversal, leaves) to time each by wall clock, "
       "instead of the frame's single submission (the same mask)",
       {}},
  };
  // Knobs that never change the mask: every variant and switch of paper 002 gives the same mask (the
  // exactness tests hold them to it bit for bit), as do the ray order, the clusters, the leaves' width
  // and the profiling. --variant names the paper's configurations for users; the switches that amend it
  // are tuning. What stays with users changes the answer (front-face culling; the leaf test, within
  // the band) or the memory (--traversal-memory, --memory-budget).
  for (SettingSpec& spec : m.settings)
    for (const char* name : {"test", "early-accept", "two-pass", "blocker-solid-angle", "blocker-max-fraction",
                             "update-min-finished", "ray-order", "clusters", "super-clusters", "last-expansion-test",
                             "last-expansion-lanes", "leaf-rays", "profile-stages"})
      if (spec.name == name) spec.tuning = true;
  m.check = [](const Settings& s) { (void)coneOptions(s); };
  m.make = [](vk::Context* ctx, const Settings& s) -> std::unique_ptr<ShadowMethod> {
    CS_CHECK(ctx, "the cone method needs a Vulkan device");
    return makeConeMethod(*ctx, coneOptions(s));
  };
  // The memory bound: the given (or default) one, 1/64 and 1/1000 of it, kept well above the smallest
  // budget the arena planner accepts.
  m.sweep = [](const Settings& s) {
    const uint64_t def = s.bytes("traversal-memory", traversal::kDefaultMemoryBytes);
    std::vector<SweepPoint> points;
    for (uint64_t mem : {def, std::max<uint64_t>(def / 64, 4096), std::max<uint64_t>(def / 1000, 4096)})
      points.push_back({std::string(kMethod) + "@" + byteSizeLabel(mem), s.with("traversal-memory", std::to_string(mem)),
                        mem == def});
    return points;
  };
  return m;
}

}  // namespace cs
