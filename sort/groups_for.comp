#version 450
#extension GL_GOOGLE_include_directive : require
// Indirect dispatch arguments for a count that lives on the GPU: ceil(min(count, bound) / perGroup)
// workgroups (at least pc.minGroups) as the 2-D grid vk::gridFor makes on the host (x up to maxPerDim,
// then rows), so a dispatch sized by an earlier kernel's output needs no host round trip. The kernel it launches indexes
// CS_FLAT_WORKGROUP and still checks its element index against the device count (the grid's last
// row may run past it). One invocation.
// bindings: 0 = count words, 1 = args (uint; x, y, z at argsIndex)
#include "sort/sort_layout.h"
layout(local_size_x = 1) in;
layout(std430, binding = 0) readonly buffer CountWords { uint countWords[]; };
layout(std430, binding = 1) writeonly buffer Args { uint args[]; };
layout(push_constant) uniform Push { GroupsPush pc; };
#include "sort/common.glsl"

void main() {
  uint n = min(countWords[pc.countIndex], pc.count);
  uint groups = max(ceilDiv(n, pc.perGroup), pc.minGroups);
  uint y = groups <= pc.maxPerDim ? 1u : ceilDiv(groups, pc.maxPerDim);
  uint x = groups == 0u ? 0u : ceilDiv(groups, y);
  args[pc.argsIndex] = x;
  args[pc.argsIndex + 1u] = y;
  args[pc.argsIndex + 2u] = 1u;
}
