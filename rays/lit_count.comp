#version 450
#extension GL_GOOGLE_include_directive : require
// Compaction of the lit samples, step 1 (rays.h, LitRays::recordCompaction; the fused compaction,
// recordCompactionWithKeys, does this in lit_runs.comp, with the runs):
// which positions of the enumeration (row-major pixels, or the tiled Morton screen order of the unsorted
// variant, SPEC_MORTON, over the tiles that meet the rect: rays.h ScreenDomain) are lit samples (geometry present and the direct-light term for pc.light > 0,
// litSampleFor: normal.w is not read), one bit each, and how many each block of SCAN_BLOCK positions holds. Invocation t of block b owns the
// SCAN_ITEMS consecutive positions from b * SCAN_BLOCK + t * SCAN_ITEMS; kept[b * SCAN_THREADS + t] holds
// its bits (bit k: the k-th of them is lit) and the lit positions of the block before its own. The
// scatter (lit_samples.comp) reads that one uvec2 instead of the G-buffer and a scan of its own (a
// barrier costs a CPU driver a switch per subgroup).
// bindings: 0 = position, 1 = normal (uniform texel buffers, RGBA32F: a texel per pixel), 2 = kept
//           (uvec2[] per invocation: bits, rank in the block), 3 = counts (uint[] per block). Positions
//           outside pc.rectX, pc.rectY (the pixels that may hold geometry) are not lit.
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = SCAN_THREADS) in;
layout(binding = 0) uniform samplerBuffer position;
layout(binding = 1) uniform samplerBuffer normal;
layout(std430, binding = 2) writeonly buffer Kept { uvec2 kept[]; };
layout(std430, binding = 3) writeonly buffer Counts { uint counts[]; };
layout(push_constant) uniform Push { LitPush pc; };
// = pc.order != 0, as a specialisation constant: the row-major pipeline holds no Morton code.
layout(constant_id = 0) const uint SPEC_MORTON = 0u;
#define WG_SIZE SCAN_THREADS
#define WG_RAKE SCAN_RAKE
#include "sort/workgroup_scan.glsl"
void main() {
  uint n = pc.domain;
  uint b = CS_FLAT_WORKGROUP;
  if (b * SCAN_BLOCK >= n) return;  // the whole workgroup: past the end
  uint t = gl_LocalInvocationIndex;
  uint first = b * SCAN_BLOCK + t * SCAN_ITEMS;
  uint bits = 0u;
  // Morton: the invocation's positions share a tile (SCAN_ITEMS divides a tile's), so one division.
  uvec2 origin = SPEC_MORTON != 0u ? windowTileOrigin(first, pc.tilesX, pc.firstTile) : uvec2(0u);
  uvec2 rx = uvec2(pc.rectX & 0xFFFFu, pc.rectX >> 16u), ry = uvec2(pc.rectY & 0xFFFFu, pc.rectY >> 16u);
  // Whether the invocation's positions can meet the rect: their box (Morton: an aligned block of the tile,
  // from its first corner to its last) or their rows and, in one row, columns. Where they cannot, the
  // loop below runs no iteration for this lane, and a subgroup none of whose lanes meets it reads
  // nothing (on a SIMD CPU driver a loop's exit skips code; a branch runs it under a mask).
  bool meets;
  if (SPEC_MORTON != 0u) {
    uvec2 a = origin + screenOffsetInTile(first), z = origin + screenOffsetInTile(first + SCAN_ITEMS - 1u);
    meets = a.x < rx.y && z.x >= rx.x && a.y < ry.y && z.y >= ry.x;
  } else {
    meets = rowStretchMeetsRect(first, min(first + SCAN_ITEMS - 1u, n - 1u), pc.width, uvec4(rx.x, ry.x, rx.y, ry.y));
  }
  uint items = meets && first < n ? SCAN_ITEMS : 0u;
  for (uint k = 0u; k < items; ++k) {
    uint pixel = min(first + k, n - 1u);
    bool inside = first + k < n;
    uvec2 p;
    if (SPEC_MORTON != 0u) {
      p = origin + screenOffsetInTile(first + k);
      inside = inside && p.x < pc.width && p.y < pc.height;
      pixel = inside ? p.y * pc.width + p.x : 0u;
    } else {
      p.y = pixel / pc.width;
      p.x = pixel - p.y * pc.width;
    }
    inside = inside && p.x >= rx.x && p.x < rx.y && p.y >= ry.x && p.y < ry.y;  // outside: not lit
    bool lit = inside && litSampleFor(texelFetch(position, int(pixel)), texelFetch(normal, int(pixel)), pc.light.xyz);
    bits |= lit ? 1u << k : 0u;
  }
  uint total;
  kept[b * SCAN_THREADS + t] = uvec2(bits, workgroupExclusiveSum(uint(bitCount(bits)), total));
  if (t == 0u) counts[b] = total;
}
