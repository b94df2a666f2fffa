// What the library's own tests see of a coneshadow::Context beyond the public API: its Vulkan context
// (the host cost counters: submissions, waits, allocations).
#pragma once
#include "coneshadow/coneshadow.h"
#include "vk/context.h"

namespace coneshadow {
struct CONESHADOW_API ContextAccess {
  static cs::vk::Context& vulkan(Context& c);
};
}  // namespace coneshadow
