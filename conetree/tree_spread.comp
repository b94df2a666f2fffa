#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// How much of the sphere each depth of the tree covers: the sum over its nodes of 1 - cos(half-angle) (a
// cone's solid angle over 2 pi), written to words p.firstWord + 2 d (uint64 fixed point, CONE_SPREAD_UNIT
// per unit). Cones that partition their parents keep the sum about level with depth; a tree whose deep
// levels cover more than its top groups rays that point apart (the cone method's choice of ray order
// reads it). Empty cones count 0. A depth of more than CONE_SPREAD_SAMPLES nodes is estimated from that
// many evenly strided nodes, scaled to the whole depth: the sums are compared, not reported to the ulp,
// and every tree gets the same estimate (no atomics, no race). In units of p.scale^2: the far frame's
// cones are as narrow as its angular scale (2^-34 rad from 10^11 away), so 1 - cos would vanish in the
// fixed point and every tree look as tight as a sorted one; the verdict compares depths, so any common
// unit serves.
// One workgroup per depth: workgroup h - 1 sums the depth h levels above the leaves (none past the tree).
// bindings: 0 = nodes (ConeNode[]), 1 = shape words, 2 = output words
#include "conetree/cone_math.h"

layout(local_size_x = CONE_SPREAD_THREADS) in;
layout(std430, binding = 0) readonly buffer Nodes { ConeNode nodes[]; };
layout(std430, binding = 1) readonly buffer Shape { uint shape[]; };
layout(std430, binding = 2) buffer Words { uint64_t words[]; };
layout(push_constant) uniform Push { SpreadPush p; };

shared float partial[CONE_SPREAD_THREADS];

void main() {
  uint l = gl_LocalInvocationIndex;
  uint height = gl_WorkGroupID.x + 1u;
  uint depth = shape[SHAPE_DEPTH];
  bool inTree = height <= depth;
  uint d = inTree ? depth - height : 0u;
  uint count = inTree ? shape[SHAPE_COUNTS + d] : 0u;
  uint offset = inTree ? shape[SHAPE_OFFSETS + d] : 0u;
  uint taken = min(count, uint(CONE_SPREAD_SAMPLES));
  uint stride = taken == 0u ? 1u : count / taken;
  float sum = 0.0f;
  for (uint k = l; k < taken; k += uint(CONE_SPREAD_THREADS)) {
    ConeNode c = nodes[offset + k * stride];
    // 1 - cos, without cancellation for narrow cones: sin^2 / (1 + cos); over scale^2, sin scaled first
    // (no square below the smallest float).
    float cosA = c.axisCos.w, sinA = c.sinLen.x / p.scale;
    sum += coneIsEmpty(c) ? 0.0f : (cosA >= 0.0f ? sinA * sinA / (1.0f + cosA) : (1.0f - cosA) / (p.scale * p.scale));
  }
  partial[l] = sum;
  barrier();
  for (uint s = uint(CONE_SPREAD_THREADS) / 2u; s > 0u; s >>= 1u) {
    if (l < s) partial[l] += partial[l + s];
    barrier();
  }
  if (l == 0u && inTree)
    words[(p.firstWord >> 1u) + d] = uint64_t(partial[0] * (float(count) / float(max(taken, 1u))) * CONE_SPREAD_UNIT);
}
