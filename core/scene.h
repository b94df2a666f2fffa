// The scene as every stage sees it: one flat, world-space triangle soup (node instances flattened),
// plus the cameras and point lights it carries. Only what shadows need (DESIGN.md: model only what a
// scene needs): no materials, no textures.
#pragma once
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace cs {

struct Camera {
  std::string name;
  glm::vec3 eye{0, 0, 5};
  glm::vec3 target{0, 0, 0};
  glm::vec3 up{0, 1, 0};
  float yfov = 0.8f;     // vertical field of view, radians
  float znear = 0.01f;   // > 0
  float zfar = 1000.0f;  // > znear
};

struct PointLight {
  std::string name;
  glm::vec3 position{0, 0, 0};
  glm::vec3 color{1, 1, 1};
  float intensity = 1.0f;
};

struct Scene {
  std::string name;                 // file name or "builtin"
  std::vector<glm::vec3> positions; // world space, one per vertex
  std::vector<glm::vec3> normals;   // world space, unit length, one per vertex (flat when the file has none)
  std::vector<uint32_t> indices;    // 3 per triangle, into positions/normals
  std::vector<Camera> cameras;      // in file order (glTF: nodes that carry a camera, traversal order)
  std::vector<PointLight> lights;   // point lights only, world-space positions
  glm::vec3 boundsMin{0}, boundsMax{0};

  size_t triangleCount() const { return indices.size() / 3; }
  float diagonal() const { return glm::length(boundsMax - boundsMin); }
  void computeBounds();             // from positions
  const Camera* findCamera(const std::string& name) const;  // nullptr if absent
};

// Loads a .gltf/.glb file. Node hierarchy with transforms; triangle primitives (strips and fans
// converted; points and lines skipped with one warning line on `warn`); indexed and non-indexed;
// positions and normals; cameras; KHR_lights_punctual point lights.
// Throws cs::Error naming the file and the problem on any malformed input.
Scene loadGltf(const std::string& path, std::ostream& warn);

// Loads a BART scene file (.aff: the animated extension of NFF, as the BART benchmark ships it) and the
// files it includes, placed at scene time `time` (default: the start of its `a` range, else 0).
// Geometry: polygons (p, pp; fans), textured triangles (tt), meshes (m: vertices, normals, texture
// coordinates, triangles), animated triangles (tpa: linear between keys), open cones and cylinders (c,
// 16 sides) and spheres (s), under static transforms (xs: scale, then rotation about an axis by degrees,
// then translation) and animated ones (x NAME, driven by k NAME: translation and scale on
// Kochanek-Bartels splines, rotations spherical-linear between the keys' axis-angle orientations).
// Cameras: the `v` view ("view"; its angle taken as the vertical field of view) and, when the file has
// a `k camera` track, "animated" (a camera at the origin looking down -z, +y up, moved by the track).
// Lights: every `l`. Materials, background and texture names are read and dropped.
// Throws cs::Error naming the file and line of any malformed input.
Scene loadAff(const std::string& path, std::ostream& warn, std::optional<double> time = std::nullopt);

// A BART file read once and placed at any time (loadAff is one placement): for dynamic scenes.
class AffAnimation {
 public:
  AffAnimation(const std::string& path, std::ostream& warn);  // throws cs::Error like loadAff
  ~AffAnimation();
  AffAnimation(AffAnimation&&) noexcept;
  AffAnimation& operator=(AffAnimation&&) noexcept;
  double start() const;   // the file's `a` range; without one, the span of its keys (0..0 if static)
  double end() const;
  bool animated() const;  // some keyframed transform or animated triangle moves
  // The scene at time t (keys held outside their range); cameras "view" and "animated" as loadAff's.
  // warn: where a transform without keyframes is reported (nullptr: silently).
  Scene sceneAt(double t, std::ostream* warn = nullptr) const;

 private:
  struct Data;
  std::unique_ptr<Data> d_;
};

// The built-in scene (needs no file): an enclosed room lit by a point light inside it, large wall and
// floor triangles grazing the light, a clutter of small meshes and a furball of thin hair-like strips.
// Named views: see builtinViewNames().
Scene builtinScene();
std::vector<std::string> builtinViewNames();

// Automatic camera / light for scenes that carry none: framing the bounds.
Camera automaticCamera(const Scene& scene);
PointLight automaticLight(const Scene& scene);

}  // namespace cs
