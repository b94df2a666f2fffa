#version 450
#extension GL_GOOGLE_include_directive : require
// RTW backward analysis (paper 004 §4.1), one invocation per pixel: every lit sample projects into its
// cube face and raises its super-cell's importance to the product of the enabled functions (§5): I_DV
// (implied: the sample is in the view), I_D, I_SN, and in the hybrid analysis I_E read from the light's
// depth image (rtw_forward.comp, RTW_FORWARD_EDGES). After a forward analysis (RTW_SAMPLE_COVERAGE) the
// same pass gives every sample's cell a floor of alpha times its value. A cell keeps the largest value of its samples
// (§6.3: "only keeping the highest value point"); importance is >= 0, so its float bits order as uints.
// bindings: 0 = position (vec4 per pixel), 1 = normal (vec4 per pixel, w = N·L̂), 2 = importance (uint
//           per cell, 6 faces of n x n, row-major), 3 = edges (float per depth-image texel, 6 faces of
//           m x m; hybrid only), 4 = the view (RtwView)
#include "shadowmaps/rtw_shared.h"
layout(local_size_x = RTW_THREADS) in;
layout(std430, binding = 0) readonly buffer Position { vec4 position[]; };
layout(std430, binding = 1) readonly buffer Normal { vec4 normal[]; };
layout(std430, binding = 2) buffer Importance { uint importance[]; };
layout(std430, binding = 3) readonly buffer Edges { float edges[]; };
layout(std430, binding = 4) readonly buffer View { RtwView view; };
layout(push_constant) uniform Push { RtwImportancePush pc; };

void main() {
  uint i = CS_FLAT_INDEX(RTW_THREADS);
  if (i >= pc.width * pc.height) return;
  vec4 p = position[i];
  vec4 nl = normal[i];
  vec3 d = p.xyz - pc.light.xyz;
  if (!litSample(p, nl) || length(d) <= pc.minDistance) return;
  uint face = cubeFace(d);
  vec2 st = faceST(faceSpace(face, d));
  float value = 1.0f;
  if ((pc.functions & RTW_UNIFORM) == 0u) {
    vec3 fromEye = p.xyz - view.eye.xyz;
    if ((pc.functions & RTW_DISTANCE) != 0u) value *= rtwDistanceImportance(dot(fromEye, view.forward.xyz), view.eye.w);
    if ((pc.functions & RTW_NORMAL) != 0u) {
      float len = length(fromEye);
      value *= rtwNormalImportance(len > 0.0 ? -dot(nl.xyz, fromEye) / len : 1.0, pc.beta);
    }
    if (pc.mode == RTW_SAMPLE_COVERAGE) {
      value *= pc.alpha;  // a floor under the forward analysis: the cell stays live, at little width
    } else if ((pc.functions & RTW_EDGE) != 0u) {
      uint m = pc.forwardRes;
      uvec2 t = uvec2(clamp(floor(st * float(m)), vec2(0.0), vec2(float(m - 1u))));
      value *= edges[face * m * m + t.y * m + t.x];
    }
  }
  uint cx = rtwCell(st.x, pc.cells), cy = rtwCell(st.y, pc.cells);
  atomicMax(importance[face * pc.cells * pc.cells + cy * pc.cells + cx], floatBitsToUint(max(value, 0.0)));
}
