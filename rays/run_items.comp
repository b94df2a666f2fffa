#version 450
#extension GL_GOOGLE_include_directive : require
// The fused compaction of the sorted cone path, step 4 (rays.h, LitRays::recordCompactionWithKeys): one
// item a run of equal keys (lit_runs.comp), in row-major order of the runs' leaders, written as the radix
// sort's input, its own pair scratch (RadixSort::recordFromPairs): (the run's key, its leader's pixel |
// (its length - 1) << RUN_PIXEL_BITS). The key is the leader's, from its cell (lit_runs.comp's cells,
// run_cell.glsl's runCellKey): the Hilbert index once a run. A run's pixels are its leader and the lit
// positions after it up to the next leader or the first unlit position: consecutive pixels, one key.
// bindings: 0 = position (uniform texel buffer, RGBA32F: a texel per pixel; run_cell.glsl's), 1 = kept
//           (uvec2[] per invocation: bits, rank in the block), 2 = runBase (uint[] per invocation: its
//           first item, the scan of runCounts), 3 = leaderBits (uint[] per invocation), 4 = pairs
//           (uvec2[]), 5 = the key grids (uniform texel buffer, RGBA32F: a texel per face; a rotated
//           frame's in texel 0), 6 = cells (uniform texel buffer, R32UI: a lit pixel's key cell, lit_runs.comp)
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = SCAN_THREADS) in;
layout(binding = 0) uniform samplerBuffer position;
layout(std430, binding = 1) readonly buffer Kept { uvec2 kept[]; };
layout(std430, binding = 2) readonly buffer RunBase { uint runBase[]; };
layout(std430, binding = 3) readonly buffer LeaderBits { uint leaderBits[]; };
layout(std430, binding = 4) writeonly buffer Pairs { uvec2 pairs[]; };
layout(binding = 5) uniform samplerBuffer grids;
layout(binding = 6) uniform usamplerBuffer cells;
layout(push_constant) uniform Push { KeysPush pc; };
layout(constant_id = 0) const uint SPEC_FRAMED = 0u;
vec4 g0, g1, g2, g3, g4, g5;
#include "rays/run_cell.glsl"
void main() {
  uint b = CS_FLAT_WORKGROUP;
  if (b * SCAN_BLOCK >= pc.count) return;
  uint t = gl_LocalInvocationIndex;
  uint inv = b * SCAN_THREADS + t;
  uint leaders = leaderBits[inv];
  if (leaders == 0u) return;
  uint first = b * SCAN_BLOCK + t * SCAN_ITEMS;
  uint lit = kept[inv].x, item = runBase[inv];
  g0 = texelFetch(grids, 0), g1 = vec4(0.0f), g2 = g1, g3 = g1, g4 = g1, g5 = g1;  // as lit_runs.comp reads them
  if (SPEC_FRAMED == 0u) {
    g1 = texelFetch(grids, 1), g2 = texelFetch(grids, 2);
    g3 = texelFetch(grids, 3), g4 = texelFetch(grids, 4), g5 = texelFetch(grids, 5);
  }
  while (leaders != 0u) {
    uint k = uint(findLSB(leaders));
    leaders &= leaders - 1u;  // the leaders after k
    uint unlit = ~lit & (0xFFFFFFFFu << k);
    uint end = min(leaders != 0u ? uint(findLSB(leaders)) : 32u, unlit != 0u ? uint(findLSB(unlit)) : 32u);
    pairs[item] = uvec2(runCellKey(texelFetch(cells, int(first + k)).x), (first + k) | ((end - k - 1u) << RUN_PIXEL_BITS));
    item++;
  }
}
