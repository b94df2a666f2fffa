// The tests' view into an Rmsm after its last run, kept out of the production class: the GPU's page
// requests, the pruned list, the unique pages, the residency and the pool, pages installed by hand and
// the page-table walk of rmsm.glsl run on chosen queries (by tests/rmsm_probe.comp, which the test binary
// builds). Nothing here runs in a frame.
#pragma once
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "shadowmaps/rmsm.h"
#include "vk/context.h"

namespace cs {

class RmsmInspector {
 public:
  explicit RmsmInspector(Rmsm& rmsm) : rmsm_(rmsm) {}

  std::vector<uint32_t> requests() const;       // 2 per pixel, SM_INVALID_KEY where none
  std::vector<uint32_t> compacted() const;      // pruned + compacted (and sorted in place by the analysis)
  std::vector<uint32_t> uniquePages() const;    // sorted unique pages the GPU returned (pre-fallback)
  std::vector<uint32_t> residentPages() const;  // pages in the pool, by slot
  std::vector<float> pool() const;              // the pool, (P+1)² texels per slot
  // Makes exactly `keys` resident (through the page-table kernel) and fills each page's texels, apron
  // included, with `texel(key, X, Y)` (X, Y: texel coordinates within the page's level of its face).
  void installPages(const std::vector<uint32_t>& keys, float (*texel)(uint32_t key, uint32_t x, uint32_t y));
  // findTexel() of rmsm.glsl for each query: (found, level, bits of the lower texel, of its diagonal), run
  // by `kernel`, the tests' rmsm_probe.comp (bindings: queries, page tables, pool, results, windows;
  // push constants sm::RmsmPush).
  struct Probe {
    uint32_t face = 0, level = 0;
    float s = 0, t = 0;
  };
  std::vector<glm::uvec4> probe(const vk::Kernel& kernel, const std::vector<Probe>& probes);

 private:
  Rmsm& rmsm_;
};

}  // namespace cs
