// Rigid per-node animation: channel sampling, the node hierarchy at time t, and posing the triangle soup.
#include "core/animation.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

namespace cs {
namespace {

glm::dquat toQuat(const glm::dvec4& v) { return glm::dquat(v.w, v.x, v.y, v.z); }
glm::dvec4 fromQuat(const glm::dquat& q) { return {q.x, q.y, q.z, q.w}; }

glm::vec3 unitOr(const glm::dvec3& v, const glm::vec3& fallback) {
  const double len = glm::length(v);
  return len > 0 && std::isfinite(len) ? glm::vec3(v / len) : fallback;
}

}  // namespace

glm::dvec4 sampleChannel(const AnimationChannel& c, double t) {
  const std::vector<double>& times = c.times;
  if (times.empty()) return glm::dvec4(0);
  if (t <= times.front()) return c.values.front();
  if (t >= times.back()) return c.values.back();
  // The last key at or before t (times strictly increase).
  const size_t k = size_t(std::upper_bound(times.begin(), times.end(), t) - times.begin()) - 1;
  if (c.interpolation == AnimationInterpolation::Step) return c.values[k];
  const double u = (t - times[k]) / (times[k + 1] - times[k]);
  if (c.path != AnimationPath::Rotation) return glm::mix(c.values[k], c.values[k + 1], u);
  glm::dquat a = glm::normalize(toQuat(c.values[k])), b = glm::normalize(toQuat(c.values[k + 1]));
  if (glm::dot(a, b) < 0) b = -b;  // shortest arc
  return fromQuat(glm::normalize(glm::slerp(a, b, u)));
}

glm::dmat4 nodeMatrix(const AnimatedScene& scene, int node, double t) {
  const AnimationNode& n = scene.nodes[size_t(node)];
  if (n.matrix) return *n.matrix;
  glm::dvec3 translation = n.translation, scale = n.scale;
  glm::dquat rotation = n.rotation;
  for (const AnimationChannel& c : scene.channels) {
    if (c.node != node) continue;
    const glm::dvec4 v = sampleChannel(c, t);
    switch (c.path) {
      case AnimationPath::Translation: translation = glm::dvec3(v); break;
      case AnimationPath::Rotation: rotation = glm::normalize(toQuat(v)); break;
      case AnimationPath::Scale: scale = glm::dvec3(v); break;
    }
  }
  return glm::translate(glm::dmat4(1), translation) * glm::mat4_cast(rotation) * glm::scale(glm::dmat4(1), scale);
}

bool AnimatedScene::animated() const {
  std::vector<char> moved(nodes.size(), 0);
  for (const AnimationChannel& c : channels) moved[size_t(c.node)] = 1;
  for (const VertexRange& r : ranges)
    for (int at = r.node; at != -1; at = nodes[size_t(at)].parent)
      if (moved[size_t(at)]) return true;
  return false;
}

double AnimatedScene::frameTime(uint32_t k, uint32_t n) const {
  if (n <= 1) return start;
  const double steps = cyclic ? double(n) : double(n - 1);
  return start + duration() * double(k) / steps;
}

std::vector<glm::dmat4> AnimatedScene::worldMatrices(double t) const {
  const size_t n = nodes.size();
  std::vector<glm::dmat4> world(n);
  std::vector<char> done(n, 0);
  std::vector<int> chain;
  for (size_t i = 0; i < n; ++i) {
    // Walk up to the first node already known (or a root), then come back down.
    chain.clear();
    for (int at = int(i); at != -1 && !done[size_t(at)]; at = nodes[size_t(at)].parent) chain.push_back(at);
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
      const int p = nodes[size_t(*it)].parent;
      const glm::dmat4 local = nodeMatrix(*this, *it, t);
      world[size_t(*it)] = p == -1 ? local : world[size_t(p)] * local;
      done[size_t(*it)] = 1;
    }
  }
  return world;
}

void AnimatedScene::pose(double t, Scene& scene) const {
  const std::vector<glm::dmat4> world = worldMatrices(t);
  for (const VertexRange& r : ranges) {
    const glm::dmat4& m = world[size_t(r.node)];
    const glm::dmat3 linear(m);
    const double det = glm::determinant(linear);
    const bool invertible = std::abs(det) > 0 && std::isfinite(det);
    const glm::dmat3 normalMatrix = invertible ? glm::transpose(glm::inverse(linear)) : glm::dmat3(1.0);
    for (uint32_t v = r.firstVertex; v < r.firstVertex + r.vertexCount; ++v)
      scene.positions[v] = glm::vec3(m * glm::dvec4(glm::dvec3(localPositions[v]), 1.0));
    if (r.flatNormals) {
      for (uint32_t i = r.firstIndex; i < r.firstIndex + r.indexCount; i += 3) {
        const glm::dvec3 a(scene.positions[scene.indices[i]]), b(scene.positions[scene.indices[i + 1]]),
            c(scene.positions[scene.indices[i + 2]]);
        const glm::vec3 n = unitOr(glm::cross(b - a, c - a), {0, 1, 0});
        for (uint32_t k = 0; k < 3; ++k) scene.normals[scene.indices[i + k]] = n;
      }
    } else {
      for (uint32_t v = r.firstVertex; v < r.firstVertex + r.vertexCount; ++v)
        scene.normals[v] = unitOr(normalMatrix * glm::dvec3(localNormals[v]), {0, 1, 0});
    }
  }
  scene.computeBounds();
}

Scene AnimatedScene::sceneAt(double t) const {
  Scene s = rest;
  pose(t, s);
  return s;
}

}  // namespace cs
