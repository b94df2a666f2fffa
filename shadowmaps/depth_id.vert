#version 450
// depth.vert with the triangle ID (ASM's ID + depth test): the draw's first triangle, passed in as its
// base instance (depth_pass.cpp draws runs of clusters with firstInstance = first index / 3), goes to
// the fragment stage, which adds gl_PrimitiveID.
#extension GL_GOOGLE_include_directive : require
#include "shadowmaps/sm_shared.h"

layout(push_constant) uniform Push { DepthPush pc; };
layout(location = 0) in vec3 inPosition;
layout(location = 0) out vec3 fromLight;
layout(location = 1) flat out uint firstTriangle;

void main() {
  fromLight = inPosition - pc.light.xyz;
  firstTriangle = uint(gl_InstanceIndex);
  gl_Position = pc.clip * vec4(fromLight, 1.0);
}
