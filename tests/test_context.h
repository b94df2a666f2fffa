// The Vulkan context tests share: created once, with VK_LAYER_KHRONOS_validation on. test_main.cpp
// installs a listener that fails any test during which the layer printed a message.
#pragma once
#include "vk/context.h"

namespace cs::test {
vk::Context& context();
}  // namespace cs::test
