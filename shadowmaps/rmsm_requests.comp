#version 450
#extension GL_GOOGLE_include_directive : require
// RMSM phase 1, steps 2-3 of Algorithm 2 (paper 000): per lit sample its cube face, (s, t), the LOD of
// eq. 1 from the derivatives of (s, t) across neighbouring samples, and the page requests at the two
// quadtree levels the lookup blends. One invocation per pixel.
//   Derivatives: per screen axis, the neighbour (left or right, up or down) that has geometry and lies
//   in the sample's tangent plane (another surface would fake a huge footprint); of two, the nearer in
//   world space. With one axis only, the footprint is taken square. With none ("isolated": a sliver of
//   a surface, a hair), a square footprint of the smallest (s, t) step to any neighbour with geometry,
//   one level finer for safety; with no neighbour at all, the finest level allowed. (Asking the finest
//   level for every isolated sample would spend thousands of pages on sub-pixel hairs and push the
//   whole frame into the pool fallback.)
//   Requests: the page holding the bilinear footprint at floor(λ') and, when fract(λ') > 0, at
//   floor(λ')+1, λ' = frameLevel(λ) (λ itself, except in cached mode after a fallback lowered the
//   cache's finest level); SM_INVALID_KEY otherwise. In cached mode a request whose page is already
//   resident is dropped here. `lod` keeps λ in [0, maxLevel] for every pixel, since every pixel looks
//   up; at a reduced analysis resolution (000 §3.3.5, analysisStep > 1) only the pixels on the
//   analysisStep grid request pages, and the others find their neighbours' pages or coarser ones.
// bindings: 0 = position (vec4 per pixel), 1 = normal (vec4 per pixel), 2 = tables (uint per entry),
//           3 = lod (float per pixel: λ, -1 where none), 4 = requests (2 uint per pixel),
//           5 = counters (uint[SM_COUNT_WORDS]), 6 = the faces' windows (vec4, fitWindows)
#include "shadowmaps/sm_shared.h"
layout(local_size_x = SM_PIXEL_THREADS) in;
layout(std430, binding = 0) readonly buffer Position { vec4 position[]; };
layout(std430, binding = 1) readonly buffer Normal { vec4 normal[]; };
layout(std430, binding = 2) readonly buffer Tables { uint tables[]; };
layout(std430, binding = 3) writeonly buffer Lod { float lod[]; };
layout(std430, binding = 4) writeonly buffer Requests { uint requests[]; };
layout(std430, binding = 5) buffer Counters { uint counters[]; };
layout(std430, binding = 6) readonly buffer Windows { vec4 windows[]; };  // per face (sm_shared.h windowST)
layout(push_constant) uniform Push { RmsmPush pc; };

const float kPlaneTolerance = 0.25;  // |n·e| <= 0.25 |e|: the neighbour is within ~14° of the tangent plane

// (s, t) of neighbour j on `face`, if it continues the sample's surface; `dist2` = its squared distance.
// anySurface: skip the tangent-plane test.
bool neighbourST(int j, vec3 p, vec3 n, uint face, bool anySurface, out vec2 st, out float dist2) {
  st = vec2(0.0);
  dist2 = 0.0;
  if (j < 0) return false;
  vec4 q = position[j];
  if (q.w <= 0.5) return false;
  vec3 e = q.xyz - p;
  dist2 = dot(e, e);
  if (!(dist2 > 0.0) || (!anySurface && abs(dot(n, e)) > kPlaneTolerance * sqrt(dist2))) return false;
  vec3 f = faceSpace(face, q.xyz - pc.light.xyz);
  if (!(f.z > 0.0)) return false;
  st = windowST(faceST(f), windows[face]);
  return true;
}

// The derivative of (s, t) along one screen axis from the neighbours a (before) and b (after).
bool derivative(int a, int b, vec3 p, vec3 n, uint face, vec2 st, out vec2 dst) {
  vec2 sa, sb;
  float da, db;
  bool okA = neighbourST(a, p, n, face, false, sa, da);
  bool okB = neighbourST(b, p, n, face, false, sb, db);
  dst = vec2(0.0);
  if (okA && (!okB || da <= db)) dst = st - sa;
  else if (okB) dst = sb - st;
  return okA || okB;
}

