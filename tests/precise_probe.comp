#version 450
#extension GL_GOOGLE_include_directive : require
// Test kernel (tests/traversal_test.cpp): the GPU side of traversal/precise_test.h on arrays of cases, so the
// property tests check the very code the traversal runs. Case i: cone = cones[i], triangle relative to the
// apex = verts[3i..3i+2].xyz, eps = verts[3i].w (the leaf test's: verts[3i+1].w), leaf ray = rays[i]; result bit 0 = preciseConeTriangle,
// bit 1 = leafHit (the leaf kernel's test; the apex at the origin, so the sample is at w), bit 2 = leafHitFromLight
// (the leaf kernel's second test, traversal/traversal.h LeafTest), bit 3 = leafHitFromSample (its third).
// bindings: 0 = cones (ConeNode), 1 = verts (vec4), 2 = rays (vec4: w, L), 3 = results (uint)
#include "traversal/precise_test.h"
#include "traversal/traverse.glsl"

layout(local_size_x = TRAVERSE_THREADS) in;
layout(std430, binding = 0) readonly buffer Cones { ConeNode cones[]; };
layout(std430, binding = 1) readonly buffer Verts { vec4 verts[]; };
layout(std430, binding = 2) readonly buffer Rays { vec4 rays[]; };
layout(std430, binding = 3) writeonly buffer Results { uint results[]; };
layout(push_constant) uniform Push { TraversePush p; };

void main() {
  uint i = flatIndex();
  if (i >= p.count) return;
  vec3 v0 = verts[3u * i].xyz;
  vec3 v1 = verts[3u * i + 1u].xyz;
  vec3 v2 = verts[3u * i + 2u].xyz;
  float eps = verts[3u * i].w;
  uint r = preciseConeTriangle(cones[i], v0, v1, v2, eps) ? 1u : 0u;
  if (leafHit(rays[i].xyz, vec3(0.0f), rays[i], verts[3u * i + 1u].w, v0, v1, v2)) r |= 2u;  // the apex at the origin: sample = w
  if (leafHitFromLight(rays[i].xyz, vec3(0.0f), rays[i], verts[3u * i + 1u].w, v0, v1, v2)) r |= 4u;
  if (leafHitFromSample(rays[i].xyz, vec3(0.0f), rays[i], verts[3u * i + 1u].w, v0, v1, v2)) r |= 8u;
  results[i] = r;
}
