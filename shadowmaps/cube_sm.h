// shadowmaps/: the standard cube shadow map — the "SM" column of paper 000's tables, for an
// omnidirectional light. CLI name "cubesm".
//
// Six faces of R x R texels (--sm-resolution, default 2048), one geometry pass each, 90° frusta around
// the major axes (face conventions in sm_shared.h). Each texel stores the linear distance from the light
// to the nearest surface (fp32; see depth_pass.h for why a distance and not a perspective depth), so
// the six faces agree where they meet.
//
// Fitted faces: each face's R x R texels cover only the window of the face that the scene's bounding box
// projects to (the whole face when the light is inside or beside the box), at an effective resolution
// res >= R for the whole face, capped at 1024 R (fp32 face coordinates; cube_sm.cpp fitFace). For a light
// far outside the scene the box is a few texels of a whole face, and a fixed 90° frustum would leave a
// far light's shadows to a handful of texels and a slope bias of L·2/R, wider than the scene: with the
// fit, the error comes from the resolution the window has. The bias's texel is the fitted one (2/res).
//
// Bias policy (every shadow map here shares it; sm_shared.h slopeScaledBias; shadowmaps/README.md): a
// sample at distance L is lit by a tap when  stored >= L - bias,
//   bias = constantBias·eps + slopeBias · L·(2/res) · min(tanθ, maxSlope),
// where eps is the shared epsilon policy's along-ray epsilon (method/epsilon.h: the reference ignores
// hits within eps of either end, so no map can resolve closer), θ the angle between the sample's normal
// and the direction to the light, and L·2/R the widest a texel gets sideways at that distance. The
// constant term covers fp32 rounding of the two distances; the slope term covers the receiver's own
// surface seen by a tap up to slopeBias texels away (the bilinear footprint reaches 1 texel per axis,
// √2 diagonally: default 1.5). Grazing receivers (tanθ > maxSlope, θ > ~84°) keep some acne rather than
// an unbounded bias that would detach every contact shadow.
#pragma once
#include <cstdint>
#include <memory>

#include "method/method.h"

namespace cs {
namespace vk { struct Context; }

struct CubeSmOptions {
  uint32_t resolution = 2048;  // texels per face side (--sm-resolution); the faces take 24·R² bytes
  float constantBias = 2.0f;   // in units of the epsilon policy's eps
  float slopeBias = 1.5f;      // in texels (see above)
  float maxSlope = 10.0f;      // clamp of tanθ in the slope term
  bool pcf = true;             // bilinear 2x2 percentage-closer filter; false: nearest texel, 0/1
  bool planeBias = false;      // receiver-plane bias per tap instead of slope-scaled (sm_shared.h planeReach)
  bool cull = true;            // per-face frustum culling of triangle clusters (depth_pass.h); same result
  bool fitFaces = true;        // each face's R x R texels over the part of it the scene's bounds cover
};

// MethodOutput: visibility per pixel in [0, 1] (PCF) or {0, 1} (nearest), 1 where the sample is not lit;
// stages "faces" (six geometry passes + copies) and "lookup" (GPU timestamps; "upload" on frames that
// upload triangles); totalMs = wall clock up to the mask on the GPU (readback: stats.readback_ms);
// bytesAllocated = geometry + render target + faces + visibility; stats: resolution, face_bytes, bias.
// Throws cs::Error when a face does not fit one storage binding or the device's image limits.
std::unique_ptr<ShadowMethod> makeCubeShadowMap(vk::Context& ctx, const CubeSmOptions& options = {});

}  // namespace cs
