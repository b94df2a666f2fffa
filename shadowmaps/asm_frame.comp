#version 450
#extension GL_GOOGLE_include_directive : require
// ASM (paper 001), one invocation per pixel, in two modes over the same walk: from depth 0 down, the
// resident node holding the sample's 2x2 footprint at that depth's resolution (the hash of
// asm_shared.h), until a depth has none; the finest one found answers.
//   ASM_MODE_ANALYSE (§3.1; pixels on the analysisStep grid): the sample's taps in its finest node; when
//   they disagree (a shadow edge crosses the footprint: the sample "straddles a depth discontinuity")
//   and the node's texel covers more of the surface than the pixel does, the cell of that node whose
//   child would hold the footprint gains one unit of benefit.
//   ASM_MODE_LOOKUP (§4.4): visibility from the finest node's nearest texel or 2x2 PCF, the shared
//   slope-scaled or receiver-plane bias with that node's texel (pcf.glsl).
// With pc.idTest (§4.2, ID + depth) a tap is lit when the triangle nearest the light there is the
// sample's own (from the G-buffer), and only otherwise by the depth comparison.
// Both modes mark every node a walk passes through as used (the host's LRU, §3.2).
// bindings: 0 = position (vec4 per pixel), 1 = normal (vec4 per pixel, w = N·L̂), 2 = pool (float per
//           texel, (N + 1)² per slot), 3 = hash (uvec2 (key, slot) per entry), 4 = benefit (uint per slot
//           and cell, C² per slot), 5 = used (uint per slot), 6 = visibility (float per pixel),
//           7 = counters (uint[4]: analysed, straddling, coarser than the pixel, benefit given),
//           8 = ID pool (uint per texel, the pool's layout; read with pc.idTest), 9 = triangle (uint per
//           pixel, the G-buffer's; read with pc.idTest), 10 = windows (vec4 per face: s0, t0, zoom, the
//           face's deepest level)
#include "shadowmaps/asm_shared.h"
layout(local_size_x = ASM_THREADS) in;
layout(std430, binding = 0) readonly buffer Position { vec4 position[]; };
layout(std430, binding = 1) readonly buffer Normal { vec4 normal[]; };
layout(std430, binding = 2) readonly buffer Pool { float pool[]; };
layout(std430, binding = 3) readonly buffer Hash { uvec2 hashTable[]; };
layout(std430, binding = 4) buffer Benefit { uint benefit[]; };
layout(std430, binding = 5) buffer Used { uint used[]; };
layout(std430, binding = 6) writeonly buffer Visibility { float visibility[]; };
layout(std430, binding = 7) buffer Counters { uint counters[]; };
layout(std430, binding = 8) readonly buffer IdPool { uint idPool[]; };
layout(std430, binding = 9) readonly buffer Triangle { uint triangle[]; };
layout(std430, binding = 10) readonly buffer Windows { vec4 windows[]; };
layout(push_constant) uniform Push { AsmPush pc; };
#include "shadowmaps/pcf.glsl"

uint findSlot(uint key) {
  uint h = asmHash(key, pc.capacity);
  for (uint probe = 0u; probe < pc.capacity; ++probe) {
    uvec2 e = hashTable[h];
    if (e.x == key) return e.y;
    if (e.x == SM_INVALID_KEY) return ASM_EMPTY_SLOT;
    h = (h + 1u) & (pc.capacity - 1u);
  }
  return ASM_EMPTY_SLOT;
}

