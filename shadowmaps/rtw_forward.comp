#version 450
#extension GL_GOOGLE_include_directive : require
// RTW forward analysis (paper 004 §4.1), one invocation per texel of the light's low-resolution depth
// image (m x m per cube face, linear distances from the depth pass): the texel's surface point, seen
// from the desired view, gives I_DV (inside the view frustum), I_D (1 / view depth) and I_SN (the normal
// from the neighbouring texels' points); I_E compares the texel's distance with its eight neighbours'.
// Mode RTW_FORWARD_IMPORTANCE raises the super-cell's importance to the product (empty texels — no
// geometry, so nothing to shadow — give none); mode RTW_FORWARD_EDGES writes only I_E per texel, for the
// hybrid analysis's backward pass (rtw_importance.comp).
// bindings: 0 = depth image (float per texel, 6 faces of m x m), 1 = importance (uint per cell, 6 faces of
//           n x n), 2 = edges (float per texel, 6 faces of m x m), 3 = the view (RtwView)
#include "shadowmaps/rtw_shared.h"
layout(local_size_x = RTW_THREADS) in;
layout(std430, binding = 0) readonly buffer Depth { float depth[]; };
layout(std430, binding = 1) buffer Importance { uint importance[]; };
layout(std430, binding = 2) writeonly buffer Edges { float edges[]; };
layout(std430, binding = 3) readonly buffer View { RtwView view; };
layout(push_constant) uniform Push { RtwImportancePush pc; };

// Light-relative world direction of face-space direction f (faceSpace's inverse).
vec3 worldOf(uint face, vec3 f) {
  uint axis = face >> 1u;
  float z = (face & 1u) != 0u ? -f.z : f.z;
  return axis == 0u ? vec3(z, f.x, f.y) : (axis == 1u ? vec3(f.y, z, f.x) : vec3(f.x, f.y, z));
}

float at(uint face, int x, int y) {
  int m = int(pc.forwardRes);
  if (x < 0 || y < 0 || x >= m || y >= m) return SM_EMPTY_DEPTH;
  return depth[face * pc.forwardRes * pc.forwardRes + uint(y) * pc.forwardRes + uint(x)];
}

vec3 pointAt(uint face, int x, int y, float dist) {
  float m = float(pc.forwardRes);
  vec3 f = vec3(2.0 * (float(x) + 0.5) / m - 1.0, 2.0 * (float(y) + 0.5) / m - 1.0, 1.0);
  return pc.light.xyz + dist * normalize(worldOf(face, f));
}

void main() {
  uint m = pc.forwardRes;
  uint i = CS_FLAT_INDEX(RTW_THREADS);
  if (i >= 6u * m * m) return;
  uint face = i / (m * m);
  int x = int(i % m), y = int((i / m) % m);
  float d = at(face, x, y);
  bool empty = !(d < 0.5 * SM_EMPTY_DEPTH);
  float edge = pc.alpha;
  if (!empty)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        if ((dx != 0 || dy != 0) &&
            rtwDepthEdge(d, at(face, x + dx, y + dy), pc.constantBias, 2.0 / float(m), RTW_EDGE_SLOPE))
          edge = 1.0;
  if (pc.mode == RTW_FORWARD_EDGES) {
    edges[i] = edge;
    return;
  }
  if (empty) return;
  float value = 1.0;
  if ((pc.functions & RTW_UNIFORM) == 0u) {
    vec3 p = pointAt(face, x, y, d);
    vec4 clip = view.viewProj * vec4(p, 1.0);
    bool inView = clip.w > 0.0 && abs(clip.x) <= clip.w && abs(clip.y) <= clip.w && clip.z >= 0.0 && clip.z <= clip.w;
    if ((pc.functions & RTW_VIEW) != 0u && !inView) return;
    vec3 fromEye = p - view.eye.xyz;
    if ((pc.functions & RTW_DISTANCE) != 0u) {
      float q = dot(fromEye, view.forward.xyz);
      // Behind the eye (possible with I_DV off): next to no importance, but not culled.
      value *= q > 0.0 ? rtwDistanceImportance(q, view.eye.w) : 1.0e-20;
    }
    if ((pc.functions & RTW_NORMAL) != 0u) {
      // The normal from the neighbours' points (central differences where both exist, else one side).
      float dxp = at(face, x + 1, y), dxm = at(face, x - 1, y), dyp = at(face, x, y + 1), dym = at(face, x, y - 1);
      vec3 px = dxp < 0.5 * SM_EMPTY_DEPTH ? pointAt(face, x + 1, y, dxp) : p;
      vec3 mx = dxm < 0.5 * SM_EMPTY_DEPTH ? pointAt(face, x - 1, y, dxm) : p;
      vec3 py = dyp < 0.5 * SM_EMPTY_DEPTH ? pointAt(face, x, y + 1, dyp) : p;
      vec3 my = dym < 0.5 * SM_EMPTY_DEPTH ? pointAt(face, x, y - 1, dym) : p;
      vec3 n = cross(px - mx, py - my);
      float len = length(n) * length(fromEye);
      // Turned to face the eye, as the G-buffer's normals are (two-sided surfaces).
      value *= rtwNormalImportance(len > 0.0 ? abs(dot(n, fromEye)) / len : 1.0, pc.beta);
    }
    if ((pc.functions & RTW_EDGE) != 0u) value *= edge;
  }
  uint n = pc.cells;
  uint cx = min(uint(x) * n / m, n - 1u), cy = min(uint(y) * n / m, n - 1u);
  atomicMax(importance[face * n * n + cy * n + cx], floatBitsToUint(max(value, 0.0)));
}
