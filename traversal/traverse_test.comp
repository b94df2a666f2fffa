#version 450
#extension GL_GOOGLE_include_directive : require
// One breadth-first pass (002 §3.1, §4.2): every input (triangle, node) pair is tested against the node's
// children with the precise cone/triangle test (002 §3.2) or the sphere test (sphere_test.h, p.test) -- or, in pass 0, every triangle against the
// root. Writes the surviving children as a 4-bit mask and their count per input; sort/'s scan turns the
// counts into output offsets and traverse_scatter.comp writes the pairs.
// Tests counted by the host (4 per input pair, 1 per triangle) less STAT_MISSING, which the pairs of a
// level's last node (fewer than four children) add to.
// Early accept (002 §3.3, p.earlyAccept, precise test only): a child the triangle covers
// (preciseConeCovered: every ray under it hits) shadows every sample under it at once -- the same atomic
// AND as the leaves, on the leaf range the implicit tree gives -- is marked in the flags (one word per
// interior node, cleared per frame) and does not continue (no pair written). An input pair whose node is
// flagged is dropped: its samples are all shadowed already (its children's tests go to STAT_MISSING).
// bindings: 0 = triangles (uniform texel buffer, RGBA32F: 3 texels per triangle, world space; in the far-light frame relative to the light), 1 = nodes (uniform texel buffer, RGBA32F: 2 texels per ConeNode), 2 = chunk (uvec2
//           input pairs), 3 = masks (uint per input), 4 = counts (uint per input), 5 = stats (uint[STAT_WORDS]),
//           6 = samples (uint pixel per sorted ray), 7 = positions (vec4 per pixel), 8 = visibility (uint per
//           pixel), 9 = flags (uint per interior node); 6-9 used with early accept only,
//           10 = cluster spheres (vec4 per cluster, relative to the light as binding 0's vertices; device path)
// Clusters (device path, STATE_MODE): a STEP_CLUSTERS step tests (cluster, node) pairs with the
// cluster's sphere (sphere_test.h: false only when no ray of the cone meets the sphere, which holds all
// the cluster's triangles); a STEP_EXPAND step's input i is triangle 64 * cluster + i % 64 of cluster
// pair i / 64, tested as a triangle pair (front-face culling applies there: its pass 0 was the clusters').
#include "traversal/precise_test.h"
#include "traversal/sphere_test.h"
#include "traversal/traverse.glsl"

layout(local_size_x = TRAVERSE_THREADS) in;
// Triangles and nodes are read as uniform texel buffers (RGBA32F, three texels a triangle, two a node):
// the gathers this kernel makes per pair are its cost, and texel fetches of 16-byte texels are the fast
// gather path on lavapipe and read through the texture cache on a GPU (TOOLCHAIN.md).
layout(binding = 0) uniform samplerBuffer tris;
layout(binding = 1) uniform samplerBuffer nodeTexels;
layout(std430, binding = 2) readonly buffer Chunk { uvec2 pairs[]; };
layout(std430, binding = 3) writeonly buffer Masks { uint masks[]; };
layout(std430, binding = 4) writeonly buffer Counts { uint counts[]; };
layout(std430, binding = 5) buffer Stats { uint stats[]; };
layout(std430, binding = 6) readonly buffer Samples { uint samples[]; };
layout(std430, binding = 7) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = 8) buffer Visibility { uint visibility[]; };
layout(std430, binding = 9) buffer Flags { uint flags[]; };
layout(std430, binding = 10) readonly buffer Clusters { vec4 clusterSpheres[]; };
layout(push_constant) uniform Push { TraversePush p; };

ConeNode node(uint n) {
  ConeNode c;
  c.axisCos = texelFetch(nodeTexels, int(2u * n));
  c.sinLen = texelFetch(nodeTexels, int(2u * n + 1u));
  return c;
}

// This dispatch's counts and offsets: the push constants, or on the device path the words the advance
// kernel wrote from the tree's shape (traverse_advance.comp).
uint count, childOffset, childCount, inputOffset, leafShift, leafCount;

// Shadows every sample under child c (of the child depth) at once and flags the node; counts it once.
void acceptChild(uint c, vec3 light) {
  if (atomicExchange(flags[childOffset + c], 1u) == 0u) atomicAdd(stats[STAT_ACCEPTED], 1u);
  uint first = c << leafShift;
  uint end = min((c + 1u) << leafShift, leafCount);
  for (uint leaf = first; leaf < end; leaf++) {
    uint sampleIndex = samples[leaf];
    vec4 ray = leafRay(positions[sampleIndex].xyz, light);
    if (leafRayUsable(ray, p.minLength) && visibility[sampleIndex] != 0u) atomicAnd(visibility[sampleIndex], 0u);
  }
}

