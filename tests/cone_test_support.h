// Shared setup of the cone-path tests: a camera from two points, and one frame rendered once with its
// Embree reference and ambiguity band, which every configuration under test is judged against.
#pragma once
#include <cstdint>
#include <vector>

#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "reference/epsilon.h"
#include "tests/test_context.h"

namespace cs::test {

inline Camera lookAt(glm::vec3 eye, glm::vec3 target, float yfov = 0.9f) {
  Camera c;
  c.eye = eye;
  c.target = target;
  c.yfov = yfov;
  c.znear = 0.01f;
  c.zfar = 1e4f;
  return c;
}

struct ReferenceFrame {
  Raster raster;
  DeviceGBuffer dev;
  GBuffer host;
  EpsilonPolicy policy;
  FrameInput input;
  std::vector<float> reference;
  std::vector<uint8_t> band;
  ReferenceFrame(const Scene& scene, const Camera& camera, glm::vec3 light, uint32_t size)
      : raster(context(), scene), policy(EpsilonPolicy::forScene(scene)) {
    raster.render(camera, light, size, size, dev, &host);
    input.scene = &scene;
    input.gbuffer = &host;
    input.device = &dev;
    input.vk = &context();
    input.light = light;
    input.epsilon = policy.eps;
    EmbreeReference embree;
    reference = embree.run(input).visibility;
    band = embree.ambiguityBand(scene, host, light, policy);
  }
};

}  // namespace cs::test
