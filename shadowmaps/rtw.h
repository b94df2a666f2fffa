// shadowmaps/: rectilinear texture warping (RTW, paper 004) for an omnidirectional light. CLI name "rtw".
// One warped shadow map of R x R texels per cube face (--rtw-resolution), each with two 1-D warp maps of
// n super-cells (--rtw-cells): the face's unwarped (s, t) maps cell by cell, linearly within a cell, onto
// the map, so texels gather where the analysis says shadows need them. The frame's steps (importance,
// warp maps, the warped geometry pass, the lookup), the bias and the limits: shadowmaps/README.md, "RTW
// (paper 004) per cube face".
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "method/method.h"

namespace cs {
namespace vk { struct Context; }

enum class RtwAnalysis { Forward, Backward, Hybrid };

struct RtwOptions {
  uint32_t resolution = 1024;  // texels per face side (--rtw-resolution)
  uint32_t cells = 0;          // super-cells per axis (--rtw-cells); 0: resolution / 4 (paper: 512 for 2048)
  RtwAnalysis analysis = RtwAnalysis::Backward;
  // RTW_* bits of rtw_shared.h (view, distance, edge, normal, or uniform alone); 0: the analysis's
  // default (backward: view, distance, normal; forward and hybrid: view, distance, edge, normal).
  uint32_t functions = 0;
  float alpha = 0.001f;        // I_E away from edges (paper: 0.001)
  float beta = 2.0f;           // I_SN's bonus (paper: 2)
  float blurSigma = 1.5f;      // cells (paper: 3 of 512 cells; 1.5 of the default 256)
  uint32_t forwardResolution = 0;  // texels a side of the forward depth image per face; 0: = cells
  // Longest warped edge a sub-triangle keeps, % of the map's side (paper 004 §6.1: 2.5; 0: off). Off, a
  // straight warped edge stands for a curve across every cell it crosses, and on a zoomed view the
  // misplaced shadow edges cost more than the warp gains (measured: shadowmaps/README.md, RTW).
  float tessellation = 2.5f;
  float warpBias = 1.0f;       // scale on the bias's texel
  float constantBias = 2.0f;   // in units of the epsilon policy's eps (as cube_sm.h)
  float slopeBias = 1.5f;      // texels
  float maxSlope = 10.0f;
  bool pcf = true;
  bool planeBias = false;
  bool cull = true;            // per-face frustum culling of triangle clusters (depth_pass.h); same result
  bool keepWarp = false;       // tests: stats "warp_knots" holds every face's knots
};

// The functions the options' analysis uses (RtwOptions::functions resolved), RTW_* bits.
uint32_t rtwFunctions(const RtwOptions& options);
// Parses a list "view,distance,edge,normal" (any order, any subset) or "uniform"; UsageError otherwise,
// or when the list does not suit the analysis (edge needs forward or hybrid; backward implies view).
uint32_t parseRtwFunctions(const std::string& list, RtwAnalysis analysis);

// The knots of one axis (n + 1 values) from its collapsed importance (n values), as rtw_warp.comp builds
// them: blur (cells with no importance stay at zero), cumulative share of the total; the identity when
// the total is zero. The CPU reference of the tests.
std::vector<float> rtwKnots(const std::vector<float>& importance, float sigma);

// MethodOutput: visibility per pixel in [0, 1] (PCF) or {0, 1}; stages "analysis" (importance; forward
// and hybrid: the depth images too), "warp", "faces" (geometry passes and copies), "lookup"; stats:
// resolution, cells, analysis, functions, mer (per face [MER_s, MER_t]: the resolution a uniform face
// would need to match the finest cell), mer_max, culled_cells (per face, fraction of cells of zero width,
// both axes), active_faces, culled_samples (lit samples in culled cells, 0 by construction: their lookup would be a guess),
// tessellation, bias terms, triangles_drawn. Throws cs::Error on the limits above.
std::unique_ptr<ShadowMethod> makeRtw(vk::Context& ctx, const RtwOptions& options = {});

}  // namespace cs
