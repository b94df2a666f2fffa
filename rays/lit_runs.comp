#version 450
#extension GL_GOOGLE_include_directive : require
// The fused compaction of the sorted cone path, step 3 (rays.h, LitRays::recordCompactionWithKeys): every
// lit pixel's ray key, in row-major order, and the runs of equal keys. A run is a stretch of consecutive
// lit pixels of one invocation's SCAN_ITEMS positions whose keys are all equal; its first pixel leads it.
// A stable sort puts a run's pixels next to each other in the order they have here (nothing else lies
// between them in row-major order), so the sort takes one item a run (run_items.comp) and
// run_expand.comp writes each run's pixels after the sort: the order is the per-ray sort's, bit for bit.
// Here: each leader's key goes to runKeys at its lit slot (offsets[block] + its rank among the block's
// lit pixels), and each invocation's leaders to leaderBits (bit k: position k leads a run) and their count
// to runCounts, which sort/'s scan turns into the invocation's first item. The lit bits and ranks come
// from lit_count.comp, the block offsets from the scan of its counts, the faces' grids from
// ray_grids.comp. The key is ray_keys.comp's: faceKey on the face's fitted grid, or frameRayKey in a
// rotated frame (SPEC_FRAMED).
// bindings: 0 = position (uniform texel buffer, RGBA32F: a texel per pixel), 1 = kept (uvec2[] per
//           invocation: bits, rank in the block), 2 = offsets (uint[] per block, exclusive), 3 = runKeys
//           (uint[] per lit slot), 4 = the faces' grids (vec4 per face; world keys), 5 = leaderBits (uint[]
//           per invocation), 6 = runCounts (uint[] per invocation)
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = SCAN_THREADS) in;
layout(binding = 0) uniform samplerBuffer position;
layout(std430, binding = 1) readonly buffer Kept { uvec2 kept[]; };
layout(std430, binding = 2) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = 3) writeonly buffer RunKeys { uint runKeys[]; };
layout(std430, binding = 4) readonly buffer Grids { vec4 grids[]; };
layout(std430, binding = 5) writeonly buffer LeaderBits { uint leaderBits[]; };
layout(std430, binding = 6) writeonly buffer RunCounts { uint runCounts[]; };
layout(push_constant) uniform Push { KeysPush pc; };
// = pc.framed, as a specialisation constant: each pipeline holds one key's code (ray_keys.comp).
layout(constant_id = 0) const uint SPEC_FRAMED = 0u;
uint flatWorkgroup() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }
void main() {
  uint n = pc.count;  // pixels
  uint b = flatWorkgroup();
  if (b * SCAN_BLOCK >= n) return;
  uint t = gl_LocalInvocationIndex;
  uint first = b * SCAN_BLOCK + t * SCAN_ITEMS;
  uvec2 mine = kept[b * SCAN_THREADS + t];  // lit_count's bits and rank: no scan, no barrier here
  uint bits = mine.x, at = offsets[b] + mine.y;
  // The six grids in registers, picked by selects: a storage load indexed by each sample's face costs
  // every lane its own bounds-checked load on a SIMD CPU driver.
  vec4 g0 = vec4(0.0f), g1 = g0, g2 = g0, g3 = g0, g4 = g0, g5 = g0;
  if (SPEC_FRAMED == 0u && bits != 0u) {
    g0 = grids[0], g1 = grids[1], g2 = grids[2], g3 = grids[3], g4 = grids[4], g5 = grids[5];
  }
  uint leaders = 0u, runs = 0u;
  uint lastKey = 0u, lastK = 0x7FFFFFFFu;  // the previous lit position's key and index (none yet: lastK + 1 is no k)
  while (bits != 0u) {
    uint k = uint(findLSB(bits));
    bits &= bits - 1u;
    vec3 x = texelFetch(position, int(first + k)).xyz;
    uint key;
    if (SPEC_FRAMED != 0u) {  // S R (x - origin) - lightFrame: the ray in the rotated frame
      vec3 d = x - pc.origin.xyz;
      vec3 f = vec3(dot(pc.rowX.xyz, d), dot(pc.rowY.xyz, d), dot(pc.rowZ.xyz, d));
      f.xy -= vec2(pc.rowY.w, pc.rowZ.w) * f.z;  // the frame's shear (cone_layout.h, ConeFrame)
      key = frameRayKey(f - pc.lightFrame.xyz, pc.rect);
    } else {
      vec3 d = x - pc.light.xyz;
      uint face = rayFace(d);
      vec4 grid = face == 0u ? g0 : face == 1u ? g1 : face == 2u ? g2 : face == 3u ? g3 : face == 4u ? g4 : g5;
      key = face == 7u ? RAY_KEY_DEGENERATE : faceKey(d, face, grid);
    }
    // A follower: the position before it is lit and has its key.
    bool leads = lastK + 1u != k || lastKey != key;
    if (leads) runKeys[at] = key;
    leaders |= leads ? 1u << k : 0u;
    runs += leads ? 1u : 0u;
    lastKey = key;
    lastK = k;
    at++;
  }
  uint inv = b * SCAN_THREADS + t;
  leaderBits[inv] = leaders;
  runCounts[inv] = runs;
}
