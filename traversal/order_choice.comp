#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
// The frame's ray order, chosen on the GPU (one invocation; cone_method.h, ConeOptions::adaptiveOrder).
// The tree was built over the lit samples in screen order and tree_spread.comp summed each depth's
// 1 - cos(half-angle). A tree whose cones partition their parents covers about the same solid angle at
// every depth -- as a Hilbert-sorted tree does by construction -- so when no depth below the top
// ORDER_TOP_DEPTHS covers more than 3/2 of the widest of them (ORDER_LOOSE_RATIO; sorted trees measure
// 0.8-1.1), the screen order groups rays as well as sorting would, and the frame keeps it. Otherwise
// some deep cones gather rays that point apart (a silhouette against a far background, grazing views,
// fur): the screen order is loose, and what that costs is more traversal, which grows with the
// triangles, with the looseness and with the tree's side (a triangle meets the cones along its outline:
// about sqrt(lit) of them), while the sort costs about the same a lit sample whatever the scene. So a
// loose frame sorts only where triangles x (looseness - 1) > ORDER_SORT_PAYS x sqrt(lit); below, its few
// triangles cost less over the loose tree than sorting its samples would (docs/ARCHITECTURE.md, "The
// ray order, chosen per frame on the GPU", has the family's measurements). ORDER_SORT_COUNT = 0 makes
// the keys, the sort and the rebuild launch nothing; the lit count sorts the rays and rebuilds.
// Either way the mask is the same; only the work differs.
// bindings: 0 = shape words (the screen-order tree's), 1 = order words (ORDER_*)
#include "conetree/cone_layout.h"
#include "traversal/traversal_layout.h"

layout(local_size_x = 1) in;
layout(std430, binding = 0) readonly buffer Shape { uint shape[]; };
layout(std430, binding = 1) buffer Order { uint words[]; };
layout(push_constant) uniform Push { OrderPush pc; };

uint64_t spread(uint d) {
  return uint64_t(words[ORDER_SPREAD + 2u * d]) | (uint64_t(words[ORDER_SPREAD + 2u * d + 1u]) << 32);
}

void main() {
  uint depth = shape[SHAPE_DEPTH];
  uint64_t top = 0ul, deep = 0ul;
  for (uint d = 0u; d < depth; d++) {
    if (d < ORDER_TOP_DEPTHS) top = max(top, spread(d));
    else deep = max(deep, spread(d));
  }
  bool loose = 2ul * deep > 3ul * top;  // deep > ORDER_LOOSE_RATIO top (no overflow: sums < 2^60)
  float looseness = top > 0ul ? float(deep) / float(top) : 3.0e38;  // (a loose tree with a top of no width: sorted)
  bool pays = float(pc.triangles) * (looseness - 1.0) > float(ORDER_SORT_PAYS) * sqrt(float(shape[SHAPE_LEAVES]));
  bool sorted = loose && pays;
  words[ORDER_SORTED] = sorted ? 1u : 0u;
  words[ORDER_LOOSE] = loose ? 1u : 0u;
  words[ORDER_SORT_COUNT] = sorted ? shape[SHAPE_LEAVES] : 0u;
  words[ORDER_GATE_ARGS] = sorted ? 1u : 0u;
  words[ORDER_GATE_ARGS + 1u] = 1u;
  words[ORDER_GATE_ARGS + 2u] = 1u;
}
