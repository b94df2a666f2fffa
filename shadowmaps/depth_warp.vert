#version 450
// The warped geometry pass of RTW (depth_warp.geom does the work): the light-relative position only.
#extension GL_GOOGLE_include_directive : require
#include "shadowmaps/rtw_shared.h"

layout(push_constant) uniform Push { RtwDepthPush pc; };
layout(location = 0) in vec3 inPosition;
layout(location = 0) out vec3 fromLight;

void main() {
  fromLight = inPosition - pc.light.xyz;
  gl_Position = vec4(0.0, 0.0, 0.0, 1.0);  // set by the geometry stage
}
