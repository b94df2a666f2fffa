#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_basic : require
// The fused compaction of the sorted cone path, its one pass over the pixels (rays.h,
// LitRays::recordCompactionWithKeys): the lit samples and the runs' in one read of the G-buffer.
// The positions are the rows of the pixels that may hold geometry (rays.h rectDomain, rectDomainPixel:
// each row padded to whole SCAN_ITEMS), so a far view pays for its scene's rect, not for the image.
// Invocation t of block b owns the SCAN_ITEMS consecutive positions from b * SCAN_BLOCK + t * SCAN_ITEMS,
// consecutive pixels of one row: which are lit samples (litSampleFor the light, a bit each) and the runs of equal keys among
// them. A run is a stretch of consecutive lit pixels of the invocation whose rays fall in one cell of the
// key grid (faceCellCode, frameCellCode: equal cells, equal keys); its first pixel leads it. A stable
// sort puts a run's pixels next to each other in the order they have here (nothing else lies between
// them in row-major order), so the sort takes one item a run (run_items.comp, which computes the
// leaders' keys) and run_expand.comp writes each run's pixels after the sort: the order is the per-ray
// sort's, bit for bit. Here each invocation writes its lit bits and its leaders (bit k: position k leads
// a run) to kept, one uvec2, and the leaders' count to runCounts, which sort/'s scan turns into the
// invocation's first item; each subgroup adds its lit count to the lit count (one atomicAdd: no workgroup
// scan and its barriers, no scan of block counts); and the cells of every four positions with a lit one
// among them go to cells, one uvec4 store (run_items reads the leaders'). The positions go four at a
// time; the normals, the light term, the cells and the store only for four with geometry, found by a loop
// that reads positions until some four have it: on a SIMD CPU driver a branch runs its code for every
// lane under a mask, even where no lane takes it, and only a loop's exit skips code, so a far view's
// empty pixels cost little more than their position's fetch (docs/ARCHITECTURE.md, "rays/"). The key
// grids come first, from a subset of the pixels that needs no compaction (ray_bounds.comp,
// ray_grids.comp); the grid once known, the G-buffer is read once here.
// bindings: 0 = position, 1 = normal (uniform texel buffers, RGBA32F: a texel per pixel), 2 = kept
//           (uvec2[] per invocation: lit bits, leaders), 3 = the lit count (uint[1], zero before the
//           dispatch), 4 = the key grids (uniform texel buffer, RGBA32F: a texel per face; a rotated
//           frame's in texel 0), 5 = runCounts (uint[] per invocation), 6 = cells (uint[] per position,
//           written four at a time where one of the four is lit), 7 = the enumeration (uniform: uvec4 x0,
//           y0, x1, y1 of DeviceGBuffer::geometryRect, clamped; uvec4 the image's width, the span of a
//           row, the positions); pc.count: the pixels
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = SCAN_THREADS) in;
layout(binding = 0) uniform samplerBuffer position;
layout(binding = 1) uniform samplerBuffer normal;
layout(std430, binding = 2) writeonly buffer Kept { uvec2 kept[]; };
layout(std430, binding = 3) buffer LitCount { uint litCount[]; };
layout(binding = 4) uniform samplerBuffer grids;
layout(std430, binding = 5) writeonly buffer RunCounts { uint runCounts[]; };
layout(std430, binding = 6) writeonly buffer Cells { uvec4 cells4[]; };
layout(std140, binding = 7) uniform Domain { uvec4 rect; uvec4 size; };
layout(push_constant) uniform Push { KeysPush pc; };
// = pc.framed, as a specialisation constant: each pipeline holds one key's code (ray_keys.comp).
layout(constant_id = 0) const uint SPEC_FRAMED = 0u;
vec4 g0, g1, g2, g3, g4, g5;
#include "rays/run_cell.glsl"

uint bits = 0u;

