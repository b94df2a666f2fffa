// Scenes in every format assimp reads besides glTF (OBJ, PLY, STL, FBX, Collada, 3DS, ...) into the flat,
// world-space triangle soup of scene.h, held to the glTF path's rules: every position finite, every index
// in range, at least one triangle; a problem is one cs::Error naming the file. Node transforms are applied
// (meshes instanced by several nodes are flattened once per instance); points and lines are skipped with
// one warning line; normals come from the file, else flat per triangle. Lights: point lights as they are,
// spot lights as point lights (the methods are omnidirectional; a warning says so), directional lights
// kept aside as unusable (a frame that would need one is refused with the way out, --light). Cameras: every camera the file names, placed by its node.
// Before assimp sees the file, checkAssimpInput refuses what it would crash on, allocate for or misread;
// every file assimp opens (the scene, an OBJ's mtllib, ...) goes through GuardedFiles.
#include <sys/stat.h>

#include <assimp/DefaultIOSystem.h>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <functional>
#include <optional>
#include <ostream>
#include <set>
#include <string>

#include <glm/glm.hpp>
#include <glm/gtc/constants.hpp>

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

Scene readAssimp(const std::string& path, std::ostream& warn) {
  checkAssimpInput(path, readSceneBytes(path));
  Assimp::Importer importer;
  auto* files = new GuardedFiles(path);
  importer.SetIOHandler(files);  // the importer owns it
  // Only triangles and normals matter: no materials, textures, animations or bones are read.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  // Not aiProcess_FindInvalidData: it drops a mesh with a NaN or infinite position without a word; the
  // loop below names it instead.
  const unsigned flags =
      aiProcess_Triangulate | aiProcess_SortByPType | aiProcess_ValidateDataStructure | aiProcess_FindDegenerates;
  const aiScene* s = importer.ReadFile(path, flags);
  if (files->refused) throw *files->refused;
  if (!s || !s->mRootNode) {
    const std::string why = oneLineClipped(importer.GetErrorString(), 160);
    // Points and lines are dropped on reading (SortByPType); a file of nothing else has no meshes left.
    if (why.find("No meshes remaining") != std::string::npos)
      throw Error("the file has no triangles (assimp: " + why + ")", path, "give a scene with triangle meshes");
    throw Error("assimp could not read it: " + why, path, "the file is malformed or not what its extension says; re-export it");
  }
  if (s->mFlags & AI_SCENE_FLAGS_INCOMPLETE)
    throw Error("the file has no meshes (assimp reads it as incomplete)", path, "give a scene with triangle meshes");

  Scene scene;
  scene.name = std::filesystem::path(path).filename().string();
  size_t skipped = 0;
  std::function<void(const aiNode*, const glm::dmat4&)> visit = [&](const aiNode* node, const glm::dmat4& parent) {
    const glm::dmat4 world = parent * toGlm(node->mTransformation);
    const glm::dmat3 normalMatrix = glm::transpose(glm::inverse(glm::dmat3(world)));
    const bool invertible = std::isfinite(glm::determinant(glm::dmat3(world))) && glm::determinant(glm::dmat3(world)) != 0;
    for (unsigned k = 0; k < node->mNumMeshes; ++k) {
      if (node->mMeshes[k] >= s->mNumMeshes) throw Error("a node names mesh " + std::to_string(node->mMeshes[k]) + " of " + std::to_string(s->mNumMeshes), path, "re-export it");
      const aiMesh* mesh = s->mMeshes[node->mMeshes[k]];
      if (!(mesh->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) {
        ++skipped;
        continue;
      }
      const uint32_t base = uint32_t(scene.positions.size());
      for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
        const aiVector3D& p = mesh->mVertices[v];
        const glm::dvec3 w = glm::dvec3(world * glm::dvec4(p.x, p.y, p.z, 1.0));
        if (!finite(w) || !finite(glm::dvec3(glm::vec3(w))))
          throw Error("mesh " + quoteInput(mesh->mName.C_Str()) + " has a position at infinity or not a number at vertex " +
                          std::to_string(v) + " of " + std::to_string(mesh->mNumVertices),
                      path, "re-export it");
        scene.positions.push_back(glm::vec3(w));
        glm::dvec3 n(0);
        if (mesh->HasNormals() && invertible) n = normalMatrix * glm::dvec3(mesh->mNormals[v].x, mesh->mNormals[v].y, mesh->mNormals[v].z);
        const double len = glm::length(n);
        scene.normals.push_back(len > 0 && std::isfinite(len) ? glm::vec3(n / len) : glm::vec3(0));
      }
      for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
        const aiFace& face = mesh->mFaces[f];
        if (face.mNumIndices != 3) {
          ++skipped;
          continue;
        }
        for (int c = 0; c < 3; ++c) {
          if (face.mIndices[c] >= mesh->mNumVertices)
            throw Error("mesh " + quoteInput(mesh->mName.C_Str()) + " face " + std::to_string(f) + " indexes vertex " +
                            std::to_string(face.mIndices[c]) + " of " + std::to_string(mesh->mNumVertices),
                        path, "re-export it");
          scene.indices.push_back(base + face.mIndices[c]);
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
    for (unsigned c = 0; c < node->mNumChildren; ++c) visit(node->mChildren[c], world);
  };
  visit(s->mRootNode, glm::dmat4(1.0));
  for (glm::vec3& n : scene.normals)
    if (n == glm::vec3(0)) n = glm::vec3(0, 1, 0);  // a vertex no triangle uses
  if (skipped) warn << "warning: " << path << ": " << skipped << " point or line primitive(s) skipped (triangles only)\n";
  if (scene.indices.empty()) throw Error("the file has no triangles", path, "give a scene with triangle meshes");
  scene.computeBounds();

  // Cameras and lights are placed by the node of the same name.
  auto nodeWorld = [&](const aiString& name) {
    glm::dmat4 m(1.0);
    const aiNode* n = s->mRootNode->FindNode(name);
    for (; n; n = n->mParent) m = toGlm(n->mTransformation) * m;
    return m;
  };
  for (unsigned i = 0; i < s->mNumCameras; ++i) {
    const aiCamera* c = s->mCameras[i];
    const glm::dmat4 w = nodeWorld(c->mName);
    Camera cam;
    cam.name = c->mName.length ? c->mName.C_Str() : "camera" + std::to_string(i);
    const std::string what = "camera " + quoteInput(cam.name);
    const glm::dvec3 eye = glm::dvec3(w * glm::dvec4(c->mPosition.x, c->mPosition.y, c->mPosition.z, 1));
    const glm::dvec3 look = glm::dvec3(w * glm::dvec4(c->mLookAt.x, c->mLookAt.y, c->mLookAt.z, 0));
    const glm::dvec3 up = glm::dvec3(w * glm::dvec4(c->mUp.x, c->mUp.y, c->mUp.z, 0));
    cam.eye = glm::vec3(eye);
    cam.target = finite(look) && glm::length(look) > 0 ? glm::vec3(eye + glm::normalize(look)) : cam.eye;
    if (glm::length(up) > 0 && finite(up)) cam.up = glm::vec3(glm::normalize(up));
    // assimp's horizontal half angle; the vertical field of view from the aspect (0: not given).
    const double half = c->mHorizontalFOV;
    if (!(half > 0 && half < 0.5 * glm::pi<double>()))
      throw Error(what + " has a horizontal field of view of " + std::to_string(2 * half) + " radians, outside (0, pi)",
                  path, "fix the camera in the file");
    const double aspect = c->mAspect > 0 && std::isfinite(c->mAspect) ? c->mAspect : 1.0;
    cam.yfov = float(2.0 * std::atan(std::tan(half) / aspect));
    cam.znear = c->mClipPlaneNear;
    cam.zfar = c->mClipPlaneFar;
    double farthest = 0;  // the scene's farthest point from the eye: a corner of the bounds
    for (int k = 0; k < 8; ++k) {
      const glm::dvec3 corner((k & 1) ? scene.boundsMax.x : scene.boundsMin.x, (k & 2) ? scene.boundsMax.y : scene.boundsMin.y,
                              (k & 4) ? scene.boundsMax.z : scene.boundsMin.z);
      farthest = std::max(farthest, glm::length(corner - glm::dvec3(cam.eye)));
    }
    checkFileCamera(cam, path, what, farthest);
    scene.cameras.push_back(cam);
  }
  for (unsigned i = 0; i < s->mNumLights; ++i) {
    const aiLight* l = s->mLights[i];
    const std::string name = l->mName.length ? l->mName.C_Str() : "light" + std::to_string(i);
    if (l->mType == aiLightSource_DIRECTIONAL) {  // refused when it would be the frame's light (chooseLight)
      scene.unusableLights.push_back(name + " (directional)");
      continue;
    }
    if (l->mType != aiLightSource_POINT && l->mType != aiLightSource_SPOT) {
      warn << "warning: " << path << ": light " << quoteInput(name) << " is neither point nor spot; skipped\n";
      continue;
    }
    if (l->mType == aiLightSource_SPOT)
      warn << "warning: " << path << ": spot light " << quoteInput(name)
           << " is used as a point light (the methods are omnidirectional: its cone is ignored)\n";
    const glm::dvec3 p = glm::dvec3(nodeWorld(l->mName) * glm::dvec4(l->mPosition.x, l->mPosition.y, l->mPosition.z, 1));
    if (!finite(p)) throw Error("light " + quoteInput(name) + " has a non-finite position", path, "re-export it");
    PointLight pl;
    pl.name = name;
    pl.position = glm::vec3(p);
    scene.lights.push_back(pl);
  }
  scene.computeBounds();
  return scene;
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
