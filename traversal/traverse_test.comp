#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
// One breadth-first pass (002 §3.1, §4.2): every input (triangle, node) pair is tested against the node's
// children with the precise cone/triangle test (002 §3.2) or the sphere test (sphere_test.h, SPEC_TEST) -- or,
// in pass 0, every triangle against the root -- and the surviving (triangle, child) pairs are appended to
// the output: each subgroup sums its survivors, one invocation reserves that many slots with an atomicAdd
// on STAT_TOTAL, and each invocation writes its own at its exclusive prefix within the reservation. No
// per-input masks or counts, no scan, no second pass over the inputs. The pairs land in subgroup order
// within a reservation and in the order the reservations were taken across them: the set of pairs, and
// so every later test and the mask, is the same whatever that order (the leaves' AND is idempotent).
// STAT_TOTAL counts every survivor; only those below p.outLimit - p.outFirst are written, and a step whose
// total passes that bound is an overflow for the caller (traverse_advance.comp on the device path,
// expandChunk() on the host), which discards the step's output: a partly written output is never read.
// Tests counted by the host (4 per input pair, 1 per triangle) less STAT_MISSING, which the pairs of a
// level's last node (fewer than four children) add to.
// Early accept (002 §3.3, SPEC_EARLY_ACCEPT, precise test only): a child the triangle covers
// (preciseConeCovered: every ray under it hits) shadows every sample under it at once -- the same atomic
// AND as the leaves, on the leaf range the implicit tree gives -- is marked in the flags (one word per
// interior node, cleared per frame) and does not continue (no pair written). An input pair whose node is
// flagged is dropped: its samples are all shadowed already (its children's tests go to STAT_MISSING).
// bindings: 0 = triangles (uniform texel buffer, RGBA32F: 3 texels per triangle, world space; in the
//           far-light frame relative to the light), 1 = nodes (uniform texel buffer, RGBA32F: 2 texels per
//           ConeNode), 2 = input pairs (uniform texel buffer, RGBA32UI: two uvec2 a texel), 3 = output pairs (uvec2, from slot p.outFirst),
//           4 = stats (uint[STAT_WORDS]; the device path's state words), 5 = rays (uvec4 per sorted ray:
//           its sample's position as float bits, its pixel; conetree's ConeTree::rays()), 6 = visibility
//           (uint per pixel), 7 = flags (uint per interior node); 5-7 used with early accept only, 8 =
//           cluster spheres (SUPER_SPHERES vec4s a super cluster: its own, then each cluster's own and its
//           groups'; relative to the light as binding 0's vertices; device path), 9 = the state words
//           (binding 4's, the device path's) as a uniform buffer, 10 = the triangles in world coordinates
//           (binding 0's, or the world triangles where binding 0 holds the far frame's), 11 = the tree's
//           sample boxes (conetree/cone_layout.h, boxOffset; RGBA32F, lo and hi)
// Clusters (device path, STATE_MODE): a STEP_CLUSTERS step tests (cluster, node) pairs with the
// cluster's sphere (sphere_test.h: false only when no ray of the cone meets the sphere, which holds all
// the cluster's triangles) and writes (cluster, child) pairs; a STEP_EXPAND step's input i is triangle
// CLUSTER_SIZE * cluster + i % CLUSTER_SIZE of cluster pair i / CLUSTER_SIZE, tested as a triangle pair
// (front-face culling applies there: its pass 0 was the clusters'). STEP_SUPER and STEP_SPLIT steps run
// in the cluster kernel: (super cluster, node) pairs tested with the super cluster's sphere, and a split's
// input i as cluster pair (SUPER_CLUSTERS * s + i % SUPER_CLUSTERS, node) of super pair i / SUPER_CLUSTERS,
// writing (cluster, child) pairs. A STEP_EXPAND_WHOLE step (its own kernel, SPEC_WHOLE) takes (cluster,
// node) pair i whole: one invocation tests the cluster's sphere against the node's children, read once,
// then its four groups' spheres against the children the cluster kept, then each of its triangles against
// the children its group kept; a STEP_EXPAND_SUPER step takes a (super cluster, node) pair so, its sphere
// first, then each of its clusters as above (expandWhole).
#include "traversal/precise_test.h"
#include "traversal/sphere_test.h"
#include "traversal/traverse.glsl"

