#version 450
#extension GL_GOOGLE_include_directive : require
// Cube shadow map lookup, one invocation per pixel: face and (s, t) of the sample's direction from the
// light, then the nearest texel or the bilinear 2x2 percentage-closer filter against the sample's
// distance minus the slope-scaled bias, or per tap the receiver-plane distance (pcf.glsl). Unlit
// samples get 1.
// bindings: 0 = position (vec4 per pixel), 1 = normal (vec4 per pixel, w = N·L̂), 2..7 = faces 0..5
//           (float per texel, row-major, R x R: cube_faces.glsl), 8 = visibility (float per pixel),
//           9 = the faces' windows (vec4: effective resolution of the whole face, first texel x0, y0;
//           cube_sm.cpp fitFace)
#include "shadowmaps/sm_shared.h"
layout(local_size_x = SM_PIXEL_THREADS) in;
layout(std430, binding = 0) readonly buffer Position { vec4 position[]; };
layout(std430, binding = 1) readonly buffer Normal { vec4 normal[]; };
#include "shadowmaps/cube_faces.glsl"
layout(std430, binding = 8) writeonly buffer Visibility { float visibility[]; };
layout(std430, binding = 9) readonly buffer Windows { vec4 windows[]; };  // per face: res, x0, y0 (fitted)
layout(push_constant) uniform Push { CubeLookupPush pc; };
#include "shadowmaps/pcf.glsl"

// Face coordinates of texel `tap`'s centre: the map's texels sit at `origin` in a face of `res` a side.
vec2 texelUV(vec2 tap, vec2 origin, float res) { return 2.0 * (tap + origin + 0.5) / res - 1.0; }

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
  Receiver r = faceReceiver(dist, cosTheta, res, dF, nF);
  float vis;
  if (pc.pcf != 0u) {
    vec2 x = footprintCoord(st, res) - origin;
    // No apron: clamp the footprint to the map (its last texel stands for the edge of face or window).
    vec2 b = clamp(floor(x), vec2(0.0), vec2(side - 2.0));
    vec2 f = clamp(x - b, vec2(0.0), vec2(1.0));
    vec4 depth = faceDepth4(face, uint(b.y) * pc.resolution + uint(b.x), pc.resolution);
    vis = pcfBlend(pcfTaps(r, depth, vec4(texelUV(b, origin, res), texelUV(b + 1.0, origin, res))), f);
  } else {
    vec2 b = clamp(floor(st * res - origin), vec2(0.0), vec2(side - 1.0));
    vis = tapLit(r, faceDepth(face, uint(b.y) * pc.resolution + uint(b.x)), texelUV(b, origin, res));
  }
  visibility[i] = vis;
}
