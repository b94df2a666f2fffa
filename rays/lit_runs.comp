#version 450
#extension GL_GOOGLE_include_directive : require
// The fused compaction of the sorted cone path, step 3 (rays.h, LitRays::recordCompactionWithKeys): the
// runs of equal keys among the lit pixels, in row-major order. A run is a stretch of consecutive lit
// pixels of one invocation's SCAN_ITEMS positions whose rays fall in one cell of the key grid
// (faceCellCode, frameCellCode: equal cells, equal keys); its first pixel leads it. A stable sort puts a
// run's pixels next to each other in the order they have here (nothing else lies between them in
// row-major order), so the sort takes one item a run (run_items.comp, which computes the leaders' keys)
// and run_expand.comp writes each run's pixels after the sort: the order is the per-ray sort's, bit for
// bit. Here each invocation writes its leaders to leaderBits (bit k: position k leads a run) and their
// count to runCounts, which sort/'s scan turns into the invocation's first item, and every position's
// cell to cells, four a uvec4 store (coherent stores cost lavapipe next to nothing; run_items reads the
// leaders'). The positions go four at a time, whether lit or not: a loop of one lit pixel an iteration,
// with a scalar store each, took this kernel twice as long on lavapipe (a loop iteration and a storage
// access cost every lane more than the cell's arithmetic). The lit bits come from lit_count.comp, the
// faces' grids from ray_grids.comp.
// bindings: 0 = position (uniform texel buffer, RGBA32F: a texel per pixel), 1 = kept (uvec2[] per
//           invocation: bits, rank in the block), 2 = the faces' grids (vec4 per face; world keys),
//           3 = leaderBits (uint[] per invocation), 4 = runCounts (uint[] per invocation), 5 = cells
//           (uint[] per position, written four at a time)
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = SCAN_THREADS) in;
layout(binding = 0) uniform samplerBuffer position;
layout(std430, binding = 1) readonly buffer Kept { uvec2 kept[]; };
layout(std430, binding = 2) readonly buffer Grids { vec4 grids[]; };
layout(std430, binding = 3) writeonly buffer LeaderBits { uint leaderBits[]; };
layout(std430, binding = 4) writeonly buffer RunCounts { uint runCounts[]; };
layout(std430, binding = 5) writeonly buffer Cells { uvec4 cells4[]; };
layout(push_constant) uniform Push { KeysPush pc; };
// = pc.framed, as a specialisation constant: each pipeline holds one key's code (ray_keys.comp).
layout(constant_id = 0) const uint SPEC_FRAMED = 0u;
uint flatWorkgroup() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }
vec4 g0, g1, g2, g3, g4, g5;
#include "rays/run_cell.glsl"
void main() {
  uint n = pc.count;  // pixels
  uint b = flatWorkgroup();
  if (b * SCAN_BLOCK >= n) return;
  uint t = gl_LocalInvocationIndex;
  uint inv = b * SCAN_THREADS + t;
  uint first = b * SCAN_BLOCK + t * SCAN_ITEMS;
  uint bits = kept[inv].x;  // lit_count's bits
  // The six grids in registers, picked by selects: a storage load indexed by each sample's face costs
  // every lane its own bounds-checked load on a SIMD CPU driver.
  g0 = vec4(0.0f), g1 = g0, g2 = g0, g3 = g0, g4 = g0, g5 = g0;
  if (SPEC_FRAMED == 0u && bits != 0u) {
    g0 = grids[0], g1 = grids[1], g2 = grids[2], g3 = grids[3], g4 = grids[4], g5 = grids[5];
  }
  // A lit position leads unless the one before it is lit and in its cell. Unlit positions are read too
  // (within the image: min) and their cells ignored.
  uint follows = 0u, last = 0u;  // bit k: position k is in position k - 1's cell; last: the cell before
  uint end = min(first + SCAN_ITEMS, n) - 1u;
  for (uint k = 0u; k < SCAN_ITEMS && (bits >> k) != 0u; k += 4u) {
    uint c0 = runCell(min(first + k, end)), c1 = runCell(min(first + k + 1u, end));
    uint c2 = runCell(min(first + k + 2u, end)), c3 = runCell(min(first + k + 3u, end));
    follows |= ((c0 == last ? 1u : 0u) | (c1 == c0 ? 2u : 0u) | (c2 == c1 ? 4u : 0u) | (c3 == c2 ? 8u : 0u)) << k;
    cells4[(first + k) >> 2u] = uvec4(c0, c1, c2, c3);
    last = c3;
  }
  uint leaders = bits & ~(follows & (bits << 1u));
  leaderBits[inv] = leaders;
  runCounts[inv] = uint(bitCount(leaders));
}
