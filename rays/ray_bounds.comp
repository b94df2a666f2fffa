#version 450
#extension GL_GOOGLE_include_directive : require
// The fitted box of each face for the ray keys (rays/hilbert.h, RAY_BOUNDS_SAMPLES): the face
// coordinates of RAY_BOUNDS_SAMPLES lit samples spread evenly over the compacted ones (boundsSample),
// each invocation taking RAY_BOUNDS_ITEMS of them, and how many of them each face has (the faces' runs of
// keys, faceKeySlot). An invocation keeps its own minima and counts per face, the workgroup merges them
// in shared memory and adds them to the buffer with one atomicMin (atomicAdd) a word.
// The subset's samples come from the compacted pixel indices, or (SPEC_FROM_BITS: the fused compaction,
// LitRays::recordCompactionWithKeys, which stores no such array) from lit_count.comp's bits and the scan
// of its block counts: the same samples, the k-th lit pixel in row-major order found by walking the
// blocks and their words forward (an invocation's subset indices are consecutive and increasing).
// bindings: 0 = position (vec4[] per pixel), 1 = samples (uint[] pixel indices), 2 = bounds
//           (RAY_BOUNDS_WORDS uint: the boxes all ones, the counts zero before the dispatch),
//           3 = countWords (device count),
//           4 = kept (uvec2[]: SCAN_ITEMS bits an invocation of lit_count.comp, and its rank), 5 = offsets (uint[] per
//           block of SCAN_BLOCK pixels, exclusive; pc.count is then the pixel count)
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = RAY_BOUNDS_THREADS) in;
layout(std430, binding = 0) readonly buffer Position { vec4 position[]; };
layout(std430, binding = 1) readonly buffer Samples { uint samples[]; };
layout(std430, binding = 2) buffer Bounds { uint bounds[]; };
layout(std430, binding = 3) readonly buffer CountWords { uint countWords[]; };
layout(std430, binding = 4) readonly buffer Kept { uvec2 kept[]; };
layout(std430, binding = 5) readonly buffer Offsets { uint offsets[]; };
layout(constant_id = 0) const uint SPEC_FROM_BITS = 0u;
layout(push_constant) uniform Push { KeysPush pc; };
#include "sort/common.glsl"

shared uint box[24];
shared uint faceCounts[6];

// SPEC_FROM_BITS: where the walk stands -- block b, word w of it, and the rank of that word's first lit
// pixel among all of them.
uint walkBlock = 0u, walkWord = 0u, walkRank = 0u;
bool walkStarted = false;
uint blockEnd(uint b, uint blocks, uint n) { return b + 1u < blocks ? offsets[b + 1u] : n; }
// The pixel of the k-th lit sample (row-major); k below the lit count n, never below the last call's k.
uint litPixel(uint k, uint n) {
  uint blocks = (pc.count + SCAN_BLOCK - 1u) / SCAN_BLOCK;
  if (!walkStarted || k >= blockEnd(walkBlock, blocks, n)) {  // the block holding rank k: the last one starting at or before it
    uint lo = walkStarted ? walkBlock + 1u : 0u, hi = blocks - 1u;
    while (lo < hi) {
      uint mid = (lo + hi + 1u) / 2u;
      if (offsets[mid] <= k) lo = mid;
      else hi = mid - 1u;
    }
    walkBlock = lo, walkWord = 0u, walkRank = offsets[lo];
    walkStarted = true;
  }
  uint bits = kept[walkBlock * SCAN_THREADS + walkWord].x;
  while (k >= walkRank + uint(bitCount(bits)) && walkWord + 1u < SCAN_THREADS) {
    walkRank += uint(bitCount(bits));
    bits = kept[walkBlock * SCAN_THREADS + ++walkWord].x;
  }
  for (uint r = k - walkRank; r > 0u; --r) bits &= bits - 1u;  // drop the lit pixels before it
  return walkBlock * SCAN_BLOCK + walkWord * SCAN_ITEMS + uint(findLSB(bits));
}

void main() {
  uint t = gl_LocalInvocationIndex;
  if (t < 24u) box[t] = RAY_BOUNDS_EMPTY;
  if (t < 6u) faceCounts[t] = 0u;
  uint n = countOf(pc.count, pc.countIndex, pc.flags);
  // Per face: the least orderedBits of u, v, -u, -v among this invocation's samples.
  uvec4 least[6];
  uint seen[6];
  for (uint f = 0u; f < 6u; ++f) least[f] = uvec4(RAY_BOUNDS_EMPTY), seen[f] = 0u;
  uint first = (gl_WorkGroupID.x * RAY_BOUNDS_THREADS + t) * RAY_BOUNDS_ITEMS;
  for (uint k = 0u; k < RAY_BOUNDS_ITEMS && n > 0u; ++k) {
    uint j = boundsSample(first + k, n);
    vec3 d = position[SPEC_FROM_BITS != 0u ? litPixel(j, n) : samples[j]].xyz - pc.light.xyz;
    uint face = rayFace(d);
    if (face == 7u) continue;
    vec2 uv = rayFaceUV(d, face);
    least[face] = min(least[face], uvec4(orderedBits(uv.x), orderedBits(uv.y), orderedBits(-uv.x), orderedBits(-uv.y)));
    ++seen[face];
  }
  barrier();
  for (uint f = 0u; f < 6u; ++f)
    if (least[f].x != RAY_BOUNDS_EMPTY) {
      for (uint c = 0u; c < 4u; ++c) atomicMin(box[4u * f + c], least[f][c]);
      atomicAdd(faceCounts[f], seen[f]);
    }
  barrier();
  if (t < 24u && box[t] != RAY_BOUNDS_EMPTY) atomicMin(bounds[t], box[t]);
  if (t < 6u && faceCounts[t] != 0u) atomicAdd(bounds[RAY_BOUNDS_COUNTS + t], faceCounts[t]);
}
