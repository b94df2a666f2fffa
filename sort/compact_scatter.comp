#version 450
#extension GL_GOOGLE_include_directive : require
// Compaction, last step: every element whose flag is nonzero writes, in input order, its index (or with
// FLAG_HAS_VALUES its value) to out[offsets[block] + its rank among the block's kept elements].
// bindings: 0 = flags (uint[], read as uvec4), 1 = values (uint[]), 2 = out (uint[]), 3 = offsets
//           (scanned kept counts, one per block), 4 = countWords (device count)
#include "sort/sort_layout.h"
layout(local_size_x = SCAN_THREADS) in;
layout(std430, binding = 0) readonly buffer Flags { uvec4 flags4[]; };
layout(std430, binding = 1) readonly buffer Values { uint values[]; };
layout(std430, binding = 2) writeonly buffer Out { uint outValues[]; };
layout(std430, binding = 3) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = 4) readonly buffer CountWords { uint countWords[]; };
layout(push_constant) uniform Push { ScanPush pc; };
#include "sort/common.glsl"
#include "sort/scan.glsl"

// Bit c of the result: element 4v + c is below n and its flag is set.
uint keptBits(uint v, uint n) {
  uvec4 f = uvec4(0u);
  if (4u * v + 3u < n) {
    f = flags4[v];
  } else {
    for (uint c = 0u; c < 3u; ++c)
      if (4u * v + c < n) f[c] = flags4[v][c];
  }
  return (f.x != 0u ? 1u : 0u) | (f.y != 0u ? 2u : 0u) | (f.z != 0u ? 4u : 0u) | (f.w != 0u ? 8u : 0u);
}

void main() {
  uint n = levelCount();
  uint b = CS_FLAT_WORKGROUP;
  if (b * SCAN_BLOCK >= n) return;
  uint first = b * SCAN_BLOCK + gl_LocalInvocationIndex * SCAN_ITEMS;
  uint kept = 0u;  // bit k: element first + k is kept
  for (uint k = 0u; k < SCAN_ITEMS / 4u; ++k) kept |= keptBits(first / 4u + k, n) << (4u * k);
  uint total;
  uint pos = offsets[b] + workgroupExclusiveSum(uint(bitCount(kept)), total);
  bool hasValues = (pc.flags & FLAG_HAS_VALUES) != 0u;
  while (kept != 0u) {
    uint k = uint(findLSB(kept));
    kept &= kept - 1u;
    outValues[pos++] = hasValues ? values[first + k] : first + k;
  }
}
