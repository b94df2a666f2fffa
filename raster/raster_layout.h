// Push constants of the camera pass, shared by GLSL and C++ (one layout, two languages).
#ifndef CONESHADOW_RASTER_LAYOUT_H
#define CONESHADOW_RASTER_LAYOUT_H

#include "core/shared.h"

#ifdef __cplusplus
namespace cs {
using mat4 = glm::mat4;
using vec4 = glm::vec4;
#endif

struct RasterPush {
  mat4 viewProj;  // world -> clip, Vulkan conventions (y down, depth 0..1)
  vec4 eye;       // xyz: camera position
  vec4 light;     // xyz: point light position
};

#ifdef __cplusplus
static_assert(sizeof(RasterPush) == 96, "RasterPush layout");
}  // namespace cs
#endif
#endif
