#version 450
#extension GL_GOOGLE_include_directive : require
// The fitted box of each face for the ray keys (rays/hilbert.h, RAY_BOUNDS_SAMPLES): the face
// coordinates of the lit pixels among RAY_BOUNDS_SAMPLES pixels spread evenly over the frame's
// (boundsSample of the pixel count, row-major), and how many of them each face has (the faces' runs of keys, faceKeySlot); in the far-light frame (SPEC_FRAMED)
// the box of their frame coordinates instead (frameUV, face 0's words). An invocation keeps its own minima
// and counts per face, the workgroup merges them in shared memory and adds them to the buffer with one
// atomicMin (atomicAdd) a word. The subset comes from the G-buffer alone, before any compaction: the
// fused compaction (lit_runs.comp) keys the pixels in the same pass that finds which are lit. Only the
// members inside the pixels that may hold geometry are read (the others are never lit): an invocation
// takes rows of the rect, (workgroups launched) * RAY_BOUNDS_THREADS apart (RAY_BOUNDS_GROUPS workgroups, or
// fewer, none, for a frame that sorts few rays or none: rays.cpp recordBounds), and in each the members between
// the rect's columns (firstBoundsSampleFrom), so a far view pays for its scene's rect; the boxes and
// counts are those of the whole subset (rays.cpp referenceBounds), bit for bit.
// bindings: 0 = position, 1 = normal (uniform texel buffers, RGBA32F: a texel per pixel), 2 = bounds
//           (RAY_BOUNDS_WORDS uint: the boxes all ones, the counts zero before the dispatch), 3 = the rect
//           (uniform: uvec4 x0, y0, x1, y1 of DeviceGBuffer::geometryRect, clamped; uvec4 the image's
//           width, ...: lit_runs.comp's binding 7); pc.count: the pixels
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = RAY_BOUNDS_THREADS) in;
layout(binding = 0) uniform samplerBuffer position;
layout(binding = 1) uniform samplerBuffer normal;
layout(std430, binding = 2) buffer Bounds { uint bounds[]; };
layout(std140, binding = 3) uniform Domain { uvec4 rect; uvec4 size; };
layout(push_constant) uniform Push { KeysPush pc; };
// = pc.framed: the box of the rays' coordinates in the rotated frame (ray_keys.comp).
layout(constant_id = 0) const uint SPEC_FRAMED = 0u;

shared uint box[24];
shared uint faceCounts[6];

void main() {
  uint t = gl_LocalInvocationIndex;
  if (t < 24u) box[t] = RAY_BOUNDS_EMPTY;
  if (t < 6u) faceCounts[t] = 0u;
  uint n = pc.count;
  // Per face: the least orderedBits of u, v, -u, -v among this invocation's lit pixels.
  uvec4 least[6];
  uint seen[6];
  for (uint f = 0u; f < 6u; ++f) least[f] = uvec4(RAY_BOUNDS_EMPTY), seen[f] = 0u;
  uint inv = gl_WorkGroupID.x * RAY_BOUNDS_THREADS + t;
  for (uint y = rect.y + inv; y < rect.w && n > 0u; y += gl_NumWorkGroups.x * uint(RAY_BOUNDS_THREADS))
  for (uint j = firstBoundsSampleFrom(y * size.x + rect.x, n), end = firstBoundsSampleFrom(y * size.x + rect.z, n);
       j < end; ++j) {
    uint pixel = boundsSample(j, n);
    vec4 x = texelFetch(position, int(pixel));
    if (!litSampleFor(x, texelFetch(normal, int(pixel)), pc.light.xyz)) continue;
    vec3 d = x.xyz - pc.light.xyz;
    if (SPEC_FRAMED != 0u) d = frameRay(x.xyz, pc.rowX, pc.rowY, pc.rowZ, pc.origin, pc.lightFrame);
    uint face = SPEC_FRAMED != 0u ? (frameRayKeyed(d) ? 0u : 7u) : rayFace(d);
    if (face == 7u) continue;
    vec2 uv = SPEC_FRAMED != 0u ? frameUV(d) : rayFaceUV(d, face);
    least[face] = min(least[face], uvec4(orderedBits(uv.x), orderedBits(uv.y), orderedBits(-uv.x), orderedBits(-uv.y)));
    ++seen[face];
  }
  barrier();
  for (uint f = 0u; f < 6u; ++f)
    if (least[f].x != RAY_BOUNDS_EMPTY) {
      for (uint c = 0u; c < 4u; ++c) atomicMin(box[4u * f + c], least[f][c]);
      atomicAdd(faceCounts[f], seen[f]);
    }
  barrier();
  if (t < 24u && box[t] != RAY_BOUNDS_EMPTY) atomicMin(bounds[t], box[t]);
  if (t < 6u && faceCounts[t] != 0u) atomicAdd(bounds[RAY_BOUNDS_COUNTS + t], faceCounts[t]);
}
