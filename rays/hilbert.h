// The ray key of 002 §3.5 and the screen order of its unsorted variant, as plain functions that glslang
// and C++ both compile: the kernels use them, and so do the tests as their CPU reference.
//
// Ray key (18 bits, ray = light -> sample, direction d = sample - light), sorted in two radix passes of
// nine bits. The key space 0 .. 2^18 - 1 is shared out among the six direction faces (faceKeySlot):
//   face = 2 * axis + (d[axis] < 0): the major axis of d (x, y, z = 0, 1, 2) and its sign. Ties
//          (|d.x| == |d.y| >= |d.z|, ...) go to the lowest axis, so boundary directions have exactly one face.
//   Each face that the lit ones among RAY_BOUNDS_SAMPLES pixels spread evenly over the frame's
//   (ray_bounds.comp, the subset: it needs no compaction, so the fused compaction keys the pixels in the
//   pass that finds the lit ones) reach gets a run of 4^k consecutive keys, k = 9, 8 or 7 (faceKeySlot): the faces with more of
//   the subset's samples choose first, each the largest run that leaves 4^7 for every face after it; the
//   runs lie in face order. One face alone gets 2^9 x 2^9 cells, up to four faces 2^8 x 2^8 each, five or
//   six 2^8 for the three with the most samples and 2^7 for the rest. A ray's key: the run's first key +
//   the Hilbert index of the cell that the face coordinates (d[axis+1], d[axis+2]) / |d[axis]| (both in
//   [-1, 1]) fall in, on the 2^k x 2^k grid over the face's *fitted square* (fittedFaceGrid): the whole
//   face zoomed in by halves while a square half the size, on the face's own grid or half a square off
//   it, still holds the box of the subset's face coordinates there. Samples outside the box (the subset
//   missed them) go to the square's edge cells; a face none of the subset reached sends its rays to
//   RAY_KEY_LAST (rare: fewer than about one lit pixel in RAY_BOUNDS_SAMPLES). A zoomed view or a distant
//   light, whose rays span a sliver of a face, still gets cells as fine as its rays. Against the 2^12 grid
//   on every face of 27 bits and three passes it replaced, about the same pairs tested for a radix pass
//   saved (docs/ARCHITECTURE.md, "rays/", has the measurements).
// In the cone path's far-light frame the same 18 bits key one fitted grid over the rays' frame coordinates
// instead of the faces' (frameRayKey, below).
// Degenerate rays (zero length: a sample at the light; or a non-finite direction) get
// RAY_KEY_DEGENERATE = 2^18 - 1, so they sort after all others: a real key is at most RAY_KEY_LAST (the
// last cell of runs that fill the key space shares the key of the cell before it, its neighbour on the
// curve).
// Rays sharing a cell keep their compaction order (row-major pixels; the sort is stable).
//
// GPU and CPU agree exactly on the face and on the integer Hilbert index of a cell; the face coordinates
// come from float divisions, which Vulkan allows to be 2.5 ulp off, so on a GPU a box may differ by a few
// ulp and a direction within ~1e-7 of a cell boundary may land in the neighbouring cell. Lavapipe's
// division is exact. The key only
// orders the rays: any order gives the same shadow, the tree is built from the rays themselves.
#ifndef CONESHADOW_RAYS_HILBERT_H
#define CONESHADOW_RAYS_HILBERT_H

#include "rays/rays_layout.h"

#define RAY_KEY_BITS 18
#define RAY_KEY_DEGENERATE 0x3FFFFu
#define RAY_KEY_LAST 0x3FFFEu  // the largest key of a real direction
#define RAY_KEY_MAX_ORDER 9    // a face's grid: 2^9 x 2^9 cells at most (one face fills the key space) ...
#define RAY_KEY_MIN_ORDER 7    // ... and 2^7 x 2^7 at least, for a face the subset reached
#if RAY_KEY_MAX_ORDER > 12
#error "faceCellCode keeps a cell's coordinates in 12 bits each"
#endif
// The box of a face: words 4 * face + (0 .. 3) hold orderedBits of the minimum of u, of v, of -u and of
// -v over the face's samples of the subset (atomicMin; all ones, RAY_BOUNDS_EMPTY, while it has none).
// Word RAY_BOUNDS_COUNTS + face counts the subset's samples on the face (zero before the pass). In the
// far-light frame the frame's coordinates (frameUV) take face 0's words, the other faces stay empty.
#define RAY_BOUNDS_SAMPLES 16384u  // at most 2^16: boundsSample multiplies below it in 32 bits (rays.cpp)
#define RAY_BOUNDS_WORDS 32u
#define RAY_BOUNDS_COUNTS 24u
#define RAY_BOUNDS_EMPTY 0xFFFFFFFFu
#define RAY_KEY_MAX_ZOOM 24  // halvings of a face's grid at most: past them cells are finer than fp32 resolves

