#version 450
#extension GL_GOOGLE_include_directive : require
// The fused compaction of the sorted cone path, step 1 (rays.h, LitRays::recordCompactionWithKeys):
// which pixels are lit samples (geometry present and direct-light term > 0, litSample), one bit a pixel,
// and how many each block of SCAN_BLOCK row-major pixels holds. Invocation t of block b owns the
// SCAN_ITEMS consecutive pixels from b * SCAN_BLOCK + t * SCAN_ITEMS; bit k of kept[b * SCAN_THREADS + t]
// says whether the k-th of them is lit, so the scatter (lit_scatter.comp) reads one word instead of
// fetching the G-buffer's normals again (and ray_bounds.comp finds the samples of its subset by them).
// bindings: 0 = position, 1 = normal (uniform texel buffers, RGBA32F: a texel per pixel), 2 = kept
//           (uint[] per invocation), 3 = counts (uint[] per block)
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = SCAN_THREADS) in;
layout(binding = 0) uniform samplerBuffer position;
layout(binding = 1) uniform samplerBuffer normal;
layout(std430, binding = 2) writeonly buffer Kept { uint kept[]; };
layout(std430, binding = 3) writeonly buffer Counts { uint counts[]; };
layout(push_constant) uniform Push { KeysPush pc; };
uint flatWorkgroup() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }
#define WG_SIZE SCAN_THREADS
#define WG_RAKE SCAN_RAKE
#include "sort/workgroup_scan.glsl"
void main() {
  uint n = pc.count;  // pixels
  uint b = flatWorkgroup();
  if (b * SCAN_BLOCK >= n) return;  // the whole workgroup: past the end
  uint t = gl_LocalInvocationIndex;
  uint first = b * SCAN_BLOCK + t * SCAN_ITEMS;
  uint bits = 0u;
  for (uint k = 0u; k < SCAN_ITEMS; ++k) {
    int p = int(min(first + k, n - 1u));
    bool lit = first + k < n && litSample(texelFetch(position, p), texelFetch(normal, p));
    bits |= lit ? 1u << k : 0u;
  }
  kept[b * SCAN_THREADS + t] = bits;
  uint total;
  workgroupExclusiveSum(uint(bitCount(bits)), total);
  if (t == 0u) counts[b] = total;
}
