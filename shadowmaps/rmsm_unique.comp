#version 450
#extension GL_GOOGLE_include_directive : require
// RMSM step 7 of Algorithm 2: after the sort, mark each key that differs from its predecessor; the
// compaction that follows keeps the marked ones. The count is the pruned count on the GPU.
// bindings: 0 = sorted keys, 1 = flags (out), 2 = counters
#include "shadowmaps/sm_shared.h"
layout(local_size_x = SM_LIST_THREADS) in;
layout(std430, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, binding = 1) writeonly buffer Flags { uint flags[]; };
layout(std430, binding = 2) readonly buffer Counters { uint counters[]; };
layout(push_constant) uniform Push { RmsmPush pc; };

void main() {
  uint i = CS_FLAT_INDEX(SM_LIST_THREADS);
  uint count = min(counters[SM_COUNT_PRUNED], pc.count);
  if (i >= count) return;
  flags[i] = (i == 0u || keys[i] != keys[i - 1u]) ? 1u : 0u;
}
