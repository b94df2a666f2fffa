#version 450
#extension GL_GOOGLE_include_directive : require
// The engine's samples for one light (traversal/cone_engine.h). Two modes, one pixel an invocation:
//   SAMPLE_LIGHT_TERM  normal.w = max(0, N·L̂) for the push's light, the expression the camera pass
//                      writes (raster/gbuffer_main.glsl), so a sample is lit here exactly when it is there
//   SAMPLE_UNDECIDED   after a frame whose pairs passed the traversal's arena (state[STATE_OVERFLOW]): a lit
//                      sample no hit has shadowed yet is undecided and written as 0.5 (a hit is a hit: 0
//                      stays); nothing changes on a frame that fit
// bindings: 0 = positions (uniform texel buffer, RGBA32F: a texel a pixel), 1 = normals (vec4 a pixel,
//           written), 2 = visibility (uint a pixel), 3 = the traversal's state words, 4 = the normals again
//           as texels (RGBA32F), how they are read
// The light term is stored only where it changes the word: for the light the camera pass lit, no store
// at all (storage loads and stores are the dear accesses on a SIMD CPU driver, texel reads the cheap ones).
#include "traversal/traverse.glsl"

layout(local_size_x = TRAVERSE_THREADS) in;
layout(binding = 0) uniform samplerBuffer positions;
layout(std430, binding = 1) writeonly buffer Normals { vec4 normals[]; };
layout(std430, binding = 2) buffer Visibility { uint visibility[]; };
layout(std430, binding = 3) readonly buffer State { uint state[]; };
layout(binding = 4) uniform samplerBuffer normalTexels;
layout(push_constant) uniform Push { SampleLightPush p; };

void main() {
  uint i = flatIndex();
  if (i >= p.count) return;
  vec4 normal = texelFetch(normalTexels, int(i));
  if (p.mode == SAMPLE_LIGHT_TERM) {
    vec3 toLight = p.light.xyz - texelFetch(positions, int(i)).xyz;
    float d = length(toLight);
    float w = d > 0.0 ? max(0.0, dot(normal.xyz, toLight / d)) : 0.0;
    if (floatBitsToUint(w) != floatBitsToUint(normal.w)) normals[i].w = w;
    return;
  }
  if (state[STATE_OVERFLOW] != 0u && visibility[i] == floatBitsToUint(1.0) &&
      litSample(texelFetch(positions, int(i)), normal))
    visibility[i] = floatBitsToUint(0.5);
}
