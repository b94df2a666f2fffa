#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_ballot : require
// The leaves (002 §3.1 steps 3-4): for each (triangle, node) pair of the deepest interior level, the exact
// ray/triangle test against each of the node's (up to) four rays; a hit shadows the sample -- or, with
// 16 or 64 rays a leaf pair (traversal.h, LeafRays), for each pair of the depth one or two above it,
// against the (up to) 16 or 64 rays under the node. One invocation per pair: the triangle is read once for its rays, and
// lavapipe's cost per invocation (more than a ray test's arithmetic) is paid once, not once a ray.
// A hit sets the ray's bit in `shadowed` (atomicOr, idempotent: the result does not depend on order,
// chunking or races); leaf_hits.comp puts the set bits into the visibility once the traversal's leaves
// have run. The bits are also the leaves' hint: a pair tests only the rays not yet known shadowed. With
// the cull (SPEC_CULL, chosen per batch where its leaf tests per ray are many: traversal.h,
// leafCullTestsPerRay), only those whose line meets the triangle's sphere (sphere_test.h, leafSphere).
// Counts nothing per test (shared or global atomics per invocation cost ~15 % on lavapipe): the host
// counts 4 (16, 64) tests per pair, and the pairs of the last node, past the last ray, count the rays they
// lack in STAT_MISSING.
// bindings: 0 = triangles (uniform texel buffer, RGBA32F, 3 texels a triangle), 1 = arena (uniform texel buffer, RGBA32UI: two uvec2 pairs a texel),
//           2 = rays (uniform texel buffer, RGBA32UI, one texel a sorted ray: the sample's position as float
//           bits and its pixel index, ConeTree::rays), 3 = stats (the device path: the state words, the
//           pair count at p.countWord), 4 = the same words as a uniform texel buffer (RGBA32UI): the counts
//           every invocation reads, fetched instead of loaded from storage, 5 = shadowed (a bit per sorted
//           ray, and a word more), 6 = the tree's sample boxes (ConeTree::boxes)
#include "traversal/precise_test.h"
#include "traversal/sphere_test.h"
#include "traversal/traverse.glsl"

// The leaf test (traversal.h, LeafTest): 0 leafHit, a ray at a time from the triangle's nearer end;
// 1 leafHitFromLight, the triangle's share computed once for the pair's rays; 2 leafHitFromSample, the
// triangle's edges once for the pair's rays, each ray's edge planes through its sample (or the light,
// the nearer end to the edge).
layout(constant_id = 0) const uint SPEC_LEAF_TEST = 0u;
// 1: the pair's rays culled first against the triangle's sphere (leafRayMissesSphere, a few products a
// ray), the exact test run only on the rays left; 0: every ray tested exactly.
layout(constant_id = 1) const uint SPEC_CULL = 0u;

layout(local_size_x = TRAVERSE_THREADS) in;
layout(binding = 0) uniform samplerBuffer tris;  // RGBA32F texels, three a triangle (traverse_test.comp)
layout(binding = 1) uniform usamplerBuffer arena;  // RGBA32UI texels, two (triangle, node) pairs a texel
layout(binding = 2) uniform usamplerBuffer rays;  // RGBA32UI texels, one a sorted ray
layout(std430, binding = 3) buffer Stats { uint stats[]; };
layout(binding = 4) uniform usamplerBuffer statTexels;  // binding 3's words, four a texel
// Bit r: a leaf test hit sorted ray r. The answer (leaf_hits.comp turns it into the visibility) and a
// hint: a pair tests only the rays its words do not mark; a stale read costs tests, never a wrong mask
// (a bit once set stays set). Cleared per traversal.
layout(std430, binding = 5) buffer Shadowed { uint shadowed[]; };
// The tree's sample boxes (conetree/cone_layout.h, boxOffset; RGBA32F, lo and hi).
layout(binding = 6) uniform samplerBuffer boxes;
layout(push_constant) uniform Push { TraversePush p; };

uint statWord(uint w) { return texelWord(statTexels, w); }

// Whether sorted ray `leaf` meets the pair's triangle within (eps, L - eps). sampleEnds: the test from
// the sample takes every edge from the sample's end (leafSamplesNearer held for the pair's box).
bool rayHits(uint leaf, LeafTriangle t, LeafEdges e, vec3 P0, vec3 P1, vec3 P2, vec3 light, bool sampleEnds) {
  vec3 samplePos = uintBitsToFloat(texelFetch(rays, int(leaf)).xyz);
  vec4 ray = leafRay(samplePos, light);
  bool hit = SPEC_LEAF_TEST == 1u ? leafHitFromLight(t, samplePos, ray, p.eps)
           : SPEC_LEAF_TEST == 2u ? (sampleEnds ? leafHitFromSampleEnd(t, e, samplePos, ray, p.eps)
                                                : leafHitFromSample(t, e, samplePos, ray, p.eps))
                                  : leafHit(t, samplePos, light, ray, p.eps, P0, P1, P2);
  return leafRayUsable(ray, p.minLength) && hit;
}

