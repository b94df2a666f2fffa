#version 450
// Camera pass, fragment stage without triangle IDs (devices without the geometryShader feature).
#extension GL_GOOGLE_include_directive : require
#include "raster/gbuffer_main.glsl"
