#version 450
// bench/access_bench.cpp's kernel: every invocation makes `perItem` accesses of one kind, at elements
// chosen coherently (consecutive invocations, consecutive elements) or at random, and writes what it read
// so nothing is optimised away. Modes:
//   0 storage buffer, four scalar float loads per element (a vec4 read as floats)
//   1 storage buffer, one vec4 load per element
//   2 uniform texel buffer (RGBA32F), one texelFetch per element
//   3 shared-memory atomicAdd into 256 bins (a radix histogram's inner step)
//   4 storage-buffer atomicAdd into 4096 words
//   5 storage buffer, one vec4 store per element
//   6 no access: the loop and the element index alone (the baseline the others are read against)
// bindings: 0 = source (vec4[]), 1 = the same source as floats, 2 = the source as a texel buffer,
//           3 = out (float per invocation, and vec4 stores in mode 5), 4 = global atomics (uint[4096])
#extension GL_GOOGLE_include_directive : require
#include "core/shared.h"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Src4 { vec4 src4[]; };
layout(std430, binding = 1) readonly buffer Src1 { float src1[]; };
layout(binding = 2) uniform samplerBuffer srcTexels;
layout(std430, binding = 3) buffer Out { vec4 out4[]; };
layout(std430, binding = 4) buffer Atomics { uint atomics[]; };
layout(push_constant) uniform Push {
  uint mode, elements, perItem, random, invocations, pad0, pad1, pad2;
} pc;

shared uint bins[256];

uint hash(uint x) {
  x ^= x >> 16u;
  x *= 0x7feb352du;
  x ^= x >> 15u;
  x *= 0x846ca68bu;
  x ^= x >> 16u;
  return x;
}

void main() {
  uint i = CS_FLAT_INDEX(64u);
  if (pc.mode == 3u) {
    for (uint b = gl_LocalInvocationIndex; b < 256u; b += 64u) bins[b] = 0u;
    barrier();
  }
  if (i >= pc.invocations) return;
  vec4 acc = vec4(0.0);
  for (uint k = 0u; k < pc.perItem; ++k) {
    // elements is a power of two: a mask, not a modulo (an integer division costs more than a load here)
    uint e = (pc.random != 0u ? hash(i * pc.perItem + k) : k * pc.invocations + i) & (pc.elements - 1u);
    if (pc.mode == 0u) {
      acc += vec4(src1[4u * e], src1[4u * e + 1u], src1[4u * e + 2u], src1[4u * e + 3u]);
    } else if (pc.mode == 1u) {
      acc += src4[e];
    } else if (pc.mode == 2u) {
      acc += texelFetch(srcTexels, int(e));
    } else if (pc.mode == 3u) {
      atomicAdd(bins[e & 255u], 1u);
    } else if (pc.mode == 4u) {
      atomicAdd(atomics[e & 4095u], 1u);
    } else if (pc.mode == 5u) {
      out4[e] = vec4(float(i), float(k), 0.0, 1.0);
    } else {
      acc.x += float(e);
    }
  }
  if (pc.mode == 3u) acc.x = float(bins[i & 255u]);
  if (pc.mode != 5u) out4[i] = acc;
}
