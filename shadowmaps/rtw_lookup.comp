#version 450
#extension GL_GOOGLE_include_directive : require
// RTW lookup (paper 004 §4.4), one invocation per pixel: the sample's face and (s, t) as for the cube
// map, warped through the face's two warp maps to (s', t'); then the nearest texel or the bilinear 2x2
// percentage-closer filter of the warped map (taps in warped texels, §6.2) against the sample's distance
// minus the shared slope-scaled bias, whose texel is the largest unwarped texel among the sample's cell
// and its neighbours (the taps may reach into them) scaled by warpBias; or per tap the receiver-plane
// distance along the tap's own unwarped ray. Unlit samples get 1. Lit samples whose cell was culled
// (zero width: the analysis gave it no importance) are counted.
// bindings: 0 = position, 1 = normal (w = N·L̂), 2..7 = faces 0..5 (float per texel, R x R:
//           cube_faces.glsl), 8 = visibility (float per pixel), 9 = warp (rtw_shared.h layout),
//           10 = counters (uint: 0 = lit samples in culled cells)
#include "shadowmaps/rtw_shared.h"
layout(local_size_x = RTW_THREADS) in;
layout(std430, binding = 0) readonly buffer Position { vec4 position[]; };
layout(std430, binding = 1) readonly buffer Normal { vec4 normal[]; };
#include "shadowmaps/cube_faces.glsl"
layout(std430, binding = 8) writeonly buffer Visibility { float visibility[]; };
layout(std430, binding = 9) readonly buffer Warp { float warp[]; };
layout(std430, binding = 10) buffer Counters { uint counters[]; };
layout(push_constant) uniform Push { RtwLookupPush pc; };
#include "shadowmaps/pcf.glsl"

float knot(uint face, uint axis, uint k) { return warp[rtwKnotBase(face, axis, pc.cells) + k]; }

// Warped width of cell k of an axis (0 for a culled cell).
float cellWidth(uint face, uint axis, uint k) { return knot(face, axis, k + 1u) - knot(face, axis, k); }

// Unwarped coordinate of texel j's centre on an axis (the warp buffer's inverse table).
float unwarpTexel(uint face, uint axis, float j) {
  return warp[rtwInverseBase(face, axis, pc.cells, pc.resolution) + uint(j)];
}

// Face coordinates of warped texel `tap`'s centre, for the receiver-plane bias: the inverse tables are
// read only when it is on.
vec2 texelUV(uint face, vec2 tap) {
  return pc.planeBias != 0u ? 2.0 * vec2(unwarpTexel(face, 0u, tap.x), unwarpTexel(face, 1u, tap.y)) - 1.0 : vec2(0.0);
}

void main() {
  uint i = CS_FLAT_INDEX(RTW_THREADS);
  if (i >= pc.width * pc.height) return;
  vec4 p = position[i];
  float cosTheta = normal[i].w;
  vec3 d = p.xyz - pc.light.xyz;
  float dist = length(d);
  if (!litSample(p, normal[i]) || dist <= pc.minDistance) {
    visibility[i] = 1.0;
    return;
  }
  uint face = cubeFace(d);
  vec3 dF = faceSpace(face, d);
  vec3 nF = faceSpace(face, normal[i].xyz);
  vec2 st = faceST(dF);
  uint n = pc.cells;
  uint cx = rtwCell(st.x, n), cy = rtwCell(st.y, n);
  vec2 sw = vec2(rtwWarpIn(st.x, cx, n, knot(face, 0u, cx), knot(face, 0u, cx + 1u)),
                 rtwWarpIn(st.y, cy, n, knot(face, 1u, cy), knot(face, 1u, cy + 1u)));
  if (cellWidth(face, 0u, cx) <= 0.0 || cellWidth(face, 1u, cy) <= 0.0) atomicAdd(counters[0], 1u);
  // The narrowest warped width (= the largest unwarped texel) among the cells the taps can reach.
  float narrowest = 1.0;
  for (uint axis = 0u; axis < 2u; ++axis) {
    uint c = axis == 0u ? cx : cy;
    for (uint k = (c > 0u ? c - 1u : 0u); k <= min(c + 1u, n - 1u); ++k) {
      float w = cellWidth(face, axis, k);
      if (w > 0.0) narrowest = min(narrowest, w);
    }
  }
  // One warped texel (1/R of s') spans (1/n) / (R · width) of s, i.e. 2 / (R · n · width) of u.
  float res = float(pc.resolution);
  float texelAngle = pc.warpBias * 2.0 / (res * float(n) * narrowest);
  Receiver r = receiver(dist, cosTheta, texelAngle, 0.25 * dist * texelAngle, dF, nF);
  float vis;
  if (pc.pcf != 0u) {
    vec2 x = footprintCoord(sw, res);
    vec2 b = clamp(floor(x), vec2(0.0), vec2(res - 2.0));
    vec2 f = clamp(x - b, vec2(0.0), vec2(1.0));
    vec4 depth = faceDepth4(face, uint(b.y) * pc.resolution + uint(b.x), pc.resolution);
    vis = pcfBlend(pcfTaps(r, depth, vec4(texelUV(face, b), texelUV(face, b + 1.0))), f);
  } else {
    vec2 b = clamp(floor(sw * res), vec2(0.0), vec2(res - 1.0));
    vis = tapLit(r, faceDepth(face, uint(b.y) * pc.resolution + uint(b.x)), texelUV(face, b));
  }
  visibility[i] = vis;
}
