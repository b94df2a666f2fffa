// Rigid per-node animation: a scene whose triangle ranges each follow one node of a transform
// hierarchy, nodes moved by keyframed translation / rotation / scale channels (glTF 2.0 §3.11). A
// static scene never touches this: loadGltf and builtinScene stay as they are, and the dynamic path
// (compare --animate) poses a copy of the rest scene per frame.
#pragma once
#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "core/scene.h"

namespace cs {

enum class AnimationPath { Translation, Rotation, Scale };
enum class AnimationInterpolation { Linear, Step };

// One keyframed property of one node. Rotations are unit quaternions stored (x, y, z, w) as in glTF;
// translations and scales use xyz.
struct AnimationChannel {
  int node = -1;
  AnimationPath path = AnimationPath::Translation;
  AnimationInterpolation interpolation = AnimationInterpolation::Linear;
  std::vector<double> times;       // strictly increasing, at least one
  std::vector<glm::dvec4> values;  // one per time
};

// A node of the hierarchy in its rest pose: translation · rotation · scale, or a fixed matrix (glTF
// `matrix` nodes, which channels may not target).
struct AnimationNode {
  int parent = -1;
  glm::dvec3 translation{0};
  glm::dquat rotation{1, 0, 0, 0};
  glm::dvec3 scale{1};
  std::optional<glm::dmat4> matrix;
};

// Scene vertices [firstVertex, firstVertex + vertexCount) and the triangles over them
// (indices [firstIndex, firstIndex + indexCount)), placed by one node.
struct VertexRange {
  int node = -1;
  uint32_t firstVertex = 0, vertexCount = 0;
  uint32_t firstIndex = 0, indexCount = 0;
  bool flatNormals = false;  // normals follow each triangle's winding (every triangle has its own vertices)
};

struct AnimatedScene {
  Scene rest;                             // the scene as loaded (rest pose); vertices outside ranges never move
  std::vector<AnimationNode> nodes;
  std::vector<AnimationChannel> channels;
  std::vector<VertexRange> ranges;
  std::vector<glm::vec3> localPositions;  // per scene vertex, in its range's node space (rest value elsewhere)
  std::vector<glm::vec3> localNormals;
  double start = 0, end = 0;              // first and last key time over all channels
  bool cyclic = false;                    // the pose at `end` equals the pose at `start` (built-in motion)

  // True when some channel moves a node that places triangles (itself or through a parent).
  bool animated() const;
  double duration() const { return end - start; }
  // Frame k of n, evenly spaced: over [start, end] inclusive, or over one cycle [start, end) when cyclic.
  double frameTime(uint32_t k, uint32_t n) const;
  // Node-to-world matrices at time t (parents before children need not hold: chains are followed).
  std::vector<glm::dmat4> worldMatrices(double t) const;
  // Writes the positions, normals and bounds at time t into `scene`, a copy of `rest`.
  void pose(double t, Scene& scene) const;
  Scene sceneAt(double t) const;
};

// A channel's value at t: held at its first and last keys; STEP takes the key at or before t; LINEAR
// interpolates translation and scale linearly and rotation by shortest-arc slerp (result unit length).
glm::dvec4 sampleChannel(const AnimationChannel& channel, double t);

// A node's local matrix at t: its rest pose with the channels that target it applied.
glm::dmat4 nodeMatrix(const AnimatedScene& scene, int node, double t);

// loadGltf plus the node hierarchy, every mesh instance's vertex range and the node animation channels
// of all the file's animations, played on one clock. LINEAR and STEP are sampled as specified;
// CUBICSPLINE is sampled as LINEAR through its keyframe values (one warning line); morph-target weight
// channels are ignored (one warning line). Cameras and lights stay in their rest pose. Malformed
// animation data throws cs::Error naming the file and the problem.
AnimatedScene loadAnimatedGltf(const std::string& path, std::ostream& warn);

// The built-in scene with its built-in motion over one cycle (t in [0, 1)): the shapes floating around
// the light swing about the light's vertical axis as one group while each spins about its own axis;
// the shapes on the floor, the table and the wall casters spin in place; the furball turns about its
// stand. The room and the table stay put.
AnimatedScene builtinAnimatedScene();

}  // namespace cs
