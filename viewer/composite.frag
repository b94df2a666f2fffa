#version 450
// The viewer's composite pass: the frame's shaded, mask or diff image, in the colours and by the rules of
// judge/frame_output.h (shadedImage, maskImage, diffImage), one window pixel a frame pixel.
//   binding 0: position vec4 a pixel   1: normal vec4 (w: the focus light's term)
//   binding 2: the method's visibility, pc.lightCount layers of a float a pixel, one a light
//   binding 3: the reference's visibility (the focus light)   4: the ambiguity band, one uint a pixel
//   binding 5: the lights' positions (xyz), layer l's at pc.firstLight + l
// Several lights: shaded sums each light's term times its visibility; mask and diff show the focus light.
#extension GL_GOOGLE_include_directive : require
#include "core/shared.h"
#include "viewer/composite_layout.h"

layout(push_constant) uniform Push { CompositePush pc; };
layout(set = 0, binding = 0) readonly buffer Positions { vec4 position[]; };
layout(set = 0, binding = 1) readonly buffer Normals { vec4 normal[]; };
layout(set = 0, binding = 2) readonly buffer Visibility { float visibility[]; };
layout(set = 0, binding = 3) readonly buffer Reference { float reference[]; };
layout(set = 0, binding = 4) readonly buffer Band { uint band[]; };
layout(set = 0, binding = 5) readonly buffer Lights { vec4 lights[]; };
layout(location = 0) out vec4 outColor;

// The direct term of layer l's light: the camera pass's for the focus light (the CLI's exact value), the
// camera pass's formula (raster/gbuffer_main.glsl) for the others.
float lightTerm(uint i, uint l) {
  if (l == pc.focusLight) return normal[i].w;
  vec3 toLight = lights[pc.firstLight + l].xyz - position[i].xyz;
  float d = length(toLight);
  return d > 0.0 ? max(0.0, dot(normal[i].xyz, toLight / d)) : 0.0;
}

// direct: the sum of the lights' terms, each times its visibility.
vec3 shade(uint i, float direct, float dim) {
  if (position[i].w <= 0.5) return floor(pc.background.rgb * dim + 0.5);
  float radiance = 0.8 * (0.15 + direct);
  float g = floor(pow(clamp(radiance, 0.0, 1.0), 1.0 / 2.2) * 255.0 + 0.5);
  return vec3(floor(g * dim + 0.5));
}

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy) - ivec2(pc.offsetX, pc.offsetY);
  if (p.x < 0 || p.y < 0 || p.x >= int(pc.width) || p.y >= int(pc.height)) {
    outColor = vec4(pc.background.rgb * 0.5 / 255.0, 1.0);
    return;
  }
  uint i = uint(p.y) * pc.width + uint(p.x);
  bool lit = litSample(position[i], normal[i]);
  uint pixels = pc.width * pc.height;
  float v = visibility[pc.focusLight * pixels + i];
  vec3 rgb;
  if (pc.mode == CS_DISPLAY_MASK) {
    rgb = vec3(!lit ? float(pc.maskGrey) : v >= 0.5 ? 255.0 : 0.0);
  } else if (pc.mode == CS_DISPLAY_DIFF && pc.reference != 0u) {
    bool methodLit = v >= 0.5, referenceLit = reference[i] >= 0.5;
    if (!lit || methodLit == referenceLit) rgb = shade(i, normal[i].w * clamp(reference[i], 0.0, 1.0), 0.5);
    else if (band[i] != 0u) rgb = pc.bandDisagree.rgb;
    else rgb = methodLit ? pc.falseLight.rgb : pc.falseShadow.rgb;
  } else {
    float direct = 0.0;
    for (uint l = 0u; l < pc.lightCount; ++l) direct += lightTerm(i, l) * clamp(visibility[l * pixels + i], 0.0, 1.0);
    rgb = shade(i, direct, 1.0);
  }
  outColor = vec4(rgb / 255.0, 1.0);
}
