#version 450
// The shadow-map texel: linear distance from the light to the nearest surface (R32F). The hardware
// depth (reversed, infinite far plane) only picks the nearest fragment; along one texel's ray it orders
// fragments exactly as their distances do.
#extension GL_GOOGLE_include_directive : require
#include "shadowmaps/sm_shared.h"

layout(location = 0) in vec3 fromLight;
layout(location = 0) out float outDistance;

void main() { outDistance = length(fromLight); }
