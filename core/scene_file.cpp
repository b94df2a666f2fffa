// Loading a scene file by its extension (glTF, BART, or a format assimp reads), the checks every input
// file passes first, and its content hash. Apart from scene.cpp so that what links the geometry helpers
// alone (libconeshadow) does not pull the loaders in.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "core/input_guard.h"
#include "core/scene.h"

namespace cs {

void checkSceneInput(const std::string& path, const std::string& from) {
  namespace fs = std::filesystem;
  const std::string where = from.empty() ? path : from;
  const std::string shown = quoteInput(path, 160);
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) throw Error("cannot open " + shown + ": no such file", where, "check the path");
  if (fs::is_directory(st)) throw Error(shown + " is a folder, not a file", where, "give the scene file itself");
  if (!fs::is_regular_file(st))
    throw Error(shown + " is not a regular file (" + std::string(fs::is_fifo(st) ? "a FIFO" : "a device or socket") + ")",
                where, "give the scene file itself");
  const uint64_t bytes = fs::file_size(path, ec);
  if (ec) throw Error("cannot read the size of " + shown, where, "check the permissions");
  if (bytes > kMaxSceneFileBytes)
    throw Error(shown + " is " + std::to_string(bytes >> 20) + " MiB, over the " +
                    std::to_string(kMaxSceneFileBytes >> 20) + " MiB a scene file may have",
                where, "split the scene or decimate it");
}

std::string fileHash(const std::string& path) {
  checkSceneInput(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot read the file", path, "check the path and permissions");
  uint64_t h = 1469598103934665603ull;
  char buf[1 << 16];
  while (in) {
    in.read(buf, sizeof buf);
    for (std::streamsize i = 0; i < in.gcount(); ++i) {
      h ^= static_cast<unsigned char>(buf[i]);
      h *= 1099511628211ull;
    }
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return hex;
}

Scene loadSceneFile(const std::string& path, std::ostream& warn, std::optional<double> time) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  Scene scene;
  try {
    if (ext == ".aff") {
      scene = loadAff(path, warn, time);
    } else if (time) {
      throw UsageError("--time places a BART (.aff) scene in time; " + oneLineClipped(path, 160) +
                       " is not one (use compare --animate)");
    } else if (ext == ".gltf" || ext == ".glb") {
      scene = loadGltf(path, warn);
    } else if (assimpReads(path)) {
      scene = loadAssimp(path, warn);
    } else {
      throw Error("unknown file type " + quoteInput(ext, 20), path,
                  "coneshadow reads glTF 2.0 (.gltf, .glb), BART (.aff) and, through assimp, " + assimpFormats());
    }
    scene.sourcePath = path;
    scene.sourceHash = fileHash(path);
  } catch (const Error& e) {
    throw clippedError(e);  // every loader's message: one line, input quoted within bounds
  }
  return scene;
}

}  // namespace cs
