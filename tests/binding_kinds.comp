#version 450
// Test kernel (tests/vk_test.cpp): one binding of every kind of descriptor a compute shader declares, for
// vk::spirvInterface's reflection of descriptor types; it is never dispatched.
// bindings: 0 = storage buffer, 1 = uniform buffer, 2 = uniform texel buffer, 3 = storage texel buffer,
//           4 = storage image, 5 = sampled image, 6 = sampler, 7 = image with its sampler,
//           8 = uniform texel buffer declared as a texture (no sampler)
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer Storage { uint words[]; };
layout(std140, binding = 1) uniform Uniform { uvec4 uniformWords; };
layout(binding = 2) uniform usamplerBuffer texels;
layout(binding = 3, r32ui) uniform uimageBuffer storageTexels;
layout(binding = 4, r32f) uniform image2D storageImage;
layout(binding = 5) uniform texture2D sampledImage;
layout(binding = 6) uniform sampler imageSampler;
layout(binding = 7) uniform sampler2D combined;
layout(binding = 8) uniform utextureBuffer textureTexels;

void main() {
  vec4 s = texture(sampler2D(sampledImage, imageSampler), vec2(0.5)) + texture(combined, vec2(0.5)) +
           imageLoad(storageImage, ivec2(0));
  words[0] = uniformWords.x + texelFetch(texels, 0).x + imageLoad(storageTexels, 0).x +
             texelFetch(textureTexels, 0).x + uint(s.x);
}
