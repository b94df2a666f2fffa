#version 450
// Camera pass, fragment stage: the G-buffer sample of raster/gbuffer.h.
//   out 0: world position (fp32), w = 1 (0 where nothing was drawn: the clear value)
//   out 1: unit normal turned towards the camera, w = max(0, N·L̂) — the light buffer
#extension GL_GOOGLE_include_directive : require
#include "raster/raster_layout.h"

layout(push_constant) uniform Push { RasterPush pc; };
layout(location = 0) in vec3 worldPosition;
layout(location = 1) in vec3 worldNormal;
layout(location = 0) out vec4 outPosition;
layout(location = 1) out vec4 outNormal;

void main() {
  vec3 n = worldNormal;
  float len = length(n);
  n = len > 0.0 ? n / len : vec3(0.0, 0.0, 1.0);
  // Two-sided: a surface seen from its back is shaded as its front.
  if (dot(n, pc.eye.xyz - worldPosition) < 0.0) n = -n;
  vec3 toLight = pc.light.xyz - worldPosition;
  float d = length(toLight);
  float direct = d > 0.0 ? max(0.0, dot(n, toLight / d)) : 0.0;
  outPosition = vec4(worldPosition, 1.0);
  outNormal = vec4(n, direct);
}
