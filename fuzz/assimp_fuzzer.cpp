// libFuzzer target: the formats read through assimp (OBJ, PLY, STL, Collada, OFF) through loadSceneFile,
// with the guards of core/input_guard.h in front. The first byte picks the file's extension ('o' .obj,
// 'p' .ply, 's' .stl, 'd' .dae, 'f' .off; any other byte by its value modulo 5); the rest is the file.
// Side files an input names (an OBJ's mtllib) go through the loader's guarded file access: the input's
// folder holds nothing else, and a system path is refused unless it is a regular file of bounded size.
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const char* const kExtensions[] = {"fuzz.obj", "fuzz.ply", "fuzz.stl", "fuzz.dae", "fuzz.off"};
  static const cs::fuzz::InputFile files[] = {cs::fuzz::InputFile(kExtensions[0]), cs::fuzz::InputFile(kExtensions[1]),
                                              cs::fuzz::InputFile(kExtensions[2]), cs::fuzz::InputFile(kExtensions[3]),
                                              cs::fuzz::InputFile(kExtensions[4])};
  if (size == 0) return 0;
  size_t k = data[0] % 5;
  switch (data[0]) {
    case 'o': k = 0; break;
    case 'p': k = 1; break;
    case 's': k = 2; break;
    case 'd': k = 3; break;
    case 'f': k = 4; break;
    default: break;
  }
  cs::fuzz::load(files[k].write(data + 1, size - 1));
  return 0;
}
