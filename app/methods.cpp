// The method registry: every shadow path plugs in here under its CLI name.
#include "app/methods.h"

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

std::unique_ptr<ShadowMethod> makeMethod(const std::string& name, vk::Context* ctx, const Options& options) {
  (void)ctx;
  (void)options;
  if (name == "embree") return std::make_unique<EmbreeReference>();
#ifdef CONESHADOW_HAS_CONE
  if (name == "cone") {
    CS_CHECK(ctx, "the cone method needs a Vulkan device");
    ConeOptions cone;
    if (options.traversalMemory) cone.traversalMemoryBytes = options.traversalMemory;
    cone.sorted = !options.unsorted;
    return makeConeMethod(*ctx, cone);
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
