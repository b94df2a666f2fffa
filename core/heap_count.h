// The count of heap allocations (operator new) on the calling thread, where the binary counts them:
// app/heap_count.cpp, linked into the coneshadow executable and the test binary, sets the hook before
// main; elsewhere (the library alone, the Python module) it stays null. The viewer's --stats and the
// tests' allocation checks read it (docs/ARCHITECTURE.md, "The viewer" and "The engine").
#pragma once
#include <cstdint>

namespace cs {

inline uint64_t (*threadHeapAllocations)() = nullptr;

}  // namespace cs
