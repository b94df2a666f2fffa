#version 450
#extension GL_GOOGLE_include_directive : require
// RMSM page-table updates (step 9 of Algorithm 2): a scatter of (table index, value) pairs — value = pool
// slot + 1 for a page made resident, 0 for one evicted. Entries [first, first + count).
// bindings: 0 = updates (uvec2 per entry), 1 = tables (uint per entry)
#include "shadowmaps/sm_shared.h"
layout(local_size_x = SM_LIST_THREADS) in;
layout(std430, binding = 0) readonly buffer Updates { uvec2 updates[]; };
layout(std430, binding = 1) writeonly buffer Tables { uint tables[]; };
layout(push_constant) uniform Push { RmsmPush pc; };

void main() {
  uint i = CS_FLAT_INDEX(SM_LIST_THREADS);
  if (i >= pc.count) return;
  uvec2 u = updates[pc.first + i];
  tables[u.x] = u.y;
}
