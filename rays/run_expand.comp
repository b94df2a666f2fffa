#version 450
#extension GL_GOOGLE_include_directive : require
// After the sort of the runs' items (rays.h, LitRays::recordCompactionWithKeys): each run's pixels in
// the order, the j-th item's from starts[j] on (sort/'s scan of the items' lengths): its leader's pixel
// and the next ones, as many as the run holds. With SPEC_KEYS the run's key too, at the same places
// (LitRays::keepSortedKeys; the sort then left the items' keys in sortedKeys). With SPEC_RECORDS each
// sorted ray's record instead of its pixel, uvec4(the float bits of its position, its pixel) (conetree/
// ConeTree::rays()): the positions read here a run's consecutive pixels at a time, where the cone tree's
// build would gather them in the sorted order, and stored once (the build reads them, the leaves after
// it): the gathers' cache misses move here and the records' stores off the build, which then reads its
// rays in order; a net gain (docs/ARCHITECTURE.md, "rays/", has the measurements).
// bindings: 0 = order (uniform texel buffer, R32UI: the sorted items, pixel | (length - 1) <<
//           RUN_PIXEL_BITS), 1 = starts (uniform texel buffer, R32UI), 2 = samples (uint[]), 3 = keys
//           (uint[]), 4 = sortedKeys (uniform texel buffer, R32UI), 5 = countWords (uniform texel buffer,
//           R32UI: every lane reads the count, and a storage load is a bounds-checked loop over the lanes
//           on a SIMD CPU driver), 6 = positions (the G-buffer, uniform texel buffer, RGBA32F: a texel a
//           pixel), 7 = records (uvec4[] a sorted ray)
#include "rays/rays_layout.h"
layout(local_size_x = PIXEL_THREADS) in;
layout(binding = 0) uniform usamplerBuffer order;
layout(binding = 1) uniform usamplerBuffer starts;
layout(std430, binding = 2) writeonly buffer Samples { uint samples[]; };
layout(std430, binding = 3) writeonly buffer Keys { uint keys[]; };
layout(binding = 4) uniform usamplerBuffer sortedKeys;
layout(binding = 5) uniform usamplerBuffer countWords;
layout(binding = 6) uniform samplerBuffer positions;
layout(std430, binding = 7) writeonly buffer Records { uvec4 records[]; };
layout(push_constant) uniform Push { RunsPush pc; };
layout(constant_id = 0) const uint SPEC_KEYS = 0u;
layout(constant_id = 1) const uint SPEC_RECORDS = 0u;
void main() {
  uint j = CS_FLAT_INDEX(PIXEL_THREADS);
  if (j >= min(texelFetch(countWords, int(pc.itemsIndex)).x, pc.items)) return;
  uint item = texelFetch(order, int(j)).x, at = texelFetch(starts, int(j)).x;
  uint pixel = item & RUN_PIXEL_MASK, length = (item >> RUN_PIXEL_BITS) + 1u;
  uint key = SPEC_KEYS != 0u ? texelFetch(sortedKeys, int(j)).x : 0u;
  for (uint k = 0u; k < length; ++k) {
    if (SPEC_RECORDS == 0u) samples[at + k] = pixel + k;
    if (SPEC_KEYS != 0u) keys[at + k] = key;
    if (SPEC_RECORDS != 0u)
      records[at + k] = uvec4(floatBitsToUint(texelFetch(positions, int(pixel + k)).xyz), pixel + k);
  }
}
