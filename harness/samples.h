// The exact shadow visibility of samples of the caller's own (points and normals from any renderer) from
// 1..L point lights: the samples laid out as a G-buffer of their own, the lights recorded through the cone
// path's engine (traversal/cone_engine.h) a batch a submission, and on request Embree's answer and the
// ambiguity band for the same samples, as the frame harness computes them. `coneshadow visibility` and
// Python's visibility() are its two front ends; each checks its own input. docs/ARCHITECTURE.md, "The engine".
#pragma once
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

namespace cs {
struct Scene;
class ConeEngine;
namespace vk {
struct Context;
}

// The samples as a G-buffer: N samples row by row in a near-square W x H >= N, the pixels past N without
// geometry. Points finite, normals finite and non-zero (the front ends check; here it is asserted).
struct SampleGrid {
  size_t count = 0;
  uint32_t width = 0, height = 0;
  std::vector<glm::vec4> position, normal;  // normal: unit length, w = 0 (not read: the engine computes each light's term)
};
SampleGrid sampleGrid(std::span<const glm::vec3> points, std::span<const glm::vec3> normals);

// The engine a caller keeps between calls (made on first use on the context it is given) and the number of
// its next frame.
struct SampleEngine {
  std::unique_ptr<ConeEngine> engine;
  uint64_t frame = 0;
  SampleEngine();
  ~SampleEngine();
  SampleEngine(SampleEngine&&) noexcept;
  SampleEngine& operator=(SampleEngine&&) noexcept;
};

// L x N answers, light-major (answer[l * count + i]). A sample is visible from a light when it faces the
// light (the light term max(0, N.L) > 0, core/shared.h litSampleFor) and nothing lies between; a sample that
// faces away is not visible, in every answer.
struct SampleAnswers {
  size_t count = 0, lights = 0;
  std::vector<uint8_t> facing;     // 1 where the sample faces the light (its light term, as the engine computed it, > 0)
  std::vector<uint8_t> visible;    // the cone engine's exact answer
  std::vector<uint8_t> reference;  // Embree's (with reference only)
  std::vector<uint8_t> band;       // 1 where the sample lies in the ambiguity band (with reference only)
};

// Lights in range of the scene (the caller checks: method/epsilon.h lightRangeProblem). Throws cs::Error when
// the traversal's memory held too few pairs for the samples in a few frames (give fewer samples a call).
SampleAnswers sampleVisibility(vk::Context& ctx, SampleEngine& engine, const Scene& scene, const SampleGrid& grid,
                               std::span<const glm::vec3> lights, bool reference);

}  // namespace cs
