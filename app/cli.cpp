// Command-line parsing for the coneshadow CLI.
#include "app/cli.h"
#include "app/methods.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace cs {

std::string usageText() {
  return R"(coneshadow — alias-free hard shadows from point lights, judged against an Embree reference

usage:
  coneshadow render [SCENE] [options]   render one frame with a shadow method, compare it with Embree
  coneshadow compare [SCENE] [options]  every method (and a small quality/memory sweep) on every view,
                                        against one Embree reference; writes a report
  coneshadow info SCENE                 triangles (flattened over node instances), bounds, cameras, lights
  coneshadow results-table DIR...       markdown table of the compare results in each DIR (the README's)
  coneshadow devices                    list the Vulkan devices
  coneshadow help                       this text

SCENE is a glTF 2.0 file (.gltf or .glb) or a BART scene (.aff, with the files it includes; e.g. the
museum, robots and kitchen of the BART benchmark). Without SCENE, render uses the built-in scene (a lit
room with clutter and a furball; views: wall, fur, room, ceiling), and `info builtin` describes it.

render options:
  --method M          shadow method: embree (the reference), cone (the cone hierarchy), cubesm, rmsm
  --width W --height H   resolution of the camera pass (default 512x512)
  --view NAME         camera by name (default: the scene's first camera; automatic when it has none)
  --light X,Y,Z       point light position (default: the scene's first point light; automatic if none)
  --time T            a BART .aff scene at scene time T (default: the start of its animation range); its
                      views: view (the file's v) and animated (its camera track at T)
  --out DIR           write shaded_<m>.png, mask_<m>.png, diff_<m>.png, results.json, results.csv (default out)
  --dump DIR          also write position.pfm, normal.pfm, visibility_<m>.pfm, band.pfm, meta.json
  --traversal-memory BYTES   cone path: bound on the traversal's pair buffers (e.g. 64M, 256K)
  --variant=NAME      cone path, paper 002 Table 1: PreciseSorted (default), Precise, SpheresSorted, Spheres,
                      PreciseSEA (early accept), PreciseEATP, PreciseSEATP (early accept + two-pass)
  --test=T, --early-accept=on|off, --two-pass=on|off   cone path switches, applied after --variant:
                      T = precise or sphere; early accept needs the precise test
  --blocker-solid-angle=SR, --blocker-max-fraction=F, --update-min-finished=F   two-pass: blockers are
                      triangles subtending >= SR at the light (default 1/4096 of the sphere), the largest
                      F of all at most (0.125); the update is skipped below F finished rays (0.1)
  --front-face-culling=on   cone path: only triangles facing away from the light cast; exact only when
                      every caster is a closed mesh with consistent winding (wrong on the built-in fur)
  --ray-order O       cone path: hilbert (sorted rays, default) or screen (2x2 Morton screen order)
  --sm-resolution N   cubesm: texels per cube face side (default 2048)
  --sm-no-pcf         cubesm: one depth tap instead of 2x2 PCF
  --plane-bias        cubesm, rmsm: receiver-plane depth bias instead of slope-scaled
  --rmsm-pool BYTES   rmsm: physical page pool (default 16M; too small -> coarser finest LOD, reported)
  --rmsm-page N       rmsm: page side in texels (default 32)
  --rmsm-max-res N    rmsm: finest effective resolution per face side (default 32768)
  --rmsm-lod-bias L   rmsm: request pages L levels finer than the resolution-matched level (default 0;
                      1 = texels half a pixel's footprint, 4x the pages)
  --rmsm-analysis K   rmsm: analysis resolution, pages requested by every K-th pixel in x and y (1, 2, 4,
                      8, 16; default 1); K > 1 also keeps a 256² backup level resident on the faces in use
  --rmsm-cached       rmsm: keep pages across frames (static scenes)
  --frames N          timed frames after one warm-up; medians are reported (default 3)
  --device D          Vulkan device by index or name substring (see `coneshadow devices`);
                      default: a discrete GPU if there is one, else lavapipe
  --validation        enable VK_LAYER_KHRONOS_validation (slow; for debugging)
  --quiet             print only errors and the final summary line

compare options (defaults: all views, all methods, 256x256, 3 frames, --out compare):
  --methods A,B       methods to compare (default: all registered); each runs a small sweep:
                      cubesm@512, @1024, @2048 (face resolution); rmsm@4M and @16M (page pool),
                      @16M,max4096 (finest LOD capped at 4096²), @16M,lod+1 (pages one level finer than
                      resolution-matched), @16M,analysis2x and 8x (analysis down-sampled: pages requested
                      by every 2nd, 8th pixel); cone at its default traversal memory, 1/64 and 1/1000 of it
  --views V1,V2       cameras by name (default: every camera of the scene; the automatic one if none)
  --width, --height, --frames, --device, --validation, --quiet: as for render
  writes into --out DIR: results.json, results.csv (one row per view and method setting, "setting" in
  stats), <view>_<setting>_{shaded,mask,diff}.png, <view>_closeups.png (the same crop of every setting,
  Embree first, enlarged nearest-neighbour), report.md, report.html, speed_vs_error.svg/.png
  --scaling           scaling runs instead: one view (the first of --views) at 256², 512², 1024², 2048², then
                      at --width x --height with the scene as 1, 4, 16, ... translated copies side by side;
                      methods embree, cone, cubesm, rmsm at their defaults (or --methods); a point a method
                      cannot run says "failed: <reason>"; writes scaling.md, scaling.json, scaling.csv,
                      scaling_resolution.svg/.png, scaling_triangles.svg/.png
  --scaling-max-triangles N   bound of the triangle sweep (default 10000000)
  --light-distances D1,D2,...   light sweep instead: one view (the first of --views) at --width x --height,
                      the light (--light, the scene's or the automatic one) moved out along its direction
                      from the scene's centre to D scene diagonals (e.g. 1,100,1000,10000); every method
                      against Embree at each distance;
                      writes light_distances.md/.json/.csv, light_distances.svg/.png
  --animate N         dynamic scene instead: N frames over the scene's motion (the built-in motion's cycle,
                      a glTF file's node animation: translation/rotation/scale channels, or a BART file's
                      keyframes and animated triangles over its `a` range, its `animated` view riding the
                      camera track), each method kept
                      across frames so every frame pays its per-frame cost (Embree BVH build, cone upload +
                      tree, rmsm pages); writes dynamic.md, results.json, results.csv (one row per method
                      and frame, with frame and time in stats)
  --moving-camera     with --animate: the camera orbits its target (a swing inside the built-in room); a
                      file without animation needs it, and then rmsm also runs cached, as the row rmsm (cached)

exit codes:
  0  success
  1  failure: a malformed scene, an unusable device, a write error (one line on stderr says which)
  2  usage error: an unknown command or option, a bad value

examples:
  coneshadow render --view fur --width 1024 --height 1024
  coneshadow render /usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb --out engine
  coneshadow info /usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb
)";
}

namespace {

uint32_t parseUint(const std::string& flag, const std::string& v, uint32_t lo, uint32_t hi) {
  errno = 0;
  char* end = nullptr;
  long long x = std::strtoll(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0' || errno || x < lo || x > hi)
    throw UsageError(flag + " wants a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                     "], got '" + v + "'");
  return uint32_t(x);
}

glm::vec3 parseVec3(const std::string& flag, const std::string& v) {
  glm::vec3 out;
  std::stringstream ss(v);
  std::string part;
  int i = 0;
  while (std::getline(ss, part, ',')) {
    char* end = nullptr;
    errno = 0;
    float x = std::strtof(part.c_str(), &end);
    if (i >= 3 || part.empty() || *end != '\0' || errno || !std::isfinite(x))
      throw UsageError(flag + " wants three finite numbers X,Y,Z, got '" + v + "'");
    out[i++] = x;
  }
  if (i != 3) throw UsageError(flag + " wants three finite numbers X,Y,Z, got '" + v + "'");
  return out;
}

// "64M", "4096", "1.5G", "512K": bytes, with an optional binary suffix.
uint64_t parseBytes(const std::string& flag, const std::string& v) {
  char* end = nullptr;
  errno = 0;
  double x = std::strtod(v.c_str(), &end);
  double mult = 1;
  std::string suffix = end ? std::string(end) : "";
  if (suffix == "K" || suffix == "KiB" || suffix == "k") mult = 1024.0;
  else if (suffix == "M" || suffix == "MiB") mult = 1024.0 * 1024;
  else if (suffix == "G" || suffix == "GiB") mult = 1024.0 * 1024 * 1024;
  else if (!suffix.empty()) x = -1;
  if (v.empty() || errno || !(x * mult >= 1) || x * mult > 1e15)  // >= 1: "0.5" is no size (0 would mean the default)
    throw UsageError(flag + " wants a positive size in bytes (e.g. 64M, 512K, 4096), got '" + v + "'");
  return uint64_t(x * mult);
}

}  // namespace

Options parseArgs(int argc, char** argv) {
  Options o;
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty()) throw UsageError("no command given (try: coneshadow help)");
  o.command = args[0];
  if (o.command == "--help" || o.command == "-h") o.command = "help";
  if (o.command != "render" && o.command != "compare" && o.command != "info" && o.command != "devices" &&
      o.command != "help")
    throw UsageError("unknown command '" + o.command + "' (commands: render, compare, info, devices, help)");
  bool widthSet = false, heightSet = false, outSet = false;
  auto list = [](const std::string& flag, const std::string& v) {
    std::vector<std::string> items;
    std::stringstream ss(v);
    std::string part;
    while (std::getline(ss, part, ','))
      if (!part.empty()) items.push_back(part);
    if (items.empty()) throw UsageError(flag + " wants a comma-separated list, got '" + v + "'");
    return items;
  };
  for (size_t i = 1; i < args.size(); ++i) {
    std::string a = args[i];
    auto value = [&](const std::string& flag) -> std::string {
      if (i + 1 >= args.size()) throw UsageError(flag + " needs a value");
      return args[++i];
    };
    if (a == "--help" || a == "-h") {
      o.command = "help";
    } else if (a == "--method") {
      o.method = value(a);
    } else if (a == "--width") {
      o.width = parseUint(a, value(a), 1, 16384);
      widthSet = true;
    } else if (a == "--height") {
      o.height = parseUint(a, value(a), 1, 16384);
      heightSet = true;
    } else if (a == "--view") {
      o.view = value(a);
    } else if (a == "--light") {
      o.light = parseVec3(a, value(a));
    } else if (a == "--out") {
      o.out = value(a);
      outSet = true;
    } else if (a == "--methods") {
      o.methods = list(a, value(a));
    } else if (a == "--views") {
      o.views = list(a, value(a));
    } else if (a == "--dump") {
      o.dump = value(a);
    } else if (a == "--frames") {
      o.frames = parseUint(a, value(a), 1, 1000);
    } else if (a == "--device") {
      o.device = value(a);
    } else if (a == "--traversal-memory") {
      o.traversalMemory = parseBytes(a, value(a));
    } else if (a == "--ray-order") {
      std::string v = value(a);
      if (v != "hilbert" && v != "screen") throw UsageError("--ray-order wants hilbert or screen, got '" + v + "'");
      o.unsorted = v == "screen";
    } else if (a == "--sm-resolution") {
      o.smResolution = parseUint(a, value(a), 16, 16384);
    } else if (a == "--sm-no-pcf") {
      o.smNoPcf = true;
    } else if (a == "--plane-bias") {
      o.smPlaneBias = true;
    } else if (a == "--rmsm-pool") {
      o.rmsmPool = parseBytes(a, value(a));
    } else if (a == "--rmsm-page") {
      o.rmsmPage = parseUint(a, value(a), 4, 4096);
    } else if (a == "--rmsm-max-res") {
      o.rmsmMaxRes = parseUint(a, value(a), 64, 1u << 20);
    } else if (a == "--rmsm-lod-bias") {
      const std::string v = value(a);
      char* end = nullptr;
      const float bias = std::strtof(v.c_str(), &end);
      if (v.empty() || *end != '\0' || !(bias >= -4.0f && bias <= 4.0f))
        throw UsageError("--rmsm-lod-bias wants a number of levels in [-4, 4], got '" + v + "'");
      o.rmsmLodBias = bias;
    } else if (a == "--time") {
      const std::string v = value(a);
      char* end = nullptr;
      const double t = std::strtod(v.c_str(), &end);
      if (v.empty() || *end != '\0' || !std::isfinite(t)) throw UsageError("--time wants a finite number (scene time), got '" + v + "'");
      o.sceneTime = t;
    } else if (a == "--rmsm-analysis") {
      const uint32_t k = parseUint(a, value(a), 1, 16);
      if (k & (k - 1)) throw UsageError("--rmsm-analysis wants 1, 2, 4, 8 or 16 (every k-th pixel), got " + std::to_string(k));
      o.rmsmAnalysis = k;
    } else if (a == "--rmsm-cached") {
      o.rmsmCached = true;
    } else if (a == "--animate") {
      o.animateFrames = parseUint(a, value(a), 1, 100000);
    } else if (a == "--moving-camera") {
      o.movingCamera = true;
    } else if (a == "--scaling") {
      o.scaling = true;
    } else if (a == "--light-distances") {
      for (const std::string& item : list(a, value(a))) {
        char* end = nullptr;
        double d = std::strtod(item.c_str(), &end);
        if (item.empty() || *end != '\0' || !(d > 0) || !(d <= 1e15))
          throw UsageError("--light-distances wants distances in scene diagonals in (0, 1e15] separated by "
                           "commas, got '" + item + "'");
        o.lightDistances.push_back(d);
      }
    } else if (a == "--scaling-max-triangles") {
      o.scalingMaxTriangles = parseUint(a, value(a), 1, 200000000u);
    } else if (a == "--validation") {
      o.validation = true;
    } else if (a == "--quiet") {
      o.quiet = true;
    } else if (a.rfind("--", 0) == 0 && a.find('=') != std::string::npos) {
      o.extra.push_back(a.substr(2));
    } else if (a.rfind("-", 0) == 0) {
      throw UsageError("unknown option '" + a + "' (try: coneshadow help)");
    } else if (o.scene.empty()) {
      o.scene = a;
    } else {
      throw UsageError("unexpected argument '" + a + "' (one SCENE at most)");
    }
  }
  if (o.command == "compare") {
    if (!widthSet) o.width = 256;
    if (!heightSet) o.height = 256;
    if (!outSet) o.out = "compare";
  }
  if (o.movingCamera && !o.animateFrames) throw UsageError("--moving-camera needs --animate N");
  if (o.animateFrames && o.command != "compare") throw UsageError("--animate is an option of compare");
  if (o.animateFrames && o.scaling) throw UsageError("--animate and --scaling are separate runs; give one of them");
  if (!o.lightDistances.empty() && (o.animateFrames || o.scaling))
    throw UsageError("--light-distances is a run of its own; give it without --animate and --scaling");
  if (!o.lightDistances.empty() && o.command != "compare") throw UsageError("--light-distances is an option of compare");

  if (o.command == "info" && o.scene.empty()) throw UsageError("info needs a SCENE (a .gltf/.glb file, or builtin)");
  checkSettings(o);  // the size settings' own limits, before any work
  return o;
}

}  // namespace cs
