#version 450
#extension GL_GOOGLE_include_directive : require
// Cube shadow map lookup, one invocation per pixel: face and (s, t) of the sample's direction from the
// light, then the nearest texel or the bilinear 2x2 percentage-closer filter against the sample's
// distance minus the slope-scaled bias, or per tap the receiver-plane distance (sm_shared.h). Unlit
// samples get 1.
// bindings: 0 = position (vec4 per pixel), 1 = normal (vec4 per pixel, w = N·L̂), 2..7 = faces 0..5
//           (float per texel, row-major, R x R), 8 = visibility (float per pixel), 9 = the faces'
//           windows (vec4: effective resolution of the whole face, first texel x0, y0; cube_sm.cpp fitFace)
#include "shadowmaps/sm_shared.h"
layout(local_size_x = SM_PIXEL_THREADS) in;
layout(std430, binding = 0) readonly buffer Position { vec4 position[]; };
layout(std430, binding = 1) readonly buffer Normal { vec4 normal[]; };
layout(std430, binding = 2) readonly buffer Face0 { float face0[]; };
layout(std430, binding = 3) readonly buffer Face1 { float face1[]; };
layout(std430, binding = 4) readonly buffer Face2 { float face2[]; };
layout(std430, binding = 5) readonly buffer Face3 { float face3[]; };
layout(std430, binding = 6) readonly buffer Face4 { float face4[]; };
layout(std430, binding = 7) readonly buffer Face5 { float face5[]; };
layout(std430, binding = 8) writeonly buffer Visibility { float visibility[]; };
layout(std430, binding = 9) readonly buffer Windows { vec4 windows[]; };  // per face: res, x0, y0 (fitted)
layout(push_constant) uniform Push { CubeLookupPush pc; };

float texel(uint face, uint index) {
  switch (face) {
    case 0u: return face0[index];
    case 1u: return face1[index];
    case 2u: return face2[index];
    case 3u: return face3[index];
    case 4u: return face4[index];
    default: return face5[index];
  }
}

void main() {
  uint i = CS_FLAT_INDEX(SM_PIXEL_THREADS);
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
  vec4 window = windows[face];
  float res = window.x;                // the whole face's effective resolution; the map holds R x R of it
  vec2 origin = window.yz;             // the map's first texel in the whole face
  float side = float(pc.resolution);
  float reach = dist - slopeScaledBias(dist, cosTheta, 2.0f / res, pc.constantBias, pc.slopeBias, pc.maxSlope);
  float slack = 0.25 * dist * 2.0f / res;
  float vis;
  if (pc.pcf != 0u) {
    vec2 x = footprintCoord(st, res) - origin;
    // No apron: clamp the footprint to the map (its last texel stands for the edge of face or window).
    vec2 b = clamp(floor(x), vec2(0.0), vec2(side - 2.0));
    vec2 f = clamp(x - b, vec2(0.0), vec2(1.0));
    uint base = uint(b.y) * pc.resolution + uint(b.x);
    float l[4];
    for (uint k = 0u; k < 4u; ++k) {
      vec2 tap = b + vec2(float(k & 1u), float(k >> 1u));
      float r = pc.planeBias != 0u
                    ? planeReach(dF, nF, 2.0 * (tap + origin + 0.5) / res - 1.0, reach, pc.constantBias, slack)
                    : reach;
      l[k] = texel(face, base + (k >> 1u) * pc.resolution + (k & 1u)) >= r ? 1.0 : 0.0;
    }
    vis = mix(mix(l[0], l[1], f.x), mix(l[2], l[3], f.x), f.y);
  } else {
    vec2 b = clamp(floor(st * res - origin), vec2(0.0), vec2(side - 1.0));
    float r = pc.planeBias != 0u
                  ? planeReach(dF, nF, 2.0 * (b + origin + 0.5) / res - 1.0, reach, pc.constantBias, slack)
                  : reach;
    vis = texel(face, uint(b.y) * pc.resolution + uint(b.x)) >= r ? 1.0 : 0.0;
  }
  visibility[i] = vis;
}
