// Work done in a child process, for parsers the project does not own (assimp): a crash, an abort, a
// runaway allocation or a hang there ends the child, and the caller gets a status it can put in one line.
// Used by core/assimp_loader.cpp; docs/ARCHITECTURE.md, "Scene loading".
#pragma once
#include <cstdint>
#include <functional>
#include <string>

namespace cs {

struct ChildResult {
  bool completed = false;  // `work` returned and everything it returned arrived
  std::string bytes;       // what `work` returned
  std::string how;         // when not completed, how the child ended: "was stopped by signal 11 (segmentation fault)"
};

// Runs `work` in a forked child and returns what it returned. In the child: only the calling thread
// exists (work must not need the others), the fault and interrupt signals have their default actions
// (the caller's handlers stay the caller's), stderr goes to /dev/null, the address space may grow by at most
// `memoryBytes` over the caller's (0: no bound),
// `seconds` of CPU time at most (0: no bound; the caller ends a child still running after twice that in
// wall-clock time), and an exception out of `work` ends it as a failure. A
// cs::Error when the process or its pipe cannot be created.
ChildResult runInChild(const std::function<std::string()>& work, uint64_t memoryBytes, unsigned seconds);

// The machine's physical memory in bytes (0 when unknown): the default bound on a child's growth.
uint64_t physicalMemoryBytes();

}  // namespace cs
