// Camera pass, fragment stage: the G-buffer sample of raster/gbuffer.h, included by gbuffer.frag and
// gbuffer_id.frag (the latter defines GBUFFER_TRIANGLE_ID).
//   out 0: world position (fp32), w = 1 (0 where nothing was drawn: the clear value)
//   out 1: unit normal turned towards the camera, w = max(0, N·L̂) — the light buffer
//   out 2 (GBUFFER_TRIANGLE_ID): the scene triangle's index (CS_NO_TRIANGLE where nothing was drawn).
//     gl_PrimitiveID in a fragment stage needs the device's geometryShader feature, hence two shaders.
#include "raster/raster_layout.h"

layout(push_constant) uniform Push { RasterPush pc; };
layout(location = 0) in vec3 worldPosition;
layout(location = 1) in vec3 worldNormal;
layout(location = 0) out vec4 outPosition;
layout(location = 1) out vec4 outNormal;
#ifdef GBUFFER_TRIANGLE_ID
layout(location = 2) out uint outTriangle;
#endif

void main() {
  vec3 n = worldNormal;
  float len = length(n);
  n = len > 0.0 ? n / len : vec3(0.0, 0.0, 1.0);
  // Two-sided: a surface seen from its back is shaded as its front.
  if (dot(n, pc.eye.xyz - worldPosition) < 0.0) n = -n;
  float direct = lightTerm(worldPosition, n, pc.light.xyz);  // core/shared.h: the cone path's kernels' too
  outPosition = vec4(worldPosition, 1.0);
  outNormal = vec4(n, direct);
#ifdef GBUFFER_TRIANGLE_ID
  outTriangle = uint(gl_PrimitiveID);  // one draw of the whole index buffer: the scene's triangle index
#endif
}
