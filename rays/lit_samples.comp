#version 450
#extension GL_GOOGLE_include_directive : require
// Compaction of the lit samples, step 3 (rays.h, LitRays::recordCompaction): every lit position of the
// enumeration, in its order, writes the pixel index it stands for (row-major: the position itself;
// SPEC_MORTON: its pixel in the tiled Morton screen order) to samples[offsets[block] + its rank among the
// block's lit positions]. The lit bits and ranks come from lit_count.comp (kept), the block offsets from
// the scan of its counts: no barrier here. The sorted path keys its lit pixels in lit_runs.comp instead.
// bindings: 0 = kept (uvec2[] per invocation: bits, rank in the block), 1 = offsets (uint[] per block,
//           exclusive), 2 = samples (uint[])
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = SCAN_THREADS) in;
layout(std430, binding = 0) readonly buffer Kept { uvec2 kept[]; };
layout(std430, binding = 1) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = 2) writeonly buffer Samples { uint samples[]; };
layout(push_constant) uniform Push { LitPush pc; };
layout(constant_id = 0) const uint SPEC_MORTON = 0u;
void main() {
  uint b = CS_FLAT_WORKGROUP;
  if (b * SCAN_BLOCK >= pc.domain) return;
  uint t = gl_LocalInvocationIndex;
  uint first = b * SCAN_BLOCK + t * SCAN_ITEMS;
  uvec2 mine = kept[b * SCAN_THREADS + t];
  uint bits = mine.x, at = offsets[b] + mine.y;
  // Morton: the invocation's positions share a tile (SCAN_ITEMS divides a tile's), so one division.
  uvec2 origin = SPEC_MORTON != 0u && bits != 0u ? windowTileOrigin(first, pc.tilesX, pc.firstTile) : uvec2(0u);
  while (bits != 0u) {
    uint i = first + uint(findLSB(bits));
    bits &= bits - 1u;
    uint pixel = i;
    if (SPEC_MORTON != 0u) {
      uvec2 p = origin + screenOffsetInTile(i);
      pixel = p.y * pc.width + p.x;
    }
    samples[at++] = pixel;
  }
}