// The pair's live rays' tests, their hits as bits (hits: rays first + 0..31, hits2: first + 32..63).
void testRays(uint live, uint live2, uint first, LeafTriangle t, LeafEdges e, vec3 P0, vec3 P1, vec3 P2, vec3 light,
              bool sampleEnds, inout uint hits, inout uint hits2) {
  // Four rays an iteration (the lowest four left of the pair's up to 64, over both words; the last again
  // when fewer are left, a ray tested twice being harmless): a loop iteration costs every lavapipe lane
  // about what the tests in it do, and one loop over the 64 runs as often as the busiest lane's rays
  // need, where a loop per word ran as often as each word's busiest. Four beat two and eight, and written
  // out beat helper functions (docs/ARCHITECTURE.md, "The leaves' hits as bits, a hint to the leaves too").
  for (uint lo = live, hi = live2; (lo | hi) != 0u;) {
    uint k0 = uint(findLSB(lo != 0u ? lo : hi)) + (lo != 0u ? 0u : 32u);
    if (lo != 0u) lo &= lo - 1u; else hi &= hi - 1u;
    uint k1 = (lo | hi) == 0u ? k0 : uint(findLSB(lo != 0u ? lo : hi)) + (lo != 0u ? 0u : 32u);
    if (lo != 0u) lo &= lo - 1u; else hi &= hi - 1u;
    uint k2 = (lo | hi) == 0u ? k1 : uint(findLSB(lo != 0u ? lo : hi)) + (lo != 0u ? 0u : 32u);
    if (lo != 0u) lo &= lo - 1u; else hi &= hi - 1u;
    uint k3 = (lo | hi) == 0u ? k2 : uint(findLSB(lo != 0u ? lo : hi)) + (lo != 0u ? 0u : 32u);
    if (lo != 0u) lo &= lo - 1u; else hi &= hi - 1u;
    bool h0 = rayHits(first + k0, t, e, P0, P1, P2, light, sampleEnds);
    bool h1 = rayHits(first + k1, t, e, P0, P1, P2, light, sampleEnds);
    bool h2 = rayHits(first + k2, t, e, P0, P1, P2, light, sampleEnds);
    bool h3 = rayHits(first + k3, t, e, P0, P1, P2, light, sampleEnds);
    hits |= (h0 && k0 < 32u ? 1u << k0 : 0u) | (h1 && k1 < 32u ? 1u << k1 : 0u) |
            (h2 && k2 < 32u ? 1u << k2 : 0u) | (h3 && k3 < 32u ? 1u << k3 : 0u);
    hits2 |= (h0 && k0 >= 32u ? 1u << (k0 - 32u) : 0u) | (h1 && k1 >= 32u ? 1u << (k1 - 32u) : 0u) |
             (h2 && k2 >= 32u ? 1u << (k2 - 32u) : 0u) | (h3 && k3 >= 32u ? 1u << (k3 - 32u) : 0u);
  }
}

