// Shared by the shadow-map tests: small analytic scenes, their cameras, and a rasterized frame with its
// Embree reference (the G-buffer on the GPU and on the host, the camera it was seen from).
#pragma once
#include <cmath>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "core/scene.h"
#include "method/epsilon.h"
#include "method/method.h"
#include "judge/metrics.h"
#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "tests/test_context.h"

namespace cs::smtest {

inline void addQuad(Scene& s, glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d) {
  uint32_t base = uint32_t(s.positions.size());
  glm::vec3 n = glm::normalize(glm::cross(b - a, c - a));
  for (glm::vec3 v : {a, b, c, d}) {
    s.positions.push_back(v);
    s.normals.push_back(n);
  }
  for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) s.indices.push_back(base + i);
}

// The analytic case: a square occluder at y = 1 over [-1, 1]² above a ground plane y = 0 over [-8, 8]².
inline Scene squareAbovePlane() {
  Scene s;
  s.name = "square-above-plane";
  addQuad(s, {-8, 0, -8}, {-8, 0, 8}, {8, 0, 8}, {8, 0, -8});
  addQuad(s, {-1, 1, -1}, {-1, 1, 1}, {1, 1, 1}, {1, 1, -1});
  s.computeBounds();
  return s;
}
inline const glm::vec3 kSquareLight(0.35f, 3.0f, 0.25f);

// The square-above-plane scene's light moved out along its own direction to k scene diagonals.
inline glm::vec3 farSquareLight(float k) {
  Scene scene = squareAbovePlane();
  const glm::vec3 c = 0.5f * (scene.boundsMin + scene.boundsMax);
  return c + k * glm::length(scene.boundsMax - scene.boundsMin) * glm::normalize(kSquareLight - c);
}

inline Camera squareCamera() {
  Camera c;
  c.eye = {2.5f, 4.0f, 4.5f};
  c.target = {-0.2f, 0.0f, -0.3f};
  c.yfov = 0.75f;
  c.znear = 0.05f;
  c.zfar = 60.0f;
  return c;
}

// Close to a corner of the square's shadow: pixels much finer than a uniform map's texels there.
inline Camera squareCloseCamera() {
  Camera c;
  c.eye = {2.3f, 0.9f, 2.4f};
  c.target = {1.2f, 0.0f, 1.25f};
  c.yfov = 0.5f;
  c.znear = 0.05f;
  c.zfar = 60.0f;
  return c;
}

// Whether p lies on triangle `tri` of `s` within `slack` (world units) of its plane and inside each of its
// edges' lines (a point on a shared edge belongs to both triangles). Rasterizers snap vertices to a
// sub-pixel grid, so a sample may lie a small fraction of a pixel outside the exact triangle.
inline bool onTriangle(const Scene& s, uint32_t tri, glm::vec3 p, double slack) {
  if (size_t(tri) * 3 + 2 >= s.indices.size()) return false;
  const glm::dvec3 v[3] = {glm::dvec3(s.positions[s.indices[3 * size_t(tri)]]),
                           glm::dvec3(s.positions[s.indices[3 * size_t(tri) + 1]]),
                           glm::dvec3(s.positions[s.indices[3 * size_t(tri) + 2]])};
  const glm::dvec3 q(p), n = glm::cross(v[1] - v[0], v[2] - v[0]);
  const double len = glm::length(n);
  if (!(len > 0) || std::abs(glm::dot(n, q - v[0])) / len > slack) return false;
  for (int e = 0; e < 3; ++e) {  // signed distance from q to edge e's line, positive inside
    const glm::dvec3 a = v[e], b = v[(e + 1) % 3];
    if (glm::dot(glm::cross(b - a, q - a), n) / (len * glm::length(b - a)) < -slack) return false;
  }
  return true;
}

// A closed box around the light: every direction hits a wall at a distance known in closed form.
inline Scene boxAroundLight(glm::vec3 lo, glm::vec3 hi) {
  Scene s;
  s.name = "box";
  auto quad = [&](glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d) { addQuad(s, a, b, c, d); };
  quad({lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, lo.y, hi.z}, {lo.x, lo.y, hi.z});  // floor
  quad({lo.x, hi.y, lo.z}, {lo.x, hi.y, hi.z}, {hi.x, hi.y, hi.z}, {hi.x, hi.y, lo.z});  // ceiling
  quad({lo.x, lo.y, lo.z}, {lo.x, hi.y, lo.z}, {hi.x, hi.y, lo.z}, {hi.x, lo.y, lo.z});  // back
  quad({lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z});  // front
  quad({lo.x, lo.y, lo.z}, {lo.x, lo.y, hi.z}, {lo.x, hi.y, hi.z}, {lo.x, hi.y, lo.z});  // left
  quad({hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {hi.x, hi.y, hi.z}, {hi.x, lo.y, hi.z});  // right
  s.computeBounds();
  return s;
}

// One rasterized frame with its Embree reference.
struct Frame {
  Scene scene;
  glm::vec3 light{0};
  Camera camera;
  DeviceGBuffer device;
  GBuffer host;
  std::vector<float> reference;
  float eps = 0;

  FrameInput input() {
    FrameInput in;
    in.scene = &scene;
    in.gbuffer = &host;
    in.device = &device;
    in.vk = &test::context();
    in.light = light;
    in.camera = &camera;
    in.epsilon = eps;
    return in;
  }
  ErrorStats compare(const std::vector<float>& visibility) const {
    return compareVisibility(host, visibility, reference, {});
  }
};

inline Frame renderFrame(Scene scene, const Camera& camera, glm::vec3 light, uint32_t w, uint32_t h) {
  Frame f;
  f.scene = std::move(scene);
  f.light = light;
  f.camera = camera;
  Raster raster(test::context(), f.scene);
  raster.render(camera, light, w, h, f.device, &f.host);
  f.eps = EpsilonPolicy::forScene(f.scene).eps;
  EmbreeReference ref;
  f.reference = ref.run(f.input()).visibility;
  return f;
}

// The box [kBoxLo, kBoxHi] around a light inside it, seen from a corner: every wall lit, nothing shadowed.
inline const glm::vec3 kBoxLo(-2.0f, -1.5f, -2.5f), kBoxHi(3.0f, 2.5f, 1.7f);
inline Frame boxFrame(uint32_t w, uint32_t h) {
  Camera cam;
  cam.eye = {2.2f, 1.8f, 1.2f};
  cam.target = {-1.5f, -0.8f, -2.0f};
  cam.yfov = 1.2f;
  return renderFrame(boxAroundLight(kBoxLo, kBoxHi), cam, glm::vec3(0.2f, 0.3f, -0.1f), w, h);
}

inline double misclassified(Frame& f, ShadowMethod& m) {
  MethodOutput out = m.run(f.input());
  EXPECT_EQ(out.visibility.size(), f.host.size());
  return f.compare(out.visibility).misclassifiedFraction;
}

inline Frame builtinFrame(const char* view, uint32_t w, uint32_t h) {
  Scene scene = builtinScene();
  const Camera* cam = scene.findCamera(view);
  EXPECT_TRUE(cam);
  Camera c = *cam;
  glm::vec3 light = scene.lights.at(0).position;
  return renderFrame(std::move(scene), c, light, w, h);
}

}  // namespace cs::smtest
