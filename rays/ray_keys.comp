#version 450
#extension GL_GOOGLE_include_directive : require
// The Hilbert ray key (rays/hilbert.h) of every compacted sample: ray = light -> position[sample], in the
// world on its face's fitted grid and run of keys (faceKey on ray_grids.comp's grid) or in a rotated frame
// (frameRayKey on the frame's fitted grid, KeysPush::framed).
// bindings: 0 = position (uniform texel buffer, RGBA32F: a texel per pixel), 1 = samples (uint[] pixel
//           indices), 2 = keys (uint[]), 3 = countWords (device count), 4 = the key grids (uniform texel
//           buffer, RGBA32F: a texel per face; a rotated frame's in texel 0)
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = PIXEL_THREADS) in;
layout(binding = 0) uniform samplerBuffer position;
layout(std430, binding = 1) readonly buffer Samples { uint samples[]; };
layout(std430, binding = 2) writeonly buffer Keys { uint keys[]; };
layout(std430, binding = 3) readonly buffer CountWords { uint countWords[]; };
layout(binding = 4) uniform samplerBuffer grids;
layout(push_constant) uniform Push { KeysPush pc; };
// = pc.framed, as a specialisation constant: each pipeline holds one key's code (on lavapipe a lane pays
// for a kernel's code whether a uniform branch enters it or not, and each key has its own Hilbert loop).
layout(constant_id = 0) const uint SPEC_FRAMED = 0u;
#include "sort/common.glsl"

void main() {
  uint i = CS_FLAT_INDEX(PIXEL_THREADS);
  if (i >= countOf(pc.count, pc.countIndex, pc.flags)) return;
  vec3 x = texelFetch(position, int(samples[i])).xyz;
  if (SPEC_FRAMED != 0u) {
    keys[i] = frameRayKey(frameRay(x, pc.rowX, pc.rowY, pc.rowZ, pc.origin, pc.lightFrame), texelFetch(grids, 0));
  } else {
    vec3 d = x - pc.light.xyz;
    uint face = rayFace(d);
    keys[i] = face == 7u ? RAY_KEY_DEGENERATE : faceKey(d, face, texelFetch(grids, int(face)));
  }
}
