// Push constants of the viewer's composite pass (composite.frag), shared by GLSL and C++. The colours
// come from judge/frame_output.h's constants, so the window shows the CLI's images' colours.
#ifndef CONESHADOW_VIEWER_COMPOSITE_LAYOUT_H
#define CONESHADOW_VIEWER_COMPOSITE_LAYOUT_H

#include "core/shared.h"

#ifdef __cplusplus
namespace cs::viewer {
CS_GLSL_TYPES
#endif

#define CS_DISPLAY_SHADED 0u
#define CS_DISPLAY_MASK 1u
#define CS_DISPLAY_DIFF 2u

struct CompositePush {
  uint width, height;    // the frame's size
  int offsetX, offsetY;  // the window pixel where the frame's pixel (0, 0) is
  uint mode;             // CS_DISPLAY_*
  uint reference;        // 1: the reference and band buffers hold this frame's
  uint maskGrey;         // the mask's grey for samples that are not lit
  uint lightCount;       // the visibility buffer's layers, one a light shown (a registry method: 1)
  uint focusLight;       // the layer the mask and the diff show; the G-buffer's light term is its light's
  uint firstLight;       // the lights buffer's entry of layer 0
  uint pad0, pad1;
  vec4 background, falseShadow, falseLight, bandDisagree;  // 0..255 RGB
};

#ifdef __cplusplus
static_assert(sizeof(CompositePush) == 112, "CompositePush layout");
}  // namespace cs::viewer
#endif
#endif
