// Scene helpers: bounds, camera lookup, the automatic camera and light for scenes carrying none, and the
// ground plane (loading a file by its extension: scene_file.cpp).
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "core/error.h"
#include "core/input_guard.h"
#include "core/scene.h"

namespace cs {

ContentKey contentKey(const void* data, size_t bytes) {
  constexpr uint64_t P1 = 0x9E3779B185EBCA87ull, P2 = 0xC2B2AE3D27D4EB4Full, P3 = 0x165667B19E3779F9ull,
                     P4 = 0x85EBCA77C2B2AE63ull;
  auto rotl = [](uint64_t x, int r) { return (x << r) | (x >> (64 - r)); };
  auto mix = [](uint64_t h) {
    h ^= h >> 33, h *= 0xFF51AFD7ED558CCDull, h ^= h >> 33, h *= 0xC4CEB9FE1A85EC53ull;
    return h ^ (h >> 33);
  };
  ContentKey k;
  k.bytes = bytes;
  k.a = P1 ^ bytes, k.b = P3 + bytes;
  const auto* p = static_cast<const unsigned char*>(data);
  size_t i = 0;
  for (; i + 8 <= bytes; i += 8) {
    uint64_t w;
    std::memcpy(&w, p + i, 8);
    k.a = rotl(k.a + w * P2, 31) * P1;
    k.b = rotl(k.b ^ (w * P4), 27) * P3 + P2;
  }
  uint64_t tail = 0;
  if (i < bytes) std::memcpy(&tail, p + i, bytes - i);
  k.a = mix(k.a ^ tail), k.b = mix(k.b + tail * P1);
  return k;
}

GeometryRevision geometryRevision(const Scene& scene) {
  return {contentKey(scene.positions.data(), scene.positions.size() * sizeof(glm::vec3)),
          contentKey(scene.indices.data(), scene.indices.size() * sizeof(uint32_t))};
}

bool finiteTriangle(const Scene& scene, size_t t) {
  for (int k = 0; k < 3; ++k) {
    const glm::vec3 p = scene.positions[scene.indices[3 * t + k]];
    if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))) return false;
  }
  return true;
}

GeometryCheck checkGeometry(const Scene& scene) {
  const std::string where = "scene '" + scene.name + "'";
  if (scene.indices.size() % 3 != 0)
    throw Error(where + ": its index count " + std::to_string(scene.indices.size()) + " is not a multiple of 3",
                "scene geometry", "a triangle list needs three indices a triangle; re-export the mesh as triangles");
  for (size_t i = 0; i < scene.indices.size(); ++i)
    if (scene.indices[i] >= scene.positions.size())
      throw Error(where + ": index " + std::to_string(i) + " = " + std::to_string(scene.indices[i]) + " is past the " +
                      std::to_string(scene.positions.size()) + " vertices",
                  "scene geometry", "every index must name a vertex; the file or the code that built the scene is wrong");
  GeometryCheck c;
  for (size_t t = 0; t < scene.triangleCount(); ++t) {
    if (!finiteTriangle(scene, t)) {
      c.droppedTriangles++;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      c.lo = glm::min(c.lo, scene.positions[scene.indices[3 * t + k]]);
      c.hi = glm::max(c.hi, scene.positions[scene.indices[3 * t + k]]);
    }
  }
  return c;
}

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

namespace cs {

void addGroundPlane(Scene& scene) { addGroundPlane(scene, scene.boundsMin, scene.boundsMax); }

void addGroundPlane(Scene& scene, glm::vec3 lo, glm::vec3 hi) {
  const glm::vec3 centre = 0.5f * (lo + hi);
  const float diagonal = glm::length(hi - lo);
  const float d = diagonal > 0 && std::isfinite(diagonal) ? diagonal : 1.0f;
  const float y = lo.y - 1e-3f * d;
  const uint32_t b = uint32_t(scene.positions.size());
  scene.positions.insert(scene.positions.end(), {{centre.x - d, y, centre.z - d},
                                                 {centre.x - d, y, centre.z + d},
                                                 {centre.x + d, y, centre.z + d},
                                                 {centre.x + d, y, centre.z - d}});
  scene.normals.insert(scene.normals.end(), 4, glm::vec3(0, 1, 0));
  scene.indices.insert(scene.indices.end(), {b, b + 1, b + 2, b, b + 2, b + 3});  // counter-clockwise seen from +y
  scene.computeBounds();
}

}  // namespace cs
