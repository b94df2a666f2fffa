#version 450
#extension GL_GOOGLE_include_directive : require
// One depth of the cone tree (002 §3.1, §3.5): node j of this depth encloses its (up to) four children,
// four consecutive elements of the depth below -- sorted rays when fromLeaves, else nodes. In the
// far-light frame (cone_layout.h, ConeFrame) the rays are in frame coordinates and their cones widened.
// With p.fromShape the depth is p.height levels above the leaves of the tree the shape buffer describes
// (tree_shape.comp): its count and offsets come from there, and a height the tree does not reach is a
// dispatch of zero workgroups (its indirect arguments) or returns at once.
// bindings: 0 = positions (the G-buffer as a uniform texel buffer, RGBA32F: a texel per pixel), 1 = samples (uint pixel index per sorted ray; offset a multiple of 16 bytes),
//           2 = nodes (ConeNode, the whole tree; this depth written), 3 = shape words (uniform texel
//           buffer, RGBA32UI: SHAPE_*, four a texel; read with fromShape only), 4 = rays (uvec4 per sorted ray, written
//           by the depth above the rays: the sample's world position as float bits and its pixel index,
//           what the leaves read, one texel a ray, instead of the pixel index and then the G-buffer),
//           5 = nodes again (uniform texel buffer, RGBA32F: two texels a ConeNode; the depth below read),
//           6 = binding 4's rays again (uniform texel buffer, RGBA32UI), read where their records are given
//           (SPEC_LEAVES 2: rays/run_expand.comp wrote them, positions read in pixel order; and at
//           height 2, the rays under each node, for its box), 7 = boxes (cone_layout.h, boxOffset: this
//           height's written, from height 2 up), 8 = binding 7 again (uniform texel buffer, RGBA32F: the
//           height below's boxes read, from height 3 up)
#include "conetree/cone_math.h"

layout(local_size_x = CONE_BUILD_THREADS) in;
layout(binding = 0) uniform samplerBuffer positions;  // texel fetches: the cheap gather
layout(std430, binding = 1) readonly buffer Samples { uvec4 samples4[]; };  // read four at a time
layout(std430, binding = 2) writeonly buffer Nodes { ConeNode nodes[]; };
// The shape words every invocation reads (binding 3), and binding 2's nodes again for the children an
// upper depth reads (binding 5), as uniform texel buffers (RGBA32UI; RGBA32F, two texels a node): a
// storage load is a loop over the lanes on lavapipe, a texel fetch a gather (docs/ARCHITECTURE.md,
// "Memory access", has what it saved the build).
layout(binding = 3) uniform usamplerBuffer shapeTexels;
layout(std430, binding = 4) writeonly buffer Rays { uvec4 rays[]; };
layout(binding = 5) uniform samplerBuffer nodeTexels;
layout(binding = 6) uniform usamplerBuffer rayTexels;
uint shapeWord(uint w) { return texelWord(shapeTexels, w); }
layout(push_constant) uniform Push { BuildPush p; };
// What the dispatch builds, as specialisation constants (ConeTree picks the pipeline): on lavapipe, code a
// kernel holds costs every invocation even where a uniform branch skips it (the far frame's code took a
// fifth of the museum's build at 1024²).
layout(constant_id = 0) const uint SPEC_FAR = 0u;     // 1: the far-light frame (= p.frame.rowX.w != 0)
// 1: the children are the sorted rays (= fromLeaves), their positions gathered by `samples` and their
// records stored; 2: the same rays, their records given (binding 6), nothing gathered or stored.
layout(constant_id = 1) const uint SPEC_LEAVES = 0u;
// The node's sample box (cone_layout.h, boxOffset): 0 none (height 1), 1 from its (up to) 16 rays'
// positions (height 2), 2 from its children's boxes (height 3 and up).
layout(constant_id = 2) const uint SPEC_BOXES = 0u;
layout(std430, binding = 7) writeonly buffer Boxes { vec4 boxes[]; };
layout(binding = 8) uniform samplerBuffer boxTexels;
vec3 boxLo = vec3(3.0e38), boxHi = vec3(-3.0e38);  // the node's sample box, grown by child() (SPEC_BOXES 2)
uint leaves, childBoxes;  // the rays under the tree; the first box of the height below

uint count, nodeOffset, childCount, childOffset;

