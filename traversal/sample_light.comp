#version 450
#extension GL_GOOGLE_include_directive : require
// The engine's samples for one light (traversal/cone_engine.h). Two modes, one pixel an invocation:
//   SAMPLE_UNDECIDED   after a frame whose pairs passed the traversal's arena (state[STATE_OVERFLOW]): a lit
//                      sample (litSampleFor the push's light) no hit has shadowed yet is undecided and
//                      written as 0.5 (a hit is a hit: 0 stays); nothing changes on a frame that fit
//   SAMPLE_LIGHT_TERM  terms[i] = (N, lightTerm for the push's light): the term every cone kernel computes
//                      for itself, written out for a caller that reports it (harness/samples.h); no frame
//                      of the cone path runs this mode
// bindings: 0 = positions (uniform texel buffer, RGBA32F: a texel a pixel), 1 = terms (vec4 a pixel,
//           written; SAMPLE_LIGHT_TERM), 2 = visibility (uint a pixel), 3 = the traversal's state words,
//           4 = the normals (RGBA32F texels; w is not read)
#include "traversal/traverse.glsl"

layout(local_size_x = TRAVERSE_THREADS) in;
layout(binding = 0) uniform samplerBuffer positions;
layout(std430, binding = 1) writeonly buffer Terms { vec4 terms[]; };
layout(std430, binding = 2) buffer Visibility { uint visibility[]; };
layout(std430, binding = 3) readonly buffer State { uint state[]; };
layout(binding = 4) uniform samplerBuffer normals;
layout(push_constant) uniform Push { SampleLightPush p; };

void main() {
  uint i = flatIndex();
  if (i >= p.count) return;
  if (p.mode == SAMPLE_LIGHT_TERM) {
    vec4 normal = texelFetch(normals, int(i));
    terms[i] = vec4(normal.xyz, lightTerm(texelFetch(positions, int(i)).xyz, normal.xyz, p.light.xyz));
    return;
  }
  if (state[STATE_OVERFLOW] != 0u && visibility[i] == floatBitsToUint(1.0) &&
      litSampleFor(texelFetch(positions, int(i)), texelFetch(normals, int(i)), p.light.xyz))
    visibility[i] = floatBitsToUint(0.5);
}
