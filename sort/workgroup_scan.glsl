// A workgroup-wide exclusive sum in shared memory only: no subgroup operations, so the result does not
// depend on the subgroup size (8 on lavapipe, 32 or 64 on GPUs). Raking: WG_SIZE / WG_RAKE invocations
// each scan a segment of WG_RAKE values serially, one invocation scans the segment sums. Three barriers.
// Define WG_SIZE (the workgroup size) and WG_RAKE (dividing it) before including.

shared uint wgScanValues[WG_SIZE];
shared uint wgScanSegments[WG_SIZE / WG_RAKE];
shared uint wgScanTotal;

// Sum of v over the invocations before this one (local invocation order); `total` = sum over all.
// Call from uniform control flow. Ends with a barrier, so callers may reuse shared memory afterwards.
uint workgroupExclusiveSum(uint v, out uint total) {
  const uint segments = WG_SIZE / WG_RAKE;
  uint t = gl_LocalInvocationIndex;
  wgScanValues[t] = v;
  barrier();
  if (t < segments) {
    uint sum = 0u;
    for (uint k = 0u; k < WG_RAKE; ++k) {
      uint x = wgScanValues[t * WG_RAKE + k];
      wgScanValues[t * WG_RAKE + k] = sum;
      sum += x;
    }
    wgScanSegments[t] = sum;
  }
  barrier();
  if (t == 0u) {
    uint sum = 0u;
    for (uint s = 0u; s < segments; ++s) {
      uint x = wgScanSegments[s];
      wgScanSegments[s] = sum;
      sum += x;
    }
    wgScanTotal = sum;
  }
  barrier();
  uint r = wgScanValues[t] + wgScanSegments[t / WG_RAKE];
  total = wgScanTotal;
  barrier();
  return r;
}