ConeNode child(uint c, uint pixel) {
  if (SPEC_LEAVES != 0u) {
    vec3 position;
    if (SPEC_LEAVES == 2u) {
      position = uintBitsToFloat(texelFetch(rayTexels, int(c)).xyz);
    } else {
      position = texelFetch(positions, int(pixel)).xyz;
      rays[c] = uvec4(floatBitsToUint(position), pixel);
    }
    if (SPEC_FAR != 0u) {  // far frame: the ray in frame coordinates, its cone widened
      vec4 ray = leafRay(toConeFrame(position, p.frame), p.frame.lightFrame.xyz);
      return leafRayUsable(ray, p.minLength) ? rayConeWidened(ray, p.beta, p.sigma) : emptyCone();
    }
    vec4 ray = leafRay(position, p.frame.lightFrame.xyz);
    return leafRayUsable(ray, p.minLength) ? rayCone(ray) : emptyCone();
  }
  if (SPEC_BOXES == 2u) {
    boxLo = min(boxLo, texelFetch(boxTexels, int(2u * (childBoxes + c))).xyz);
    boxHi = max(boxHi, texelFetch(boxTexels, int(2u * (childBoxes + c) + 1u)).xyz);
  }
  ConeNode n;
  n.axisCos = texelFetch(nodeTexels, int(2u * (childOffset + c)));
  n.sinLen = texelFetch(nodeTexels, int(2u * (childOffset + c) + 1u));
  return n;
}

void main() {
  uint j = CS_FLAT_INDEX(CONE_BUILD_THREADS);
  if (p.fromShape != 0u) {
    uint depth = shapeWord(SHAPE_DEPTH);
    if (p.height == 0u || p.height > depth) return;
    uint d = depth - p.height;
    count = shapeWord(SHAPE_COUNTS + d);
    nodeOffset = shapeWord(SHAPE_OFFSETS + d);
    childCount = shapeWord(SHAPE_COUNTS + d + 1u);
    childOffset = p.height > 1u ? shapeWord(SHAPE_OFFSETS + d + 1u) : 0u;
    leaves = shapeWord(SHAPE_LEAVES);
  } else {
    count = p.count, nodeOffset = p.nodeOffset, childCount = p.childCount, childOffset = p.childOffset;
    leaves = p.leaves;
  }
  childBoxes = SPEC_BOXES == 2u ? boxOffset(leaves, p.height - 1u) : 0u;
  if (j >= count) return;
  uvec2 r = childRange(j, childCount);
  uint n = r.y - r.x;
  // The leaves' four pixel indices in one vector load (a lavapipe lane pays per access, not per byte);
  // the last node's, when it has fewer children, one by one, so nothing past the rays is read.
  uvec4 pixels = uvec4(0u);
  if (SPEC_LEAVES == 1u) {
    if (n == 4u) {
      pixels = samples4[j];
    } else {
      for (uint k = 0u; k < n; ++k) pixels[k] = samples4[j][k];
    }
  }
  ConeNode c0 = child(r.x, pixels.x);
  ConeNode c1 = n > 1u ? child(r.x + 1u, pixels.y) : emptyCone();
  ConeNode c2 = n > 2u ? child(r.x + 2u, pixels.z) : emptyCone();
  ConeNode c3 = n > 3u ? child(r.x + 3u, pixels.w) : emptyCone();
  // In the far frame the axis from the children's sum and the widening CONE_PAD times the frame's angular
  // scale; in the world frame the approximate minimal merge and CONE_PAD (of rays, coneParentOfRays).
  // Four children always: those past n are empty cones above, which every merge skips, so the parent is
  // the one of the n children bit for bit, and the merges' loops over the children have a constant trip
  // count (unrolled; a loop to n ran, on lavapipe, as an iteration a child in every lane).
  nodes[nodeOffset + j] = SPEC_FAR != 0u      ? coneParentFar(c0, c1, c2, c3, 4u, CONE_PAD * p.frame.centre.w)
                          : SPEC_LEAVES != 0u ? coneParentOfRays(c0, c1, c2, c3, 4u, CONE_PAD)
                                              : coneParent(c0, c1, c2, c3, 4u, CONE_PAD);
  if (SPEC_BOXES == 1u) {  // height 2: the rays' positions, as the records the height below left them
    uint end = min(16u * j + 16u, leaves);
    for (uint k = 16u * j; k < end; ++k) {
      vec3 position = uintBitsToFloat(texelFetch(rayTexels, int(k)).xyz);
      boxLo = min(boxLo, position);
      boxHi = max(boxHi, position);
    }
  }
  if (SPEC_BOXES != 0u) {
    uint b = boxOffset(leaves, p.height) + j;
    boxes[2u * b] = vec4(boxLo, 0.0f);
    boxes[2u * b + 1u] = vec4(boxHi, 0.0f);
  }
}
