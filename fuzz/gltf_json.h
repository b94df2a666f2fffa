// The glTF fuzzers' guard: tinygltf reads a buffer whose uri is not a data URI from the file system
// (beside the input, then beside the working directory, absolute paths as they are), so such an input
// could make the fuzzer read any file on the machine. Those inputs are skipped; everything else the
// loader sees, including JSON it refuses.
#pragma once
#include <string>

#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

namespace cs::fuzz {

// True when the JSON text parses and one of its buffers names a file rather than carrying its bytes.
// Text that does not parse, or whose buffers are not objects with string uris, is refused by the loader
// (json::parse, then its schema check) before tinygltf reads a buffer.
inline bool readsExternalBuffer(const std::string& text) {
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) return false;
  const auto buffers = j.find("buffers");
  if (buffers == j.end() || !buffers->is_array()) return false;
  for (const nlohmann::json& b : *buffers) {
    if (!b.is_object()) continue;
    const auto uri = b.find("uri");
    if (uri != b.end() && uri->is_string() && !uri->get<std::string>().empty() &&
        !tinygltf::IsDataURI(uri->get<std::string>()))
      return true;
  }
  return false;
}

}  // namespace cs::fuzz
