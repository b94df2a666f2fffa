#version 450
#extension GL_GOOGLE_include_directive : require
// The far-light frame's copy of the triangles (traversal.h, "Far-light frame"): every vertex P as
// R (P - C) - lightFrame, i.e. relative to the light in the frame, where the pass tests use them as they
// are. One invocation per triangle; the world copy stays for the leaves.
// bindings: 0 = triangles (vec4 x 3, world), 1 = frame triangles (vec4 x 3, out)
#include "conetree/cone_math.h"
#include "traversal/traverse.glsl"

layout(local_size_x = TRAVERSE_THREADS) in;
layout(std430, binding = 0) readonly buffer Triangles { vec4 tris[]; };
layout(std430, binding = 1) writeonly buffer FrameTriangles { vec4 frameTris[]; };
layout(push_constant) uniform Push { FrameTrianglesPush p; };

void main() {
  uint i = flatIndex();
  if (i >= p.count) return;
  ConeFrame f;
  f.rowX = p.rowX;
  f.rowY = p.rowY;
  f.rowZ = p.rowZ;
  f.centre = p.centre;
  f.lightFrame = p.lightFrame;
  for (uint k = 0u; k < 3u; k++)
    frameTris[3u * i + k] = vec4(toConeFrame(tris[3u * i + k].xyz, f) - p.lightFrame.xyz, 1.0f);
}
