// What the loader fuzzers share. The loaders read paths only, so each input is written to a file of the
// loader's extension, alone in a folder of the process's own, and loaded through loadSceneFile (what
// `coneshadow info SCENE` calls). A cs::Error is the loader refusing bad input, a normal outcome; any other
// exception escapes to libFuzzer, and a scene that breaks scene.h's promises aborts: both are findings.
#pragma once
#include <stdlib.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "core/error.h"
#include "core/scene.h"

namespace cs::fuzz {

// A fresh folder under $TMPDIR holding one file, `name`, rewritten for every input; removed at exit.
class InputFile {
 public:
  explicit InputFile(const std::string& name) {
    std::string pattern = (std::filesystem::temp_directory_path() / "coneshadow_fuzz_XXXXXX").string();
    if (!mkdtemp(pattern.data())) fail("cannot create a folder under $TMPDIR");
    dir_ = pattern;
    path_ = (dir_ / name).string();
  }
  ~InputFile() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;

  const std::string& write(const uint8_t* data, size_t size) const {
    std::ofstream out(path_, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
    out.close();
    if (!out) fail("cannot write the input file");
    return path_;
  }

  [[noreturn]] static void fail(const char* what) {
    std::fprintf(stderr, "fuzz: %s\n", what);
    std::abort();
  }

 private:
  std::filesystem::path dir_;
  std::string path_;
};

// scene.h's promises for a loaded scene: whole triangles, indices in range, a normal per vertex, finite
// values, at least one triangle.
inline void checkScene(const Scene& s) {
  if (s.indices.empty() || s.indices.size() % 3 != 0) InputFile::fail("the scene's index count is not whole triangles");
  if (s.normals.size() != s.positions.size()) InputFile::fail("the scene has not one normal per vertex");
  for (uint32_t i : s.indices)
    if (i >= s.positions.size()) InputFile::fail("a scene index is out of range");
  for (size_t i = 0; i < s.positions.size(); ++i)
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(s.positions[i][c]) || !std::isfinite(s.normals[i][c]))
        InputFile::fail("a scene vertex or normal is not finite");
}

inline void load(const std::string& path) {
  std::ostringstream warn;
  try {
    checkScene(loadSceneFile(path, warn));
  } catch (const Error&) {
    // refused with a cs::Error: what bad input should get
  }
}

}  // namespace cs::fuzz
