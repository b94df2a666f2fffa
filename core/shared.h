// The prelude of every file that GLSL and C++ both compile (the *_layout.h and *_shared.h headers, the
// cone tests, the Hilbert key): one function qualifier, the GLSL names C++ needs to read the code as
// written, the constants and rules more than one stage states, the flat invocation index.
//
//   CS_FN          before every shared function: `inline` in C++, nothing in GLSL
//   CS_PRECISE     before a value whose rounding a conservative test bounds: GLSL's `precise` (no fused or
//                  reassociated arithmetic), nothing in C++ (which does not contract across statements here)
//   CS_GLSL_TYPES  inside a C++ namespace: uint, vec2..4, uvec2..4, mat4 as GLSL spells them
//   CS_GLSL_MATH   inside a C++ namespace: the built-ins the shared code calls, from glm. The cone headers
//                  take theirs through CONE_CPU_MATH (conetree/cone_layout.h), which a test may replace with
//                  an emulation of the worst arithmetic a GPU is allowed.
//   CS_FLAT_WORKGROUP, CS_FLAT_INDEX(threads)  GLSL compute only: the workgroup's index, and the
//                  invocation's, in a one-dimensional launch of `threads`-wide workgroups spread over a 2D
//                  grid, x first (vk::gridFor); the one place that grid is flattened.
//   evenBits(v)    the even bits of v packed into the low 16: a Morton (Z-order) code's x (and, of v >> 1, y)
//   lightTerm(position, normal, light)  the direct-light term max(0, N·L̂) of a surface point for a point
//                  light: the one expression the camera pass writes into the G-buffer's normal.w
//                  (raster/gbuffer_main.glsl) and the cone path computes for each of its lights.
//   litSample(position, normal)  the lit-sample rule: the G-buffer has geometry at the pixel (position.w
//                  is 1) and the direct-light term N·L there is positive (normal.w). The shadow maps, the
//                  metric and GBuffer::isLit ask this function.
//   litSampleFor(position, normal, light)  the same rule with the term computed for `light` (normal.w
//                  ignored): the cone path's kernels ask this one, so no pass writes a light's term into
//                  the samples and one G-buffer serves every light of a frame.
#ifndef CONESHADOW_CORE_SHARED_H
#define CONESHADOW_CORE_SHARED_H

#define CS_FLT_MAX 3.402823466e+38f  // FLT_MAX as a float literal in both languages
#define CS_NO_TRIANGLE 0xFFFFFFFFu   // "no triangle" in every triangle-ID image and list

#ifdef __cplusplus
#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>
#define CS_FN inline
#define CS_PRECISE
#define CS_GLSL_TYPES   \
  using uint = uint32_t; \
  using glm::mat4;      \
  using glm::uvec2;     \
  using glm::uvec3;     \
  using glm::uvec4;     \
  using glm::vec2;      \
  using glm::vec3;      \
  using glm::vec4;
#define CS_GLSL_MATH   \
  using glm::abs;      \
  using glm::atan;     \
  using glm::ceil;     \
  using glm::clamp;    \
  using glm::cos;      \
  using glm::cross;    \
  using glm::dot;      \
  using glm::floor;    \
  using glm::length;   \
  using glm::log2;     \
  using glm::max;      \
  using glm::min;      \
  using glm::normalize; \
  using glm::sin;      \
  using glm::sqrt;
namespace cs::shared {
CS_GLSL_TYPES
#else
#define CS_FN
#define CS_PRECISE precise
#define CS_GLSL_TYPES
#define CS_GLSL_MATH
#define CS_FLAT_WORKGROUP (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x)
#define CS_FLAT_INDEX(threads) (CS_FLAT_WORKGROUP * (threads) + gl_LocalInvocationIndex)
// GLSL only: the (x, y) workgroups of an indirect dispatch a kernel writes for `items` in workgroups of
// `groupSize`: x up to maxPerDim, then as many rows as that takes (one row and zero columns for none).
uvec2 indirectGrid(uint items, uint groupSize, uint maxPerDim) {
  uint groups = (items + groupSize - 1u) / groupSize;
  uint x = min(groups, maxPerDim);
  return uvec2(x, x == 0u ? 1u : (groups + x - 1u) / x);
}
// GLSL only: word w of a uint array bound as a uniform texel buffer of RGBA32UI texels (four words a
// texel) -- how kernels read the few words every invocation needs (a tree's shape, the traversal's
// state): a texel fetch is a gather on lavapipe, a storage load a loop over the lanes.
uint texelWord(usamplerBuffer words, uint w) {
  uvec4 t = texelFetch(words, int(w >> 2u));
  uint k = w & 3u;
  return k == 0u ? t.x : (k == 1u ? t.y : (k == 2u ? t.z : t.w));
}
#endif

CS_FN bool litSample(vec4 position, vec4 normal) { return position.w > 0.5f && normal.w > 0.0f; }

#ifdef __cplusplus
using glm::dot;
using glm::length;
using glm::max;
#endif
// GLSL may contract the arithmetic (no `precise`): every kernel compiles this same sequence of
// operations, so the lit set is the same bit for bit in each of them (docs/ARCHITECTURE.md, "rays/").
CS_FN float lightTerm(vec3 position, vec3 normal, vec3 light) {
  vec3 toLight = light - position;
  float d = length(toLight);
  return d > 0.0f ? max(0.0f, dot(normal, toLight / d)) : 0.0f;
}
CS_FN bool litSampleFor(vec4 position, vec4 normal, vec3 light) {
  return position.w > 0.5f && lightTerm(vec3(position), vec3(normal), light) > 0.0f;
}

CS_FN uint evenBits(uint v) {
  v &= 0x55555555u;
  v = (v | (v >> 1u)) & 0x33333333u;
  v = (v | (v >> 2u)) & 0x0F0F0F0Fu;
  v = (v | (v >> 4u)) & 0x00FF00FFu;
  v = (v | (v >> 8u)) & 0x0000FFFFu;
  return v;
}

#ifdef __cplusplus
}  // namespace cs::shared
namespace cs {
using shared::evenBits;
using shared::lightTerm;
using shared::litSample;
using shared::litSampleFor;
}
#endif

#endif