uint requestAt(uint face, vec2 st, uint level) {
  float res = float(1u << (pc.log2Page + level));
  uvec2 page = uvec2(footprintBase(footprintCoord(st, res), res)) >> pc.log2Page;
  uint key = pageKey(face, level, page.x, page.y);
  if (pc.cachedFilter != 0u && tables[tableIndex(face, level, page.x, page.y, pc.maxLevel)] != 0u)
    return SM_INVALID_KEY;
  return key;
}

shared uint groupFaces;

// Pixel i's LOD and requests; returns its face, or -1 when it is not a lit sample.
int analyse(uint i) {
  if (i >= pc.width * pc.height) return -1;
  requests[2u * i] = SM_INVALID_KEY;
  requests[2u * i + 1u] = SM_INVALID_KEY;
  lod[i] = -1.0;
  vec4 p = position[i];
  vec4 n = normal[i];
  vec3 d = p.xyz - pc.light.xyz;
  if (!litSample(p, n) || length(d) <= pc.minDistance) return -1;
  uint face = cubeFace(d);
  vec2 st = windowST(faceST(faceSpace(face, d)), windows[face]);

  int x = int(i % pc.width), y = int(i / pc.width), w = int(pc.width), h = int(pc.height);
  int ii = int(i);
  vec2 dX, dY;
  bool okX = derivative(x > 0 ? ii - 1 : -1, x + 1 < w ? ii + 1 : -1, p.xyz, n.xyz, face, st, dX);
  bool okY = derivative(y > 0 ? ii - w : -1, y + 1 < h ? ii + w : -1, p.xyz, n.xyz, face, st, dY);
  float lambda;
  if (okX || okY) {
    if (!okY) dY = vec2(-dX.y, dX.x);
    if (!okX) dX = vec2(dY.y, -dY.x);
    lambda = quadtreeLevel(lodFromDerivatives(dX, dY) - pc.lodBias, pc.log2Page, pc.maxLevel);
  } else {
    float step = 1e30;
    int around[4] = int[4](x > 0 ? ii - 1 : -1, x + 1 < w ? ii + 1 : -1, y > 0 ? ii - w : -1, y + 1 < h ? ii + w : -1);
    for (int k = 0; k < 4; ++k) {
      vec2 sn;
      float dn;
      if (neighbourST(around[k], p.xyz, n.xyz, face, true, sn, dn)) {
        float len = length(sn - st);
        if (len > 0.0) step = min(step, len);
      }
    }
    lambda = step < 1e30 ? quadtreeLevel(lodFromDerivatives(vec2(step, 0.0), vec2(0.0, step)) - pc.lodBias - 1.0f,
                                         pc.log2Page, pc.maxLevel)
                         : float(pc.maxLevel);
    atomicAdd(counters[SM_COUNT_ISOLATED], 1u);
  }
  lod[i] = lambda;
  if (x % int(pc.analysisStep) != 0 || y % int(pc.analysisStep) != 0) return int(face);
  lambda = frameLevel(lambda, pc.levelLimit);  // cached mode: the cache's fallback state
  uint level = uint(floor(lambda));
  requests[2u * i] = requestAt(face, st, level);
  if (lambda > float(level)) requests[2u * i + 1u] = requestAt(face, st, level + 1u);
  return int(face);
}

void main() {
  if (gl_LocalInvocationIndex == 0u) groupFaces = 0u;
  barrier();
  int face = analyse(CS_FLAT_INDEX(SM_PIXEL_THREADS));
  // The faces in use: only a reduced analysis needs them (its backup level, shadowmaps/README.md, RMSM).
  if (pc.analysisStep > 1u && face >= 0) atomicOr(groupFaces, 1u << uint(face));
  barrier();
  if (gl_LocalInvocationIndex == 0u && groupFaces != 0u) atomicOr(counters[SM_COUNT_FACES], groupFaces);
}
