// A count of heap allocations (operator new), per thread (core/heap_count.h), so that `view --stats` can
// say how many its frame loop makes and the tests can hold the engine's warm frames to none
// (docs/ARCHITECTURE.md, "The viewer" and "The engine"). Linked into the coneshadow executable and the test
// binary only (cs_heap_count), never into the library. Every unaligned operator new and delete is
// replaced, as a set: they allocate with malloc and free with free, so a sanitizer's runtime (which brings
// its own operators) never sees a mix. Aligned new and direct malloc calls (C libraries, the Vulkan
// driver) are not counted.
#include <cstdint>
#include <cstdlib>
#include <new>

#include "core/heap_count.h"

namespace {

thread_local uint64_t heapAllocations = 0;

uint64_t countedOnThisThread() { return heapAllocations; }

// Set before main: the viewer and the tests read the count through cs::threadHeapAllocations.
[[maybe_unused]] const bool installed = (cs::threadHeapAllocations = countedOnThisThread, true);

}  // namespace

void* operator new(std::size_t bytes) {
  ++heapAllocations;
  if (bytes == 0) bytes = 1;
  for (;;) {
    if (void* p = std::malloc(bytes)) return p;
    std::new_handler handler = std::get_new_handler();
    if (!handler) throw std::bad_alloc();
    handler();
  }
}
void* operator new[](std::size_t bytes) { return ::operator new(bytes); }
void* operator new(std::size_t bytes, const std::nothrow_t&) noexcept {
  try {
    return ::operator new(bytes);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t bytes, const std::nothrow_t& tag) noexcept { return ::operator new(bytes, tag); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
