#version 450
#extension GL_GOOGLE_include_directive : require
// The engine's instances (traversal/cone_engine.h): each triangle slot's vertices from its mesh's own
// space to the world, by its instance's row-major 3x4 transform. An identity instance is copied as it
// is, so a scene given as one identity instance is the bench's triangles bit for bit.
// bindings: 0 = object-space triangles (3 vec4 a slot), 1 = the instance of each slot (uint),
//           2 = transforms (4 vec4 an instance: the three rows, then x = 1 for the identity),
//           3 = world triangles (3 vec4 a slot)
#include "traversal/traverse.glsl"

layout(local_size_x = TRAVERSE_THREADS) in;
layout(std430, binding = 0) readonly buffer Object { vec4 object[]; };
layout(std430, binding = 1) readonly buffer Instance { uint instanceOf[]; };
layout(std430, binding = 2) readonly buffer Transforms { vec4 transforms[]; };
layout(std430, binding = 3) writeonly buffer World { vec4 world[]; };
layout(push_constant) uniform Push { TraversePush p; };

void main() {
  uint i = flatIndex();
  if (i >= p.count) return;
  uint k = instanceOf[i];
  vec4 r0 = transforms[4 * k], r1 = transforms[4 * k + 1], r2 = transforms[4 * k + 2];
  bool identity = transforms[4 * k + 3].x == 1.0;
  for (uint v = 0; v < 3; ++v) {
    vec4 o = object[3 * i + v];
    world[3 * i + v] = identity ? o : vec4(dot(r0, vec4(o.xyz, 1.0)), dot(r1, vec4(o.xyz, 1.0)), dot(r2, vec4(o.xyz, 1.0)), 1.0);
  }
}
