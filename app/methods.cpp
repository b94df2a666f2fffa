// The method registry: every shadow path plugs in here under its CLI name.
#include "app/methods.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>

#include "reference/embree_reference.h"
#ifdef CONESHADOW_HAS_CONE
#include "traversal/cone_method.h"
#include "traversal/traversal.h"
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
// Cone settings from the CLI; throws UsageError for anything it does not take. --variant=NAME (paper 002
// Table 1) is applied first, then the switches, whatever their order on the command line, so a switch
// amends a variant: --variant=PreciseSorted --two-pass=on is PreciseSTP.
ConeOptions coneOptions(const Options& options) {
  ConeOptions cone;
  if (options.traversalMemory) cone.traversalMemoryBytes = options.traversalMemory;
  cone.sorted = !options.unsorted;
  const std::string settings =
      "cone settings: --variant=NAME, --test=precise|sphere, --early-accept=on|off, --two-pass=on|off, "
      "--front-face-culling=on|off, --blocker-solid-angle=SR, --blocker-max-fraction=F, --update-min-finished=F";
  std::vector<std::pair<std::string, std::string>> switches;
  for (const std::string& kv : options.extra) {
    const size_t eq = kv.find('=');
    const std::string key = kv.substr(0, eq), value = eq == std::string::npos ? "" : kv.substr(eq + 1);
    if (key != "variant") {
      switches.emplace_back(key, value);
      continue;
    }
    if (!applyConeVariant(value, cone)) {
      std::string all;
      for (auto& n : coneVariantNames()) all += (all.empty() ? "" : ", ") + n;
      throw UsageError("cone: unknown variant '" + value + "' (variants: " + all + ")");
    }
    if (options.unsorted && cone.sorted)
      throw UsageError("cone: variant '" + value + "' is sorted, but --ray-order screen asks for unsorted rays");
  }
  auto onOff = [](const std::string& key, const std::string& value) {
    if (value != "on" && value != "off")
      throw UsageError("cone: --" + key + " takes on or off, not '" + value + "'");
    return value == "on";
  };
  auto fraction = [](const std::string& key, const std::string& value, float lo, float hi) {
    char* end = nullptr;
    const float v = std::strtof(value.c_str(), &end);
    if (value.empty() || *end != '\0' || !(v >= lo && v <= hi))
      throw UsageError("cone: --" + key + " takes a number in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                       "], not '" + value + "'");
    return v;
  };
  for (auto& [key, value] : switches) {
    if (key == "front-face-culling") cone.frontFaceCulling = onOff(key, value);
    else if (key == "early-accept") cone.earlyAccept = onOff(key, value);
    else if (key == "two-pass") cone.twoPass = onOff(key, value);
    else if (key == "test") {
      if (value != "precise" && value != "sphere")
        throw UsageError("cone: --test takes precise or sphere, not '" + value + "'");
      cone.test = value == "sphere" ? ConeTest::Sphere : ConeTest::Precise;
    } else if (key == "blocker-solid-angle") cone.blockerSolidAngle = fraction(key, value, 0.0f, 12.5664f);
    else if (key == "blocker-max-fraction") cone.blockerMaxFraction = fraction(key, value, 0.0f, 1.0f);
    else if (key == "update-min-finished") cone.updateMinFinished = fraction(key, value, 0.0f, 1.0f);
    else throw UsageError("cone: unknown setting --" + key + (value.empty() ? "" : "=" + value) + " (" + settings + ")");
  }
  if (cone.earlyAccept && cone.test == ConeTest::Sphere)
    throw UsageError("cone: early accept needs the precise test (the sphere test cannot prove a cone covered)");
  return cone;
}
#endif

}  // namespace

#ifdef CONESHADOW_HAS_SHADOWMAPS
namespace {
RmsmOptions rmsmOptions(const Options& options) {
  RmsmOptions rm;
  if (options.rmsmPool) rm.poolBytes = options.rmsmPool;
  if (options.rmsmPage) rm.pageSize = options.rmsmPage;
  if (options.rmsmMaxRes) rm.maxResolution = options.rmsmMaxRes;
  rm.lodBias = options.rmsmLodBias;
  rm.analysisStep = options.rmsmAnalysis;
  rm.cached = options.rmsmCached;
  rm.planeBias = options.smPlaneBias;
  return rm;
}
}  // namespace
#endif

void checkSettings(const Options& options) {
#ifdef CONESHADOW_HAS_CONE
  if (options.traversalMemory) {
    // The smallest arena the traversal can make progress in: 4 pairs and one chunk's scratch.
    const uint64_t least = traversal::kMinPairs * sizeof(glm::uvec2) + traversal::chunkScratchBytes(1);
    if (options.traversalMemory < least)
      throw UsageError("--traversal-memory " + std::to_string(options.traversalMemory) + " is too small: the traversal needs at least " +
                       std::to_string(least) + " bytes (4 pairs and one chunk's scratch)");
  }
#endif
#ifdef CONESHADOW_HAS_SHADOWMAPS
  if (options.rmsmPool || options.rmsmPage || options.rmsmMaxRes) {
    try {
      (void)sm::rmsmLayout(rmsmOptions(options), UINT64_MAX);  // no device limit: only the settings' own
    } catch (const Error& e) {
      throw UsageError(e.what());
    }
  }
#endif
}

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
    return makeRmsm(*ctx, rmsmOptions(options));
  }
#endif
  std::string all;
  for (auto& n : methodNames()) all += (all.empty() ? "" : ", ") + n;
  throw UsageError("unknown method '" + name + "' (methods: " + all + ")");
}

}  // namespace cs
