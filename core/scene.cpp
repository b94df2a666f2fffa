// Scene helpers: bounds, camera lookup, and the automatic camera and light for scenes carrying none.
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/scene.h"

namespace cs {

void Scene::computeBounds() {
  if (positions.empty()) {
    boundsMin = boundsMax = glm::vec3(0);
    return;
  }
  boundsMin = glm::vec3(std::numeric_limits<float>::max());
  boundsMax = glm::vec3(-std::numeric_limits<float>::max());
  for (const glm::vec3& p : positions) {
    boundsMin = glm::min(boundsMin, p);
    boundsMax = glm::max(boundsMax, p);
  }
}

const Camera* Scene::findCamera(const std::string& cameraName) const {
  for (const Camera& c : cameras)
    if (c.name == cameraName) return &c;
  return nullptr;
}

namespace {
// A scene whose bounds collapse to a point still gets a usable camera and light.
float usableDiagonal(const Scene& scene) {
  const float d = scene.diagonal();
  return d > 0 && std::isfinite(d) ? d : 1.0f;
}
}  // namespace

// Looks at the bounds' centre from above-front-right, far enough that the bounding sphere fits the
// vertical field of view.
Camera automaticCamera(const Scene& scene) {
  const glm::vec3 centre = 0.5f * (scene.boundsMin + scene.boundsMax);
  const float diagonal = usableDiagonal(scene);
  const float radius = 0.5f * diagonal;
  Camera c;
  c.name = "auto";
  c.yfov = 0.8f;
  const float distance = 1.05f * radius / std::sin(0.5f * c.yfov);
  c.target = centre;
  c.eye = centre + glm::normalize(glm::vec3(0.9f, 0.6f, 1.2f)) * distance;
  c.up = glm::vec3(0, 1, 0);
  c.znear = 1e-3f * diagonal;
  c.zfar = distance + diagonal;  // beyond the far side of the bounding sphere
  return c;
}

// Most glTF files are objects, not rooms: a light inside the bounds would usually sit inside the
// model and leave every visible surface in its shadow. So the light hangs above the bounds, at a
// third of the diagonal over the top, and off the centre in x and z so that shadows fall sideways
// (not straight down, where they hide under their casters) and the view is not symmetric.
PointLight automaticLight(const Scene& scene) {
  const glm::vec3 centre = 0.5f * (scene.boundsMin + scene.boundsMax);
  const glm::vec3 extent = scene.boundsMax - scene.boundsMin;
  const float diagonal = usableDiagonal(scene);
  PointLight l;
  l.name = "auto";
  l.position = glm::vec3(centre.x + 0.2f * extent.x, scene.boundsMax.y + diagonal / 3, centre.z + 0.15f * extent.z);
  return l;
}

}  // namespace cs
