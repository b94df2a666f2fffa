#version 450
#extension GL_GOOGLE_include_directive : require
// RTW warp maps (paper 004 §4.2), one workgroup per (face, axis): (i) collapse the face's n x n
// importance map to one value per column (axis 0) or row (axis 1) by the maximum, (ii) blur it with a
// Gaussian of `sigma` cells (zero outside the face), cells that had no importance staying at zero so
// they stay culled, (iii) knots K[k] = the cumulative importance of cells 0..k-1 over the total: a
// cell's warped width is its share of the importance (zero-importance cells get zero width). A face with
// no importance gets the identity warp and is marked inactive (the warped pass draws nothing into it).
// Also the live range of each axis and the inverse at the texel centres (rtw_shared.h).
// bindings: 0 = importance (uint = float bits per cell, 6 faces of n x n), 1 = warp (rtw_shared.h layout)
#include "shadowmaps/rtw_shared.h"
layout(local_size_x = RTW_WARP_THREADS) in;
layout(std430, binding = 0) readonly buffer Importance { uint importance[]; };
layout(std430, binding = 1) buffer Warp { float warp[]; };
layout(push_constant) uniform Push { RtwWarpPush pc; };

shared float collapsed[RTW_MAX_CELLS + 1u];  // the importance, then the knots
shared float blurred[RTW_MAX_CELLS];
shared float partial[RTW_WARP_THREADS];
shared uint firstLive, lastLive;

void main() {
  uint face = gl_WorkGroupID.x >> 1u, axis = gl_WorkGroupID.x & 1u;
  uint n = pc.cells, tid = gl_LocalInvocationIndex;
  uint faceBase = face * n * n;
  if (tid == 0u) {
    firstLive = n;
    lastLive = 0u;
  }
  for (uint k = tid; k < n; k += RTW_WARP_THREADS) {
    float m = 0.0;
    for (uint j = 0u; j < n; ++j)
      m = max(m, uintBitsToFloat(importance[faceBase + (axis == 0u ? j * n + k : k * n + j)]));
    collapsed[k] = m;
  }
  barrier();
  int r = int(pc.radius);
  for (uint k = tid; k < n; k += RTW_WARP_THREADS) {
    float v = collapsed[k];
    if (v > 0.0 && r > 0) {
      float sum = 0.0, weight = 0.0;
      for (int o = -r; o <= r; ++o) {
        float g = exp(-0.5 * float(o * o) / (pc.sigma * pc.sigma));
        int j = int(k) + o;
        if (j >= 0 && j < int(n)) {  // the kernel's weight inside the face only: edge cells keep their share
          sum += g * collapsed[j];
          weight += g;
        }
      }
      v = sum / weight;
    }
    blurred[k] = v;
    if (v > 0.0) {
      atomicMin(firstLive, k);
      atomicMax(lastLive, k);
    }
  }
  barrier();
  // The total, then each thread's run of consecutive cells summed in order (one scan, two passes).
  uint per = (n + RTW_WARP_THREADS - 1u) / RTW_WARP_THREADS;
  uint first = tid * per, last = min(first + per, n);
  float run = 0.0;
  for (uint k = first; k < last; ++k) run += blurred[k];
  partial[tid] = run;
  barrier();
  if (tid == 0u) {
    float acc = 0.0;
    for (uint t = 0u; t < RTW_WARP_THREADS; ++t) {
      float v = partial[t];
      partial[t] = acc;
      acc += v;
    }
    collapsed[0] = acc;  // the total (collapsed[] is no longer needed)
  }
  barrier();
  float total = collapsed[0];
  bool live = total > 0.0 && !isinf(total) && !isnan(total);
  uint base = rtwKnotBase(face, axis, n);
  float acc = partial[tid];
  barrier();  // every thread has read the total
  for (uint k = first; k < last; ++k) {
    float knot = live ? min(acc / total, 1.0) : float(k) / float(n);
    warp[base + k] = knot;
    collapsed[k] = knot;
    acc += blurred[k];
  }
  if (tid == 0u) collapsed[n] = 1.0;
  if (tid == 0u) {
    warp[base + n] = 1.0;
    if (axis == 0u) warp[rtwActiveIndex(face, n)] = live ? 1.0 : 0.0;
    uint range = rtwRangeIndex(face, axis, n);
    warp[range] = live ? float(firstLive) / float(n) : 0.0;
    warp[range + 1u] = live ? float(lastLive + 1u) / float(n) : 1.0;
  }
  barrier();
  // The inverse at the texel centres: the last cell whose start is <= s' (binary search of the knots).
  uint inv = rtwInverseBase(face, axis, n, pc.resolution);
  for (uint j = tid; j < pc.resolution; j += RTW_WARP_THREADS) {
    float sw = (float(j) + 0.5) / float(pc.resolution);
    uint lo = 0u, hi = n - 1u;
    while (lo < hi) {
      uint mid = (lo + hi + 1u) >> 1u;
      if (collapsed[mid] <= sw) lo = mid; else hi = mid - 1u;
    }
    warp[inv + j] = rtwUnwarpIn(sw, lo, n, collapsed[lo], collapsed[lo + 1u]);
  }
}
