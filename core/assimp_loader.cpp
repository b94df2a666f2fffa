// Scenes in every format assimp reads besides glTF (OBJ, PLY, STL, FBX, Collada, 3DS, ...) into the flat,
// world-space triangle soup of scene.h, held to the glTF path's rules: every position finite, every index
// in range, at least one triangle; a problem is one cs::Error naming the file. Node transforms are applied
// (meshes instanced by several nodes are flattened once per instance); points and lines are skipped with
// one warning line; normals come from the file, else flat per triangle. Lights: point lights as they are,
// spot lights as point lights (the methods are omnidirectional; a warning says so), directional lights
// kept aside as unusable (a frame that would need one is refused with the way out, --light). Cameras: every camera the file names, placed by its node.
// Before assimp sees the file, checkAssimpInput refuses what it would crash on, allocate for or misread;
// every file assimp opens (the scene, an OBJ's mtllib, ...) goes through GuardedFiles. assimp itself runs
// in a reader process (core/child_process.h): what slips past the checks and crashes it, or makes it
// allocate without end, ends that process, and the caller gets one line. The rules above are applied
// here, in the caller, to the plain copy of assimp's scene the reader sends back.
#include <sys/stat.h>

#include <assimp/DefaultIOSystem.h>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <optional>
#include <ostream>
#include <set>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/constants.hpp>

#include "core/child_process.h"
#include "core/error.h"
#include "core/input_guard.h"
#include "core/scene.h"

namespace cs {

namespace {

glm::dmat4 toGlm(const aiMatrix4x4& m) {
  // assimp matrices are row-major with the translation in the fourth column.
  glm::dmat4 out;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out[c][r] = m[r][c];
  return out;
}

std::string lowerExtension(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e;
}

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// assimp's file access held to the scene file's rules: only regular files of bounded size, read only, at
// most kMaxFiles distinct files and 2 x kMaxSceneFileBytes in all. assimp's own existence test opens the
// file, which blocks on a FIFO: here it only asks whether the name exists, and Open refuses what is not
// a regular file. The first refusal is kept: assimp reports a failed open vaguely, or not at all.
class GuardedFiles : public Assimp::DefaultIOSystem {
 public:
  static constexpr size_t kMaxFiles = 1024;
  explicit GuardedFiles(std::string scene) : scene_(std::move(scene)) {}
  using Assimp::DefaultIOSystem::Exists;
  using Assimp::DefaultIOSystem::Open;

  bool Exists(const char* file) const override {
    struct stat st {};
    return file && ::stat(file, &st) == 0;
  }

  Assimp::IOStream* Open(const char* file, const char* mode) override {
    if (!file) return nullptr;
    try {
      const std::string m = mode ? mode : "rb";
      if (m.find_first_of("wa+") != std::string::npos)
        throw Error("assimp asked to write " + quoteInput(file, 160), scene_, "coneshadow writes no scene files");
      checkSceneInput(file, scene_);
      std::error_code ec;
      const std::string key = std::filesystem::weakly_canonical(file, ec).string();
      if (seen_.insert(key).second) {
        bytes_ += std::filesystem::file_size(file, ec);
        if (seen_.size() > kMaxFiles || bytes_ > 2 * kMaxSceneFileBytes)
          throw Error("the scene's side files pass " + std::to_string(kMaxFiles) + " files or " +
                          std::to_string((2 * kMaxSceneFileBytes) >> 20) + " MiB",
                      scene_, "split the scene");
      }
    } catch (const Error& e) {
      if (!refused) refused = e;
      return nullptr;
    }
    return Assimp::DefaultIOSystem::Open(file, mode);
  }

  std::optional<Error> refused;

