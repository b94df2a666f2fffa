// libFuzzer target: a binary glTF file (.glb) through loadSceneFile. An input whose JSON chunk has a
// buffer naming a file is skipped (gltf_json.h); the chunk is found as the loader and tinygltf find it
// (header, then the JSON chunk's length), and an input without one is the loader's to refuse.
#include <cstring>

#include "fuzz/fuzz_input.h"
#include "fuzz/gltf_json.h"

namespace {

uint32_t readU32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

std::string jsonChunk(const uint8_t* data, size_t size) {
  if (size < 20 || std::memcmp(data + 16, "JSON", 4) != 0) return {};
  const uint32_t length = readU32(data + 12);
  if (length > size - 20) return {};
  return std::string(reinterpret_cast<const char*>(data + 20), length);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const cs::fuzz::InputFile file("fuzz.glb");
  if (cs::fuzz::readsExternalBuffer(jsonChunk(data, size))) return 0;
  cs::fuzz::load(file.write(data, size));
  return 0;
}
