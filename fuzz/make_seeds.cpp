// Builds the glTF and GLB fuzzers' seed corpora from glTF files on the machine (assimp's test models,
// the broken ones included, and fuzz/seeds/gltf). The fuzzers read no file but their input, so a .gltf
// whose buffers are files beside it gets them inlined as data URIs; every file is also written in the
// other container (a .gltf's first buffer becomes a GLB's BIN chunk, a GLB's BIN chunk a data URI). Text
// that is not JSON is kept as it is (and wrapped as a GLB's JSON chunk). Seeds over MAX_BYTES are dropped.
// Usage: fuzz_seeds GLTF_DIR GLB_DIR MAX_BYTES FILE...
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using Bytes = std::vector<unsigned char>;

constexpr const char* kDataUri = "data:application/octet-stream;base64,";
constexpr const char* kBase64 = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

std::optional<Bytes> readFile(const fs::path& p) {
  std::error_code ec;
  if (!fs::is_regular_file(p, ec)) return std::nullopt;
  std::ifstream in(p, std::ios::binary);
  if (!in) return std::nullopt;
  return Bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::string base64(const Bytes& bytes) {
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const size_t n = std::min<size_t>(3, bytes.size() - i);
    uint32_t v = 0;
    for (size_t k = 0; k < 3; ++k) v = v << 8 | (k < n ? bytes[i + k] : 0u);
    for (size_t k = 0; k < 4; ++k) out += k <= n ? kBase64[(v >> (18 - 6 * k)) & 63] : '=';
  }
  return out;
}

// The bytes of a base64 data URI of any media type; nullopt for anything else.
std::optional<Bytes> dataUriBytes(const std::string& uri) {
  const size_t comma = uri.find(";base64,");
  if (uri.rfind("data:", 0) != 0 || comma == std::string::npos) return std::nullopt;
  Bytes out;
  uint32_t v = 0;
  int bits = 0;
  for (size_t i = comma + 8; i < uri.size() && uri[i] != '='; ++i) {
    const char* c = std::strchr(kBase64, uri[i]);
    if (!c || !*c) return std::nullopt;
    v = v << 6 | uint32_t(c - kBase64);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back((unsigned char)(v >> bits));
    }
  }
  return out;
}

void appendU32(Bytes& b, uint32_t v) {
  for (int i = 0; i < 4; ++i) b.push_back((unsigned char)(v >> (8 * i)));
}

// A GLB 2 container: the JSON chunk padded with spaces, the BIN chunk (if any) with zeros.
Bytes glb(std::string text, const std::optional<Bytes>& bin) {
  while (text.size() % 4) text += ' ';
  Bytes b;
  b.insert(b.end(), {'g', 'l', 'T', 'F'});
  appendU32(b, 2);
  appendU32(b, 0);  // total length, set below
  appendU32(b, uint32_t(text.size()));
  b.insert(b.end(), {'J', 'S', 'O', 'N'});
  b.insert(b.end(), text.begin(), text.end());
  if (bin) {
    Bytes chunk = *bin;
    while (chunk.size() % 4) chunk.push_back(0);
    appendU32(b, uint32_t(chunk.size()));
    b.insert(b.end(), {'B', 'I', 'N', 0});
    b.insert(b.end(), chunk.begin(), chunk.end());
  }
  const uint32_t total = uint32_t(b.size());
  for (int i = 0; i < 4; ++i) b[8 + i] = (unsigned char)(total >> (8 * i));
  return b;
}

uint32_t readU32(const Bytes& b, size_t at) {
  return uint32_t(b[at]) | uint32_t(b[at + 1]) << 8 | uint32_t(b[at + 2]) << 16 | uint32_t(b[at + 3]) << 24;
}

struct Writer {
  fs::path gltfDir, glbDir;
  size_t maxBytes = 0;
  size_t written = 0;

