#version 450
#extension GL_GOOGLE_include_directive : require
// RMSM lookup (paper 000 §3.3.1): per lit sample, two percentage-closer lookups of 4 texels at the two
// quadtree levels around its λ (after the frame's fallback: frameLevel), blended by fract(λ). A footprint
// with no resident page at any level counts as a miss and is lit (never with full-resolution analysis;
// at a reduced one the backup level makes it rare: shadowmaps/README.md, RMSM).
// bindings: 0 = position, 1 = normal, 2 = lod (float per pixel), 3 = tables, 4 = pool (float per texel),
//           5 = visibility (float per pixel), 6 = counters, 7 = the faces' windows (vec4, fitWindows)
#include "shadowmaps/sm_shared.h"
layout(local_size_x = SM_PIXEL_THREADS) in;
layout(std430, binding = 0) readonly buffer Position { vec4 position[]; };
layout(std430, binding = 1) readonly buffer Normal { vec4 normal[]; };
layout(std430, binding = 2) readonly buffer Lod { float lod[]; };
layout(std430, binding = 3) readonly buffer Tables { uint tables[]; };
layout(std430, binding = 4) readonly buffer Pool { float pool[]; };
layout(std430, binding = 5) writeonly buffer Visibility { float visibility[]; };
layout(std430, binding = 6) buffer Counters { uint counters[]; };
layout(std430, binding = 7) readonly buffer Windows { vec4 windows[]; };  // per face (sm_shared.h windowST)
layout(push_constant) uniform Push { RmsmPush pc; };
#include "shadowmaps/rmsm.glsl"

void main() {
  uint i = CS_FLAT_INDEX(SM_PIXEL_THREADS);
  if (i >= pc.width * pc.height) return;
  vec4 p = position[i];
  float cosTheta = normal[i].w;
  float lambda = lod[i];
  vec3 d = p.xyz - pc.light.xyz;
  float dist = length(d);
  if (!litSample(p, normal[i]) || dist <= pc.minDistance || lambda < 0.0) {
    visibility[i] = 1.0;
    return;
  }
  uint face = cubeFace(d);
  vec3 dF = faceSpace(face, d);
  vec3 nF = faceSpace(face, normal[i].xyz);
  vec2 st = windowST(faceST(dF), windows[face]);
  lambda = frameLevel(lambda, pc.levelLimit);
  uint level = uint(floor(lambda));
  float w = lambda - float(level);
  float v = pcfAtLevel(face, st, level, dist, cosTheta, dF, nF);
  if (w > 0.0) {
    float v1 = pcfAtLevel(face, st, level + 1u, dist, cosTheta, dF, nF);
    v = v < 0.0 ? v1 : (v1 < 0.0 ? v : mix(v, v1, w));
  }
  if (v < 0.0) {
    atomicAdd(counters[SM_COUNT_MISSES], 1u);
    v = 1.0;
  }
  visibility[i] = v;
}
