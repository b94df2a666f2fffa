// The multi-level scan's two steps and the compaction's scatter (002 §3.5: "compaction is very cheap").
// A level's array is cut into blocks of SCAN_BLOCK; invocation t owns SCAN_ITEMS consecutive elements.
// Expects the bindings named in the entry shaders and `pc` (ScanPush).
#define WG_SIZE SCAN_THREADS
#define WG_RAKE SCAN_RAKE
#include "sort/workgroup_scan.glsl"

// The count of this dispatch's level: the base count divided by SCAN_BLOCK, rounded up, `level` times.
uint levelCount() {
  uint n = countOf(pc.count, pc.countIndex, pc.flags);
  for (uint l = 0u; l < pc.level; ++l) n = ceilDiv(n, SCAN_BLOCK);
  return n;
}

// What an element of the level counts for: itself, or with FLAG_FIELD (level 0) its high field plus one.
uvec4 counted4(uvec4 x) { return (pc.flags & FLAG_FIELD) != 0u ? (x >> pc.fieldShift) + 1u : x; }
uint counted(uint x) { return (pc.flags & FLAG_FIELD) != 0u ? (x >> pc.fieldShift) + 1u : x; }
