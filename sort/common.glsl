// Helpers every sort/ kernel shares. Include after the kernel's bindings: countOf() reads the count
// binding, which each kernel declares as `countWords`.

uint ceilDiv(uint a, uint b) { return a / b + ((a % b) != 0u ? 1u : 0u); }

// The element count a dispatch works on: the pushed count, or the device count clamped to it (the
// pushed value is then the host's upper bound, which sized the dispatch and the scratch).
uint countOf(uint pushCount, uint countIndex, uint flags) {
  return (flags & FLAG_COUNT_FROM_BUFFER) != 0u ? min(countWords[countIndex], pushCount) : pushCount;
}
