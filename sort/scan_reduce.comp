#version 450
#extension GL_GOOGLE_include_directive : require
// Scan, step 1 of a level: sums[b] = the sum of block b of the level's array (with FLAG_NONZERO_AS_ONE:
// how many of its elements are nonzero, the compaction's kept count).
// bindings: 0 = src (uint[], read as uvec4), 1 = sums (uint[], one per block), 2 = countWords (device count)
#include "sort/sort_layout.h"
layout(local_size_x = SCAN_THREADS) in;
layout(std430, binding = 0) readonly buffer Src { uvec4 src4[]; };
layout(std430, binding = 1) writeonly buffer Sums { uint sums[]; };
layout(std430, binding = 2) readonly buffer CountWords { uint countWords[]; };
layout(push_constant) uniform Push { ScanPush pc; };
#include "sort/common.glsl"
#include "sort/scan.glsl"

uvec4 load4(uint v, uint n) {
  if (4u * v + 3u < n) return counted4(src4[v]);
  uvec4 r = uvec4(0u);
  for (uint c = 0u; c < 3u; ++c)
    if (4u * v + c < n) r[c] = counted(src4[v][c]);
  return r;
}

void main() {
  uint n = levelCount();
  uint b = CS_FLAT_WORKGROUP;
  if (b * SCAN_BLOCK >= n) return;  // the whole workgroup: past the end
  uint first = (b * SCAN_BLOCK + gl_LocalInvocationIndex * SCAN_ITEMS) / 4u;
  bool flagsOnly = (pc.flags & FLAG_NONZERO_AS_ONE) != 0u;
  uint sum = 0u;
  for (uint k = 0u; k < SCAN_ITEMS / 4u; ++k) {
    uvec4 x = load4(first + k, n);
    sum += flagsOnly ? uint(x.x != 0u) + uint(x.y != 0u) + uint(x.z != 0u) + uint(x.w != 0u) : x.x + x.y + x.z + x.w;
  }
  uint total;
  workgroupExclusiveSum(sum, total);
  if (gl_LocalInvocationIndex == 0u) sums[b] = total;
}