layout(local_size_x = TRAVERSE_THREADS) in;
// Triangles and nodes are read as uniform texel buffers (RGBA32F, three texels a triangle, two a node):
// the gathers this kernel makes per pair are its cost, and texel fetches of 16-byte texels are the fast
// gather path on lavapipe and read through the texture cache on a GPU (docs/ARCHITECTURE.md, "Memory
// access").
layout(binding = 0) uniform samplerBuffer tris;
layout(binding = 1) uniform samplerBuffer nodeTexels;
// The input pairs as RGBA32UI texels, two a texel: a texel fetch costs lavapipe next to nothing, a storage
// load one load per lane.
layout(binding = 2) uniform usamplerBuffer inputs;
uvec2 inputPair(uint at) {
  uvec4 two = texelFetch(inputs, int(at >> 1u));
  return (at & 1u) == 0u ? two.xy : two.zw;
}
layout(std430, binding = 3) writeonly buffer Outputs { uvec2 outPairs[]; };
layout(std430, binding = 4) buffer Stats { uint stats[]; };
layout(std430, binding = 5) readonly buffer Rays { uvec4 rays[]; };
layout(std430, binding = 6) buffer Visibility { uint visibility[]; };
layout(std430, binding = 7) buffer Flags { uint flags[]; };
layout(std430, binding = 8) readonly buffer Clusters { vec4 clusterSpheres[]; };
// The state words again (the device path's binding 4), as a uniform buffer: the words every invocation
// reads (the count, the shape fields, the mode), written by earlier dispatches. Read at a uniform offset,
// lavapipe loads a uniform buffer's word once for the SIMD lanes, where a texel fetch gathers a lane at a
// time and a storage load loops over the lanes (docs/ARCHITECTURE.md, "Memory access").
layout(std140, binding = 9) uniform StateWords { uvec4 stateWords[STATE_WORDS / 4]; };
layout(binding = 10) uniform samplerBuffer worldTris;
layout(binding = 11) uniform samplerBuffer boxes;
layout(push_constant) uniform Push { TraversePush p; };
// The switches of a frame, as specialisation constants (Traversal::testKernel): the kernel holds only the
// code its switches run: on lavapipe, code a uniform branch never enters still costs every invocation
// (docs/ARCHITECTURE.md, "Kernels that hold only the code they run").
layout(constant_id = 0) const uint SPEC_TEST = TRAVERSE_TEST_PRECISE;  // = p.test
layout(constant_id = 1) const uint SPEC_EARLY_ACCEPT = 0u;             // = p.earlyAccept
layout(constant_id = 2) const uint SPEC_FRONT_FACE_CULLING = 0u;       // = p.frontFaceCulling
// 1: the cluster kernel, which tests (cluster, node) pairs (STEP_CLUSTERS) and nothing else; 0: the
// triangle kernel (STEP_TRIANGLES, STEP_EXPAND). The device path records both for every step, the advance
// kernel giving the other zero workgroups.
layout(constant_id = 3) const uint SPEC_CLUSTERS = 0u;
// 1: the whole-cluster expansion kernel (STEP_EXPAND_WHOLE or STEP_EXPAND_SUPER, sphere test, no early
// accept): expandWhole and nothing else. Its own pipeline, because on lavapipe the lanes of a kernel pay
// for its code whether a uniform branch enters it or not.
layout(constant_id = 4) const uint SPEC_WHOLE = 0u;
// 1: the frame's angular scale p.coneScale is below 1 (the far-light frame's, traversal.h); 0: it is 1,
// and the kernel holds the constant instead. The tests then compute bit for bit what they would from
// p.coneScale = 1, without the far frame's arithmetic, which lavapipe would run on every lane anyway
// (it runs both sides of every branch, docs/ARCHITECTURE.md, "Memory access").
layout(constant_id = 5) const uint SPEC_SCALED = 0u;
float coneScale() { return SPEC_SCALED != 0u ? p.coneScale : 1.0f; }

uint statWord(uint w) { return stateWords[w >> 2u][w & 3u]; }

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
    uvec4 r = rays[leaf];  // the sample's position, its pixel
    vec4 ray = leafRay(uintBitsToFloat(r.xyz), light);
    if (leafRayUsable(ray, p.minLength) && visibility[r.w] != 0u) atomicAnd(visibility[r.w], 0u);
  }
}