// Pixel i's texel (clamped into the image; the padding's pixels are never lit, see mayBeLit).
vec4 positionAt(uint i, uint n) { return texelFetch(position, int(min(i, n - 1u))); }
// 1 where the invocation's k-th position, at x, may be lit: in the rect's row (k < real) and with
// geometry (litSample with a normal that passes: false whatever the normal where the pixel is empty).
uint mayBeLit(vec4 x, uint k, uint real) { return k < real && litSample(x, vec4(1.0f)) ? 1u : 0u; }
// 1 where position i, at x and possibly lit (may), is lit: its light term for pc.light, computed here
// (litSampleFor; the G-buffer's normal.w is not read).
uint litAt(vec4 x, uint i, uint n, uint may) {
  return may & (litSampleFor(x, texelFetch(normal, int(min(i, n - 1u))), pc.light.xyz) ? 1u : 0u);
}
void main() {
  uint n = pc.count;  // pixels
  uint b = CS_FLAT_WORKGROUP;
  if (b * SCAN_BLOCK >= size.z) return;  // the whole workgroup: past the end
  uint t = gl_LocalInvocationIndex;
  uint inv = b * SCAN_THREADS + t;
  uint first = b * SCAN_BLOCK + t * SCAN_ITEMS;
  // The six grids in registers, picked by selects: a storage load indexed by each sample's face costs
  // every lane its own bounds-checked load on a SIMD CPU driver (and a storage load of all six, 24 of
  // them; texel fetches are the cheap reads there).
  g0 = texelFetch(grids, 0), g1 = vec4(0.0f), g2 = g1, g3 = g1, g4 = g1, g5 = g1;  // a rotated frame: g0 alone
  if (SPEC_FRAMED == 0u) {
    g1 = texelFetch(grids, 1), g2 = texelFetch(grids, 2);
    g3 = texelFetch(grids, 3), g4 = texelFetch(grids, 4), g5 = texelFetch(grids, 5);
  }
  // A lit position leads unless the one before it is lit and in its cell.
  uint follows = 0u, last = 0u;  // bit k: position k is in position k - 1's cell; last: the cell before
  // The invocation's positions are the pixels from p0 on; the first `real` of them are in the rect, the
  // rest padding of its row (or past the enumeration's end): a lane of padding alone leaves the loops at
  // once, and a subgroup of such lanes reads nothing.
  uint col = first % size.y, width = rect.z - rect.x;
  uint real = first < size.z && col < width ? min(uint(SCAN_ITEMS), width - col) : 0u;
  uint p0 = rectDomainPixel(first, rect, size.y, size.x);
  uint end = (real + 3u) & ~3u;  // whole fours
  uint k = 0u;  // the next four positions to look at
  while (k < end) {
    // On four positions at a time until this invocation's four have geometry (or the end): the loop
    // runs as often as the lane that goes furthest needs, and the code below once for the subgroup's
    // next fours with geometry.
    vec4 x0, x1, x2, x3;
    uint m0, m1, m2, m3;
    do {
      uint i = p0 + k;
      x0 = positionAt(i, n), x1 = positionAt(i + 1u, n), x2 = positionAt(i + 2u, n), x3 = positionAt(i + 3u, n);
      m0 = mayBeLit(x0, k, real), m1 = mayBeLit(x1, k + 1u, real), m2 = mayBeLit(x2, k + 2u, real),
      m3 = mayBeLit(x3, k + 3u, real);
      k += 4u;
    } while ((m0 | m1 | m2 | m3) == 0u && k < end);
    uint at = k - 4u, i = p0 + at;
    uint lit = litAt(x0, i, n, m0) | (litAt(x1, i + 1u, n, m1) << 1u) | (litAt(x2, i + 2u, n, m2) << 2u) |
               (litAt(x3, i + 3u, n, m3) << 3u);
    if (lit != 0u) {
      bits |= lit << at;
      uint c0 = runCellAt(x0.xyz), c1 = runCellAt(x1.xyz), c2 = runCellAt(x2.xyz), c3 = runCellAt(x3.xyz);
      follows |= ((c0 == last ? 1u : 0u) | (c1 == c0 ? 2u : 0u) | (c2 == c1 ? 4u : 0u) | (c3 == c2 ? 8u : 0u)) << at;
      cells4[(first + at) >> 2u] = uvec4(c0, c1, c2, c3);  // by position
      last = c3;
    }
  }
  uint leaders = bits & ~(follows & (bits << 1u));
  kept[inv] = uvec2(bits, leaders);
  runCounts[inv] = uint(bitCount(leaders));
  uint lit = subgroupAdd(uint(bitCount(bits)));
  if (subgroupElect() && lit != 0u) atomicAdd(litCount[0], lit);
}
