#version 450
// One geometry pass into a window of a cube face (cube SM faces, RMSM superpages): light-relative
// position through the face's clip transform; the fragment stage writes the distance to the light.
#extension GL_GOOGLE_include_directive : require
#include "shadowmaps/sm_shared.h"

layout(push_constant) uniform Push { DepthPush pc; };
layout(location = 0) in vec3 inPosition;
layout(location = 0) out vec3 fromLight;

void main() {
  fromLight = inPosition - pc.light.xyz;
  gl_Position = pc.clip * vec4(fromLight, 1.0);
}