 private:
  std::string scene_;
  std::set<std::string> seen_;
  uint64_t bytes_ = 0;
};

}  // namespace

bool assimpReads(const std::string& path) {
  const std::string ext = lowerExtension(path);
  if (ext.empty() || ext == ".gltf" || ext == ".glb" || ext == ".aff") return false;
  Assimp::Importer importer;
  return importer.IsExtensionSupported(ext);
}

std::string assimpFormats() {
  Assimp::Importer importer;
  std::string list;
  importer.GetExtensionList(list);  // "*.3ds;*.obj;..."
  std::string out;
  for (size_t at = 0; at < list.size();) {
    const size_t end = std::min(list.find(';', at), list.size());
    std::string ext = list.substr(at, end - at);
    if (ext.rfind("*", 0) == 0) ext = ext.substr(1);
    if (ext != ".gltf" && ext != ".glb") out += (out.empty() ? "" : " ") + ext;
    at = end + 1;
  }
  return out;
}

namespace {

// The parts of an aiScene the loader reads, as plain data: what the reader process sends back. Nodes in
// depth-first order (a parent before its children), as aiNode::FindNode searches them.
struct RawMesh {
  std::string name;
  uint32_t primitiveTypes = 0;
  std::vector<glm::vec3> vertices, normals;  // normals empty when the mesh has none
  std::vector<uint32_t> faceSizes, faceIndices;
};
struct RawNode {
  std::string name;
  aiMatrix4x4 transform;
  int64_t parent = -1;
  std::vector<uint32_t> meshes;
};
struct RawCamera {
  std::string name;
  glm::vec3 position{0}, lookAt{0}, up{0};
  float horizontalFov = 0, aspect = 0, znear = 0, zfar = 0;
};
struct RawLight {
  std::string name;
  uint32_t type = 0;
  glm::vec3 position{0};
};
struct RawScene {
  std::vector<RawMesh> meshes;
  std::vector<RawNode> nodes;
  std::vector<RawCamera> cameras;
  std::vector<RawLight> lights;
};

glm::vec3 vec(const aiVector3D& v) { return {v.x, v.y, v.z}; }

// The reader process's answer: a tag, then an Error's three parts or the RawScene.
enum class Answer : uint8_t { Scene = 1, Failure = 2 };

struct Writer {
  std::string bytes;
  template <class T>
  void pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void text(const std::string& v) {
    pod(uint64_t(v.size()));
    bytes += v;
  }
  template <class T>
  void list(const std::vector<T>& v) {
    pod(uint64_t(v.size()));
    bytes.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
};

struct Reader {
  std::string_view bytes;
  const std::string& path;
  size_t at = 0;
  void need(uint64_t n) const {
    if (n > bytes.size() - at) throw Error("assimp's reader process sent a truncated answer", path, "report it with the file");
  }
  template <class T>
  T pod() {
    need(sizeof(T));
    T v;
    std::memcpy(&v, bytes.data() + at, sizeof v);
    at += sizeof v;
    return v;
  }
  std::string text() {
    const uint64_t n = pod<uint64_t>();
    need(n);
    std::string v(bytes.substr(at, n));
    at += n;
    return v;
  }
  template <class T>
  std::vector<T> list() {
    const uint64_t n = pod<uint64_t>();
    need(n > (bytes.size() - at) / sizeof(T) ? ~uint64_t(0) : n * sizeof(T));
    std::vector<T> v(n);
    if (n) std::memcpy(v.data(), bytes.data() + at, n * sizeof(T));
    at += n * sizeof(T);
    return v;
  }
};

std::string failureAnswer(const Error& e) {
  // The message without the parts Error's constructor adds around it.
  const std::string_view full = e.what();
  const std::string head = e.where + ": ", tail = " (" + e.hint + ")";
  std::string_view what = full;
  if (!e.where.empty() && what.substr(0, head.size()) == head) what.remove_prefix(head.size());
  if (!e.hint.empty() && what.size() >= tail.size() && what.substr(what.size() - tail.size()) == tail)
    what.remove_suffix(tail.size());
  Writer w;
  w.pod(Answer::Failure);
  w.text(std::string(what));
  w.text(e.where);
  w.text(e.hint);
  return w.bytes;
}

// In the reader process: assimp reads the file, and its scene is copied out as a RawScene.
std::string readInChild(const std::string& path, uint64_t memory) {
  try {
    Assimp::Importer importer;
    auto* files = new GuardedFiles(path);
    importer.SetIOHandler(files);  // the importer owns it
    // Only triangles and normals matter: no materials, textures, animations or bones are read.
    importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
    // Not aiProcess_FindInvalidData: it drops a mesh with a NaN or infinite position without a word;
    // buildScene names it instead.
    const unsigned flags =
        aiProcess_Triangulate | aiProcess_SortByPType | aiProcess_ValidateDataStructure | aiProcess_FindDegenerates;
    const aiScene* s = importer.ReadFile(path, flags);
    if (files->refused) throw *files->refused;
    if (!s || !s->mRootNode) {
      const std::string why = oneLineClipped(importer.GetErrorString(), 160);
      if (why.find("bad_alloc") != std::string::npos) throw std::bad_alloc();
      // Points and lines are dropped on reading (SortByPType); a file of nothing else has no meshes left.
      if (why.find("No meshes remaining") != std::string::npos)
        throw Error("the file has no triangles (assimp: " + why + ")", path, "give a scene with triangle meshes");
      throw Error("assimp could not read it: " + why, path, "the file is malformed or not what its extension says; re-export it");
    }
    if (s->mFlags & AI_SCENE_FLAGS_INCOMPLETE)
      throw Error("the file has no meshes (assimp reads it as incomplete)", path, "give a scene with triangle meshes");

    Writer w;
    w.pod(Answer::Scene);
    w.pod(uint64_t(s->mNumMeshes));
    for (unsigned m = 0; m < s->mNumMeshes; ++m) {
      const aiMesh* mesh = s->mMeshes[m];
      RawMesh raw;
      raw.name = mesh->mName.C_Str();
      raw.primitiveTypes = mesh->mPrimitiveTypes;
      for (unsigned v = 0; v < mesh->mNumVertices; ++v) raw.vertices.push_back(vec(mesh->mVertices[v]));
      if (mesh->HasNormals())
        for (unsigned v = 0; v < mesh->mNumVertices; ++v) raw.normals.push_back(vec(mesh->mNormals[v]));
      for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
        raw.faceSizes.push_back(mesh->mFaces[f].mNumIndices);
        raw.faceIndices.insert(raw.faceIndices.end(), mesh->mFaces[f].mIndices, mesh->mFaces[f].mIndices + mesh->mFaces[f].mNumIndices);
      }
      w.text(raw.name);
      w.pod(raw.primitiveTypes);
      w.list(raw.vertices);
      w.list(raw.normals);
      w.list(raw.faceSizes);
      w.list(raw.faceIndices);
    }
    // Depth first, children in order: aiNode::FindNode's order, and a parent before its children.
    std::vector<std::pair<const aiNode*, int64_t>> nodes, stack{{s->mRootNode, -1}};
    while (!stack.empty()) {
      nodes.push_back(stack.back());
      stack.pop_back();
      const aiNode* n = nodes.back().first;
      for (unsigned c = n->mNumChildren; c-- > 0;) stack.push_back({n->mChildren[c], int64_t(nodes.size() - 1)});
    }
    w.pod(uint64_t(nodes.size()));
    for (const auto& [n, parent] : nodes) {
      w.text(n->mName.C_Str());
      w.pod(n->mTransformation);
      w.pod(parent);
      w.list(std::vector<uint32_t>(n->mMeshes, n->mMeshes + n->mNumMeshes));
    }
    w.pod(uint64_t(s->mNumCameras));
    for (unsigned i = 0; i < s->mNumCameras; ++i) {
      const aiCamera* c = s->mCameras[i];
      w.text(c->mName.C_Str());
      w.pod(vec(c->mPosition));
      w.pod(vec(c->mLookAt));
      w.pod(vec(c->mUp));
      w.pod(c->mHorizontalFOV);
      w.pod(c->mAspect);
      w.pod(c->mClipPlaneNear);
      w.pod(c->mClipPlaneFar);
    }
    w.pod(uint64_t(s->mNumLights));
    for (unsigned i = 0; i < s->mNumLights; ++i) {
      const aiLight* l = s->mLights[i];
      w.text(l->mName.C_Str());
      w.pod(uint32_t(l->mType));
      w.pod(vec(l->mPosition));
    }
    return w.bytes;
  } catch (const Error& e) {
    return failureAnswer(e);
  } catch (const std::bad_alloc&) {
    return failureAnswer(Error("assimp ran out of memory reading it (it may use " + std::to_string(memory >> 20) +
                                   " MiB: 1 GiB and 128 bytes a byte of file)",
                               path, "the file is malformed, or too large for assimp: convert it to glTF"));
  } catch (const std::exception& e) {
    return failureAnswer(Error("assimp failed: " + oneLineClipped(e.what(), 160), path, "the file is malformed; re-export it"));
  }
}

// The reader process's answer read back: the RawScene, or the Error it reported thrown here.
RawScene decodeAnswer(const std::string& bytes, const std::string& path) {
  Reader r{bytes, path};
  const auto tag = r.pod<Answer>();
  if (tag == Answer::Failure) {
    std::string what = r.text(), where = r.text(), hint = r.text();
    throw Error(std::move(what), std::move(where), std::move(hint));
  }
  if (tag != Answer::Scene) throw Error("assimp's reader process sent an answer of unknown kind", path, "report it with the file");
  RawScene raw;
  for (uint64_t m = 0, n = r.pod<uint64_t>(); m < n; ++m) {
    RawMesh mesh;
    mesh.name = r.text();
    mesh.primitiveTypes = r.pod<uint32_t>();
    mesh.vertices = r.list<glm::vec3>();
    mesh.normals = r.list<glm::vec3>();
    mesh.faceSizes = r.list<uint32_t>();
    mesh.faceIndices = r.list<uint32_t>();
    raw.meshes.push_back(std::move(mesh));
  }
  for (uint64_t k = 0, n = r.pod<uint64_t>(); k < n; ++k) {
    RawNode node;
    node.name = r.text();
    node.transform = r.pod<aiMatrix4x4>();
    node.parent = r.pod<int64_t>();
    node.meshes = r.list<uint32_t>();
    if (node.parent >= int64_t(k) || (k > 0 && node.parent < 0) || (k == 0 && node.parent != -1))
      throw Error("assimp's reader process sent a node before its parent", path, "report it with the file");
    raw.nodes.push_back(std::move(node));
  }
  if (raw.nodes.empty()) throw Error("assimp's reader process sent no root node", path, "report it with the file");
  for (uint64_t k = 0, n = r.pod<uint64_t>(); k < n; ++k) {
    RawCamera c;
    c.name = r.text();
    c.position = r.pod<glm::vec3>();
    c.lookAt = r.pod<glm::vec3>();
    c.up = r.pod<glm::vec3>();
    c.horizontalFov = r.pod<float>();
    c.aspect = r.pod<float>();
    c.znear = r.pod<float>();
    c.zfar = r.pod<float>();
    raw.cameras.push_back(std::move(c));
  }
  for (uint64_t k = 0, n = r.pod<uint64_t>(); k < n; ++k) {
    RawLight l;
    l.name = r.text();
    l.type = r.pod<uint32_t>();
    l.position = r.pod<glm::vec3>();
    raw.lights.push_back(std::move(l));
  }
  if (r.at != bytes.size()) throw Error("assimp's reader process sent more than a scene", path, "report it with the file");
  return raw;
}

// The scene soup from what assimp read, held to the loaders' rules (the file's opening comment).
Scene buildScene(const RawScene& raw, const std::string& path, std::ostream& warn) {
  Scene scene;
  scene.name = std::filesystem::path(path).filename().string();
  size_t skipped = 0;
  std::vector<glm::dmat4> worlds(raw.nodes.size());
  for (size_t i = 0; i < raw.nodes.size(); ++i) {
    const RawNode& node = raw.nodes[i];
    const glm::dmat4 world = (node.parent < 0 ? glm::dmat4(1.0) : worlds[size_t(node.parent)]) * toGlm(node.transform);
    worlds[i] = world;
    const glm::dmat3 normalMatrix = glm::transpose(glm::inverse(glm::dmat3(world)));
    const bool invertible = std::isfinite(glm::determinant(glm::dmat3(world))) && glm::determinant(glm::dmat3(world)) != 0;
    for (const uint32_t index : node.meshes) {
      if (index >= raw.meshes.size())
        throw Error("a node names mesh " + std::to_string(index) + " of " + std::to_string(raw.meshes.size()), path, "re-export it");
      const RawMesh& mesh = raw.meshes[index];
      if (!(mesh.primitiveTypes & aiPrimitiveType_TRIANGLE)) {
        ++skipped;
        continue;
      }
      const size_t vertices = mesh.vertices.size();
      if (scene.positions.size() + vertices > UINT32_MAX)
        throw Error("the flattened scene has more than 2^32 vertices", path, "coneshadow indexes vertices with 32 bits");
      const uint32_t base = uint32_t(scene.positions.size());
      const bool normals = mesh.normals.size() == vertices && invertible;
      for (size_t v = 0; v < vertices; ++v) {
        const glm::vec3& p = mesh.vertices[v];
        const glm::dvec3 w = glm::dvec3(world * glm::dvec4(p.x, p.y, p.z, 1.0));
        if (!finite(w) || !finite(glm::dvec3(glm::vec3(w))))
          throw Error("mesh " + quoteInput(mesh.name) + " has a position at infinity or not a number at vertex " +
                          std::to_string(v) + " of " + std::to_string(vertices),
                      path, "re-export it");
        scene.positions.push_back(glm::vec3(w));
        const glm::dvec3 n = normals ? normalMatrix * glm::dvec3(mesh.normals[v]) : glm::dvec3(0);
        const double len = glm::length(n);
        scene.normals.push_back(len > 0 && std::isfinite(len) ? glm::vec3(n / len) : glm::vec3(0));
      }
      size_t at = 0;
      for (size_t f = 0; f < mesh.faceSizes.size(); ++f) {
        const uint32_t size = mesh.faceSizes[f];
        if (size > mesh.faceIndices.size() - at)
          throw Error("mesh " + quoteInput(mesh.name) + " face " + std::to_string(f) + " has more indices than the mesh", path, "re-export it");
        const uint32_t* face = mesh.faceIndices.data() + at;
        at += size;
        if (size != 3) {
          ++skipped;
          continue;
        }
        for (int c = 0; c < 3; ++c) {
          if (face[c] >= vertices)
            throw Error("mesh " + quoteInput(mesh.name) + " face " + std::to_string(f) + " indexes vertex " +
                            std::to_string(face[c]) + " of " + std::to_string(vertices),
                        path, "re-export it");
          scene.indices.push_back(base + face[c]);
        }
        // A vertex without a usable normal takes its triangle's face normal.
        const size_t t = scene.indices.size() - 3;
        const glm::vec3 a = scene.positions[scene.indices[t]], b = scene.positions[scene.indices[t + 1]],
                        c = scene.positions[scene.indices[t + 2]];
        glm::vec3 fn = glm::cross(b - a, c - a);
        const float fl = glm::length(fn);
        fn = fl > 0 && std::isfinite(fl) ? fn / fl : glm::vec3(0, 1, 0);
        for (int q = 0; q < 3; ++q)
          if (scene.normals[scene.indices[t + q]] == glm::vec3(0)) scene.normals[scene.indices[t + q]] = fn;
      }
    }
  }
  for (glm::vec3& n : scene.normals)
    if (n == glm::vec3(0)) n = glm::vec3(0, 1, 0);  // a vertex no triangle uses
  if (skipped) warn << "warning: " << path << ": " << skipped << " point or line primitive(s) skipped (triangles only)\n";
  if (scene.indices.empty()) throw Error("the file has no triangles", path, "give a scene with triangle meshes");
  scene.computeBounds();

  // Cameras and lights are placed by the first node of the same name, depth first.
  auto nodeWorld = [&](const std::string& name) {
    for (size_t i = 0; i < raw.nodes.size(); ++i)
      if (raw.nodes[i].name == name) return worlds[i];
    return glm::dmat4(1.0);
  };
  for (size_t i = 0; i < raw.cameras.size(); ++i) {
    const RawCamera& c = raw.cameras[i];
    const glm::dmat4 w = nodeWorld(c.name);
    Camera cam;
    cam.name = !c.name.empty() ? c.name : "camera" + std::to_string(i);
    const std::string what = "camera " + quoteInput(cam.name);
    const glm::dvec3 eye = glm::dvec3(w * glm::dvec4(glm::dvec3(c.position), 1));
    const glm::dvec3 look = glm::dvec3(w * glm::dvec4(glm::dvec3(c.lookAt), 0));
    const glm::dvec3 up = glm::dvec3(w * glm::dvec4(glm::dvec3(c.up), 0));
    cam.eye = glm::vec3(eye);
    cam.target = finite(look) && glm::length(look) > 0 ? glm::vec3(eye + glm::normalize(look)) : cam.eye;
    if (glm::length(up) > 0 && finite(up)) cam.up = glm::vec3(glm::normalize(up));
    // assimp's horizontal half angle; the vertical field of view from the aspect (0: not given).
    const double half = c.horizontalFov;
    if (!(half > 0 && half < 0.5 * glm::pi<double>()))
      throw Error(what + " has a horizontal field of view of " + std::to_string(2 * half) + " radians, outside (0, pi)",
                  path, "fix the camera in the file");
    const double aspect = c.aspect > 0 && std::isfinite(c.aspect) ? c.aspect : 1.0;
    cam.yfov = float(2.0 * std::atan(std::tan(half) / aspect));
    cam.znear = c.znear;
    cam.zfar = c.zfar;
    double farthest = 0;  // the scene's farthest point from the eye: a corner of the bounds
    for (int k = 0; k < 8; ++k) {
      const glm::dvec3 corner((k & 1) ? scene.boundsMax.x : scene.boundsMin.x, (k & 2) ? scene.boundsMax.y : scene.boundsMin.y,
                              (k & 4) ? scene.boundsMax.z : scene.boundsMin.z);
      farthest = std::max(farthest, glm::length(corner - glm::dvec3(cam.eye)));
    }
    checkFileCamera(cam, path, what, farthest);
    scene.cameras.push_back(cam);
  }
  for (size_t i = 0; i < raw.lights.size(); ++i) {
    const RawLight& l = raw.lights[i];
    const std::string name = !l.name.empty() ? l.name : "light" + std::to_string(i);
    if (l.type == aiLightSource_DIRECTIONAL) {  // refused when it would be the frame's light (chooseLight)
      scene.unusableLights.push_back(name + " (directional)");
      continue;
    }
    if (l.type != aiLightSource_POINT && l.type != aiLightSource_SPOT) {
      warn << "warning: " << path << ": light " << quoteInput(name) << " is neither point nor spot; skipped\n";
      continue;
    }
    if (l.type == aiLightSource_SPOT)
      warn << "warning: " << path << ": spot light " << quoteInput(name)
           << " is used as a point light (the methods are omnidirectional: its cone is ignored)\n";
    const glm::dvec3 p = glm::dvec3(nodeWorld(l.name) * glm::dvec4(glm::dvec3(l.position), 1));
    if (!finite(p)) throw Error("light " + quoteInput(name) + " has a non-finite position", path, "re-export it");
    PointLight pl;
    pl.name = name;
    pl.position = glm::vec3(p);
    scene.lights.push_back(pl);
  }
  scene.computeBounds();
  return scene;
}

// assimp runs in a reader process: a file that crashes it, or makes it allocate without end, ends that
// process, and the caller gets one line. Its bounds, from the file's size: memory 1 GiB plus 128 bytes a
// byte of file (the most a format needs is about 64: an OBJ face line of 8 bytes becomes a face object,
// three vertices with normals and the triangulated copy; docs/ARCHITECTURE.md, "Scenes"), at most the
// machine's; CPU two minutes plus a second per MiB.
Scene readAssimp(const std::string& path, std::ostream& warn) {
  const std::string bytes = readSceneBytes(path);
  checkAssimpInput(path, bytes);
  uint64_t memory = (uint64_t(1) << 30) + 128 * uint64_t(bytes.size());
  if (const uint64_t machine = physicalMemoryBytes()) memory = std::min(memory, machine);
  const ChildResult child = runInChild([&] { return readInChild(path, memory); }, memory, 120 + unsigned(bytes.size() >> 20));
  if (!child.completed)
    throw Error("assimp's reader process " + child.how + " while reading it", path,
                "the file is malformed or too large for assimp; re-export it, or convert it to glTF");
  return buildScene(decodeAnswer(child.bytes, path), path, warn);
}

}  // namespace

Scene loadAssimp(const std::string& path, std::ostream& warn) {
  try {
    return readAssimp(path, warn);
  } catch (const Error& e) {
    throw clippedError(e);
  } catch (const std::bad_alloc&) {
    throw Error("out of memory while loading", path, "the file is too large or malformed");
  }
}

}  // namespace cs