void main() {
  uint i = CS_FLAT_INDEX(ASM_THREADS);
  if (i >= pc.width * pc.height) return;
  bool analyse = pc.mode == ASM_MODE_ANALYSE;
  if (analyse && ((i % pc.width) % pc.analysisStep != 0u || (i / pc.width) % pc.analysisStep != 0u)) return;
  vec4 p = position[i];
  vec4 nl = normal[i];
  float cosTheta = nl.w;
  vec3 d = p.xyz - pc.light.xyz;
  float dist = length(d);
  if (!litSample(p, nl) || dist <= pc.minDistance) {
    if (!analyse) visibility[i] = 1.0;
    return;
  }
  uint face = cubeFace(d);
  vec3 dF = faceSpace(face, d);
  vec3 nF = faceSpace(face, nl.xyz);
  // The face's fitted window (depth_pass.h fitWindows: s0, t0, zoom, and here the face's deepest level):
  // the tree's coordinates are the window's; `zoom` turns its texels into the face's.
  vec4 w = windows[face];
  vec2 st = windowST(faceST(dF), w);
  float zoom = w.z;
  uint maxDepth = min(pc.maxDepth, uint(w.w));

  // The walk: the finest resident node holding the footprint.
  uint N = pc.nodeRes;
  uint slot = ASM_EMPTY_SLOT, depth = 0u;
  float res = 0.0, levelRes = float(N);
  uvec2 node = uvec2(0u), base = uvec2(0u);
  vec2 frac = vec2(0.0);
  for (uint L = 0u; L <= maxDepth; ++L) {
    vec2 x = footprintCoord(st, levelRes);
    vec2 b = footprintBase(x, levelRes);
    uvec2 n = uvec2(b) / N;
    uint s = findSlot(pageKey(face, L, n.x, n.y));
    if (s == ASM_EMPTY_SLOT) break;
    used[s] = 1u;
    slot = s;
    depth = L;
    res = levelRes;
    node = n;
    base = uvec2(b);
    frac = clamp(x - b, vec2(0.0), vec2(1.0));
    levelRes *= float(pc.cells);
  }
  if (slot == ASM_EMPTY_SLOT) {  // no root on this face: the host renders one for every face, so never
    if (!analyse) visibility[i] = 1.0;
    return;
  }

  uint stride = N + 1u;
  uvec2 local = base - node * N;
  uint t = slot * asmSlotStride(N) + local.y * stride + local.x;  // the footprint's first texel in the pool
  uvec4 taps = uvec4(t, t + 1u, t + stride, t + stride + 1u);
  float faceRes = res * zoom;  // the level's texels across the whole face
  Receiver r = faceReceiver(dist, cosTheta, faceRes, dF, nF);
  vec4 uv = vec4(windowFaceUV(vec2(base) + 0.5, res, w), windowFaceUV(vec2(base + 1u) + 0.5, res, w));
  vec4 l = pcfTaps(r, vec4(pool[taps.x], pool[taps.y], pool[taps.z], pool[taps.w]), uv);
  uint ownTriangle = pc.idTest != 0u ? triangle[i] : CS_NO_TRIANGLE;
  if (ownTriangle != CS_NO_TRIANGLE)  // a tap whose nearest triangle is the sample's own lights it
    l = mix(l, vec4(1.0), equal(uvec4(idPool[taps.x], idPool[taps.y], idPool[taps.z], idPool[taps.w]), uvec4(ownTriangle)));

  if (!analyse) {
    if (pc.pcf != 0u) {
      visibility[i] = pcfBlend(l, frac);
    } else {
      uint k = (frac.x >= 0.5 ? 1u : 0u) + (frac.y >= 0.5 ? 2u : 0u);
      visibility[i] = l[k];
    }
    return;
  }

  atomicAdd(counters[0], 1u);
  float lit = l[0] + l[1] + l[2] + l[3];
  bool straddles = lit > 0.0 && lit < 4.0;
  vec3 toEye = pc.eye.xyz - p.xyz;
  float eyeDistance = length(toEye);
  float cosView = eyeDistance > 0.0 ? abs(dot(nl.xyz, toEye)) / eyeDistance : 1.0;
  bool coarser = asmTexelArea(faceRes, dist, dist / dF.z, cosTheta) > asmPixelArea(pc.eye.w, eyeDistance, cosView);
  if (straddles) atomicAdd(counters[1], 1u);
  if (coarser) atomicAdd(counters[2], 1u);
  if (!straddles || !coarser || depth >= maxDepth) return;
  // The child holding the footprint at the next depth; a footprint whose child belongs to the
  // neighbouring node (its base moved across the node's edge) counts for this node's nearest cell.
  float childRes = res * float(pc.cells);
  uvec2 child = uvec2(footprintBase(footprintCoord(st, childRes), childRes)) / N;
  ivec2 cell = clamp(ivec2(child) - ivec2(node * pc.cells), ivec2(0), ivec2(int(pc.cells) - 1));
  atomicAdd(benefit[slot * pc.cells * pc.cells + uint(cell.y) * pc.cells + uint(cell.x)], 1u);
  atomicAdd(counters[3], 1u);
}
