#version 450
#extension GL_GOOGLE_include_directive : require
// RMSM step 4 of Algorithm 2 (paper 000 §3.2): connected-components pruning. A request survives only
// when neither the pixel to its left nor the pixel below it asks for the same page (in either of its two
// requests); a chain of equal neighbours always ends at a survivor, so no page is lost. At a reduced
// analysis resolution the neighbours are the analysed pixels analysisStep away. Writes the compaction
// flags and counts the valid requests before pruning.
// bindings: 0 = requests (2 uint per pixel), 1 = flags (2 uint per pixel), 2 = counters
#include "shadowmaps/sm_shared.h"
layout(local_size_x = SM_PIXEL_THREADS) in;
layout(std430, binding = 0) readonly buffer Requests { uint requests[]; };
layout(std430, binding = 1) writeonly buffer Flags { uint flags[]; };
layout(std430, binding = 2) buffer Counters { uint counters[]; };
layout(push_constant) uniform Push { RmsmPush pc; };

shared uint groupValid;

void main() {
  if (gl_LocalInvocationIndex == 0u) groupValid = 0u;
  barrier();
  uint i = CS_FLAT_INDEX(SM_PIXEL_THREADS);
  uint valid = 0u;
  if (i < pc.width * pc.height) {
    uint x = i % pc.width, y = i / pc.width, step = pc.analysisStep;
    uvec2 mine = uvec2(requests[2u * i], requests[2u * i + 1u]);
    uint l = i - step;
    uvec2 left = x >= step ? uvec2(requests[2u * l], requests[2u * l + 1u]) : uvec2(SM_INVALID_KEY);
    uint j = i + step * pc.width;  // the analysed pixel below (row 0 is the top of the image)
    uvec2 below = y + step < pc.height ? uvec2(requests[2u * j], requests[2u * j + 1u]) : uvec2(SM_INVALID_KEY);
    for (uint k = 0u; k < 2u; ++k) {
      uint key = mine[k];
      bool isValid = key != SM_INVALID_KEY;
      bool keep = isValid && key != left.x && key != left.y && key != below.x && key != below.y;
      flags[2u * i + k] = keep ? 1u : 0u;
      valid += isValid ? 1u : 0u;
    }
  }
  if (valid > 0u) atomicAdd(groupValid, valid);
  barrier();
  if (gl_LocalInvocationIndex == 0u && groupValid > 0u) atomicAdd(counters[SM_COUNT_REQUESTS], groupValid);
}
