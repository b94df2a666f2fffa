#version 450
// The warped geometry pass of RTW (paper 004 §4.3), one invocation per triangle and cube face: the
// triangle is clipped in face space against the near plane and the face's four side planes (widened by
// `margin`), since the warp is defined for points in front of the light and on the face only; each
// vertex of the clipped polygon moves through the face's two warp maps (rtw_shared.h), and the polygon
// is emitted as a fan. With tessellation on, each fan triangle is subdivided into k² triangles (k from
// its longest warped edge over tessTexels, within the stage's output budget) whose vertices are warped
// in turn: straight edges rasterized straight in the warped space bend less the shorter they are (§6.1).
// The fragment stage (depth_warp.frag) writes the distance along the texel's own ray to the triangle's
// plane, which the geometry stage passes on flat.
// bindings: 0 = warp (rtw_shared.h layout)
#extension GL_GOOGLE_include_directive : require
#include "shadowmaps/rtw_shared.h"

layout(triangles) in;
layout(triangle_strip, max_vertices = RTW_GS_MAX_VERTICES) out;
layout(location = 0) in vec3 fromLightIn[];
layout(location = 0) out vec3 fromLight;
layout(location = 1) flat out vec4 plane;  // the triangle's plane in face space (depth_warp.frag)
layout(std430, binding = 0) readonly buffer Warp { float warp[]; };
layout(push_constant) uniform Push { RtwDepthPush pc; };

float warpAxis(uint axis, float s) {
  uint base = rtwKnotBase(pc.face, axis, pc.cells);
  uint k = rtwCell(s, pc.cells);
  return rtwWarpIn(s, k, pc.cells, warp[base + k], warp[base + k + 1u]);
}

// The warped window position (in [0, 1]², up to the margin) of a light-relative point.
vec2 warped(vec3 p) {
  vec3 f = faceSpace(pc.face, p);
  vec2 st = faceST(f);
  return vec2(warpAxis(0u, st.x), warpAxis(1u, st.y));
}

vec4 trianglePlane;

void emitAt(vec3 p) {
  vec3 f = faceSpace(pc.face, p);
  vec2 w = warped(p);
  // The perspective divide by z_f gives the warped position; depth near / z_f (reversed, infinite far).
  gl_Position = vec4((2.0 * w - 1.0) * f.z, pc.nearPlane, f.z);
  fromLight = p;
  plane = trianglePlane;
  EmitVertex();
}

// The live range in face coordinates u = 2s - 1, widened by the margin: (u0, u1, v0, v1).
vec4 liveRange() {
  uint rs = rtwRangeIndex(pc.face, 0u, pc.cells), rt = rtwRangeIndex(pc.face, 1u, pc.cells);
  return vec4(2.0 * warp[rs] - 1.0 - pc.margin, 2.0 * warp[rs + 1u] - 1.0 + pc.margin,
              2.0 * warp[rt] - 1.0 - pc.margin, 2.0 * warp[rt + 1u] - 1.0 + pc.margin);
}

// Signed distance (up to a positive scale) of a light-relative point to clip plane `plane` (>= 0 inside).
float planeDistance(uint plane, vec3 p, vec4 range) {
  vec3 f = faceSpace(pc.face, p);
  if (plane == 0u) return f.z - pc.nearPlane;
  if (plane == 1u) return range.y * f.z - f.x;
  if (plane == 2u) return f.x - range.x * f.z;
  if (plane == 3u) return range.w * f.z - f.y;
  return f.y - range.z * f.z;
}

void main() {
  if (warp[rtwActiveIndex(pc.face, pc.cells)] == 0.0) return;  // no sample uses this face
  {
    vec3 a = faceSpace(pc.face, fromLightIn[0]), b = faceSpace(pc.face, fromLightIn[1]),
         c = faceSpace(pc.face, fromLightIn[2]);
    vec3 nrm = cross(b - a, c - a);
    float len = length(nrm);
    if (!(len > 0.0)) return;  // degenerate: covers no texel
    nrm /= len;
    trianglePlane = vec4(nrm, dot(nrm, a));
  }
  vec4 range = liveRange();
  // Sutherland-Hodgman against five planes: 3 vertices grow to at most 8.
  vec3 poly[8];
  vec3 next[8];
  uint count = 3u;
  poly[0] = fromLightIn[0];
  poly[1] = fromLightIn[1];
  poly[2] = fromLightIn[2];
  for (uint plane = 0u; plane < 5u && count > 0u; ++plane) {
    uint out_ = 0u;
    for (uint i = 0u; i < count; ++i) {
      vec3 a = poly[i], b = poly[(i + 1u) % count];
      float da = planeDistance(plane, a, range), db = planeDistance(plane, b, range);
      if (da >= 0.0) next[out_++] = a;
      if ((da >= 0.0) != (db >= 0.0)) next[out_++] = mix(a, b, da / (da - db));
    }
    count = min(out_, 8u);
    for (uint i = 0u; i < count; ++i) poly[i] = next[i];
  }
  if (count < 3u) return;
  uint budget = RTW_GS_MAX_VERTICES;
  for (uint t = 1u; t + 1u < count; ++t) {
    vec3 a = poly[0], b = poly[t], c = poly[t + 1u];
    uint k = 1u;
    if (pc.tessellate != 0u) {
      vec2 wa = warped(a), wb = warped(b), wc = warped(c);
      float longest = max(max(length(wb - wa), length(wc - wb)), length(wa - wc)) * float(pc.resolution);
      // k² + 2k vertices for k rows of strips; share what is left evenly among the fan's triangles.
      uint share = budget / (count - 1u - t);
      uint kMax = uint(floor(sqrt(float(share + 1u)))) - 1u;
      k = clamp(uint(ceil(longest / max(pc.tessTexels, 1.0e-3))), 1u, max(kMax, 1u));
    }
    if (k == 1u) {
      emitAt(a);
      emitAt(b);
      emitAt(c);
      EndPrimitive();
      budget -= 3u;
      continue;
    }
    // Rows j = 0..k-1 of the subdivided triangle, each one strip between lattice rows j and j + 1.
    vec3 e1 = (b - a) / float(k), e2 = (c - a) / float(k);
    for (uint j = 0u; j < k; ++j) {
      for (uint i = 0u; i + j < k; ++i) {
        emitAt(a + float(i) * e1 + float(j) * e2);
        emitAt(a + float(i) * e1 + float(j + 1u) * e2);
      }
      emitAt(a + float(k - j) * e1 + float(j) * e2);
      EndPrimitive();
    }
    budget -= k * k + 2u * k;
  }
}