  void put(const fs::path& dir, const std::string& name, const Bytes& bytes) {
    if (bytes.empty() || bytes.size() > maxBytes) return;
    std::ofstream out(dir / name, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    ++written;
  }
  void put(const fs::path& dir, const std::string& name, const std::string& text) {
    put(dir, name, Bytes(text.begin(), text.end()));
  }

  // A parsed document: external buffers beside `from` inlined, then as .gltf, and as .glb with its first
  // buffer's bytes (when it has them) as the BIN chunk.
  void document(json doc, const fs::path& from, const std::string& stem) {
    if (doc.is_object() && doc.contains("buffers") && doc["buffers"].is_array())
      for (json& b : doc["buffers"]) {
        if (!b.is_object() || !b.contains("uri") || !b["uri"].is_string()) continue;
        const std::string uri = b["uri"].get<std::string>();
        if (uri.rfind("data:", 0) == 0) continue;
        if (const auto bytes = readFile(from.parent_path() / uri)) b["uri"] = kDataUri + base64(*bytes);
      }
    put(gltfDir, stem + ".gltf", doc.dump());
    std::optional<Bytes> bin;
    if (doc.is_object() && doc.contains("buffers") && doc["buffers"].is_array() && !doc["buffers"].empty()) {
      json& first = doc["buffers"][0];
      if (first.is_object() && first.contains("uri") && first["uri"].is_string())
        if ((bin = dataUriBytes(first["uri"].get<std::string>()))) first.erase("uri");
    }
    put(glbDir, stem + ".glb", glb(doc.dump(), bin));
  }

  void file(const fs::path& path) {
    const auto bytes = readFile(path);
    if (!bytes) {
      std::fprintf(stderr, "fuzz_seeds: cannot read %s\n", path.c_str());
      return;
    }
    // Seed names keep the folder: assimp's models repeat file names (BoxTextured.gltf).
    std::string stem = (path.parent_path().filename() / path.stem()).string();
    for (char& c : stem)
      if (c == '/') c = '_';
    if (path.extension() == ".glb") {
      put(glbDir, stem + ".glb", *bytes);
      if (bytes->size() < 20 || readU32(*bytes, 12) > bytes->size() - 20) return;
      const size_t jsonEnd = 20 + size_t(readU32(*bytes, 12));
      const json doc = json::parse(bytes->begin() + 20, bytes->begin() + long(jsonEnd), nullptr, false);
      if (doc.is_discarded() || jsonEnd + 8 > bytes->size()) return;
      const size_t binLength = std::min<size_t>(readU32(*bytes, jsonEnd), bytes->size() - jsonEnd - 8);
      Bytes bin(bytes->begin() + long(jsonEnd + 8), bytes->begin() + long(jsonEnd + 8 + binLength));
      json text = doc;
      if (text.is_object() && text.contains("buffers") && text["buffers"].is_array() && !text["buffers"].empty() &&
          text["buffers"][0].is_object() && !text["buffers"][0].contains("uri")) {
        // A data URI holds exactly byteLength bytes; the BIN chunk may be padded past them.
        json& first = text["buffers"][0];
        const auto length = first.find("byteLength");
        if (length != first.end() && length->is_number_unsigned() && length->get<size_t>() <= bin.size())
          bin.resize(length->get<size_t>());
        first["uri"] = kDataUri + base64(bin);
      }
      put(gltfDir, stem + ".gltf", text.dump());
      return;
    }
    const json doc = json::parse(bytes->begin(), bytes->end(), nullptr, false);
    if (doc.is_discarded()) {
      put(gltfDir, stem + ".gltf", *bytes);
      put(glbDir, stem + ".glb", glb(std::string(bytes->begin(), bytes->end()), std::nullopt));
      return;
    }
    document(doc, path, stem);
  }
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: fuzz_seeds GLTF_DIR GLB_DIR MAX_BYTES FILE...\n");
    return 2;
  }
  Writer w{argv[1], argv[2], size_t(std::strtoull(argv[3], nullptr, 10))};
  fs::create_directories(w.gltfDir);
  fs::create_directories(w.glbDir);
  for (int i = 4; i < argc; ++i) w.file(argv[i]);
  std::printf("fuzz_seeds: %zu seeds from %d files\n", w.written, argc - 4);
  return 0;
}
