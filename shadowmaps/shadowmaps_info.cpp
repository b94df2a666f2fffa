// The cube shadow map, RMSM, RTW and ASM in the method registry: their settings, compare's sweeps (face
// resolution; page pool, finest level, matching and analysis resolution; map resolution, analysis,
// importance functions, tessellation; memory, node resolution, analysis fraction) and the factories.
#include "method/registry.h"
#include "shadowmaps/asm.h"
#include "shadowmaps/asm_shared.h"
#include "shadowmaps/cube_sm.h"
#include "shadowmaps/rmsm.h"
#include "shadowmaps/rtw.h"
#include "shadowmaps/rtw_shared.h"
#include "vk/context.h"

namespace cs {

namespace {

const SettingSpec kPlaneBias = {"plane-bias", "", "receiver-plane depth bias instead of slope-scaled", {}};
const SettingSpec kCull = {"sm-cull", "on|off",
                           "frustum culling of triangle clusters per face or superpage (default on; the same result)", {},
                           /*tuning=*/true};

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

RtwOptions rtwOptions(const Settings& s) {
  RtwOptions o;
  o.resolution = s.count("rtw-resolution", 16, 16384, o.resolution);
  o.cells = s.count("rtw-cells", 2, RTW_MAX_CELLS, o.resolution / 4);
  if (o.cells > o.resolution)
    throw UsageError("rtw: --rtw-cells " + std::to_string(o.cells) + " exceeds the map's " +
                     std::to_string(o.resolution) + " texels a side");
  const std::string analysis = s.choice("rtw-analysis", {"forward", "backward", "hybrid"}, "backward");
  o.analysis = analysis == "forward" ? RtwAnalysis::Forward : analysis == "hybrid" ? RtwAnalysis::Hybrid : RtwAnalysis::Backward;
  if (s.has("rtw-importance")) o.functions = parseRtwFunctions(s.values().at("rtw-importance"), o.analysis);
  o.alpha = float(s.number("rtw-alpha", 0.0, 1.0, o.alpha));
  o.beta = float(s.number("rtw-beta", 0.0, 100.0, o.beta));
  o.blurSigma = float(s.number("rtw-blur", 0.0, 64.0, o.blurSigma));
  o.forwardResolution = s.count("rtw-forward-res", 2, 16384, o.cells);
  if (o.forwardResolution < o.cells || o.forwardResolution > o.resolution)
    throw UsageError("rtw: --rtw-forward-res " + std::to_string(o.forwardResolution) +
                     " must lie between the cell count (" + std::to_string(o.cells) + ") and the map resolution");
  o.tessellation = float(s.number("rtw-tessellation", 0.0, 100.0, o.tessellation));
  o.warpBias = float(s.number("rtw-warp-bias", 1.0, 64.0, o.warpBias));
  o.pcf = !s.present("sm-no-pcf");
  o.planeBias = s.present("plane-bias");
  o.cull = s.onOff("sm-cull", o.cull);
  return o;
}

AsmOptions asmOptions(const Settings& s) {
  AsmOptions o;
  o.nodeResolution = s.count("asm-node-res", 16, 4096, o.nodeResolution);
  o.cells = s.count("asm-cells", 2, 16, o.cells);
  if (o.nodeResolution % o.cells)
    throw UsageError("asm: --asm-cells " + std::to_string(o.cells) + " does not divide the node resolution " +
                     std::to_string(o.nodeResolution));
  o.memoryBytes = s.bytes("asm-memory", o.memoryBytes);
  o.idTest = s.onOff("asm-id-test", o.idTest);
  const uint64_t nodeBytes = asmSlotBytes(o.nodeResolution, o.idTest);
  if (o.memoryBytes < 7 * nodeBytes)
    throw UsageError("asm: --asm-memory " + byteSizeLabel(o.memoryBytes) + " holds fewer than the six roots and one "
                     "child of " + std::to_string(o.nodeResolution) + "² (" + byteSizeLabel(7 * nodeBytes) + ")");
  o.budgetMs = s.number("asm-budget-ms", 0.0, 1e6, o.budgetMs);
  o.analysisStep = s.count("asm-analysis", 1, 16, o.analysisStep);
  o.maxDepth = s.count("asm-max-depth", 1, ASM_MAX_DEPTH, asmMaxDepth(o.nodeResolution, o.cells));
  o.lodBias = float(s.number("asm-lod-bias", 0.0, 4.0, o.lodBias));
  o.pcf = !s.present("sm-no-pcf");
  o.planeBias = s.present("plane-bias");
  o.cull = s.onOff("sm-cull", o.cull);
  return o;
}

}  // namespace

MethodInfo rtwMethodInfo() {
  MethodInfo m;
  m.name = "rtw";
  m.summary = "rectilinear texture warping: one warped map per cube face, texels where the importance is";
  m.settings = {
      {"rtw-resolution", "N", "texels per warped face side (default 1024)", {}},
      {"rtw-cells", "N", "super-cells per axis of the warp maps (default resolution / 4)", {}},
      {"rtw-analysis", "NAME", "importance from the samples (backward), the light's depth image (forward) or both",
       {"backward", "forward", "hybrid"}},
      {"rtw-importance", "LIST",
       "importance functions, multiplied: view, distance, edge (forward, hybrid), normal; or uniform (identity "
       "warp). Default: view,distance,normal (backward), view,distance,edge,normal (forward, hybrid)",
       {}},
      {"rtw-alpha", "A", "edge function's importance away from edges (default 0.001)", {}},
      {"rtw-beta", "B", "normal function's bonus for surfaces facing the eye (default 2)", {}},
      {"rtw-blur", "SIGMA", "Gaussian blur of the 1-D importance, in cells (default 1.5; 0 = none)", {}},
      {"rtw-forward-res", "M", "texels a side of the forward depth image per face (default = cells)", {}},
      {"rtw-tessellation", "PCT",
       "subdivide triangles whose warped edges exceed PCT % of the map side (default 2.5, the paper's; 0 = off)", {}},
      {"rtw-warp-bias", "F", "scale on the slope bias's texel, for the warp's non-linearity (default 1)", {}},
      {"sm-no-pcf", "", "one depth tap instead of 2x2 PCF", {}},
      kPlaneBias,
      kCull,
  };
  m.check = [](const Settings& s) { (void)rtwOptions(s); };
  m.make = [](vk::Context* ctx, const Settings& s) -> std::unique_ptr<ShadowMethod> {
    CS_CHECK(ctx, "the rtw method needs a Vulkan device");
    return makeRtw(*ctx, rtwOptions(s));
  };
  // The map's side (a quarter, then the same texels as a 1024² cube map), then at 1024² the other
  // analyses, the plain view-and-distance importance, and no tessellation (straight warped edges).
  m.sweep = [](const Settings& s) {
    std::vector<SweepPoint> points;
    for (uint32_t r : {512u, 1024u})
      points.push_back({"rtw@" + std::to_string(r), s.with("rtw-resolution", std::to_string(r)).without("rtw-cells"),
                        r == RtwOptions{}.resolution});
    const Settings at1024 = s.with("rtw-resolution", "1024").without("rtw-cells");
    points.push_back({"rtw@1024,forward", at1024.with("rtw-analysis", "forward").without("rtw-importance")});
    points.push_back({"rtw@1024,hybrid", at1024.with("rtw-analysis", "hybrid").without("rtw-importance")});
    points.push_back({"rtw@1024,view+distance", at1024.with("rtw-importance", "view,distance")});
    points.push_back({"rtw@1024,no-tess", at1024.with("rtw-tessellation", "0")});
    return points;
  };
  m.unsupported = [](const vk::Context& ctx, const Settings&) {
    return ctx.geometryShader ? std::string() : std::string("needs the geometryShader feature, which this device lacks");
  };
  return m;
}

MethodInfo asmMethodInfo() {
  MethodInfo m;
  m.name = "asm";
  m.progressive = true;
  m.summary = "adaptive shadow maps: a tree of nodes per cube face, refined over frames where shadow edges are too coarse";
  m.settings = {
      {"asm-node-res", "N", "texels a side of every node (default 256)", {}},
      {"asm-cells", "C", "cells a side of a node, each may hold a child at C x the resolution (default 4)", {}},
      {"asm-memory", "BYTES", "node pool, roots included (default 32M)", {}},
      {"asm-budget-ms", "MS", "time for new nodes per frame by the calibrated cost model (default 30; 0 = no limit)", {}},
      {"asm-analysis", "K", "analyse every K-th pixel in x and y (default 1; the paper's eighth is about 3)", {}},
      {"asm-max-depth", "L", "deepest node level (default: as deep as fp32 face coordinates resolve)", {}},
      {"asm-lod-bias", "L", "refine until texels are 2^L times finer than pixels (default 0: matched, the paper's)", {}},
      {"asm-id-test", "on|off",
       "paper 001's ID + depth test: a texel whose nearest triangle is the sample's own lights it, the depth "
       "comparison decides the rest (default off; twice the bytes a node; needs the geometryShader feature)",
       {}},
      {"sm-no-pcf", "", "one depth tap instead of 2x2 PCF", {}},
      kPlaneBias,
      kCull,
  };
  m.check = [](const Settings& s) { (void)asmOptions(s); };
  m.make = [](vk::Context* ctx, const Settings& s) -> std::unique_ptr<ShadowMethod> {
    CS_CHECK(ctx, "the asm method needs a Vulkan device");
    return makeAdaptiveShadowMap(*ctx, asmOptions(s));
  };
  // The memory limit, then at 32M the node resolution, finer-than-matched texels and the analysis fraction.
  m.sweep = [](const Settings& s) {
    std::vector<SweepPoint> points;
    for (uint64_t mem : {8ull << 20, 32ull << 20})
      points.push_back({"asm@" + byteSizeLabel(mem), s.with("asm-memory", std::to_string(mem)), mem == AsmOptions{}.memoryBytes});
    const Settings at32 = s.with("asm-memory", std::to_string(32ull << 20));
    points.push_back({"asm@32M,node512", at32.with("asm-node-res", "512").without("asm-cells")});
    points.push_back({"asm@32M,lod+1", at32.with("asm-lod-bias", "1")});
    points.push_back({"asm@32M,analysis3x", at32.with("asm-analysis", "3")});
    points.push_back({"asm@32M,id", at32.with("asm-id-test", "on")});
    return points;
  };
  m.unsupported = [](const vk::Context& ctx, const Settings& settings) {
    return !asmOptions(settings).idTest || ctx.geometryShader
               ? std::string()
               : std::string("--asm-id-test on needs the geometryShader feature, which this device lacks");
  };
  return m;
}

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
      points.push_back({"cubesm@" + std::to_string(r), s.with("sm-resolution", std::to_string(r)), r == CubeSmOptions{}.resolution});
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
      points.push_back({"rmsm@" + byteSizeLabel(pool), s.with("rmsm-pool", std::to_string(pool)), pool == RmsmOptions{}.poolBytes});
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
