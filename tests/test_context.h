// The Vulkan context tests share: created once, with VK_LAYER_KHRONOS_validation on. test_main.cpp
// installs a listener that fails any test during which the layer printed a message.
#pragma once
#include "vk/context.h"

namespace cs::test {
vk::Context& context();

// Lowers the shared context's maxTexelBufferElements for one scope (the texel paths' limits without
// buffers of gigabytes), and restores it.
struct TexelLimitForTesting {
  explicit TexelLimitForTesting(uint32_t limit) : saved(context().properties.limits.maxTexelBufferElements) {
    context().properties.limits.maxTexelBufferElements = limit;
  }
  ~TexelLimitForTesting() { context().properties.limits.maxTexelBufferElements = saved; }
  TexelLimitForTesting(const TexelLimitForTesting&) = delete;
  TexelLimitForTesting& operator=(const TexelLimitForTesting&) = delete;
  uint32_t saved;
};
}  // namespace cs::test
