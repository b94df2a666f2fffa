// The method registry: every shadow path plugs in here under its CLI name.
#include "app/methods.h"

#include "reference/embree_reference.h"
#ifdef CONESHADOW_HAS_CONE
#include "traversal/cone_method.h"
#endif

namespace cs {

std::vector<std::string> methodNames() {
  std::vector<std::string> names = {"embree"};
#ifdef CONESHADOW_HAS_CONE
  names.push_back("cone");
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
  std::string all;
  for (auto& n : methodNames()) all += (all.empty() ? "" : ", ") + n;
  throw UsageError("unknown method '" + name + "' (methods: " + all + ")");
}

}  // namespace cs
