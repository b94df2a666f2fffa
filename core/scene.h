// The scene as every stage sees it: one flat, world-space triangle soup (node instances flattened),
// plus the cameras and point lights it carries. Only what shadows need (docs/ARCHITECTURE.md,
// "Contracts": model only what a scene needs): no materials, no textures.
#pragma once
#include <cmath>
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
  std::string sourcePath;           // the file it was loaded from ("" for the built-in scene)
  std::string sourceHash;           // FNV-1a 64 of that file's bytes, hex (the main file of a BART scene)
  std::vector<std::string> unusableLights;  // lights the file has but no method can shadow ("sun (directional)")

  size_t triangleCount() const { return indices.size() / 3; }
  float diagonal() const { return glm::length(boundsMax - boundsMin); }
  void computeBounds();             // from positions
  const Camera* findCamera(const std::string& name) const;  // nullptr if absent
};

// 128-bit content key of a byte range (two independent multiply-rotate lanes over 8-byte words, as in
// xxHash's rounds, finished with an avalanche). Two different ranges share a key with probability ~2^-128.
struct ContentKey {
  uint64_t a = 0, b = 0, bytes = ~uint64_t(0);
  bool operator==(const ContentKey&) const = default;
};
ContentKey contentKey(const void* data, size_t bytes);

// The revision of a scene's geometry: keys of its positions and of its index list, from their contents,
// so an edit in place (an animation step, a test moving a vertex) is a new revision without anyone
// counting. The frame harness computes it once per frame (FrameInput::revision); every cache of geometry
// on the device or the host (the shared DeviceScene, the cone path's triangles, the depth passes'
// clusters) is keyed on it, and nothing keeps a copy of the scene to compare against.
struct GeometryRevision {
  ContentKey positions, indices;
  bool operator==(const GeometryRevision&) const = default;
  bool known() const { return positions.bytes != ~uint64_t(0); }  // false: not computed
};
GeometryRevision geometryRevision(const Scene& scene);

// The one geometry policy, checked once per revision by whatever uploads the scene first:
//   - the index count is a multiple of 3 and every index names a vertex: otherwise a cs::Error naming the
//     scene, the index and its value;
//   - a triangle with a non-finite vertex coordinate is no geometry: no method draws, tests or hits it
//     (the device copy writes it as the degenerate triangle 0, 0, 0; the cone path and Embree skip it),
//     and it is counted.
// Returns the triangles that the second rule drops and the bounds of the finite vertices the kept ones
// use (lo > hi when there are none).
struct GeometryCheck {
  uint64_t droppedTriangles = 0;
  glm::vec3 lo{INFINITY}, hi{-INFINITY};
};
GeometryCheck checkGeometry(const Scene& scene);
// True when all three vertices of triangle t are finite.
bool finiteTriangle(const Scene& scene, size_t t);

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

// Every other format assimp reads (OBJ, PLY, STL, FBX, Collada, 3DS, ...), by the glTF path's rules:
// finite positions, indices in range, at least one triangle, else one cs::Error naming the file. Point
// lights as they are, spot lights as point lights (with a warning), directional lights in unusableLights.
Scene loadAssimp(const std::string& path, std::ostream& warn);
// True when the extension is one assimp reads and the glTF/BART loaders do not take.
bool assimpReads(const std::string& path);
// Assimp's extensions besides glTF, space-separated (".obj .ply .stl ...").
std::string assimpFormats();

// A scene file by its extension: .gltf/.glb (tinygltf), .aff (BART, at `time` or its start), any other
// format assimp reads; an unknown extension is a cs::Error listing what is read. Fills sourcePath and
// sourceHash.
Scene loadSceneFile(const std::string& path, std::ostream& warn, std::optional<double> time = std::nullopt);
// FNV-1a 64 of a file's bytes, 16 hex digits; cs::Error when it cannot be read.
std::string fileHash(const std::string& path);
// Every scene reader's first step: the path names a regular file (not a FIFO, a device or a folder,
// which would block or read forever) of at most kMaxSceneFileBytes; cs::Error naming it otherwise,
// before a byte is read. `from` names what referred to it (an including file), if anything.
inline constexpr uint64_t kMaxSceneFileBytes = 2ull << 30;
void checkSceneInput(const std::string& path, const std::string& from = {});

