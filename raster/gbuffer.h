// The raster pass's output on the host: one sample per pixel, shared by every shadow method
// (docs/ARCHITECTURE.md, "Contracts": one sample set). Row-major, row 0 at the top of the image.
#pragma once
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "core/shared.h"

namespace cs {

struct GBuffer {
  uint32_t width = 0, height = 0;
  // xyz: world position (fp32); w: 1 where the pixel has geometry, 0 where it has none (xyz = 0 there).
  std::vector<glm::vec4> position;
  // xyz: world unit normal, turned to face the camera (two-sided); w: the direct-light term of the point
  // light, max(0, N·L̂) — the "light buffer" (core/shared.h lightTerm). A sample is *lit* (takes part in
  // shadow work and in the error metric) when it has geometry and w > 0: litSample (core/shared.h). The
  // cone path's kernels compute the same term for each of their lights (litSampleFor) and never read w.
  std::vector<glm::vec4> normal;

  size_t size() const { return size_t(width) * height; }
  bool hasGeometry(size_t i) const { return position[i].w > 0.5f; }
  bool isLit(size_t i) const { return litSample(position[i], normal[i]); }
  size_t litCount() const {
    size_t n = 0;
    for (size_t i = 0; i < size(); ++i) n += isLit(i);
    return n;
  }
};

}  // namespace cs
