// libFuzzer target: a text glTF file (.gltf) through loadSceneFile. Inputs whose buffers name files are
// skipped (gltf_json.h), so every byte the loader reads is the fuzzer's.
#include "fuzz/fuzz_input.h"
#include "fuzz/gltf_json.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const cs::fuzz::InputFile file("fuzz.gltf");
  if (cs::fuzz::readsExternalBuffer(std::string(reinterpret_cast<const char*>(data), size))) return 0;
  cs::fuzz::load(file.write(data, size));
  return 0;
}
