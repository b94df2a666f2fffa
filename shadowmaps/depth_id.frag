#version 450
// depth.frag with a second target: the index of the scene triangle nearest the light (R32UI), the same
// numbering as the G-buffer's (raster/gbuffer_main.glsl). gl_PrimitiveID in a fragment stage needs the
// device's geometryShader feature.
#extension GL_GOOGLE_include_directive : require
#include "shadowmaps/sm_shared.h"

layout(location = 0) in vec3 fromLight;
layout(location = 1) flat in uint firstTriangle;
layout(location = 0) out float outDistance;
layout(location = 1) out uint outTriangle;

void main() {
  outDistance = length(fromLight);
  outTriangle = firstTriangle + uint(gl_PrimitiveID);
}
