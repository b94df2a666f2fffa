#version 450
// Camera pass, vertex stage: world-space position and normal through to the fragment stage.
#extension GL_GOOGLE_include_directive : require
#include "raster/raster_layout.h"

layout(push_constant) uniform Push { RasterPush pc; };
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 0) out vec3 worldPosition;
layout(location = 1) out vec3 worldNormal;

void main() {
  worldPosition = inPosition;
  worldNormal = inNormal;
  gl_Position = pc.viewProj * vec4(inPosition, 1.0);
}
