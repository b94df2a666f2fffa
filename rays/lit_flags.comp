#version 450
#extension GL_GOOGLE_include_directive : require
// The lit samples of the G-buffer (geometry present and direct-light term > 0, as GBuffer::isLit) as
// compaction flags over an enumeration of the pixels: row-major, or the tiled Morton screen order of
// the unsorted variant, which also records the pixel each position stands for.
// bindings: 0 = position, 1 = normal (uniform texel buffers, RGBA32F: a texel per pixel), 2 = flags
//           (uint[] per domain position), 3 = pixelOf (uint[] per domain position; Morton order only)
#include "rays/rays_layout.h"
#include "rays/hilbert.h"
layout(local_size_x = PIXEL_THREADS) in;
layout(binding = 0) uniform samplerBuffer position;  // texel fetches: the cheap gather (docs/ARCHITECTURE.md)
layout(binding = 1) uniform samplerBuffer normal;
layout(std430, binding = 2) writeonly buffer Flags { uint flags[]; };
layout(std430, binding = 3) writeonly buffer PixelOf { uint pixelOf[]; };
layout(push_constant) uniform Push { LitPush pc; };
// = pc.order != 0, as a specialisation constant: the row-major pipeline holds no Morton code (on lavapipe a
// lane pays for a kernel's code whether a uniform branch enters it or not).
layout(constant_id = 0) const uint SPEC_MORTON = 0u;

void main() {
  uint i = CS_FLAT_INDEX(PIXEL_THREADS);
  if (i >= pc.domain) return;
  uint pixel = i;
  bool inside = true;
  if (SPEC_MORTON != 0u) {
    uvec2 p = screenOrderPixel(i, pc.tilesX);
    inside = p.x < pc.width && p.y < pc.height;
    pixel = inside ? p.y * pc.width + p.x : 0u;
    pixelOf[i] = pixel;
  }
  flags[i] = inside && litSample(texelFetch(position, int(pixel)), texelFetch(normal, int(pixel))) ? 1u : 0u;
}
