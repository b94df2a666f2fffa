// libFuzzer target: a BART file (.aff) through loadSceneFile. An include (`i DETAIL NAME`) is read
// relative to the including file, and NAME may be absolute or climb with "..": an input with a '/' in it
// is skipped, so every include names a file in the input's own folder, where the input is the only file
// (a folder, "." or "..", is refused by the loader before it is read).
#include <algorithm>

#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const cs::fuzz::InputFile file("fuzz.aff");
  if (std::find(data, data + size, uint8_t('/')) != data + size) return 0;
  cs::fuzz::load(file.write(data, size));
  return 0;
}
