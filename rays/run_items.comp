#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_arithmetic : require
// The fused compaction of the sorted cone path, step 4 (rays.h, LitRays::recordCompactionWithKeys): one
// item a run of equal keys (lit_runs.comp), in row-major order of the runs' leaders, written as the radix
// sort's input, its own pair scratch (RadixSort::recordFromPairs): (the run's key, its leader's pixel |
// (its length - 1) << RUN_PIXEL_BITS), the leader's pixel from its position (rectDomainPixel). The key is the leader's, from its cell (lit_runs.comp's cells,
// run_cell.glsl's runCellKey): the Hilbert index once a run. A run's pixels are its leader and the lit
// positions after it up to the next leader or the first unlit position: consecutive pixels, one key.
// An invocation takes RUN_ITEMS_SPAN of lit_runs' invocations, S = RUN_ITEMS_SPAN apart, in rounds: in
// round r the S invocations of a group of S take S neighbouring ones of lit_runs (the cells they read lie
// together, as when an invocation took one), and a round in which no invocation of the subgroup has a
// leader is skipped by the loop (subgroupOr: uniform). On a SIMD CPU driver a branch runs every lane's code
// under a mask, and only a loop's exit skips code: a kernel of one lit_runs invocation an invocation paid
// its loop's body for every 32 pixels, runs or not (docs/ARCHITECTURE.md, "rays/").
// bindings: 0 = position (uniform texel buffer, RGBA32F: a texel per pixel; run_cell.glsl's), 1 = kept
//           (uniform texel buffer, RGBA32UI: lit_runs' uvec2 per invocation, lit bits and leaders, two a
//           texel), 2 = runBase (uniform texel buffer, R32UI: an invocation's first item, the scan of its
//           runs' counts), 3 = pairs (uvec2[]), 4 = the key grids (uniform texel buffer, RGBA32F: a texel
//           per face; a rotated frame's in texel 0), 5 = cells (uniform texel buffer, R32UI: a lit pixel's
//           key cell by position, lit_runs.comp), 6 = the enumeration (uniform, as lit_runs.comp's binding 7)
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = SCAN_THREADS) in;
layout(binding = 0) uniform samplerBuffer position;
layout(binding = 1) uniform usamplerBuffer kept;
layout(binding = 2) uniform usamplerBuffer runBase;
layout(std430, binding = 3) writeonly buffer Pairs { uvec2 pairs[]; };
layout(binding = 4) uniform samplerBuffer grids;
layout(binding = 5) uniform usamplerBuffer cells;
layout(std140, binding = 6) uniform Domain { uvec4 rect; uvec4 size; };
layout(push_constant) uniform Push { KeysPush pc; };
layout(constant_id = 0) const uint SPEC_FRAMED = 0u;
vec4 g0, g1, g2, g3, g4, g5;
#include "rays/run_cell.glsl"
void main() {
  // Invocation j takes lit_runs' invocations inv + S r, r < S: inv = (j / S) S S + j % S (S = RUN_ITEMS_SPAN).
  uint j = CS_FLAT_INDEX(SCAN_THREADS);
  uint invocations = ((size.z + uint(SCAN_BLOCK) - 1u) / uint(SCAN_BLOCK)) * uint(SCAN_THREADS);
  uint inv = (j / uint(RUN_ITEMS_SPAN)) * uint(RUN_ITEMS_SPAN * RUN_ITEMS_SPAN) + j % uint(RUN_ITEMS_SPAN);
  if (inv >= invocations) return;
  g0 = texelFetch(grids, 0), g1 = vec4(0.0f), g2 = g1, g3 = g1, g4 = g1, g5 = g1;  // as lit_runs.comp reads them
  if (SPEC_FRAMED == 0u) {
    g1 = texelFetch(grids, 1), g2 = texelFetch(grids, 2);
    g3 = texelFetch(grids, 3), g4 = texelFetch(grids, 4), g5 = texelFetch(grids, 5);
  }
  uint todo = 0u;  // bit r: invocation inv + S r has leaders
  for (uint r = 0u; r < uint(RUN_ITEMS_SPAN); ++r) {
    uint at = inv + r * uint(RUN_ITEMS_SPAN);
    uvec4 w = texelFetch(kept, int(at >> 1u));
    todo |= ((at & 1u) != 0u ? w.w : w.y) != 0u ? 1u << r : 0u;
  }
  // The rounds in which an invocation of the subgroup has leaders.
  uint rounds = subgroupOr(todo);
  do {
    uint r = rounds != 0u ? uint(findLSB(rounds)) : 0u;  // (none: one pass of no leaders)
    rounds &= rounds - 1u;
    uint at = inv + r * uint(RUN_ITEMS_SPAN);
    uvec4 w = texelFetch(kept, int(at >> 1u));
    uint lit = (at & 1u) != 0u ? w.z : w.x;
    uint leaders = (at & 1u) != 0u ? w.w : w.y;
    uint first = at * uint(SCAN_ITEMS), item = texelFetch(runBase, int(at)).x;
    uint p0 = rectDomainPixel(first, rect, size.y, size.x);  // the pixel of position first
    while (leaders != 0u) {
      uint k = uint(findLSB(leaders));
      leaders &= leaders - 1u;  // the leaders after k
      uint unlit = ~lit & (0xFFFFFFFFu << k);
      uint stop = min(leaders != 0u ? uint(findLSB(leaders)) : 32u, unlit != 0u ? uint(findLSB(unlit)) : 32u);
      pairs[item] = uvec2(runCellKey(texelFetch(cells, int(first + k)).x), (p0 + k) | ((stop - k - 1u) << RUN_PIXEL_BITS));
      item++;
    }
  } while (rounds != 0u);
}
