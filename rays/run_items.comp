#version 450
#extension GL_GOOGLE_include_directive : require
// The fused compaction of the sorted cone path, step 4 (rays.h, LitRays::recordCompactionWithKeys): one
// item a run of equal keys (lit_runs.comp), in row-major order of the runs' leaders, written as the radix
// sort's input, its own pair scratch (RadixSort::recordFromPairs): (the run's key, its leader's pixel |
// (its length - 1) << RUN_PIXEL_BITS). A run's pixels are its leader and the lit positions after it up
// to the next leader or the first unlit position: consecutive pixels, all of one key.
// bindings: 0 = kept (uvec2[] per invocation: bits, rank in the block), 1 = offsets (uint[] per block,
//           exclusive), 2 = runBase (uint[] per invocation: its first item, the scan of runCounts),
//           3 = leaderBits (uint[] per invocation), 4 = runKeys (uniform texel buffer, R32UI, per lit
//           slot), 5 = pairs (uvec2[])
#include "rays/rays_layout.h"
layout(local_size_x = SCAN_THREADS) in;
layout(std430, binding = 0) readonly buffer Kept { uvec2 kept[]; };
layout(std430, binding = 1) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = 2) readonly buffer RunBase { uint runBase[]; };
layout(std430, binding = 3) readonly buffer LeaderBits { uint leaderBits[]; };
layout(binding = 4) uniform usamplerBuffer runKeys;
layout(std430, binding = 5) writeonly buffer Pairs { uvec2 pairs[]; };
layout(push_constant) uniform Push { RunsPush pc; };
uint flatWorkgroup() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }
void main() {
  uint b = flatWorkgroup();
  if (b * SCAN_BLOCK >= pc.positions) return;
  uint t = gl_LocalInvocationIndex;
  uint inv = b * SCAN_THREADS + t;
  uint leaders = leaderBits[inv];
  if (leaders == 0u) return;
  uint first = b * SCAN_BLOCK + t * SCAN_ITEMS;
  uvec2 mine = kept[inv];
  uint lit = mine.x, slot = offsets[b] + mine.y, item = runBase[inv];
  while (leaders != 0u) {
    uint k = uint(findLSB(leaders));
    leaders &= leaders - 1u;  // the leaders after k
    uint unlit = ~lit & (0xFFFFFFFFu << k);
    uint end = min(leaders != 0u ? uint(findLSB(leaders)) : 32u, unlit != 0u ? uint(findLSB(unlit)) : 32u);
    uint at = slot + uint(bitCount(lit & ((1u << k) - 1u)));  // the leader's lit slot
    pairs[item] = uvec2(texelFetch(runKeys, int(at)).x, (first + k) | ((end - k - 1u) << RUN_PIXEL_BITS));
    item++;
  }
}
