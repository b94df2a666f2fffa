#version 450
#extension GL_GOOGLE_include_directive : require
// Test kernel (tests/shadowmaps_test.cpp, run by RmsmInspector::probe): the page-table walk of
// shadowmaps/rmsm.glsl for a list of queries (face, level, s, t). Writes per query (found ? 1 : 0, found
// level, the raw bits of the footprint's lower texel, of its diagonal neighbour).
// bindings: 0 = queries (uvec4: face, level, floatBits(s), floatBits(t)), 1 = tables, 2 = pool,
//           3 = results (uvec4), 4 = the faces' windows (s, t are window coordinates)
#include "shadowmaps/sm_shared.h"
layout(local_size_x = SM_LIST_THREADS) in;
layout(std430, binding = 0) readonly buffer Queries { uvec4 queries[]; };
layout(std430, binding = 1) readonly buffer Tables { uint tables[]; };
layout(std430, binding = 2) readonly buffer Pool { float pool[]; };
layout(std430, binding = 3) writeonly buffer Results { uvec4 results[]; };
layout(std430, binding = 4) readonly buffer Windows { vec4 windows[]; };  // per face (sm_shared.h windowST)
layout(push_constant) uniform Push { RmsmPush pc; };
#include "shadowmaps/rmsm.glsl"

void main() {
  uint i = CS_FLAT_INDEX(SM_LIST_THREADS);
  if (i >= pc.count) return;
  uvec4 q = queries[i];
  uint found, base;
  vec2 frac;
  uvec2 texel;
  bool ok = findTexel(q.x, vec2(uintBitsToFloat(q.z), uintBitsToFloat(q.w)), q.y, found, base, frac, texel);
  uint row = pageSide() + 1u;
  results[i] = ok ? uvec4(1u, found, floatBitsToUint(pool[base]), floatBitsToUint(pool[base + row + 1u]))
                  : uvec4(0u);
}