void main() {
  uint i = flatIndex();
  if (i >= (p.countWord != 0u ? statWord(p.countWord) : p.count)) return;
  uint at = p.first + i;
  uvec4 two = texelFetch(arena, int(at >> 1u));
  uvec2 pair = (at & 1u) == 0u ? two.xy : two.zw;
  uint leafCount = p.deviceParams != 0u ? statWord(STATE_LEAF_COUNT) : p.childCount;
  uint shift = p.deviceParams != 0u ? statWord(STATE_LEAF_SHIFT) : p.leafShift;  // 2, 4 or 6: 4, 16 or 64 rays
  uint span = 1u << shift;
  uint first = pair.y << shift;
  uint end = min(first + span, leafCount);
  if (end < first + span) atomicAdd(stats[p.missingWord], first + span - max(end, first));  // past the last ray
  // The rays still to test: those of the pair not yet known shadowed (a span of 4 or 16 rays lies in one
  // word, 64 in two). None: the pair is done (a SIMD batch whose pairs all are skips the triangle too).
  uint n = end > first ? end - first : 0u, w = first >> 5u, sh = first & 31u;
  uint live = n == 0u ? 0u : ~(shadowed[w] >> sh) & (n >= 32u ? 0xFFFFFFFFu : (1u << n) - 1u);
  uint live2 = n <= 32u ? 0u : ~shadowed[w + 1u] & (n >= 64u ? 0xFFFFFFFFu : (1u << (n - 32u)) - 1u);
  if ((live | live2) == 0u) return;
  vec3 light = p.light.xyz;
  vec3 P0 = texelFetch(tris, int(3u * pair.x)).xyz;
  vec3 P1 = texelFetch(tris, int(3u * pair.x + 1u)).xyz;
  vec3 P2 = texelFetch(tris, int(3u * pair.x + 2u)).xyz;
  // The tests first, the hits as bits, then one atomic OR a word of them: lavapipe makes a storage
  // access lane by lane in a loop that runs for every lane, active or not, and an `if` does not skip it
  // (it runs both sides of every branch), so an access per ray or per hit would cost the kernel such a
  // loop each. Bit k of hits (k < 32) or of hits2 (k >= 32): ray first + k hit (at most 64 rays a pair;
  // two selects a ray, not an index into a vector, which lavapipe makes a trip through memory).
  if (SPEC_CULL != 0u) {
    // The pair's live rays against the sphere, four an iteration: the four of the lowest quarter-word
    // holding a live ray (one bit pick a quarter-word, its dead rays tested too, rays past the count read
    // the last one again: their bits are not live). A pair's exact tests then run on the live rays whose
    // line meets the sphere, on lavapipe as often as the lane with the most of them needs.
    vec4 s = leafSphere(P0 - light, P1 - light, P2 - light);
    uint near = 0u, near2 = 0u;
    for (uint lo = live, hi = live2; (lo | hi) != 0u;) {
      uint j = (lo != 0u ? uint(findLSB(lo)) : uint(findLSB(hi)) + 32u) & ~3u;
      if (lo != 0u) lo &= ~(15u << j); else hi &= ~(15u << (j - 32u));
      vec3 w0 = uintBitsToFloat(texelFetch(rays, int(first + j)).xyz) - light;
      vec3 w1 = uintBitsToFloat(texelFetch(rays, int(first + min(j + 1u, n - 1u))).xyz) - light;
      vec3 w2 = uintBitsToFloat(texelFetch(rays, int(first + min(j + 2u, n - 1u))).xyz) - light;
      vec3 w3 = uintBitsToFloat(texelFetch(rays, int(first + min(j + 3u, n - 1u))).xyz) - light;
      uint m = (leafRayMissesSphere(s, w0) ? 0u : 1u) | (leafRayMissesSphere(s, w1) ? 0u : 2u) |
               (leafRayMissesSphere(s, w2) ? 0u : 4u) | (leafRayMissesSphere(s, w3) ? 0u : 8u);
      if (j < 32u) near |= m << j;
      else near2 |= m << (j - 32u);
    }
    live &= near;
    live2 &= near2;
    if ((live | live2) == 0u) return;
  }
  // The plane cull (precise_test.h, leafPlaneMissesBox): the pair's node's sample box (conetree's
  // boxes: the 16 or 64 rays of a leaf pair; 4 have none) wholly where the plane's crossings cannot
  // count -- on the light's side of the triangle's plane, or beyond it by less than eps times the
  // crossing's slope (the receivers: samples on the triangle's own plane). Every pair computes the plane
  // anyway (every leaf test asks leafCrosses); the box is two texels.
  LeafTriangle t = SPEC_LEAF_TEST == 1u ? leafTriangle(P0, P1, P2, light) : leafPlane(P0, P1, P2, light);
  uint box = 2u * (boxOffset(leafCount, shift >> 1u) + pair.y);
  bool hasBox = (shift >> 1u) >= CONE_BOX_FIRST_HEIGHT;
  vec3 boxLo = vec3(1.0f), boxHi = vec3(0.0f);  // none: empty
  if (hasBox) {
    boxLo = texelFetch(boxes, int(box)).xyz;
    boxHi = texelFetch(boxes, int(box + 1u)).xyz;
  }
  if (hasBox && leafPlaneMissesBox(t, boxLo, boxHi, light, p.eps)) return;
  LeafEdges e;
  if (SPEC_LEAF_TEST == 2u) e = leafEdges(P0, P1, P2, light);
  uint hits = 0u, hits2 = 0u;
  // The test from the sample without its per-edge choice of end where the pair's sample box says every
  // ray takes the sample's end (leafSamplesNearer: a far light's pairs always), as a branch all the
  // subgroup's pairs take (lavapipe then runs only that loop; a branch its lanes split on runs both).
  // (The other tests' kernels fold the condition away, and the loop's second copy with it.)
  bool sampleEnds = SPEC_LEAF_TEST == 2u && leafSamplesNearer(e, boxLo, boxHi);
  if (SPEC_LEAF_TEST == 2u && subgroupBallot(!sampleEnds) == uvec4(0u)) testRays(live, live2, first, t, e, P0, P1, P2, light, true, hits, hits2);
  else testRays(live, live2, first, t, e, P0, P1, P2, light, false, hits, hits2);
  if (hits != 0u) atomicOr(shadowed[w], hits << sh);
  if (hits2 != 0u) atomicOr(shadowed[w + 1u], hits2);
}
