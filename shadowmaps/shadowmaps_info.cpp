// The cube shadow map and RMSM in the method registry: their settings, compare's sweeps (face
// resolution; page pool, finest level, matching and analysis resolution) and the factories.
#include "eval/registry.h"
#include "shadowmaps/cube_sm.h"
#include "shadowmaps/rmsm.h"

namespace cs {

namespace {

const SettingSpec kPlaneBias = {"plane-bias", "", "receiver-plane depth bias instead of slope-scaled", {}};
const SettingSpec kCull = {"sm-cull", "on|off",
                           "frustum culling of triangle clusters per face or superpage (default on; the same result)", {}};

CubeSmOptions cubeOptions(const Settings& s) {
  CubeSmOptions sm;
  sm.resolution = s.count("sm-resolution", 16, 16384, sm.resolution);
  sm.pcf = !s.present("sm-no-pcf");
  sm.planeBias = s.present("plane-bias");
  sm.cull = s.onOff("sm-cull", sm.cull);
  return sm;
}

RmsmOptions rmsmOptions(const Settings& s) {
  RmsmOptions rm;
  rm.poolBytes = s.bytes("rmsm-pool", rm.poolBytes);
  rm.pageSize = s.count("rmsm-page", 4, 4096, rm.pageSize);
  rm.maxResolution = s.count("rmsm-max-res", 64, 1u << 20, rm.maxResolution);
  rm.lodBias = float(s.number("rmsm-lod-bias", -4.0, 4.0, rm.lodBias));
  rm.analysisStep = s.count("rmsm-analysis", 1, 16, rm.analysisStep);
  if (rm.analysisStep & (rm.analysisStep - 1))
    throw UsageError("rmsm: --rmsm-analysis wants 1, 2, 4, 8 or 16 (every k-th pixel), got " +
                     std::to_string(rm.analysisStep));
  rm.cached = s.present("rmsm-cached");
  rm.planeBias = s.present("plane-bias");
  rm.cull = s.onOff("sm-cull", rm.cull);
  rm.superpageSize = s.count("rmsm-superpage", 4, 1u << 20, rm.superpageSize);
  rm.minOccupancy = float(s.number("rmsm-occupancy", 0.0, 1.0, rm.minOccupancy));
  // The layout's own limits (a power-of-two page, a pool holding six roots), without the device's.
  try {
    (void)sm::rmsmLayout(rm, UINT64_MAX);
  } catch (const Error& e) {
    throw UsageError(std::string("rmsm: ") + e.what());
  }
  return rm;
}

}  // namespace

MethodInfo cubeShadowMapMethodInfo() {
  MethodInfo m;
  m.name = "cubesm";
  m.summary = "a cube shadow map with slope-scaled bias and 2x2 PCF";
  m.settings = {{"sm-resolution", "N", "texels per cube face side (default 2048)", {}},
                {"sm-no-pcf", "", "one depth tap instead of 2x2 PCF", {}},
                kPlaneBias,
                kCull};
  m.check = [](const Settings& s) { (void)cubeOptions(s); };
  m.make = [](vk::Context* ctx, const Settings& s) -> std::unique_ptr<ShadowMethod> {
    CS_CHECK(ctx, "the cubesm method needs a Vulkan device");
    return makeCubeShadowMap(*ctx, cubeOptions(s));
  };
  m.sweep = [](const Settings& s) {
    std::vector<SweepPoint> points;
    for (uint32_t r : {512u, 1024u, 2048u})
      points.push_back({"cubesm@" + std::to_string(r), s.with("sm-resolution", std::to_string(r))});
    return points;
  };
  return m;
}

MethodInfo rmsmMethodInfo() {
  MethodInfo m;
  m.name = "rmsm";
  m.summary = "resolution-matched shadow maps: virtual cube faces, pages where the samples need them";
  m.settings = {
      {"rmsm-pool", "BYTES", "physical page pool (default 16M; too small -> coarser finest level, reported)", {}},
      {"rmsm-page", "N", "page side in texels (default 32)", {}},
      {"rmsm-max-res", "N", "finest effective resolution per face side (default 32768)", {}},
      {"rmsm-lod-bias", "L",
       "request pages L levels finer than the resolution-matched level (default 0; 1 = texels half a pixel's "
       "footprint, 4x the pages)",
       {}},
      {"rmsm-analysis", "K",
       "pages requested by every K-th pixel in x and y (1, 2, 4, 8, 16; default 1); K > 1 also keeps a 256² "
       "backup level resident",
       {}},
      {"rmsm-cached", "", "keep pages across frames (static scenes)", {}},
      {"rmsm-superpage", "N", "texels a superpage side (a power of two >= the page; default 1024)", {}},
      {"rmsm-occupancy", "F", "split a superpage's box while its pages fill less than F of it (default 0.5; 0 = plain)", {}},
      kPlaneBias,
      kCull,
  };
  m.check = [](const Settings& s) { (void)rmsmOptions(s); };
  m.make = [](vk::Context* ctx, const Settings& s) -> std::unique_ptr<ShadowMethod> {
    CS_CHECK(ctx, "the rmsm method needs a Vulkan device");
    return makeRmsm(*ctx, rmsmOptions(s));
  };
  // Pool size, then at the default pool the finest level (a 4096² cap per face), the analysis's matching
  // (one level finer than resolution-matched) and the analysis resolution (every 2nd and 8th pixel).
  m.sweep = [](const Settings& s) {
    std::vector<SweepPoint> points;
    for (uint64_t pool : {4ull << 20, 16ull << 20})
      points.push_back({"rmsm@" + byteSizeLabel(pool), s.with("rmsm-pool", std::to_string(pool))});
    const Settings at16 = s.with("rmsm-pool", std::to_string(16ull << 20));
    points.push_back({"rmsm@16M,max4096", at16.with("rmsm-max-res", "4096")});
    points.push_back({"rmsm@16M,lod+1", at16.with("rmsm-lod-bias", "1")});
    for (uint32_t k : {2u, 8u})
      points.push_back({"rmsm@16M,analysis" + std::to_string(k) + "x", at16.with("rmsm-analysis", std::to_string(k))});
    return points;
  };
  // Rebuilt every frame; cached too where that pays: a static scene seen by a moving camera (in a moving
  // scene rmsm drops its cache whenever the geometry changes, so that row runs only when asked for).
  m.dynamicRows = [](const Settings& s, bool staticGeometry) {
    std::vector<SweepPoint> rows = {{"rmsm", s.without("rmsm-cached")}};
    if (staticGeometry || s.present("rmsm-cached")) rows.push_back({"rmsm (cached)", s.with("rmsm-cached", "")});
    return rows;
  };
  return m;
}

}  // namespace cs