// A receiver under a scene that has none (a single model): one square of two triangles, normal +y, just
// below the bounds' lowest y (by 1e-3 of the diagonal), the diagonal wide on each side of the centre, so
// the model's shadow from a light above has somewhere to fall. Bounds are recomputed. The second form
// places it for the bounds lo..hi (a moving scene keeps the plane of its rest pose).
void addGroundPlane(Scene& scene);
void addGroundPlane(Scene& scene, glm::vec3 lo, glm::vec3 hi);

// The built-in scene (needs no file): an enclosed room lit by a point light inside it, large wall and
// floor triangles grazing the light, a clutter of small meshes and a furball of thin hair-like strips.
// Named views: see builtinViewNames().
Scene builtinScene();
std::vector<std::string> builtinViewNames();

// A generated height field of about `triangles` triangles (n x n cells, two triangles each, the n whose
// 2 n^2 is nearest): a 2 x 2 square at y = 0 carrying two octaves of waves (0.08 and 0.03 high) whose
// crests shadow their neighbours, smooth normals, a point light 1.5 above its centre, no camera (the
// automatic one sees all of it). The scale benchmark's and the memory budget's scene: any size, no
// file. cs::Error outside [2, kMaxHeightFieldTriangles].
inline constexpr uint64_t kMaxHeightFieldTriangles = 100000000;
Scene heightFieldScene(uint64_t triangles);
// The triangle count of a scene argument "heightfield:N" (N digits, optionally k = 10^3 or M = 10^6:
// heightfield:10M); 0 for any other argument; UsageError for a malformed N.
uint64_t parseHeightFieldArg(const std::string& arg);

// The scene family ("family:SEED", docs/ARCHITECTURE.md, "The scene family"): generated scenes for the
// benchmarks that no rule was tuned on, each deterministic from its parameters, which a seed draws:
// 2 to 11 objects -- closed (spheres, tori, boxes) or open (wavy sheets, tubes, domes) -- on or over a
// tessellated ground plane or none, about `triangles` in all (a tenth in the ground), one point light and
// one camera. Parameters given after the seed replace the drawn ones and move nothing else.
struct FamilyParams {
  uint64_t seed = 0;
  uint64_t triangles = 0;      // in all: 300 .. 100k drawn (log-uniform); 100 .. kMaxHeightFieldTriangles given
  double view = 0;             // 0: the whole scene in ~300 pixels of 1024; 1: a close-up of one object
  double lightElevation = 45;  // degrees over the horizon: ~4 grazing .. 90 overhead
  double lightDistance = 1;    // from the centre, in scene diagonals: 0.7 (among the objects) .. 1000 (a sun)
  bool ground = true;          // a tessellated ground plane under the objects
  double openShare = 0;        // the share of open meshes among the objects (0, 0.5 or 1 drawn)
  uint32_t objects = 4;
  bool valid = false;          // parseFamilyArg: the argument was a family member
};
FamilyParams familyMember(uint64_t seed);
// "family:SEED" or "family:SEED:key=value:..." (keys tris, view, elevation, distance, ground, open,
// objects; "seed=S" may open it); .valid false for any other argument; UsageError naming the argument for
// a malformed one.
FamilyParams parseFamilyArg(const std::string& arg);
std::string familyDescription(const FamilyParams& params);  // the full "family:..." of these parameters
Scene familyScene(const FamilyParams& params);               // cs::Error for a count out of range

// Automatic camera / light for scenes that carry none: framing the bounds.
Camera automaticCamera(const Scene& scene);
PointLight automaticLight(const Scene& scene);

}  // namespace cs