#ifdef __cplusplus
namespace cs::rays {
namespace glsl {  // the functions below are GLSL; these names let C++ read them as written
CS_GLSL_TYPES
CS_GLSL_MATH
using glm::floatBitsToUint;
using glm::uintBitsToFloat;
#endif

// Index of cell (x, y) along the Hilbert curve over a 2^order x 2^order grid (order 1..16). The curve
// starts at (0, 0) and ends at (2^order - 1, 0); consecutive indices are edge-neighbouring cells.
//
// Without a loop over the levels. Walking the levels from the coarsest, each level's quadrant (a bit of x
// and of y) gives two bits of the index, read in the frame the coarser levels left: the identity, a
// transpose, an anti-transpose or a half turn -- four frames, a group in which composing is an XOR of two
// bits. Which frame change a level makes depends on its quadrant read in its own frame, so each level is
// a map "frame in -> frame out", and a level's frame is the composition of the maps of all levels above
// it: a prefix. A map takes four bits (bit planes a, b, c, d below, one bit per level), composing two is
// a handful of ANDs and XORs, so a parallel prefix over the 16 bit positions takes four rounds, shifts by
// 1, 2, 4 and 8. Each level's frame then turns its quadrant into the index's two bits, spread into odd
// and even positions. About 70 integer operations and no branch, where the level loop takes ~20 a level
// with branches: on a SIMD CPU driver, which runs both sides of a branch, the Hilbert loop was the ray
// keys' dearest part (docs/ARCHITECTURE.md, "rays/"). The tests hold it to a textbook level-by-level
// reference on every cell of grids up to 2^12 x 2^12 and on samples of larger ones.
CS_FN uint hilbertSpreadBits(uint v) {  // bit i of v to bit 2i (v < 2^16)
  v = (v | (v << 8u)) & 0x00FF00FFu;
  v = (v | (v << 4u)) & 0x0F0F0F0Fu;
  v = (v | (v << 2u)) & 0x33333333u;
  return (v | (v << 1u)) & 0x55555555u;
}
CS_FN uint hilbertIndex(uint x, uint y, uint order) {
  x <<= 16u - order;  // the coarsest level at bit 15, the finest at bit 16 - order
  y <<= 16u - order;
  // Round one: each level's map from its quadrant, composed with the map of the level just above it.
  uint a = x ^ y, b = 0xFFFFu ^ a, c = 0xFFFFu ^ (x | y), d = x & (y ^ 0xFFFFu);
  uint pa = a | (b >> 1u), pb = (a >> 1u) ^ a;
  uint pc = ((c >> 1u) ^ (b & (d >> 1u))) ^ c, pd = ((a & (c >> 1u)) ^ (d >> 1u)) ^ d;
  // Rounds two to four: composed with the maps 2, 4 and 8 levels above (the last needs only the frames).
  for (uint s = 2u; s <= 8u; s <<= 1u) {
    uint qa = pa, qb = pb, qc = pc, qd = pd;
    pa = (qa & (qa >> s)) ^ (qb & (qb >> s));
    pb = (qa & (qb >> s)) ^ (qb & ((qa ^ qb) >> s));
    pc = qc ^ (qa & (qc >> s)) ^ (qb & (qd >> s));
    pd = qd ^ (qb & (qc >> s)) ^ ((qa ^ qb) & (qd >> s));
  }
  // Each level's frame, and its quadrant read in it: the index's low and high bit of the level.
  uint fa = pc ^ (pc >> 1u), fb = pd ^ (pd >> 1u);
  uint low = x ^ y, high = fb | (0xFFFFu ^ (low | fa));
  return ((hilbertSpreadBits(high) << 1u) | hilbertSpreadBits(low)) >> (32u - 2u * order);
}

// Which of the six direction faces d belongs to (2 * axis + negative), or 7 for a degenerate d.
CS_FN uint rayFace(vec3 d) {
  vec3 a = abs(d);
  // NaN fails every comparison and +-inf exceeds FLT_MAX: both are degenerate, as is d == 0.
  if (!(a.x <= CS_FLT_MAX && a.y <= CS_FLT_MAX && a.z <= CS_FLT_MAX)) return 7u;
  uint axis = 2u;
  if (a.x >= a.y && a.x >= a.z)
    axis = 0u;
  else if (a.y >= a.z)
    axis = 1u;
  float m = a[axis];
  if (!(m > 0.0f)) return 7u;
  return 2u * axis + (d[axis] < 0.0f ? 1u : 0u);
}

// The face coordinates of d on its face (d must not be degenerate): (d[axis+1], d[axis+2]) / |d[axis]|,
// both in [-1, 1].
CS_FN vec2 rayFaceUV(vec3 d, uint face) {
  uint axis = face >> 1u;
  // (d[axis], d[axis+1], d[axis+2]) by selects, not by indexing with a remainder (a kernel's every lane
  // pays for both on a SIMD CPU driver).
  float m = abs(d[axis]);
  return vec2(d[(axis + 1u) % 3u] / m, d[(axis + 2u) % 3u] / m);
}

// A key grid over a box of a face: (u0, v0, su, sv), cell = floor(((u, v) - (u0, v0)) * (su, sv)) clamped to
// 0 .. 2^order - 1. The whole face [-1, 1]^2 (scaling by a power of two is exact):
CS_FN vec4 wholeFaceGrid(uint order) {
  float half_ = float(1u << (order - 1u));
  return vec4(-1.0f, -1.0f, half_, half_);
}
CS_FN uvec2 gridCell(vec2 uv, vec4 grid, uint order) {
  float last = float((1u << order) - 1u);
  return uvec2(uint(clamp(floor((uv.x - grid.x) * grid.z), 0.0f, last)),
               uint(clamp(floor((uv.y - grid.y) * grid.w), 0.0f, last)));
}

// The face-local cell of d on the 2^order grid over the whole face (the value 1 itself goes to the last
// cell). d must not be degenerate.
CS_FN uvec2 rayCell(vec3 d, uint face, uint order) { return gridCell(rayFaceUV(d, face), wholeFaceGrid(order), order); }

// Floats as uints in the same order (atomicMin over them is a float minimum): non-negative floats get the
// sign bit set, negative ones are inverted. Finite values never map to RAY_BOUNDS_EMPTY.
CS_FN uint orderedBits(float x) {
  uint b = floatBitsToUint(x);
  return (b & 0x80000000u) != 0u ? ~b : (b | 0x80000000u);
}
CS_FN float fromOrderedBits(uint o) { return uintBitsToFloat((o & 0x80000000u) != 0u ? (o & 0x7FFFFFFFu) : ~o); }

// The start of an interval of length s on a face axis ([-1, 1]) that holds [lo, hi]: one of the face's
// own intervals of that length (aligned at -1 + k s), else one offset by half their length; 2 (past the
// face) when neither holds it.
CS_FN float zoomOrigin(float lo, float hi, float s) {
  float aligned = floor((lo + 1.0f) / s) * s - 1.0f;  // s is a power of two: the division is exact
  if (hi <= aligned + s) return aligned;
  float offset = floor((lo + 1.0f + 0.5f * s) / s) * s - 0.5f * s - 1.0f;
  if (offset <= lo && hi <= offset + s) return offset;
  return 2.0f;
}

// The grid over a face's fitted box (box: its four words, see RAY_BOUNDS_SAMPLES): the whole face's grid
// zoomed in by halves while a square of half the side still holds the box, each axis's start on the face's
// own grid of that square's side or half a side off it (RAY_KEY_MAX_ZOOM halvings at most). The cells stay
// square and the squares stay on the face's grid: a grid placed at the box's own corner, or stretched to
// its sides, costs more pairs than the whole face's (docs/ARCHITECTURE.md, "rays/"). The whole
// face when the subset had no sample there.
CS_FN vec4 fittedFaceGrid(uvec4 box, uint order) {
  vec4 grid = wholeFaceGrid(order);
  if (box.x == RAY_BOUNDS_EMPTY) return grid;
  vec2 lo = vec2(fromOrderedBits(box.x), fromOrderedBits(box.y));
  vec2 hi = vec2(-fromOrderedBits(box.z), -fromOrderedBits(box.w));
  float side = 2.0f;
  for (uint level = 1u; level <= uint(RAY_KEY_MAX_ZOOM); ++level) {
    float s = 0.5f * side;
    float x = zoomOrigin(lo.x, hi.x, s), y = zoomOrigin(lo.y, hi.y, s);
    if (x > 1.0f || y > 1.0f) break;
    side = s;
    grid = vec4(x, y, float(1u << order) / s, float(1u << order) / s);
  }
  return grid;
}

// Which pixel the subset's j-th member is (j < RAY_BOUNDS_SAMPLES, n pixels, row-major): spread evenly,
// floor(j * n / RAY_BOUNDS_SAMPLES) in 32-bit arithmetic (j and n % RAY_BOUNDS_SAMPLES below 2^16). May
// repeat a pixel when n is small. The subset is its lit ones.
CS_FN uint boundsSample(uint j, uint n) {
  return j * (n / RAY_BOUNDS_SAMPLES) + (j * (n % RAY_BOUNDS_SAMPLES)) / RAY_BOUNDS_SAMPLES;
}

// The first of the subset's members at or after pixel p (n pixels, p <= n): the least j with
// boundsSample(j, n) >= p, ceil(p RAY_BOUNDS_SAMPLES / n) (RAY_BOUNDS_SAMPLES past the last), by long
// division in 32 bits whatever n. ray_bounds.comp takes the members of a row of the rect from it.
CS_FN uint firstBoundsSampleFrom(uint p, uint n) {
  uint q = 0u, r = p;  // r < n throughout (p == n: the end)
  if (r >= n) return RAY_BOUNDS_SAMPLES;
  for (uint bit = 1u; bit < RAY_BOUNDS_SAMPLES; bit <<= 1u) {  // RAY_BOUNDS_SAMPLES is a power of two
    bool carry = r >= n - r;  // 2 r >= n without overflow
    r = carry ? r - (n - r) : r + r;
    q = q + q + (carry ? 1u : 0u);
  }
  return q + (r != 0u ? 1u : 0u);
}

// The size of the run of keys `face` gets, as the order k of its 2^k x 2^k grid, from the subset's samples
// on each face (counts, the bounds' words RAY_BOUNDS_COUNTS ..): the faces ranked by count (ties to the
// lower face), each taking the largest order whose run leaves 4^RAY_KEY_MIN_ORDER keys for every face
// ranked after it. The face must have a count.
CS_FN uint faceKeyOrder(uint face, uint counts[6]) {
  uint seen = 0u, rank = 0u;
  for (uint f = 0u; f < 6u; ++f) {
    seen += counts[f] > 0u ? 1u : 0u;
    rank += counts[f] > counts[face] || (counts[f] == counts[face] && f < face) ? 1u : 0u;
  }
  uint used = 0u, order = uint(RAY_KEY_MAX_ORDER);  // keys taken by the faces ranked before
  for (uint r = 0u; r <= rank; ++r) {
    used += r > 0u ? 1u << (2u * order) : 0u;
    uint later = (seen - r - 1u) << (2u * uint(RAY_KEY_MIN_ORDER));
    order = uint(RAY_KEY_MAX_ORDER);
    while (order > uint(RAY_KEY_MIN_ORDER) && (1u << (2u * order)) + later > (1u << uint(RAY_KEY_BITS)) - used) --order;
  }
  return order;
}
// The run of keys `face` gets, (order, first key): the runs of the faces with a count back to back in face
// order (ranked order costs more pairs, docs/ARCHITECTURE.md, "rays/": where one face's curve ends and
// the next begins changes the nodes that straddle them). Order 0 and RAY_KEY_LAST for a face with no
// count, whose rays all take that key. The same on every device: integer arithmetic on the same counts.
CS_FN uvec2 faceKeySlot(uint face, uint counts[6]) {
  if (counts[face] == 0u) return uvec2(0u, uint(RAY_KEY_LAST));
  uint first = 0u;
  for (uint f = 0u; f < face; ++f) first += counts[f] > 0u ? 1u << (2u * faceKeyOrder(f, counts)) : 0u;
  return uvec2(faceKeyOrder(face, counts), first);
}

// The key of a non-degenerate direction d on `face`, with the face's grid (fittedFaceGrid of its slot's
// order) and slot (faceKeySlot).
CS_FN uint faceRayKey(vec3 d, uint face, vec4 grid, uvec2 slot) {
  if (slot.x == 0u) return slot.y;
  uvec2 c = gridCell(rayFaceUV(d, face), grid, slot.x);
  return min(slot.y + hilbertIndex(c.x, c.y, slot.x), uint(RAY_KEY_LAST));
}

// A face's key grid as ray_grids.comp writes it for the keys kernels, one vec4: (u0, v0, scale, slot),
// the slot as the exact float first * 16 + order (< 2^22), the cells square (fittedFaceGrid's scales are
// equal). faceKey is faceRayKey on it.
CS_FN vec4 faceKeyGrid(uvec4 box, uvec2 slot) {
  vec4 g = fittedFaceGrid(box, max(slot.x, 1u));
  return vec4(g.x, g.y, g.z, float(slot.y * 16u + slot.x));
}
// faceKey in two steps, for the fused compaction's runs (lit_runs.comp, run_items.comp): faceCellCode
// names d's cell, (face << 24) | (x << 12) | y (the face alone when its slot has no grid), and
// faceCodeKey turns a code into the key; equal codes, equal keys, and faceCodeKey(faceCellCode(d)) is
// faceRayKey's key. The cell costs a fraction of the Hilbert index, which the runs then take once a run.
CS_FN uint faceCellCode(vec3 d, uint face, vec4 keyGrid) {
  uint order = uint(keyGrid.w) & 15u;
  if (order == 0u) return face << 24u;
  uvec2 c = gridCell(rayFaceUV(d, face), vec4(keyGrid.x, keyGrid.y, keyGrid.z, keyGrid.z), order);
  return (face << 24u) | (c.x << 12u) | c.y;
}
CS_FN uint faceCodeKey(uint code, vec4 keyGrid) {  // keyGrid: the grid of face code >> 24
  uint s = uint(keyGrid.w), order = s & 15u;
  if (order == 0u) return s >> 4u;
  return min((s >> 4u) + hilbertIndex((code >> 12u) & 0xFFFu, code & 0xFFFu, order), uint(RAY_KEY_LAST));
}
CS_FN uint faceKey(vec3 d, uint face, vec4 keyGrid) { return faceCodeKey(faceCellCode(d, face, keyGrid), keyGrid); }

// The key of d on its whole face, every face counted alike (faces 0-2 get 2^8 cells, 3-5 2^7): the tests'
// reference for faces and Hilbert order.
CS_FN uint rayKey(vec3 d) {
  uint face = rayFace(d);
  if (face == 7u) return RAY_KEY_DEGENERATE;
  uint same[6];
  for (uint f = 0u; f < 6u; ++f) same[f] = 1u;
  uvec2 slot = faceKeySlot(face, same);
  return faceRayKey(d, face, wholeFaceGrid(slot.x), slot);
}

// The ray key in a rotated frame (the cone path's far-light frame, traversal/traversal.h): all rays
// within a few degrees of the frame's +z, each ray d_f put in the frame by frameRay and keyed on its
// frame coordinates (d_f.x / d_f.z, d_f.y / d_f.z) (frameUV) -- the whole key space one face, as a
// light outside the view gives the world key: a Hilbert curve over a 2^RAY_KEY_MAX_ORDER square grid
// (18 bits, two radix passes), min'ed with RAY_KEY_LAST so RAY_KEY_DEGENERATE (d_f.z <= 0, non-finite)
// sorts last. The grid is fitted to the subset's box of frame coordinates (ray_bounds.comp, face 0's
// words; frameKeyGrid), its cells square; samples outside the box go to the edge cells. It replaced a
// 2^15 x 2^15 grid over the scene's projection (31 bits, four passes, and neighbours rarely in one cell, so
// the runs saved nothing); the measurements are in docs/ARCHITECTURE.md, "rays/".
#define FRAME_CODE_DEGENERATE (7u << 24u)  // frameCellCode of a degenerate ray (as a face code's face 7)

// The ray to position x in the frame (cone_layout.h ConeFrame): S R (x - origin) - lightFrame, R's rows
// in rowX .. rowZ, the shear in rowY.w and rowZ.w.
CS_FN vec3 frameRay(vec3 x, vec4 rowX, vec4 rowY, vec4 rowZ, vec4 origin, vec4 lightFrame) {
  vec3 d = x - vec3(origin);
  vec3 f = vec3(dot(vec3(rowX), d), dot(vec3(rowY), d), dot(vec3(rowZ), d));
  f.x -= rowY.w * f.z;  // the frame's shear
  f.y -= rowZ.w * f.z;
  return f - vec3(lightFrame);
}
// Whether a ray in the frame has a key cell: d_f.z > 0, d_f finite and so its frame coordinates.
CS_FN bool frameRayKeyed(vec3 d) {
  if (!(d.z > 0.0f) || !(abs(d.x) <= CS_FLT_MAX && abs(d.y) <= CS_FLT_MAX && d.z <= CS_FLT_MAX)) return false;
  return abs(d.x / d.z) <= CS_FLT_MAX && abs(d.y / d.z) <= CS_FLT_MAX;
}
CS_FN vec2 frameUV(vec3 d) { return vec2(d.x / d.z, d.y / d.z); }

// The frame's key grid as ray_grids.comp writes it for the keys kernels, faceKeyGrid's form (u0, v0,
// scale, slot: the run starts at key 0, so the slot is the order): a square at the lower corner of the
// subset's `box` of frame coordinates (face 0's words) whose side is the box's larger extent, so the box
// spans all 2^order cells along that axis; without a box (the subset had no lit sample), the same over the
// scene's projection `rect` (KeysPush::rect: (u0, v0, 1 / (u1 - u0), 1 / (v1 - v0))). Not on power-of-two
// squares as a face's (fittedFaceGrid): measured in this frame, those cost more pairs, and varied with where
// the box fell on the plane's grid of them (docs/ARCHITECTURE.md, "rays/").
CS_FN vec4 frameKeyGrid(uvec4 box, vec4 rect, uint order) {
  vec2 lo = vec2(rect.x, rect.y), extent = vec2(1.0f / rect.z, 1.0f / rect.w);
  if (box.x != RAY_BOUNDS_EMPTY) {
    lo = vec2(fromOrderedBits(box.x), fromOrderedBits(box.y));
    extent = vec2(-fromOrderedBits(box.z), -fromOrderedBits(box.w)) - lo;
  }
  // A box of one direction: any cells (its rays share one; those the subset missed go to the edges).
  float side = max(max(extent.x, extent.y), 1e-30f);
  return vec4(lo.x, lo.y, float(1u << order) / side, float(order));
}
// frameRayKey in two steps, as faceKey's: frameCellCode names d's cell, (x << 12) | y (FRAME_CODE_DEGENERATE
// where it has none), frameCodeKey turns the code into the key: equal codes, equal keys.
CS_FN uint frameCellCode(vec3 d, vec4 keyGrid) {
  if (!frameRayKeyed(d)) return FRAME_CODE_DEGENERATE;
  uvec2 c = gridCell(frameUV(d), vec4(keyGrid.x, keyGrid.y, keyGrid.z, keyGrid.z), uint(keyGrid.w) & 15u);
  return (c.x << 12u) | c.y;
}
CS_FN uint frameCodeKey(uint code, vec4 keyGrid) {
  if (code == FRAME_CODE_DEGENERATE) return RAY_KEY_DEGENERATE;
  return min(hilbertIndex((code >> 12u) & 0xFFFu, code & 0xFFFu, uint(keyGrid.w) & 15u), uint(RAY_KEY_LAST));
}
CS_FN uint frameRayKey(vec3 d, vec4 keyGrid) { return frameCodeKey(frameCellCode(d, keyGrid), keyGrid); }

// The pixel (x, y) at position i of the unsorted screen order over tiles of 2^MORTON_TILE_BITS pixels
// a side, tilesX tiles per row. May lie outside the image when its size is not a multiple of the tile.
// In two parts, so that a kernel walking consecutive positions of one tile divides once: the tile's
// first pixel (an integer division by tilesX, which a SIMD CPU driver does lane by lane) and the offset
// of position i inside its tile (bit shuffles only).
CS_FN uvec2 screenTileOrigin(uint i, uint tilesX) {
  uint tile = i >> (2u * uint(MORTON_TILE_BITS));
  return uvec2(tile % tilesX, tile / tilesX) << uint(MORTON_TILE_BITS);
}
CS_FN uvec2 screenOffsetInTile(uint i) {
  uint local = i & ((1u << (2u * uint(MORTON_TILE_BITS))) - 1u);
  return uvec2(evenBits(local), evenBits(local >> 1u));
}
CS_FN uvec2 screenOrderPixel(uint i, uint tilesX) { return screenTileOrigin(i, tilesX) + screenOffsetInTile(i); }
// The same in a window of the image's tiles tilesX wide whose first tile is (firstTile & 0xFFFF,
// firstTile >> 16) (rays.h ScreenDomain): its tiles in the image's order.
CS_FN uvec2 windowTileOrigin(uint i, uint tilesX, uint firstTile) {
  return screenTileOrigin(i, tilesX) + (uvec2(firstTile & 0xFFFFu, firstTile >> 16u) << uint(MORTON_TILE_BITS));
}
// Whether row-major positions first .. last (rows of `width`) can meet the pixel rect (x0, y0, x1, y1),
// exclusive ends: in its rows and, where they stay in one row, overlapping its columns (a stretch that
// wraps to the next row: by the rows alone). lit_runs.comp and lit_count.comp skip a stretch that cannot.
CS_FN bool rowStretchMeetsRect(uint first, uint last, uint width, uvec4 rect) {
  uint ya = first / width, yb = last / width;
  return ya < rect.w && yb >= rect.y && (ya != yb || (last - yb * width >= rect.x && first - ya * width < rect.z));
}

// The fused compaction's enumeration of the pixels that may hold geometry (LitRays::recordCompactionWithKeys,
// rectDomain): the rect's rows top to bottom, each as `span` positions (its width rounded up to a whole
// SCAN_ITEMS, so an invocation's positions lie in one row: consecutive pixels); position i's pixel, of a
// row of the image `width` wide. Positions past the rect's width in their row (i % span >= x1 - x0) are
// padding: never lit. The lit pixels come in row-major order, as over the whole image.
CS_FN uint rectDomainPixel(uint i, uvec4 rect, uint span, uint width) {
  uint row = i / span;
  return (rect.y + row) * width + rect.x + (i - row * span);
}

#ifdef __cplusplus
}  // namespace glsl
using glsl::hilbertIndex;
using glsl::rayCell;
using glsl::rayFace;
using glsl::rayKey;
using glsl::frameRayKey;
using glsl::frameCellCode;
using glsl::frameCodeKey;
using glsl::frameKeyGrid;
using glsl::frameRay;
using glsl::frameRayKeyed;
using glsl::frameUV;
using glsl::rayFaceUV;
using glsl::wholeFaceGrid;
using glsl::gridCell;
using glsl::orderedBits;
using glsl::fromOrderedBits;
using glsl::fittedFaceGrid;
using glsl::zoomOrigin;
using glsl::boundsSample;
using glsl::firstBoundsSampleFrom;
using glsl::faceRayKey;
using glsl::faceKeySlot;
using glsl::faceKeyGrid;
using glsl::faceKey;
using glsl::screenOffsetInTile;
using glsl::screenOrderPixel;
using glsl::rowStretchMeetsRect;
using glsl::rectDomainPixel;
using glsl::screenTileOrigin;
using glsl::windowTileOrigin;
constexpr uint32_t kRayKeyDegenerate = RAY_KEY_DEGENERATE;
constexpr uint32_t kRayKeyBits = RAY_KEY_BITS;
constexpr uint32_t kRayKeyLast = RAY_KEY_LAST;
}  // namespace cs::rays
#endif
#endif
