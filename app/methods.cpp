// The method registry: every shadow path plugs in here under its CLI name.
#include "app/methods.h"

#include <algorithm>

#include "reference/embree_reference.h"
#ifdef CONESHADOW_HAS_CONE
#include "traversal/cone_method.h"
#endif
#ifdef CONESHADOW_HAS_SHADOWMAPS
#include "shadowmaps/cube_sm.h"
#include "shadowmaps/rmsm.h"
#endif

namespace cs {

std::vector<std::string> methodNames() {
  std::vector<std::string> names = {"embree"};
#ifdef CONESHADOW_HAS_CONE
  names.push_back("cone");
#endif
#ifdef CONESHADOW_HAS_SHADOWMAPS
  names.push_back("cubesm");
  names.push_back("rmsm");
#endif
  return names;
}

namespace {
#ifdef CONESHADOW_HAS_CONE
// Cone settings from the CLI; throws UsageError for anything it does not take.
ConeOptions coneOptions(const Options& options) {
  ConeOptions cone;
  if (options.traversalMemory) cone.traversalMemoryBytes = options.traversalMemory;
  cone.sorted = !options.unsorted;
  // Method-specific settings: --variant=NAME (paper 002 Table 1), --front-face-culling=on|off.
  for (const std::string& kv : options.extra) {
    const size_t eq = kv.find('=');
    const std::string key = kv.substr(0, eq), value = eq == std::string::npos ? "" : kv.substr(eq + 1);
    if (key == "variant") {
      if (isUnimplementedConeVariant(value))
        throw UsageError("cone: variant '" + value + "' needs two-pass, which is not implemented yet");
      if (!applyConeVariant(value, cone))
        throw UsageError("cone: unknown variant '" + value + "' (variants: Precise, PreciseSorted, Spheres, SpheresSorted, PreciseSEA)");
      if (options.unsorted && cone.sorted)
        throw UsageError("cone: variant '" + value + "' is sorted, but --ray-order screen asks for unsorted rays");
    } else if (key == "front-face-culling") {
      if (value != "on" && value != "off")
        throw UsageError("cone: --front-face-culling takes on or off, not '" + value + "'");
      cone.frontFaceCulling = value == "on";
    } else {
      throw UsageError("cone: unknown setting --" + kv + " (cone settings: --variant=NAME, --front-face-culling=on|off)");
    }
  }
  return cone;
}
#endif

}  // namespace

void checkMethod(const std::string& name, const Options& options) {
  auto names = methodNames();
  if (std::find(names.begin(), names.end(), name) == names.end()) makeMethod(name, nullptr, options);  // throws
#ifdef CONESHADOW_HAS_CONE
  if (name == "cone") {
    coneOptions(options);
    return;
  }
#endif
  if (!options.extra.empty())
    throw UsageError(name + " takes no setting --" + options.extra.front());
}

std::unique_ptr<ShadowMethod> makeMethod(const std::string& name, vk::Context* ctx, const Options& options) {
  (void)ctx;
  (void)options;
  if (name == "embree") return std::make_unique<EmbreeReference>();
#ifdef CONESHADOW_HAS_CONE
  if (name == "cone") {
    CS_CHECK(ctx, "the cone method needs a Vulkan device");
    return makeConeMethod(*ctx, coneOptions(options));
  }
#endif
#ifdef CONESHADOW_HAS_SHADOWMAPS
  if (name == "cubesm") {
    CS_CHECK(ctx, "the cubesm method needs a Vulkan device");
    CubeSmOptions sm;
    if (options.smResolution) sm.resolution = options.smResolution;
    if (options.smNoPcf) sm.pcf = false;
    sm.planeBias = options.smPlaneBias;
    return makeCubeShadowMap(*ctx, sm);
  }
  if (name == "rmsm") {
    CS_CHECK(ctx, "the rmsm method needs a Vulkan device");
    RmsmOptions rm;
    if (options.rmsmPool) rm.poolBytes = options.rmsmPool;
    if (options.rmsmPage) rm.pageSize = options.rmsmPage;
    if (options.rmsmMaxRes) rm.maxResolution = options.rmsmMaxRes;
    rm.cached = options.rmsmCached;
    rm.planeBias = options.smPlaneBias;
    return makeRmsm(*ctx, rm);
  }
#endif
  std::string all;
  for (auto& n : methodNames()) all += (all.empty() ? "" : ", ") + n;
  throw UsageError("unknown method '" + name + "' (methods: " + all + ")");
}

}  // namespace cs
