#version 450
#extension GL_GOOGLE_include_directive : require
// Scan, step 2 of a level: the exclusive sum of each block plus, with FLAG_ADD_OFFSETS, the block's
// offset (the next level's scanned sums). At the single-block top level FLAG_WRITE_TOTAL stores the
// grand total. With FLAG_IN_PLACE the input is read through dst (src is then not touched).
// bindings: 0 = src (uint[], read as uvec4), 1 = dst (uint[], as uvec4), 2 = offsets (uint[], one per
//           block), 3 = countWords (device count), 4 = totals (uint[], receives totals[pc.totalIndex])
#include "sort/sort_layout.h"
layout(local_size_x = SCAN_THREADS) in;
layout(std430, binding = 0) readonly buffer Src { uvec4 src4[]; };
layout(std430, binding = 1) buffer Dst { uvec4 dst4[]; };
layout(std430, binding = 2) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = 3) readonly buffer CountWords { uint countWords[]; };
layout(std430, binding = 4) writeonly buffer Totals { uint totals[]; };
layout(push_constant) uniform Push { ScanPush pc; };
#include "sort/common.glsl"
#include "sort/scan.glsl"

uvec4 load4(uint v, uint n, bool inPlace) {
  if (4u * v + 3u < n) return counted4(inPlace ? dst4[v] : src4[v]);
  uvec4 r = uvec4(0u);
  for (uint c = 0u; c < 3u; ++c)
    if (4u * v + c < n) r[c] = counted(inPlace ? dst4[v][c] : src4[v][c]);
  return r;
}

void store4(uint v, uint n, uvec4 x) {
  if (4u * v + 3u < n) {
    dst4[v] = x;
    return;
  }
  for (uint c = 0u; c < 3u; ++c)
    if (4u * v + c < n) dst4[v][c] = x[c];
}

void main() {
  uint n = levelCount();
  uint b = CS_FLAT_WORKGROUP;
  if (b > 0u && b * SCAN_BLOCK >= n) return;  // block 0 always runs: it writes the total, even of nothing
  uint first = (b * SCAN_BLOCK + gl_LocalInvocationIndex * SCAN_ITEMS) / 4u;
  bool inPlace = (pc.flags & FLAG_IN_PLACE) != 0u;
  uvec4 v[SCAN_ITEMS / 4];
  uint sum = 0u;
  for (uint k = 0u; k < SCAN_ITEMS / 4u; ++k) {
    v[k] = load4(first + k, n, inPlace);
    sum += v[k].x + v[k].y + v[k].z + v[k].w;
  }
  uint total;
  uint running = workgroupExclusiveSum(sum, total);
  if ((pc.flags & FLAG_ADD_OFFSETS) != 0u) running += offsets[b];
  for (uint k = 0u; k < SCAN_ITEMS / 4u; ++k) {
    uvec4 x = v[k];
    uvec4 out4 = uvec4(running, running + x.x, running + x.x + x.y, running + x.x + x.y + x.z);
    running += x.x + x.y + x.z + x.w;
    store4(first + k, n, out4);
  }
  if ((pc.flags & FLAG_WRITE_TOTAL) != 0u && b == 0u && gl_LocalInvocationIndex == 0u) totals[pc.totalIndex] = total;
}