// The input's surviving children as a 4-bit mask (bit k: child r.x + k), its pair in `pair` and its first
// child in `firstChild`. Adds the tests it skips to `missing` (for STAT_MISSING: one atomic an invocation,
// whatever the path, since lavapipe makes every storage access in a loop over the lanes that runs whether
// a branch is taken or not) and counts the early-accept events.
// The children [r.x, r.y) (at most four) whose cones the sphere may meet, as a mask (bit k: child r.x + k):
// four tests written out, the ones past r.y dropped, not a loop (a loop iteration costs lavapipe's lanes
// more than a node's fetch). A level's last node may have fewer children: the tests past them read its
// last child again (the node array ends there; expandWhole does the same), and their bits are dropped.
// The four children's nodes as nearChildren read them (the precise test picks its node from these, not
// fetching it again).
ConeNode kid0, kid1, kid2, kid3;
uint nearChildren(uvec2 r, vec4 sphere, float scale) {
  uint c = childOffset + r.x, last = childOffset + r.y - 1u, n = r.y - r.x;
  kid0 = node(c);
  kid1 = node(min(c + 1u, last));
  kid2 = node(min(c + 2u, last));
  kid3 = node(min(c + 3u, last));
  uint m = (sphereConeTriangle(kid0, sphere, p.eps, scale) ? 1u : 0u) |
           (sphereConeTriangle(kid1, sphere, p.eps, scale) ? 2u : 0u) |
           (sphereConeTriangle(kid2, sphere, p.eps, scale) ? 4u : 0u) |
           (sphereConeTriangle(kid3, sphere, p.eps, scale) ? 8u : 0u);
  return m & ((1u << n) - 1u);
}

// The plane cull of the child whose sample box is box b (conetree/cone_layout.h, boxOffset).
bool childPlaneMisses(LeafTriangle lp, uint b, vec3 light) {
  return leafPlaneMissesBox(lp, texelFetch(boxes, int(2u * b)).xyz, texelFetch(boxes, int(2u * b + 1u)).xyz, light, p.eps);
}

