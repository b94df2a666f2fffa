#version 450
// Camera pass, fragment stage with the triangle ID attachment (gbuffer_main.glsl).
#extension GL_GOOGLE_include_directive : require
#define GBUFFER_TRIANGLE_ID 1
#include "raster/gbuffer_main.glsl"
