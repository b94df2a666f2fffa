#version 450
#extension GL_GOOGLE_include_directive : require
// The engine's samples for one light (traversal/cone_engine.h). Two modes, one pixel an invocation:
//   SAMPLE_LIGHT_TERM  normal.w = max(0, N·L̂) for the push's light, the expression the camera pass
//                      writes (raster/gbuffer_main.glsl), so a sample is lit here exactly when it is there
//   SAMPLE_UNDECIDED   after a frame whose pairs passed the traversal's arena (state[STATE_OVERFLOW]): a lit
//                      sample no hit has shadowed yet is undecided and written as 0.5 (a hit is a hit: 0
//                      stays); nothing changes on a frame that fit
// bindings: 0 = positions (vec4 a pixel), 1 = normals (vec4 a pixel), 2 = visibility (uint a pixel),
//           3 = the traversal's state words
#include "traversal/traverse.glsl"

layout(local_size_x = TRAVERSE_THREADS) in;
layout(std430, binding = 0) readonly buffer Positions { vec4 positions[]; };
layout(std430, binding = 1) buffer Normals { vec4 normals[]; };
layout(std430, binding = 2) buffer Visibility { uint visibility[]; };
layout(std430, binding = 3) readonly buffer State { uint state[]; };
layout(push_constant) uniform Push { SampleLightPush p; };

void main() {
  uint i = flatIndex();
  if (i >= p.count) return;
  if (p.mode == SAMPLE_LIGHT_TERM) {
    vec3 n = normals[i].xyz;
    vec3 toLight = p.light.xyz - positions[i].xyz;
    float d = length(toLight);
    normals[i].w = d > 0.0 ? max(0.0, dot(n, toLight / d)) : 0.0;
    return;
  }
  if (state[STATE_OVERFLOW] != 0u && visibility[i] == floatBitsToUint(1.0) && litSample(positions[i], normals[i]))
    visibility[i] = floatBitsToUint(0.5);
}