uint testInput(uint i, uint mode, out uvec2 pair, out uint firstChild, inout uint missing) {
  firstChild = 0u;
  // One input fetch whatever the step (lavapipe runs every side of a branch, a fetch in each included):
  // an expansion's input i is part of pair i / CLUSTER_SIZE (triangle kernel) or i / SUPER_CLUSTERS
  // (cluster kernel), any other step's is pair p.first + i; pass 0 reads pair 0, in range, and ignores it.
  bool expand = SPEC_CLUSTERS == 0u && mode == STEP_EXPAND, split = SPEC_CLUSTERS != 0u && mode == STEP_SPLIT;
  uvec2 in_ = inputPair(p.fromTriangles != 0u ? 0u : expand ? i >> CLUSTER_SHIFT : split ? i >> 2u : p.first + i);
  if (expand) {
    pair = uvec2((in_.x << CLUSTER_SHIFT) + (i & (CLUSTER_SIZE - 1u)), in_.y);
    if (pair.x >= p.triangleEnd) {  // past the last cluster's triangles: no test
      missing += 4u;
      return 0u;
    }
  } else if (split) {
    pair = uvec2(SUPER_CLUSTERS * in_.x + (i & (SUPER_CLUSTERS - 1u)), in_.y);
    if ((pair.x << CLUSTER_SHIFT) >= p.triangleEnd) {  // past the last super cluster's clusters: no test
      missing += 4u;
      return 0u;
    }
  } else {
    // pass 0: super clusters, clusters or triangles
    uint first = SPEC_CLUSTERS == 0u ? p.first : (mode == STEP_SUPER ? p.first >> SUPER_SHIFT : p.first >> CLUSTER_SHIFT);
    pair = p.fromTriangles != 0u ? uvec2(first + i, 0u) : in_;
  }
  uvec2 r = p.fromTriangles != 0u ? uvec2(0u, 1u) : childRange(pair.y, childCount);
  firstChild = r.x;
  uint expected = p.fromTriangles != 0u ? 1u : 4u;
  missing += expected - (r.y - r.x);  // the last node only
  uint mask = 0u;
  if (SPEC_CLUSTERS != 0u) {
    vec4 sphere = clusterSpheres[mode == STEP_SUPER ? SUPER_SPHERES * pair.x : clusterSphereAt(pair.x)];
    return nearChildren(r, sphere, coneScale());
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
  float scale = coneScale();
  if (SPEC_EARLY_ACCEPT != 0u && p.fromTriangles == 0u && flags[inputOffset + pair.y] != 0u) {
    // the node was accepted (by another triangle): every sample under it is shadowed already
    atomicAdd(stats[STAT_DROPPED], 1u);
    missing += r.y - r.x;
  } else if (SPEC_FRONT_FACE_CULLING != 0u && (p.fromTriangles != 0u || mode == STEP_EXPAND) && facesLight(v0, v1, v2)) {
    // 002 §3.6: a triangle facing the light casts no shadow in a closed mesh; dropped at the root.
  } else if (SPEC_TEST == TRAVERSE_TEST_SPHERE) {
    mask = nearChildren(r, boundingSphere(v0, v1, v2, scale), scale);
  } else {
    // The precise test, with the sphere test ANDed in: both conservative, and the sphere's margins are
    // the tighter ones for small triangles (traversal.h). The sphere test first, on every child: it
    // rejects most pairs below the top levels, and the precise test's per-triangle set-up (lengths,
    // plane slab, three edge planes) is then not computed (unless another lane of the subgroup needs it).
    vec4 sphere = boundingSphere(v0, v1, v2, scale);
    uint near = nearChildren(r, sphere, scale);
    if (near != 0u && (leafShift >> 1u) >= CONE_BOX_FIRST_HEIGHT) {
      // The plane cull first (precise_test.h, leafPlaneMissesBox): a child whose samples' box lies where
      // the triangle's plane crossings cannot count has no leaf hit under it. In world coordinates, as the
      // leaves test; the children's boxes at their height (the leaf shift is twice it; nodes of 4 rays
      // have none).
      // Four tests written out, not a loop over the near ones (nearChildren's reason); a level's last node
      // may have fewer children: the tests past them read its last child's box again, and their bits are
      // not in `near`.
      LeafTriangle lp = leafPlane(texelFetch(worldTris, int(3u * pair.x)).xyz, texelFetch(worldTris, int(3u * pair.x + 1u)).xyz,
                                  texelFetch(worldTris, int(3u * pair.x + 2u)).xyz, light);
      uint box = boxOffset(leafCount, leafShift >> 1u) + r.x, last = r.y - r.x - 1u;
      uint culled = (childPlaneMisses(lp, box, light) ? 1u : 0u) |
                    (childPlaneMisses(lp, box + min(1u, last), light) ? 2u : 0u) |
                    (childPlaneMisses(lp, box + min(2u, last), light) ? 4u : 0u) |
                    (childPlaneMisses(lp, box + min(3u, last), light) ? 8u : 0u);
      near &= ~culled;
    }
    if (near != 0u) {
      PreciseTriangle t = preciseTriangle(v0, v1, v2, scale);  // once for the (up to) four children
      // Over the set bits of `near` only: lavapipe runs a loop as many times as its busiest lane needs
      // (an `if` it runs whole, for every lane), so this is the test's cost where a triangle is near few
      // of the four children.
      for (uint todo = near; todo != 0u; todo &= todo - 1u) {
        uint k = uint(findLSB(todo)), c = r.x + k;
        ConeNode n = k == 0u ? kid0 : k == 1u ? kid1 : k == 2u ? kid2 : kid3;  // selects, not a fetch
        if (!preciseConeTriangle(n, t, p.eps)) continue;
        if (SPEC_EARLY_ACCEPT != 0u && preciseConeCovered(n, t, p.eps)) acceptChild(c, light);
        else mask |= 1u << (c - r.x);
      }
    }
  }
  return mask;
}

// The appends' slots: `n` pairs of this invocation, `total` (subgroupAdd(n)) of the invocations still
// active here. One atomic per subgroup; each invocation's pairs at its exclusive prefix within the
// subgroup's reservation. Returns the first slot of this invocation's pairs.
uint reserve(uint n, uint total) {
  uint before = subgroupExclusiveAdd(n);
  uint base = 0u;
  if (subgroupElect()) base = atomicAdd(stats[STAT_TOTAL], total);
  return subgroupBroadcastFirst(base) + before;
}

// A STEP_EXPAND_WHOLE input: (cluster, node) pair i, or a STEP_EXPAND_SUPER input: (super cluster, node)
// pair i, whose sphere is tested against the node's children first. Then for each cluster: its sphere
// against the children kept so far, its groups' against those it kept, and its triangles against those
// their group kept, with the sphere test; the survivors appended as (triangle, child) pairs, a cluster
// at a time. The tests not made of the step's four per triangle pair go to STAT_MISSING.
void expandWhole(uint i, bool super) {
  uvec2 cp = inputPair(p.first + i);
  uvec2 r = childRange(cp.y, childCount);
  uint kids = r.y - r.x;
  ConeNode n0 = node(childOffset + r.x);
  ConeNode n1 = node(childOffset + min(r.x + 1u, r.y - 1u));
  ConeNode n2 = node(childOffset + min(r.x + 2u, r.y - 1u));
  ConeNode n3 = node(childOffset + min(r.x + 3u, r.y - 1u));
  float scale = coneScale();
  uint outer = (1u << kids) - 1u;  // the children still in play
  uint made = 0u;                  // tests made
  if (super) {
    vec4 ss = clusterSpheres[SUPER_SPHERES * cp.x];
    uint m = sphereConeTriangle(n0, ss, p.eps, scale) ? 1u : 0u;
    if (kids > 1u && sphereConeTriangle(n1, ss, p.eps, scale)) m |= 2u;
    if (kids > 2u && sphereConeTriangle(n2, ss, p.eps, scale)) m |= 4u;
    if (kids > 3u && sphereConeTriangle(n3, ss, p.eps, scale)) m |= 8u;
    outer = m;
    made += kids;
  }
  uint clusters = super ? SUPER_CLUSTERS : 1u;
  uint room = p.outLimit - p.outFirst;
  for (uint q = 0u; q < clusters; q++) {  // a uniform trip count: the appends are subgroup operations
    uint cluster = super ? SUPER_CLUSTERS * cp.x + q : cp.x;
    uint first = cluster << CLUSTER_SHIFT;
    uint tris_ = min(CLUSTER_SIZE, p.triangleEnd > first ? p.triangleEnd - first : 0u);
    // The cluster's sphere against the children in play: a child it misses, no triangle of it can meet.
    uint near = 0u;
    if (tris_ > 0u && outer != 0u) {
      vec4 cs = clusterSpheres[clusterSphereAt(cluster)];
      if ((outer & 1u) != 0u && sphereConeTriangle(n0, cs, p.eps, scale)) near |= 1u;
      if ((outer & 2u) != 0u && sphereConeTriangle(n1, cs, p.eps, scale)) near |= 2u;
      if ((outer & 4u) != 0u && sphereConeTriangle(n2, cs, p.eps, scale)) near |= 4u;
      if ((outer & 8u) != 0u && sphereConeTriangle(n3, cs, p.eps, scale)) near |= 8u;
      made += uint(bitCount(outer));
    }
    // Then each group's sphere against the children the cluster kept, and each triangle against the
    // children its group kept (bits 4 g + k of `groupNear`).
    uint groups = (tris_ + GROUP_SIZE - 1u) / GROUP_SIZE;
    uint groupNear = 0u;
    for (uint g = 0u; near != 0u && g < groups; g++) {
      vec4 gs = clusterSpheres[clusterSphereAt(cluster) + 1u + g];
      uint m = (near & 1u) != 0u && sphereConeTriangle(n0, gs, p.eps, scale) ? 1u : 0u;
      if ((near & 2u) != 0u && sphereConeTriangle(n1, gs, p.eps, scale)) m |= 2u;
      if ((near & 4u) != 0u && sphereConeTriangle(n2, gs, p.eps, scale)) m |= 4u;
      if ((near & 8u) != 0u && sphereConeTriangle(n3, gs, p.eps, scale)) m |= 8u;
      groupNear |= m << (4u * g);
      made += uint(bitCount(near));
    }
    uvec2 mask = uvec2(0u);  // bit 4 t + k of the 64: triangle first + t against child r.x + k
    for (uint t = 0u; groupNear != 0u && t < tris_; t++) {
      uint kept = (groupNear >> (4u * (t / GROUP_SIZE))) & 15u;
      if (kept == 0u) continue;
      made += uint(bitCount(kept));
      precise vec3 v0 = texelFetch(tris, int(3u * (first + t))).xyz;
      precise vec3 v1 = texelFetch(tris, int(3u * (first + t) + 1u)).xyz;
      precise vec3 v2 = texelFetch(tris, int(3u * (first + t) + 2u)).xyz;
      if (p.frameVertices == 0u) {
        v0 -= p.light.xyz;
        v1 -= p.light.xyz;
        v2 -= p.light.xyz;
      }
      if (SPEC_FRONT_FACE_CULLING != 0u && facesLight(v0, v1, v2)) continue;
      vec4 sphere = boundingSphere(v0, v1, v2, scale);
      uint m = (kept & 1u) != 0u && sphereConeTriangle(n0, sphere, p.eps, scale) ? 1u : 0u;
      if ((kept & 2u) != 0u && sphereConeTriangle(n1, sphere, p.eps, scale)) m |= 2u;
      if ((kept & 4u) != 0u && sphereConeTriangle(n2, sphere, p.eps, scale)) m |= 4u;
      if ((kept & 8u) != 0u && sphereConeTriangle(n3, sphere, p.eps, scale)) m |= 8u;
      if (t < 8u) mask.x |= m << (4u * t);
      else mask.y |= m << (4u * (t - 8u));
    }
    uint n = bitCount(mask.x) + bitCount(mask.y);
    uint total = subgroupAdd(n);
    if (total == 0u) continue;
    uint slot = reserve(n, total);
    for (uint w = 0u; w < 2u; w++) {
      uint bits = mask[w];
      while (bits != 0u) {
        uint b = uint(findLSB(bits));
        bits &= bits - 1u;
        if (slot < room) outPairs[p.outFirst + slot] = uvec2(first + 8u * w + (b >> 2u), r.x + (b & 3u));
        slot++;
      }
    }
  }
  // The step counts four tests a triangle pair: STAT_MISSING gets the difference (mod 2^32).
  uint missing = 4u * CLUSTER_SIZE * clusters - made;
  if (missing != 0u) atomicAdd(stats[STAT_MISSING], missing);
}

void main() {
  uint i = flatIndex();
  count = p.countWord != 0u ? statWord(p.countWord) : p.count;
  if (i >= count) return;
  if (p.deviceParams != 0u) {
    childOffset = statWord(STATE_CHILD_OFFSET), childCount = statWord(STATE_CHILD_COUNT);
    inputOffset = statWord(STATE_INPUT_OFFSET), leafShift = statWord(STATE_LEAF_SHIFT), leafCount = statWord(STATE_LEAF_COUNT);
  } else {
    childOffset = p.childOffset, childCount = p.childCount;
    inputOffset = p.inputOffset, leafShift = p.leafShift, leafCount = p.leafCount;
  }
  uint mode = p.deviceParams != 0u ? statWord(STATE_MODE) : STEP_TRIANGLES;
  if (SPEC_WHOLE != 0u) {
    if (mode == STEP_EXPAND_WHOLE || mode == STEP_EXPAND_SUPER) expandWhole(i, mode == STEP_EXPAND_SUPER);  // (no other step)
    return;
  }
  bool clusterStep = mode == STEP_CLUSTERS || mode == STEP_SUPER || mode == STEP_SPLIT;
  if (clusterStep != (SPEC_CLUSTERS != 0u)) return;  // the other kernel's step (given no workgroups)
  uvec2 pair;
  uint firstChild;
  uint missing = 0u;
  uint mask = testInput(i, mode, pair, firstChild, missing);
  if (missing != 0u) atomicAdd(stats[STAT_MISSING], missing);

  // The append: one atomic per subgroup (the invocations still active here), each invocation's pairs at
  // its exclusive prefix within the subgroup's reservation.
  uint n = bitCount(mask);
  uint total = subgroupAdd(n);
  if (total == 0u) return;
  uint room = p.outLimit - p.outFirst;
  uint slot = reserve(n, total);
  for (uint todo = mask; todo != 0u; todo &= todo - 1u) {
    if (slot < room) outPairs[p.outFirst + slot] = uvec2(pair.x, firstChild + uint(findLSB(todo)));
    slot++;
  }
}