void main() {
  uint i = flatIndex();
  count = p.countWord != 0u ? stats[p.countWord] : p.count;
  if (i >= count) return;
  if (p.deviceParams != 0u) {
    childOffset = stats[STATE_CHILD_OFFSET], childCount = stats[STATE_CHILD_COUNT];
    inputOffset = stats[STATE_INPUT_OFFSET], leafShift = stats[STATE_LEAF_SHIFT], leafCount = stats[STATE_LEAF_COUNT];
  } else {
    childOffset = p.childOffset, childCount = p.childCount;
    inputOffset = p.inputOffset, leafShift = p.leafShift, leafCount = p.leafCount;
  }
  uint mode = p.deviceParams != 0u ? stats[STATE_MODE] : STEP_TRIANGLES;
  uvec2 pair;
  if (mode == STEP_EXPAND) {
    uvec2 cp = pairs[i >> CLUSTER_SHIFT];
    pair = uvec2((cp.x << CLUSTER_SHIFT) + (i & (CLUSTER_SIZE - 1u)), cp.y);
    if (pair.x >= p.triangleEnd) {  // past the last cluster's triangles: no test
      masks[i] = 0u;
      counts[i] = 0u;
      atomicAdd(stats[STAT_MISSING], 4u);
      return;
    }
  } else {
    uint first = mode == STEP_CLUSTERS ? p.first >> CLUSTER_SHIFT : p.first;  // pass 0: clusters or triangles
    pair = p.fromTriangles != 0u ? uvec2(first + i, 0u) : pairs[p.first + i];
  }
  if (mode == STEP_CLUSTERS) {
    uvec2 r = p.fromTriangles != 0u ? uvec2(0u, 1u) : childRange(pair.y, childCount);
    vec4 sphere = clusterSpheres[pair.x];
    uint mask = 0u;
    for (uint c = r.x; c < r.y; c++)
      if (sphereConeTriangle(node(childOffset + c), sphere, p.eps, p.coneScale)) mask |= 1u << (c - r.x);
    masks[i] = mask;
    counts[i] = bitCount(mask);
    uint expected = p.fromTriangles != 0u ? 1u : 4u;
    if (r.y - r.x < expected) atomicAdd(stats[STAT_MISSING], expected - (r.y - r.x));
    return;
  }
  vec3 light = p.light.xyz;
  // Relative to the light, exactly as the leaf test computes them from the light's end; in the far-light
  // frame, as frame_triangles.comp wrote them.
  precise vec3 v0 = texelFetch(tris, int(3u * pair.x)).xyz;
  precise vec3 v1 = texelFetch(tris, int(3u * pair.x + 1u)).xyz;
  precise vec3 v2 = texelFetch(tris, int(3u * pair.x + 2u)).xyz;
  if (p.frameVertices == 0u) {
    v0 -= light;
    v1 -= light;
    v2 -= light;
  }
  float scale = p.coneScale;
  uvec2 r = p.fromTriangles != 0u ? uvec2(0u, 1u) : childRange(pair.y, childCount);
  uint mask = 0u;
  if (p.earlyAccept != 0u && p.fromTriangles == 0u && flags[inputOffset + pair.y] != 0u) {
    // the node was accepted (by another triangle): every sample under it is shadowed already
    atomicAdd(stats[STAT_DROPPED], 1u);
    atomicAdd(stats[STAT_MISSING], r.y - r.x);
  } else if (p.frontFaceCulling != 0u && (p.fromTriangles != 0u || mode == STEP_EXPAND) && facesLight(v0, v1, v2)) {
    // 002 §3.6: a triangle facing the light casts no shadow in a closed mesh; dropped at the root.
  } else if (p.test == TRAVERSE_TEST_SPHERE) {
    vec4 sphere = boundingSphere(v0, v1, v2, scale);
    for (uint c = r.x; c < r.y; c++)
      if (sphereConeTriangle(node(childOffset + c), sphere, p.eps, scale)) mask |= 1u << (c - r.x);
  } else {
    // The precise test, with the sphere test ANDed in: both conservative, and the sphere's margins are
    // the tighter ones for small triangles (traversal.h).
    PreciseTriangle t = preciseTriangle(v0, v1, v2, scale);  // once for the (up to) four children
    vec4 sphere = boundingSphere(v0, v1, v2, scale);
    for (uint c = r.x; c < r.y; c++) {
      ConeNode n = node(childOffset + c);
      if (!sphereConeTriangle(n, sphere, p.eps, scale) || !preciseConeTriangle(n, t, p.eps)) continue;
      if (p.earlyAccept != 0u && preciseConeCovered(n, t, p.eps)) acceptChild(c, light);
      else mask |= 1u << (c - r.x);
    }
  }
  masks[i] = mask;
  counts[i] = bitCount(mask);
  uint expected = p.fromTriangles != 0u ? 1u : 4u;
  if (r.y - r.x < expected) atomicAdd(stats[STAT_MISSING], expected - (r.y - r.x));  // the last node only
}
