#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_vote : require
// The fused compaction of the sorted cone path, its one pass over the pixels (rays.h,
// LitRays::recordCompactionWithKeys): lit_count.comp's work and the runs' in one read of the G-buffer.
// Invocation t of block b owns the SCAN_ITEMS consecutive pixels from b * SCAN_BLOCK + t * SCAN_ITEMS
// (row-major): which are lit samples (litSampleFor the light, a bit each, kept[] with the lit pixels of the block
// before its own, and the block's count, as lit_count.comp writes them), and the runs of equal keys among
// them. A run is a stretch of consecutive lit pixels of the invocation whose rays fall in one cell of the
// key grid (faceCellCode, frameCellCode: equal cells, equal keys); its first pixel leads it. A stable
// sort puts a run's pixels next to each other in the order they have here (nothing else lies between
// them in row-major order), so the sort takes one item a run (run_items.comp, which computes the
// leaders' keys) and run_expand.comp writes each run's pixels after the sort: the order is the per-ray
// sort's, bit for bit. Here each invocation writes its leaders to leaderBits (bit k: position k leads a
// run) and their count to runCounts, which sort/'s scan turns into the invocation's first item, and
// the cells of every four positions with a lit one among them to cells, one uvec4 store (run_items reads
// the leaders'). The positions go four at a time, lit or not (a loop of one lit pixel an iteration, with a
// scalar store each, took the runs twice as long on lavapipe); where no lane of a subgroup has geometry
// among its four, the subgroup skips the normals, the cells and the store (a far view's empty rows). The
// key grids come first, from a subset of the pixels that needs no compaction (ray_bounds.comp,
// ray_grids.comp); the grid once known, the G-buffer is read once here, where lit_count.comp and a pass
// of its own for the runs read it twice.
// bindings: 0 = position, 1 = normal (uniform texel buffers, RGBA32F: a texel per pixel), 2 = kept
//           (uvec2[] per invocation: bits, rank in the block), 3 = counts (uint[] per block), 4 = the
//           key grids (uniform texel buffer, RGBA32F: a texel per face; a rotated frame's in texel 0),
//           5 = leaderBits (uint[] per invocation), 6 = runCounts (uint[] per invocation), 7 = cells
//           (uint[] per position, written four at a time where one of the four is lit), 8 = the pixels
//           that may hold geometry (uniform: uvec4 x0, y0, x1, y1 of DeviceGBuffer::geometryRect, clamped,
//           then uvec4 width): a subgroup whose positions all lie outside reads none of them
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = SCAN_THREADS) in;
layout(binding = 0) uniform samplerBuffer position;
layout(binding = 1) uniform samplerBuffer normal;
layout(std430, binding = 2) writeonly buffer Kept { uvec2 kept[]; };
layout(std430, binding = 3) writeonly buffer Counts { uint counts[]; };
layout(binding = 4) uniform samplerBuffer grids;
layout(std430, binding = 5) writeonly buffer LeaderBits { uint leaderBits[]; };
layout(std430, binding = 6) writeonly buffer RunCounts { uint runCounts[]; };
layout(std430, binding = 7) writeonly buffer Cells { uvec4 cells4[]; };
layout(std140, binding = 8) uniform GeometryRect { uvec4 rect; uvec4 size; };
layout(push_constant) uniform Push { KeysPush pc; };
// = pc.framed, as a specialisation constant: each pipeline holds one key's code (ray_keys.comp).
layout(constant_id = 0) const uint SPEC_FRAMED = 0u;
vec4 g0, g1, g2, g3, g4, g5;
#include "rays/run_cell.glsl"
#define WG_SIZE SCAN_THREADS
#define WG_RAKE SCAN_RAKE
#include "sort/workgroup_scan.glsl"

uint bits = 0u;

// Whether one of positions i .. i + 3 (row-major, rows of size.x) may hold geometry: in the rect's rows
// and, where the four stay in one row, overlapping its columns (four that wrap to the next row: by the rows).
bool mayHoldGeometry(uint i) {
  uint w = size.x, ya = i / w, yb = (i + 3u) / w;
  bool rows = (ya >= rect.y && ya < rect.w) || (yb >= rect.y && yb < rect.w);
  return rows && (ya != yb || ((i + 3u) - yb * w >= rect.x && i - ya * w < rect.z));
}

// Position i's texel (clamped into the image; positions past it are never lit, see mayBeLit).
vec4 positionAt(uint i, uint n) { return texelFetch(position, int(min(i, n - 1u))); }
// 1 where position i, at x, may be lit: it is in the image and has geometry (litSample with a normal
// that passes: false whatever the normal where the pixel is empty).
uint mayBeLit(vec4 x, uint i, uint n) { return i < n && litSample(x, vec4(1.0f)) ? 1u : 0u; }
// 1 where position i, at x and possibly lit (may), is lit: its light term for pc.light, computed here
// (litSampleFor; the G-buffer's normal.w is not read).
uint litAt(vec4 x, uint i, uint n, uint may) {
  return may & (litSampleFor(x, texelFetch(normal, int(min(i, n - 1u))), pc.light.xyz) ? 1u : 0u);
}
void main() {
  uint n = pc.count;  // pixels
  uint b = CS_FLAT_WORKGROUP;
  if (b * SCAN_BLOCK >= n) return;  // the whole workgroup: past the end
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
  for (uint k = 0u; k < SCAN_ITEMS; k += 4u) {
    uint i = first + k;
    // Outside the rect for every lane: none of the subgroup's positions is read (a far view's empty rows
    // and columns, most of its image), as none is lit.
    if (!subgroupAny(mayHoldGeometry(i))) continue;
    vec4 x0 = positionAt(i, n), x1 = positionAt(i + 1u, n), x2 = positionAt(i + 2u, n), x3 = positionAt(i + 3u, n);
    uint m0 = mayBeLit(x0, i, n), m1 = mayBeLit(x1, i + 1u, n);
    uint m2 = mayBeLit(x2, i + 2u, n), m3 = mayBeLit(x3, i + 3u, n);
    // No lane's four has geometry: none is lit, and their cells are never read (run_items reads the
    // leaders', which are lit), nor is `last` (a position whose left neighbour is unlit leads). The
    // test is the subgroup's (subgroupOr: uniform), so the lanes branch together and skip the normals,
    // the cells and the store (a SIMD CPU driver may run a lane's divergent branch under a mask).
    if (subgroupOr(m0 | m1 | m2 | m3) == 0u) continue;
    uint lit = litAt(x0, i, n, m0) | (litAt(x1, i + 1u, n, m1) << 1u) | (litAt(x2, i + 2u, n, m2) << 2u) |
               (litAt(x3, i + 3u, n, m3) << 3u);
    if (subgroupOr(lit) == 0u) continue;
    bits |= lit << k;
    uint c0 = runCellAt(x0.xyz), c1 = runCellAt(x1.xyz), c2 = runCellAt(x2.xyz), c3 = runCellAt(x3.xyz);
    follows |= ((c0 == last ? 1u : 0u) | (c1 == c0 ? 2u : 0u) | (c2 == c1 ? 4u : 0u) | (c3 == c2 ? 8u : 0u)) << k;
    cells4[(first + k) >> 2u] = uvec4(c0, c1, c2, c3);
    last = c3;
  }
  uint leaders = bits & ~(follows & (bits << 1u));
  leaderBits[inv] = leaders;
  runCounts[inv] = uint(bitCount(leaders));
  uint total;
  kept[inv] = uvec2(bits, workgroupExclusiveSum(uint(bitCount(bits)), total));
  if (t == 0u) counts[b] = total;
}
