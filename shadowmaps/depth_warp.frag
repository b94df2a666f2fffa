#version 450
// The warped pass's texel (RTW): the exact distance to the triangle's plane along the texel's own ray.
// A triangle rasterized in the warped map is straight where the warped surface bends, so interpolating
// the vertices' positions gives each texel a point of the triangle that is not on the texel's ray (the
// error grows with the triangle's size and the warp's curvature, and large receivers shadowed
// themselves). Instead the texel centre is unwarped (the warp buffer's inverse table) to its face
// direction (u, v, 1), which meets the triangle's plane (flat input from the geometry stage) at z_f = t:
// distance t·|(u, v, 1)|, depth near / t. Rays nearly parallel to the plane, or meeting it behind the
// light, keep the interpolated point. Coverage stays approximate (tessellation bounds it).
#extension GL_GOOGLE_include_directive : require
#include "shadowmaps/rtw_shared.h"

layout(location = 0) in vec3 fromLight;
layout(location = 1) flat in vec4 plane;  // face space: dot(plane.xyz, f) = plane.w on the triangle
layout(location = 0) out float outDistance;
layout(std430, binding = 0) readonly buffer Warp { float warp[]; };
layout(push_constant) uniform Push { RtwDepthPush pc; };

void main() {
  uvec2 j = min(uvec2(gl_FragCoord.xy), uvec2(pc.resolution - 1u));
  vec3 r = vec3(2.0 * warp[rtwInverseBase(pc.face, 0u, pc.cells, pc.resolution) + j.x] - 1.0,
                2.0 * warp[rtwInverseBase(pc.face, 1u, pc.cells, pc.resolution) + j.y] - 1.0, 1.0);
  float den = dot(plane.xyz, r);
  float t = plane.w / den;
  float interpolated = length(fromLight);
  if (t > pc.nearPlane && abs(den) > 1.0e-3 * length(r) && t * length(r) < 4.0 * interpolated + 1.0) {
    outDistance = t * length(r);
    gl_FragDepth = pc.nearPlane / t;
  } else {
    outDistance = interpolated;
    gl_FragDepth = gl_FragCoord.z;
  }
}
