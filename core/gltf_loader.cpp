// Loads a glTF 2.0 file (.gltf or .glb) into the flat, world-space triangle soup of scene.h.
// tinygltf parses the file but checks little (wrong JSON types pass silently, accessors are not
// bounds-checked), so every piece we read is validated here first: a JSON type check of the schema,
// then indices, bounds and values. Any problem becomes one cs::Error naming the file.
#include <tiny_gltf.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include "core/animation.h"
#include "core/error.h"
#include "core/input_guard.h"
#include "core/scene.h"

namespace cs {
namespace {

using json = nlohmann::json;

constexpr const char* kMalformed = "the file is malformed; re-export it";

// A JSON value in a message: its text, clipped (a string may be a 6 MB base64 payload).
std::string shownJson(const json& v) { return clipInput(v.dump(-1, ' ', true, json::error_handler_t::replace)); }

// Error and warning text from tinygltf or a JSON parser spans lines; our messages are one line.
std::string oneLine(const std::string& text) {
  std::string out;
  bool space = false;
  for (char c : text) {
    if (c == '\n' || c == '\r') {
      if (!out.empty() && out.back() != ';') out += ';';
      space = true;
    } else if (c == ' ' || c == '\t') {
      space = true;
    } else {
      if (space && !out.empty()) out += ' ';
      space = false;
      out += c;
    }
  }
  while (!out.empty() && (out.back() == ';' || out.back() == ' ')) out.pop_back();
  return out;
}

// ------------------------------------------------------------------------------------------------
// JSON type check against the glTF 2.0 schema (the properties that matter to any reader: types,
// required members, enums of the geometry path). tinygltf ignores a property of the wrong type,
// which would turn a malformed file into a silently different scene.
class SchemaCheck {
 public:
  explicit SchemaCheck(const std::string& path) : path_(path) {}

  void root(const json& j) {
    if (!j.is_object()) bad("the top level", "must be a JSON object");
    common(j, "");
    object(j, "", "asset", true, [&](const json& a, const std::string& w) {
      common(a, w);
      string(a, w, "version", true);
      string(a, w, "minVersion");
      string(a, w, "generator");
      string(a, w, "copyright");
    });
    uint(j, "", "scene");
    stringArray(j, "", "extensionsUsed");
    stringArray(j, "", "extensionsRequired");
    objects(j, "", "scenes", [&](const json& s, const std::string& w) {
      common(s, w);
      uintArray(s, w, "nodes");
    });
    objects(j, "", "nodes", [&](const json& n, const std::string& w) { node(n, w); });
    objects(j, "", "meshes", [&](const json& m, const std::string& w) { mesh(m, w); });
    objects(j, "", "accessors", [&](const json& a, const std::string& w) { accessor(a, w); });
    objects(j, "", "bufferViews", [&](const json& v, const std::string& w) {
      common(v, w);
      uint(v, w, "buffer", true);
      uint(v, w, "byteOffset");
      uint(v, w, "byteLength", true);
      uint(v, w, "byteStride");
      uint(v, w, "target");
    });
    objects(j, "", "buffers", [&](const json& b, const std::string& w) {
      common(b, w);
      string(b, w, "uri");
      uint(b, w, "byteLength", true);
    });
    objects(j, "", "cameras", [&](const json& c, const std::string& w) { camera(c, w); });
    objects(j, "", "materials", [&](const json& m, const std::string& w) { material(m, w); });
    objects(j, "", "textures", [&](const json& t, const std::string& w) {
      common(t, w);
      uint(t, w, "sampler");
      uint(t, w, "source");
    });
    objects(j, "", "images", [&](const json& i, const std::string& w) {
      common(i, w);
      string(i, w, "uri");
      string(i, w, "mimeType");
      uint(i, w, "bufferView");
    });
    objects(j, "", "samplers", [&](const json& s, const std::string& w) {
      common(s, w);
      for (const char* k : {"magFilter", "minFilter", "wrapS", "wrapT"}) uint(s, w, k);
    });
    objects(j, "", "skins", [&](const json& s, const std::string& w) {
      common(s, w);
      uint(s, w, "inverseBindMatrices");
      uint(s, w, "skeleton");
      uintArray(s, w, "joints", true);
    });
    objects(j, "", "animations", [&](const json& a, const std::string& w) {
      common(a, w);
      objects(
          a, w, "channels",
          [&](const json& c, const std::string& wc) {
            common(c, wc);
            uint(c, wc, "sampler", true);
            object(c, wc, "target", true, [&](const json& t, const std::string& wt) {
              common(t, wt);
              uint(t, wt, "node");
              string(t, wt, "path", true);
            });
          },
          true);
      objects(
          a, w, "samplers",
          [&](const json& s, const std::string& ws) {
            common(s, ws);
            uint(s, ws, "input", true);
            uint(s, ws, "output", true);
            string(s, ws, "interpolation");
          },
          true);
    });
    // KHR_lights_punctual: the one extension whose content we read.
    if (const json* ext = find(j, "extensions"); ext && ext->contains("KHR_lights_punctual")) {
      object(*ext, "extensions", "KHR_lights_punctual", false, [&](const json& l, const std::string& w) {
        objects(l, w, "lights", [&](const json& light, const std::string& wl) {
          common(light, wl);
          oneOf(light, wl, "type", {"point", "spot", "directional"}, true);
          numberArray(light, wl, "color", 3);
          number(light, wl, "intensity");
          number(light, wl, "range");
          object(light, wl, "spot", false, [&](const json& s, const std::string& ws) {
            common(s, ws);
            number(s, ws, "innerConeAngle");
            number(s, ws, "outerConeAngle");
          });
        });
      });
    }
  }

 private:
  const std::string& path_;

  [[noreturn]] void bad(const std::string& where, const std::string& must) const {
    throw Error(where + " " + must, path_, kMalformed);
  }
  static std::string at(const std::string& where, const std::string& key) {
    return where.empty() ? key : where + "." + key;
  }
  static const json* find(const json& o, const char* key) {
    auto it = o.find(key);
    return it == o.end() ? nullptr : &*it;
  }
  const json* get(const json& o, const std::string& where, const char* key, bool required) const {
    const json* v = find(o, key);
    if (!v && required) bad(at(where, key), "is required but missing");
    return v;
  }
  // A non-negative integer below 2^31, written as one or as a whole float (the schema's integers).
  // tinygltf keeps indices in an int: 2^32 read as 0 and referred to element 0 silently. Sizes,
  // offsets and counts fit too, as no scene file is over 2 GiB (kMaxSceneFileBytes).
  static bool isUint(const json& v) {
    constexpr double kLimit = 2147483647.0;
    if (v.is_number_unsigned()) return double(v.get<uint64_t>()) <= kLimit;
    if (v.is_number_integer()) return v.get<int64_t>() >= 0 && double(v.get<int64_t>()) <= kLimit;
    if (v.is_number_float()) {
      const double d = v.get<double>();
      return d >= 0 && d == std::floor(d) && d <= kLimit;
    }
    return false;
  }

  void uint(const json& o, const std::string& w, const char* key, bool required = false) const {
    if (const json* v = get(o, w, key, required); v && !isUint(*v))
      bad(at(w, key), "must be a non-negative integer below 2^31, not " + shownJson(*v));
  }
  void number(const json& o, const std::string& w, const char* key, bool required = false) const {
    if (const json* v = get(o, w, key, required); v && !v->is_number())
      bad(at(w, key), "must be a number, not " + shownJson(*v));
  }
  void string(const json& o, const std::string& w, const char* key, bool required = false) const {
    if (const json* v = get(o, w, key, required); v && !v->is_string())
      bad(at(w, key), "must be a string, not " + shownJson(*v));
  }
  void boolean(const json& o, const std::string& w, const char* key) const {
    if (const json* v = get(o, w, key, false); v && !v->is_boolean())
      bad(at(w, key), "must be true or false, not " + shownJson(*v));
  }
  void oneOf(const json& o, const std::string& w, const char* key, std::initializer_list<const char*> values,
             bool required = false) const {
    const json* v = get(o, w, key, required);
    if (!v) return;
    if (v->is_string())
      for (const char* s : values)
        if (*v == s) return;
    std::string list;
    for (const char* s : values) list += (list.empty() ? "\"" : ", \"") + std::string(s) + "\"";
    bad(at(w, key), "must be one of " + list + ", not " + shownJson(*v));
  }
  void uintOneOf(const json& o, const std::string& w, const char* key, std::initializer_list<int> values,
                 bool required = false) const {
    const json* v = get(o, w, key, required);
    if (!v) return;
    if (isUint(*v))
      for (int s : values)
        if (v->get<double>() == s) return;
    std::string list;
    for (int s : values) list += (list.empty() ? "" : ", ") + std::to_string(s);
    bad(at(w, key), "must be one of " + list + ", not " + shownJson(*v));
  }
  // `exact` = 0: any length of at least `minItems`.
  void numberArray(const json& o, const std::string& w, const char* key, size_t exact = 0, size_t minItems = 0,
                   bool required = false) const {
    const json* v = get(o, w, key, required);
    if (!v) return;
    bool ok = v->is_array() && (exact == 0 ? v->size() >= minItems : v->size() == exact);
    if (ok)
      for (const json& e : *v) ok = ok && e.is_number();
    if (!ok)
      bad(at(w, key), exact ? "must be an array of " + std::to_string(exact) + " numbers"
                            : "must be an array of at least " + std::to_string(minItems) + " numbers");
  }
  void uintArray(const json& o, const std::string& w, const char* key, bool required = false) const {
    const json* v = get(o, w, key, required);
    if (!v) return;
    bool ok = v->is_array();
    if (ok)
      for (const json& e : *v) ok = ok && isUint(e);
    if (!ok) bad(at(w, key), "must be an array of non-negative integers");
  }
  void stringArray(const json& o, const std::string& w, const char* key) const {
    const json* v = get(o, w, key, false);
    if (!v) return;
    bool ok = v->is_array();
    if (ok)
      for (const json& e : *v) ok = ok && e.is_string();
    if (!ok) bad(at(w, key), "must be an array of strings");
  }
  template <class F>
  void object(const json& o, const std::string& w, const char* key, bool required, F&& fn) const {
    const json* v = get(o, w, key, required);
    if (!v) return;
    if (!v->is_object()) bad(at(w, key), "must be a JSON object, not " + shownJson(*v));
    fn(*v, at(w, key));
  }
  template <class F>
  void objects(const json& o, const std::string& w, const char* key, F&& fn, bool required = false) const {
    const json* v = get(o, w, key, required);
    if (!v) return;
    if (!v->is_array()) bad(at(w, key), "must be an array");
    for (size_t i = 0; i < v->size(); ++i) {
      const std::string wi = at(w, key) + "[" + std::to_string(i) + "]";
      if (!(*v)[i].is_object()) bad(wi, "must be a JSON object, not " + shownJson((*v)[i]));
      fn((*v)[i], wi);
    }
  }
  // glTFProperty and glTFChildOfRootProperty: `name` is a string, `extensions` an object of objects.
  void common(const json& o, const std::string& w) const {
    string(o, w, "name");
    object(o, w, "extensions", false, [&](const json& e, const std::string& we) {
      for (auto it = e.begin(); it != e.end(); ++it)
        if (!it.value().is_object()) bad(we + "." + clipInput(it.key()), "must be a JSON object, not " + shownJson(it.value()));
    });
  }

  void node(const json& n, const std::string& w) const {
    common(n, w);
    uint(n, w, "camera");
    uint(n, w, "mesh");
    uint(n, w, "skin");
    uintArray(n, w, "children");
    numberArray(n, w, "matrix", 16);
    numberArray(n, w, "rotation", 4);
    numberArray(n, w, "scale", 3);
    numberArray(n, w, "translation", 3);
    numberArray(n, w, "weights", 0, 1);
    if (const json* e = find(n, "extensions"); e && e->contains("KHR_lights_punctual"))
      uint((*e)["KHR_lights_punctual"], at(w, "extensions.KHR_lights_punctual"), "light", true);
  }
  void mesh(const json& m, const std::string& w) const {
    common(m, w);
    numberArray(m, w, "weights", 0, 1);
    objects(
        m, w, "primitives",
        [&](const json& p, const std::string& wp) {
          common(p, wp);
          object(p, wp, "attributes", true, [&](const json& a, const std::string& wa) {
            for (auto it = a.begin(); it != a.end(); ++it)
              if (!isUint(it.value())) bad(wa + "." + clipInput(it.key()), "must be an accessor index, not " + shownJson(it.value()));
          });
          uint(p, wp, "indices");
          uint(p, wp, "material");
          uintOneOf(p, wp, "mode", {0, 1, 2, 3, 4, 5, 6});
          objects(p, wp, "targets", [&](const json& t, const std::string& wt) {
            for (auto it = t.begin(); it != t.end(); ++it)
              if (!isUint(it.value())) bad(wt + "." + clipInput(it.key()), "must be an accessor index, not " + shownJson(it.value()));
          });
        },
        true);
  }
  void accessor(const json& a, const std::string& w) const {
    common(a, w);
    uint(a, w, "bufferView");
    uint(a, w, "byteOffset");
    uintOneOf(a, w, "componentType", {5120, 5121, 5122, 5123, 5125, 5126}, true);
    boolean(a, w, "normalized");
    uint(a, w, "count", true);
    oneOf(a, w, "type", {"SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4"}, true);
    numberArray(a, w, "max", 0, 1);
    numberArray(a, w, "min", 0, 1);
    object(a, w, "sparse", false, [&](const json& s, const std::string& ws) {
      common(s, ws);
      uint(s, ws, "count", true);
      object(s, ws, "indices", true, [&](const json& i, const std::string& wi) {
        common(i, wi);
        uint(i, wi, "bufferView", true);
        uint(i, wi, "byteOffset");
        uintOneOf(i, wi, "componentType", {5121, 5123, 5125}, true);
      });
      object(s, ws, "values", true, [&](const json& v, const std::string& wv) {
        common(v, wv);
        uint(v, wv, "bufferView", true);
        uint(v, wv, "byteOffset");
      });
    });
  }
  void camera(const json& c, const std::string& w) const {
    common(c, w);
    oneOf(c, w, "type", {"perspective", "orthographic"}, true);
    const bool persp = c["type"] == "perspective";
    object(c, w, "perspective", persp, [&](const json& p, const std::string& wp) {
      common(p, wp);
      number(p, wp, "aspectRatio");
      number(p, wp, "yfov", true);
      number(p, wp, "zfar");
      number(p, wp, "znear", true);
    });
    object(c, w, "orthographic", !persp, [&](const json& o, const std::string& wo) {
      common(o, wo);
      for (const char* k : {"xmag", "ymag", "zfar", "znear"}) number(o, wo, k, true);
    });
  }
  void textureInfo(const json& o, const std::string& w, const char* key, const char* factor = nullptr) const {
    object(o, w, key, false, [&](const json& t, const std::string& wt) {
      common(t, wt);
      uint(t, wt, "index", true);
      uint(t, wt, "texCoord");
      if (factor) number(t, wt, factor);
    });
  }
  void material(const json& m, const std::string& w) const {
    common(m, w);
    object(m, w, "pbrMetallicRoughness", false, [&](const json& p, const std::string& wp) {
      common(p, wp);
      numberArray(p, wp, "baseColorFactor", 4);
      textureInfo(p, wp, "baseColorTexture");
      number(p, wp, "metallicFactor");
      number(p, wp, "roughnessFactor");
      textureInfo(p, wp, "metallicRoughnessTexture");
    });
    textureInfo(m, w, "normalTexture", "scale");
    textureInfo(m, w, "occlusionTexture", "strength");
    textureInfo(m, w, "emissiveTexture");
    numberArray(m, w, "emissiveFactor", 3);
    oneOf(m, w, "alphaMode", {"OPAQUE", "MASK", "BLEND"});
    number(m, w, "alphaCutoff");
    boolean(m, w, "doubleSided");
  }
};

// Required extensions we may accept: the one we implement, and those that only change appearance
// (we model no materials or textures: docs/ARCHITECTURE.md, "Contracts"). Anything else in
// extensionsRequired may change the geometry (Draco, meshopt, quantization, instancing), and the spec
// says a loader must then refuse.
bool harmlessRequiredExtension(const std::string& name) {
  for (const char* prefix : {"KHR_materials_", "KHR_texture_", "EXT_texture_", "KHR_technique"})
    if (name.starts_with(prefix)) return true;
  return name == "KHR_lights_punctual" || name == "MSFT_texture_dds" || name == "KHR_xmp_json_ld";
}

// ------------------------------------------------------------------------------------------------
// The glTF file on disk: read, split (GLB), JSON-checked, then handed to tinygltf.

std::vector<unsigned char> readFile(const std::string& path) {
  const std::string text = readSceneBytes(path);
  if (text.empty()) throw Error("the file is empty", path, kMalformed);
  return std::vector<unsigned char>(text.begin(), text.end());
}

// tinygltf's file access for external buffers and images, held to the scene file's rules (a regular file
// of bounded size, never a FIFO: tinygltf's own existence check opens the file and would block on one).
// The first refusal is kept and reported as it is.
struct ExternalFiles {
  std::string scene;  // the .gltf/.glb naming them
  std::optional<Error> refused;
  uint64_t bytes = 0;  // over every external file: no more than one scene file may hold
};

bool externalExists(const std::string& path, void*) {
  std::error_code ec;
  return std::filesystem::exists(std::filesystem::symlink_status(path, ec)) && !ec;
}

std::string externalPath(const std::string& path, void*) { return path; }  // no shell expansion

bool externalRead(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
  auto& files = *static_cast<ExternalFiles*>(user);
  try {
    const std::string text =
        readSceneBytes(path, files.scene, kMaxSceneFileBytes - std::min(files.bytes, kMaxSceneFileBytes));
    files.bytes += text.size();
    out->assign(text.begin(), text.end());
    return true;
  } catch (const Error& e) {
    if (!files.refused) files.refused = e;
    if (err) *err += "refused";
    return false;
  }
}

bool externalWrite(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "coneshadow writes no glTF files";
  return false;
}

uint32_t readU32(const unsigned char* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

// The JSON chunk of a GLB container (header and chunk 0 validated).
std::string glbJson(const std::vector<unsigned char>& b, const std::string& path) {
  if (b.size() < 20 || std::memcmp(b.data(), "glTF", 4) != 0)
    throw Error("not a binary glTF file (no 'glTF' magic)", path, kMalformed);
  if (readU32(&b[4]) != 2)
    throw Error("GLB container version " + std::to_string(readU32(&b[4])) + ", expected 2", path, kMalformed);
  if (readU32(&b[8]) != b.size())  // shorter: bytes past the container; longer: a cut file
    throw Error("GLB header length says " + std::to_string(readU32(&b[8])) + " bytes, the file has " +
                    std::to_string(b.size()),
                path, kMalformed);
  const uint32_t jsonLength = readU32(&b[12]);
  if (std::memcmp(&b[16], "JSON", 4) != 0) throw Error("the first GLB chunk is not JSON", path, kMalformed);
  if (jsonLength > b.size() - 20) throw Error("the GLB JSON chunk runs past the end of the file", path, kMalformed);
  return std::string(reinterpret_cast<const char*>(&b[20]), jsonLength);
}

bool noImageDecode(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int,
                   void*) {
  return true;  // we model no textures: leave image bytes undecoded
}

// How deep the JSON value nests (a scalar: 0), walked without recursion; stops counting past `limit`.
// tinygltf copies "extras" recursively, one stack frame a level: a small file nesting 20,000 levels
// would overflow the stack, so such a file is refused before it gets there.
constexpr size_t kMaxJsonDepth = 128;  // a glTF's own structure needs about 8
size_t jsonDepth(const json& root, size_t limit) {
  std::vector<std::pair<const json*, size_t>> stack{{&root, 0}};
  size_t deepest = 0;
  while (!stack.empty()) {
    auto [v, d] = stack.back();
    stack.pop_back();
    if (!v->is_structured() || v->empty()) continue;
    deepest = std::max(deepest, d + 1);
    if (deepest > limit) return deepest;
    for (const json& e : *v) stack.push_back({&e, d + 1});
  }
  return deepest;
}

// Every number written with a fraction of zero (1.0, 12.0e0) becomes the integer it equals, so that
// tinygltf, which reads an integer property only from a JSON integer (it skipped "indices": 1.0 and read
// "byteOffset": 12.0 as 0), reads what the schema check validated: glTF's schema counts 1.0 as an
// integer. Number properties take integers as well, so the rest of the file reads the same. Values of
// 2^53 and more keep their form (no integer property is that large). Returns whether any changed.
bool integralNumbersAsIntegers(json& root) {
  bool changed = false;
  std::vector<json*> stack{&root};
  while (!stack.empty()) {
    json* v = stack.back();
    stack.pop_back();
    if (v->is_structured()) {
      for (json& e : *v) stack.push_back(&e);
    } else if (v->is_number_float()) {
      const double d = v->get<double>();
      if (d == std::floor(d) && std::abs(d) < 9.007199254740992e15) {
        *v = d >= 0 ? json(uint64_t(d)) : json(int64_t(d));
        changed = true;
      }
    }
  }
  return changed;
}

// The GLB `bytes` with its JSON chunk replaced by `text` (padded with spaces to 4 bytes, as the
// container wants), the chunks after it unchanged.
std::vector<unsigned char> withGlbJson(const std::vector<unsigned char>& bytes, std::string text) {
  while (text.size() % 4) text += ' ';
  const uint32_t oldLength = readU32(&bytes[12]);
  const size_t restAt = std::min<size_t>(bytes.size(), 20 + size_t(oldLength));
  std::vector<unsigned char> out(bytes.begin(), bytes.begin() + 12);
  auto put = [&](uint32_t v) {
    for (int k = 0; k < 4; ++k) out.push_back(static_cast<unsigned char>(v >> (8 * k)));
  };
  put(uint32_t(text.size()));
  out.insert(out.end(), {'J', 'S', 'O', 'N'});
  out.insert(out.end(), text.begin(), text.end());
  out.insert(out.end(), bytes.begin() + restAt, bytes.end());
  const uint32_t total = uint32_t(out.size());
  for (int k = 0; k < 4; ++k) out[8 + k] = static_cast<unsigned char>(total >> (8 * k));
  return out;
}

tinygltf::Model parseFile(const std::string& path, std::ostream& warn) {
  const std::string ext = [&] {
    std::string e = std::filesystem::path(path).extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return e;
  }();
  if (ext != ".gltf" && ext != ".glb")
    throw Error("unknown file type '" + ext + "'", path, "the glTF loader reads .gltf and .glb files");
  const bool binary = ext == ".glb";

  std::vector<unsigned char> bytes = readFile(path);
  if (bytes.size() > std::numeric_limits<unsigned int>::max()) throw Error("the file is larger than 4 GiB", path);
  std::string text = binary ? glbJson(bytes, path) : std::string(bytes.begin(), bytes.end());
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    throw Error("not valid JSON: " + oneLineClipped(e.what(), 160), path, kMalformed);
  }
  // The version first: a glTF 1.0 file differs in structure, and would otherwise read as malformed.
  if (j.is_object() && j.contains("asset") && j["asset"].is_object() && j["asset"].contains("version") &&
      j["asset"]["version"].is_string()) {
    const std::string version = j["asset"]["version"].get<std::string>();
    if (version.rfind("1.", 0) == 0 || version == "1")
      throw Error("this is a glTF " + clipInput(version) + " file; coneshadow reads glTF 2.0", path,
                  "convert it, e.g. `assimp export in.gltf out.glb`");
    if (version.rfind("2.", 0) != 0)
      throw Error("glTF version " + quoteInput(version) + " is not one coneshadow knows (it reads 2.x)", path,
                  "re-export it as glTF 2.0");
  }
  // minVersion: the oldest reader the file allows; one newer than 2.0 uses what a 2.0 reader misreads.
  if (j.is_object() && j.contains("asset") && j["asset"].is_object() && j["asset"].contains("minVersion") &&
      j["asset"]["minVersion"].is_string() && j["asset"]["minVersion"] != "2.0")
    throw Error("asset.minVersion is " + quoteInput(j["asset"]["minVersion"].get<std::string>()) +
                    "; coneshadow reads glTF 2.0 only",
                path, "re-export it for glTF 2.0");
  if (j.is_object())
    for (auto it = j.begin(); it != j.end(); ++it)
      if (jsonDepth(it.value(), kMaxJsonDepth - 1) > kMaxJsonDepth - 1)
        throw Error("the JSON nests more than " + std::to_string(kMaxJsonDepth) + " levels deep (under \"" +
                        clipInput(it.key()) + "\")",
                    path, "a glTF needs about 8 levels; remove the deeply nested extras or extensions");
  SchemaCheck(path).root(j);
  if (const auto it = j.find("extensionsRequired"); it != j.end())
    for (const json& e : *it)
      if (!harmlessRequiredExtension(e.get<std::string>()))
        throw Error("requires the extension " + clipInput(e.get<std::string>()) + ", which coneshadow does not implement", path,
                    "re-export the file without it");

  if (integralNumbersAsIntegers(j)) {  // what tinygltf reads is what was validated
    text = j.dump();
    if (binary) bytes = withGlbJson(bytes, text);
  }

  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(noImageDecode, nullptr);
  ExternalFiles external{path, std::nullopt, 0};
  loader.SetFsCallbacks({externalExists, externalPath, externalRead, externalWrite, &external});
  const std::optional<Error>& fileRefused = external.refused;
  tinygltf::Model model;
  std::string err, warnText;
  std::string baseDir = std::filesystem::path(path).parent_path().string();
  if (baseDir.empty()) baseDir = ".";
  const bool ok = binary ? loader.LoadBinaryFromMemory(&model, &err, &warnText, bytes.data(),
                                                       static_cast<unsigned int>(bytes.size()), baseDir)
                         : loader.LoadASCIIFromString(&model, &err, &warnText, text.data(),
                                                      static_cast<unsigned int>(text.size()), baseDir);
  // tinygltf sometimes reports an error yet returns true; either way the file is not usable.
  if (fileRefused) throw *fileRefused;
  if (!ok || !err.empty())
    throw Error(oneLineClipped(oneLine(err.empty() ? "tinygltf could not load it" : err), 200), path, kMalformed);
  if (!oneLine(warnText).empty()) warn << path << ": " << oneLineClipped(oneLine(warnText), 200) << "\n";
  return model;
}

// ------------------------------------------------------------------------------------------------
// Accessors: validated once, read with their byteStride, sparse substitution included.

size_t componentSize(int componentType) {
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
  }
}

size_t componentCount(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4:
    case TINYGLTF_TYPE_MAT2: return 4;
    case TINYGLTF_TYPE_MAT3: return 9;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
  }
}

uint32_t readIndex(const unsigned char* p, int componentType) {
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return *p;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      uint16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    default: {
      uint32_t v;
      std::memcpy(&v, p, 4);
      return v;
    }
  }
}

bool isIndexType(int componentType) {
  return componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
         componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ||
         componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
}

// True when [offset, offset + count * stride - stride + elementSize) fits in `length` (no overflow).
bool fits(uint64_t offset, uint64_t count, uint64_t stride, uint64_t elementSize, uint64_t length) {
  if (count == 0) return offset <= length;
  if (offset > length || elementSize > length - offset) return false;
  const uint64_t room = length - offset - elementSize;
  return stride == 0 || (count - 1) <= room / stride;
}

class Loader {
 public:
  Loader(const std::string& path, std::ostream& warn) : path_(path), warn_(warn), model_(parseFile(path, warn)) {}

  Scene load();
  // load() keeping what the animation needs: node hierarchy, vertex ranges, channels.
  AnimatedScene loadAnimated();

 private:
  struct Primitive {  // one decoded mesh primitive, object space, referenced vertices only
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals;  // empty: use flat normals
    std::vector<uint32_t> triangles;
  };
  struct CameraUse {
    int camera;
    glm::dmat4 world;
  };

  const std::string& path_;
  std::ostream& warn_;
  tinygltf::Model model_;
  Scene scene_;
  std::map<int, std::vector<Primitive>> meshCache_;  // meshes are decoded once, instanced many times
  std::vector<CameraUse> cameraUses_;
  size_t skippedNonTriangle_ = 0, repairedNormals_ = 0, skippedOrtho_ = 0, skippedLights_ = 0, skinned_ = 0;
  AnimatedScene* anim_ = nullptr;  // set by loadAnimated(): record each mesh instance's node and local vertices

  [[noreturn]] void bad(const std::string& what) const { throw Error(what, path_, kMalformed); }

  void validateBuffers() const;
  void validateAccessors() const;
  void validateReferences() const;
  std::vector<int> sceneRoots() const;
  glm::dmat4 localMatrix(int node) const;
  void traverse(const std::vector<int>& roots);
  void addMeshInstance(int mesh, const glm::dmat4& world, int node);
  void readAnimations();
  std::vector<double> readScalars(int accessor, const std::string& what) const;
  Primitive decode(int mesh, int prim);
  std::vector<glm::vec3> readVec3(int accessor, const char* what) const;
  std::vector<uint32_t> readIndices(int accessor, size_t vertexCount) const;
  template <class Fn>
  void forEachElement(const tinygltf::Accessor& a, Fn&& fn) const;
  void addCameras();
  void addLight(int light, const glm::dmat4& world);
  std::string uniqueName(std::string name, bool camera) const;
  std::string nodeName(int n) const {
    const std::string& name = model_.nodes[size_t(n)].name;
    return name.empty() ? "" : " (" + quoteInput(name) + ")";
  }
};

void Loader::validateBuffers() const {
  for (size_t i = 0; i < model_.bufferViews.size(); ++i) {
    const tinygltf::BufferView& v = model_.bufferViews[i];
    const std::string name = "buffer view " + std::to_string(i);
    if (v.buffer < 0 || size_t(v.buffer) >= model_.buffers.size())
      bad(name + " refers to buffer " + std::to_string(v.buffer) + ", which does not exist");
    const size_t size = model_.buffers[size_t(v.buffer)].data.size();
    if (v.byteLength == 0) bad(name + " has byteLength 0");
    if (!fits(v.byteOffset, 1, 0, v.byteLength, size))
      bad(name + " (bytes " + std::to_string(v.byteOffset) + " + " + std::to_string(v.byteLength) +
          ") reads past the end of buffer " + std::to_string(v.buffer) + " (" + std::to_string(size) + " bytes)");
    if (v.byteStride != 0 && (v.byteStride < 4 || v.byteStride > 252 || v.byteStride % 4 != 0))
      bad(name + " has byteStride " + std::to_string(v.byteStride) + " (must be a multiple of 4 in [4, 252])");
  }
}

void Loader::validateAccessors() const {
  // An accessor without a buffer view is zeros the file does not store (sparse values may replace some): no
  // more of them than the file's buffers hold bytes, or a few bytes of JSON could ask for terabytes.
  size_t bufferBytes = 0;
  for (const tinygltf::Buffer& b : model_.buffers) bufferBytes += b.data.size();
  for (size_t i = 0; i < model_.accessors.size(); ++i) {
    const tinygltf::Accessor& a = model_.accessors[i];
    const std::string name = "accessor " + std::to_string(i);
    const size_t elementSize = componentSize(a.componentType) * componentCount(a.type);
    if (elementSize == 0) bad(name + " has an unknown componentType or type");
    if (a.count == 0) bad(name + " has count 0");
    if (a.bufferView < 0 && a.count > bufferBytes / elementSize)
      bad(name + " has no buffer view and " + std::to_string(a.count) + " elements of " + std::to_string(elementSize) +
          " bytes, more than the file's buffers hold (" + std::to_string(bufferBytes) + " bytes)");
    if (a.bufferView >= 0) {
      if (size_t(a.bufferView) >= model_.bufferViews.size())
        bad(name + " refers to buffer view " + std::to_string(a.bufferView) + ", which does not exist");
      const tinygltf::BufferView& v = model_.bufferViews[size_t(a.bufferView)];
      const size_t stride = v.byteStride ? v.byteStride : elementSize;
      if (stride < elementSize)
        bad(name + " has elements of " + std::to_string(elementSize) + " bytes, longer than the byteStride " +
            std::to_string(stride) + " of buffer view " + std::to_string(a.bufferView));
      if (!fits(a.byteOffset, a.count, stride, elementSize, v.byteLength))
        bad(name + " (" + std::to_string(a.count) + " elements) reads past the end of buffer view " +
            std::to_string(a.bufferView));
    }
    if (a.sparse.isSparse) {
      const auto& s = a.sparse;
      if (s.count <= 0 || size_t(s.count) > a.count)
        bad(name + " has a sparse count of " + std::to_string(s.count) + " for " + std::to_string(a.count) +
            " elements");
      auto checkView = [&](int view, int offset, size_t size, const char* what) {
        if (view < 0 || size_t(view) >= model_.bufferViews.size())
          bad(name + " sparse " + what + " refer to buffer view " + std::to_string(view) + ", which does not exist");
        if (offset < 0 ||
            !fits(uint64_t(offset), uint64_t(s.count), size, size, model_.bufferViews[size_t(view)].byteLength))
          bad(name + " sparse " + what + " read past the end of buffer view " + std::to_string(view));
      };
      if (!isIndexType(s.indices.componentType)) bad(name + " sparse indices are not unsigned integers");
      checkView(s.indices.bufferView, s.indices.byteOffset, componentSize(s.indices.componentType), "indices");
      checkView(s.values.bufferView, s.values.byteOffset, elementSize, "values");
    }
  }
}

void Loader::validateReferences() const {
  auto in = [](int i, size_t n) { return i >= 0 && size_t(i) < n; };
  for (size_t m = 0; m < model_.meshes.size(); ++m)
    for (size_t p = 0; p < model_.meshes[m].primitives.size(); ++p) {
      const tinygltf::Primitive& prim = model_.meshes[m].primitives[p];
      const std::string name = "mesh " + std::to_string(m) + " primitive " + std::to_string(p);
      for (const auto& [attribute, accessor] : prim.attributes)
        if (!in(accessor, model_.accessors.size()))
          bad(name + " attribute " + attribute + " refers to accessor " + std::to_string(accessor) +
              ", which does not exist");
      if (prim.indices != -1 && !in(prim.indices, model_.accessors.size()))
        bad(name + " indices refer to accessor " + std::to_string(prim.indices) + ", which does not exist");
    }
  for (size_t n = 0; n < model_.nodes.size(); ++n) {
    const tinygltf::Node& node = model_.nodes[n];
    const std::string name = "node " + std::to_string(n);
    if (node.mesh != -1 && !in(node.mesh, model_.meshes.size()))
      bad(name + " refers to mesh " + std::to_string(node.mesh) + ", which does not exist");
    if (node.camera != -1 && !in(node.camera, model_.cameras.size()))
      bad(name + " refers to camera " + std::to_string(node.camera) + ", which does not exist");
    if (node.skin != -1 && !in(node.skin, model_.skins.size()))
      bad(name + " refers to skin " + std::to_string(node.skin) + ", which does not exist");
    for (int c : node.children)
      if (!in(c, model_.nodes.size())) bad(name + " has child " + std::to_string(c) + ", which does not exist");
    if (auto it = node.extensions.find("KHR_lights_punctual"); it != node.extensions.end()) {
      const int light = it->second.Get("light").GetNumberAsInt();
      if (!in(light, model_.lights.size()))
        bad(name + " refers to light " + std::to_string(light) + ", which does not exist");
    }
  }
  for (size_t s = 0; s < model_.scenes.size(); ++s)
    for (int n : model_.scenes[s].nodes)
      if (!in(n, model_.nodes.size()))
        bad("scene " + std::to_string(s) + " lists node " + std::to_string(n) + ", which does not exist");
  if (model_.defaultScene != -1 && !in(model_.defaultScene, model_.scenes.size()))
    bad("the default scene " + std::to_string(model_.defaultScene) + " does not exist (the file has " +
        std::to_string(model_.scenes.size()) + " scenes)");
}

// The roots to draw, after checking that the nodes form disjoint trees (the glTF rule): a cycle would
// recurse forever and a shared child would be drawn twice.
std::vector<int> Loader::sceneRoots() const {
  const size_t n = model_.nodes.size();
  std::vector<int> parent(n, -1);
  for (size_t p = 0; p < n; ++p)
    for (int c : model_.nodes[p].children) {
      if (parent[size_t(c)] != -1)
        bad("node " + std::to_string(c) + " is a child of both node " + std::to_string(parent[size_t(c)]) +
            " and node " + std::to_string(p) + " (glTF nodes form trees)");
      parent[size_t(c)] = int(p);
    }
  // With one parent each, a cycle is a chain of parents that comes back to its start.
  std::vector<char> state(n, 0);  // 0 unvisited, 1 on the current chain, 2 known to reach a root
  for (size_t start = 0; start < n; ++start) {
    std::vector<size_t> chain;
    size_t at = start;
    while (state[at] == 0) {
      state[at] = 1;
      chain.push_back(at);
      if (parent[at] == -1) break;
      at = size_t(parent[at]);
    }
    if (state[at] == 1 && parent[at] != -1) bad("the node hierarchy has a cycle through node " + std::to_string(at));
    for (size_t c : chain) state[c] = 2;
  }

  std::vector<int> roots;
  if (model_.scenes.empty()) {
    // No scenes: the spec leaves drawing to the application; we draw every root node.
    for (size_t i = 0; i < n; ++i)
      if (parent[i] == -1) roots.push_back(int(i));
    return roots;
  }
  const size_t s = model_.defaultScene >= 0 ? size_t(model_.defaultScene) : 0;
  for (int r : model_.scenes[s].nodes) {
    if (std::find(roots.begin(), roots.end(), r) != roots.end())
      bad("scene " + std::to_string(s) + " lists node " + std::to_string(r) + nodeName(r) +
          " twice among its roots (its geometry would be drawn twice)");
    if (parent[size_t(r)] != -1)
      bad("scene " + std::to_string(s) + " lists node " + std::to_string(r) + " as a root, but it is a child of node " +
          std::to_string(parent[size_t(r)]));
    roots.push_back(r);
  }
  return roots;
}

bool finite(const glm::dmat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

glm::dmat4 Loader::localMatrix(int n) const {
  const tinygltf::Node& node = model_.nodes[size_t(n)];
  glm::dmat4 m(1.0);
  if (node.matrix.size() == 16) {
    for (int i = 0; i < 16; ++i) m[i / 4][i % 4] = node.matrix[size_t(i)];  // column-major, as glTF
    // An affine matrix (glTF wants one decomposable to TRS): a projective one or w = 0 maps points to
    // infinity or divides by what the flattening ignores.
    const glm::dvec4 row(m[0][3], m[1][3], m[2][3], m[3][3]);
    if (std::abs(row.x) > 1e-6 || std::abs(row.y) > 1e-6 || std::abs(row.z) > 1e-6 || !(std::abs(row.w - 1) <= 1e-6)) {
      char text[96];
      std::snprintf(text, sizeof text, "(%g, %g, %g, %g)", row.x, row.y, row.z, row.w);
      bad("node " + std::to_string(n) + nodeName(n) + " has a matrix whose last row is " + text +
          ", not (0, 0, 0, 1): projective transforms are not glTF");
    }
  } else {
    if (node.translation.size() == 3)
      m = glm::translate(m, glm::dvec3(node.translation[0], node.translation[1], node.translation[2]));
    if (node.rotation.size() == 4) {
      glm::dquat q(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);  // glTF: x, y, z, w
      const double len = glm::length(q);
      if (!(len > 0) || !std::isfinite(len)) bad("node " + std::to_string(n) + " has a zero or non-finite rotation");
      m = m * glm::mat4_cast(q / len);  // the spec wants unit quaternions; tolerate rounding
    }
    if (node.scale.size() == 3) m = glm::scale(m, glm::dvec3(node.scale[0], node.scale[1], node.scale[2]));
  }
  if (!finite(m)) bad("node " + std::to_string(n) + " has a non-finite transform");
  return m;
}

// Depth-first, children in file order: the order in which cameras are listed.
void Loader::traverse(const std::vector<int>& roots) {
  std::vector<std::pair<int, glm::dmat4>> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.emplace_back(*it, glm::dmat4(1.0));
  while (!stack.empty()) {
    const auto [n, parentWorld] = stack.back();
    stack.pop_back();
    const glm::dmat4 world = parentWorld * localMatrix(n);
    if (!finite(world)) bad("node " + std::to_string(n) + " has a world transform that overflows");
    const tinygltf::Node& node = model_.nodes[size_t(n)];
    if (node.mesh != -1) {
      if (node.skin != -1) ++skinned_;
      addMeshInstance(node.mesh, world, n);
    }
    if (node.camera != -1) cameraUses_.push_back({node.camera, world});
    if (auto it = node.extensions.find("KHR_lights_punctual"); it != node.extensions.end())
      addLight(it->second.Get("light").GetNumberAsInt(), world);
    for (auto c = node.children.rbegin(); c != node.children.rend(); ++c) stack.emplace_back(*c, world);
  }
}

template <class Fn>
void Loader::forEachElement(const tinygltf::Accessor& a, Fn&& fn) const {
  const size_t elementSize = componentSize(a.componentType) * componentCount(a.type);
  if (a.bufferView >= 0) {
    const tinygltf::BufferView& v = model_.bufferViews[size_t(a.bufferView)];
    const unsigned char* base = model_.buffers[size_t(v.buffer)].data.data() + v.byteOffset + a.byteOffset;
    const size_t stride = v.byteStride ? v.byteStride : elementSize;
    for (size_t i = 0; i < a.count; ++i) fn(i, base + i * stride);
  } else {
    static const unsigned char zeros[64] = {};  // no buffer view: all zeros (glTF 2.0 §3.6.2.3)
    for (size_t i = 0; i < a.count; ++i) fn(i, zeros);
  }
  if (a.sparse.isSparse) {
    const auto& s = a.sparse;
    const tinygltf::BufferView& iv = model_.bufferViews[size_t(s.indices.bufferView)];
    const tinygltf::BufferView& vv = model_.bufferViews[size_t(s.values.bufferView)];
    const unsigned char* indices =
        model_.buffers[size_t(iv.buffer)].data.data() + iv.byteOffset + size_t(s.indices.byteOffset);
    const unsigned char* values =
        model_.buffers[size_t(vv.buffer)].data.data() + vv.byteOffset + size_t(s.values.byteOffset);
    const size_t indexSize = componentSize(s.indices.componentType);
    int64_t previous = -1;
    for (size_t k = 0; k < size_t(s.count); ++k) {
      const uint32_t i = readIndex(indices + k * indexSize, s.indices.componentType);
      if (int64_t(i) <= previous || i >= a.count)
        bad("a sparse accessor has index " + std::to_string(i) + " out of order or out of range (count " +
            std::to_string(a.count) + ")");
      previous = i;
      fn(i, values + k * elementSize);
    }
  }
}

std::vector<glm::vec3> Loader::readVec3(int index, const char* what) const {
  const tinygltf::Accessor& a = model_.accessors[size_t(index)];
  if (a.type != TINYGLTF_TYPE_VEC3 || a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
    bad("accessor " + std::to_string(index) + " (" + what + ") must be VEC3 of FLOAT");
  std::vector<glm::vec3> out(a.count);
  forEachElement(a, [&](size_t i, const unsigned char* p) { std::memcpy(&out[i], p, 12); });
  return out;
}

std::vector<uint32_t> Loader::readIndices(int index, size_t vertexCount) const {
  const tinygltf::Accessor& a = model_.accessors[size_t(index)];
  if (a.type != TINYGLTF_TYPE_SCALAR || !isIndexType(a.componentType))
    bad("accessor " + std::to_string(index) + " (indices) must be SCALAR of unsigned byte, short or int");
  if (a.bufferView >= 0 && model_.bufferViews[size_t(a.bufferView)].byteStride != 0)
    bad("accessor " + std::to_string(index) + " (indices) lies in a buffer view with a byteStride");
  std::vector<uint32_t> out(a.count);
  forEachElement(a, [&](size_t i, const unsigned char* p) { out[i] = readIndex(p, a.componentType); });
  for (size_t i = 0; i < out.size(); ++i)
    if (out[i] >= vertexCount)
      bad("accessor " + std::to_string(index) + " (indices) has index " + std::to_string(out[i]) + " at position " +
          std::to_string(i) + ", but there are only " + std::to_string(vertexCount) + " vertices");
  return out;
}

// Reads one primitive into triangles over the vertices it references. Strips and fans become
// triangle lists with the winding of glTF 2.0 §3.7.2.1; points and lines are left empty (counted).
Loader::Primitive Loader::decode(int mesh, int prim) {
  const tinygltf::Primitive& p = model_.meshes[size_t(mesh)].primitives[size_t(prim)];
  const std::string name = "mesh " + std::to_string(mesh) + " primitive " + std::to_string(prim);
  const int mode = p.mode < 0 ? TINYGLTF_MODE_TRIANGLES : p.mode;
  Primitive out;
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN) {
    ++skippedNonTriangle_;
    return out;
  }
  const auto pos = p.attributes.find("POSITION");
  if (pos == p.attributes.end()) bad(name + " has no POSITION attribute");
  std::vector<glm::vec3> positions = readVec3(pos->second, "POSITION");
  for (size_t i = 0; i < positions.size(); ++i)
    if (!std::isfinite(positions[i].x) || !std::isfinite(positions[i].y) || !std::isfinite(positions[i].z))
      bad("accessor " + std::to_string(pos->second) + " (POSITION) has a non-finite value at vertex " +
          std::to_string(i));

  std::vector<glm::vec3> normals;
  if (const auto nrm = p.attributes.find("NORMAL"); nrm != p.attributes.end()) {
    normals = readVec3(nrm->second, "NORMAL");
    if (normals.size() != positions.size())
      bad(name + " has " + std::to_string(normals.size()) + " normals for " + std::to_string(positions.size()) +
          " positions");
    // A zero or non-finite normal cannot be repaired per vertex; the primitive falls back to flat normals.
    for (const glm::vec3& n : normals)
      if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z) || glm::dot(n, n) == 0.0f) {
        ++repairedNormals_;
        normals.clear();
        break;
      }
  }

  std::vector<uint32_t> elements;
  if (p.indices >= 0) {
    elements = readIndices(p.indices, positions.size());
  } else {
    elements.resize(positions.size());
    for (size_t i = 0; i < elements.size(); ++i) elements[i] = uint32_t(i);
  }
  std::vector<uint32_t> tris;
  const size_t n = elements.size();
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    if (n % 3 != 0) bad(name + " is a triangle list of " + std::to_string(n) + " vertices, not a multiple of 3");
    tris = std::move(elements);
  } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    for (size_t i = 0; i + 2 < n; ++i) {
      const bool odd = i % 2;
      tris.insert(tris.end(), {elements[i], elements[i + (odd ? 2 : 1)], elements[i + (odd ? 1 : 2)]});
    }
  } else {  // fan
    for (size_t i = 0; i + 2 < n; ++i) tris.insert(tris.end(), {elements[i + 1], elements[i + 2], elements[0]});
  }

  // Keep only the referenced vertices, so unused ones neither cost memory nor widen the bounds.
  std::vector<uint32_t> remap(positions.size(), UINT32_MAX);
  for (uint32_t& v : tris) {
    if (remap[v] == UINT32_MAX) {
      remap[v] = uint32_t(out.positions.size());
      out.positions.push_back(positions[v]);
      if (!normals.empty()) out.normals.push_back(normals[v]);
    }
    v = remap[v];
  }
  out.triangles = std::move(tris);
  return out;
}

std::string counted(size_t n, const std::string& thing) {
  return std::to_string(n) + " " + thing + (n == 1 ? "" : "s");
}

glm::vec3 unitOr(const glm::dvec3& v, const glm::dvec3& fallback) {
  const double len = glm::length(v);
  return glm::vec3(len > 0 && std::isfinite(len) ? v / len : fallback);
}

void Loader::addMeshInstance(int mesh, const glm::dmat4& world, int node) {
  auto cached = meshCache_.find(mesh);
  if (cached == meshCache_.end()) {
    std::vector<Primitive> prims;
    for (size_t p = 0; p < model_.meshes[size_t(mesh)].primitives.size(); ++p) prims.push_back(decode(mesh, int(p)));
    cached = meshCache_.emplace(mesh, std::move(prims)).first;
  }
  const glm::dmat3 linear(world);
  const double det = glm::determinant(linear);
  // A mirroring transform turns counter-clockwise into clockwise: swap two corners to keep the
  // front face front. Normals use the inverse-transpose, undefined when the transform is singular
  // (then the triangles are flattened anyway and get flat normals).
  const bool flip = det < 0;
  const bool invertible = std::abs(det) > 0 && std::isfinite(det);
  const glm::dmat3 normalMatrix = invertible ? glm::transpose(glm::inverse(linear)) : glm::dmat3(1.0);

  auto toWorld = [&](const glm::vec3& p) {
    const glm::dvec3 w = glm::dvec3(world * glm::dvec4(glm::dvec3(p), 1.0));
    const glm::vec3 stored(w);  // what the scene keeps must be finite too
    if (!std::isfinite(stored.x) || !std::isfinite(stored.y) || !std::isfinite(stored.z))
      bad("mesh " + std::to_string(mesh) + " has a vertex that overflows in world space");
    return w;
  };
  for (const Primitive& prim : cached->second) {
    const size_t added = prim.normals.empty() || !invertible ? prim.triangles.size() : prim.positions.size();
    if (scene_.positions.size() + added > UINT32_MAX)
      throw Error("the flattened scene has more than 2^32 vertices", path_, "coneshadow indexes vertices with 32 bits");
    if (anim_ && !prim.triangles.empty()) {
      VertexRange r;
      r.node = node;
      r.firstVertex = uint32_t(scene_.positions.size());
      r.vertexCount = uint32_t(added);
      r.firstIndex = uint32_t(scene_.indices.size());
      r.indexCount = uint32_t(prim.triangles.size());
      r.flatNormals = prim.normals.empty() || !invertible;
      anim_->ranges.push_back(r);
      if (!r.flatNormals) {
        anim_->localPositions.insert(anim_->localPositions.end(), prim.positions.begin(), prim.positions.end());
        anim_->localNormals.insert(anim_->localNormals.end(), prim.normals.begin(), prim.normals.end());
      } else {
        for (size_t t = 0; t < prim.triangles.size(); t += 3)
          for (size_t k : {size_t(0), flip ? size_t(2) : size_t(1), flip ? size_t(1) : size_t(2)}) {
            anim_->localPositions.push_back(prim.positions[prim.triangles[t + k]]);
            anim_->localNormals.emplace_back(0, 1, 0);  // recomputed from the winding when posed
          }
      }
    }
    if (!prim.normals.empty() && invertible) {
      const auto base = uint32_t(scene_.positions.size());
      for (size_t v = 0; v < prim.positions.size(); ++v) {
        scene_.positions.push_back(glm::vec3(toWorld(prim.positions[v])));
        scene_.normals.push_back(unitOr(normalMatrix * glm::dvec3(prim.normals[v]), {0, 1, 0}));
      }
      for (size_t t = 0; t < prim.triangles.size(); t += 3) {
        const uint32_t a = prim.triangles[t], b = prim.triangles[t + 1], c = prim.triangles[t + 2];
        scene_.indices.insert(scene_.indices.end(), {base + a, base + (flip ? c : b), base + (flip ? b : c)});
      }
    } else {
      // Flat normals: three vertices of its own per triangle, normal from the (final) winding.
      for (size_t t = 0; t < prim.triangles.size(); t += 3) {
        const glm::dvec3 a = toWorld(prim.positions[prim.triangles[t]]);
        glm::dvec3 b = toWorld(prim.positions[prim.triangles[t + 1]]);
        glm::dvec3 c = toWorld(prim.positions[prim.triangles[t + 2]]);
        if (flip) std::swap(b, c);
        const glm::vec3 normal = unitOr(glm::cross(b - a, c - a), {0, 1, 0});  // degenerate: any unit vector
        const auto first = uint32_t(scene_.positions.size());
        for (const glm::dvec3& p : {a, b, c}) {
          scene_.positions.push_back(glm::vec3(p));
          scene_.normals.push_back(normal);
        }
        scene_.indices.insert(scene_.indices.end(), {first, first + 1, first + 2});
      }
    }
  }
}

std::vector<double> Loader::readScalars(int index, const std::string& what) const {
  if (index < 0 || size_t(index) >= model_.accessors.size())
    bad(what + " refers to accessor " + std::to_string(index) + ", which does not exist");
  const tinygltf::Accessor& a = model_.accessors[size_t(index)];
  if (a.type != TINYGLTF_TYPE_SCALAR || a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
    bad(what + " (accessor " + std::to_string(index) + ") must be SCALAR of FLOAT");
  std::vector<double> out(a.count);
  forEachElement(a, [&](size_t i, const unsigned char* p) {
    float f;
    std::memcpy(&f, p, 4);
    out[i] = f;
  });
  for (size_t i = 0; i < out.size(); ++i) {
    if (!std::isfinite(out[i])) bad(what + " (accessor " + std::to_string(index) + ") has a non-finite time");
    if (i > 0 && !(out[i] > out[i - 1]))
      bad(what + " (accessor " + std::to_string(index) + ") times do not increase: key " + std::to_string(i) + " at " +
          std::to_string(out[i]) + " after " + std::to_string(out[i - 1]));
  }
  return out;
}

// Node animation channels of every animation (glTF 2.0 §3.11), validated like the geometry.
void Loader::readAnimations() {
  AnimatedScene& a = *anim_;
  const size_t nodeCount = model_.nodes.size();
  a.nodes.assign(nodeCount, AnimationNode{});
  for (size_t n = 0; n < nodeCount; ++n) {
    const tinygltf::Node& node = model_.nodes[n];
    for (int c : node.children) a.nodes[size_t(c)].parent = int(n);
    if (node.matrix.size() == 16) {
      a.nodes[n].matrix = localMatrix(int(n));
      continue;
    }
    localMatrix(int(n));  // validates the rotation and finiteness
    if (node.translation.size() == 3) a.nodes[n].translation = {node.translation[0], node.translation[1], node.translation[2]};
    if (node.rotation.size() == 4)
      a.nodes[n].rotation = glm::normalize(glm::dquat(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]));
    if (node.scale.size() == 3) a.nodes[n].scale = {node.scale[0], node.scale[1], node.scale[2]};
  }

  size_t weights = 0, cubic = 0;
  for (size_t ai = 0; ai < model_.animations.size(); ++ai) {
    const tinygltf::Animation& anim = model_.animations[ai];
    const std::string name = "animation " + std::to_string(ai);
    for (size_t ci = 0; ci < anim.channels.size(); ++ci) {
      const tinygltf::AnimationChannel& ch = anim.channels[ci];
      const std::string cname = name + " channel " + std::to_string(ci);
      if (ch.sampler < 0 || size_t(ch.sampler) >= anim.samplers.size())
        bad(cname + " refers to sampler " + std::to_string(ch.sampler) + ", which does not exist (the animation has " +
            counted(anim.samplers.size(), "sampler") + ")");
      AnimationChannel c;
      if (ch.target_path == "weights") {
        ++weights;
        continue;
      } else if (ch.target_path == "translation") {
        c.path = AnimationPath::Translation;
      } else if (ch.target_path == "rotation") {
        c.path = AnimationPath::Rotation;
      } else if (ch.target_path == "scale") {
        c.path = AnimationPath::Scale;
      } else {
        bad(cname + " targets path " + quoteInput(ch.target_path) + " (must be translation, rotation, scale or weights)");
      }
      if (ch.target_node < 0) continue;  // no node: nothing this file animates (extensions may use it)
      if (size_t(ch.target_node) >= nodeCount)
        bad(cname + " targets node " + std::to_string(ch.target_node) + ", which does not exist");
      if (model_.nodes[size_t(ch.target_node)].matrix.size() == 16)
        bad(cname + " targets node " + std::to_string(ch.target_node) +
            ", which has a matrix (animated nodes must use translation, rotation and scale)");
      c.node = ch.target_node;

      const tinygltf::AnimationSampler& s = anim.samplers[size_t(ch.sampler)];
      const std::string sname = name + " sampler " + std::to_string(ch.sampler);
      bool cubicSpline = false;
      if (s.interpolation.empty() || s.interpolation == "LINEAR") {
        c.interpolation = AnimationInterpolation::Linear;
      } else if (s.interpolation == "STEP") {
        c.interpolation = AnimationInterpolation::Step;
      } else if (s.interpolation == "CUBICSPLINE") {
        c.interpolation = AnimationInterpolation::Linear;
        cubicSpline = true;
        ++cubic;
      } else {
        bad(sname + " has interpolation " + quoteInput(s.interpolation) + " (must be LINEAR, STEP or CUBICSPLINE)");
      }
      c.times = readScalars(s.input, sname + " input");
      if (s.output < 0 || size_t(s.output) >= model_.accessors.size())
        bad(sname + " output refers to accessor " + std::to_string(s.output) + ", which does not exist");
      const tinygltf::Accessor& out = model_.accessors[size_t(s.output)];
      const bool rotation = c.path == AnimationPath::Rotation;
      const int type = rotation ? TINYGLTF_TYPE_VEC4 : TINYGLTF_TYPE_VEC3;
      if (out.type != type || out.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
        bad(sname + " output (accessor " + std::to_string(s.output) + ") must be " + (rotation ? "VEC4" : "VEC3") +
            " of FLOAT for a " + ch.target_path + " channel");
      const size_t perKey = cubicSpline ? 3 : 1;
      if (out.count != c.times.size() * perKey)
        bad(sname + " has " + std::to_string(out.count) + " output values for " + counted(c.times.size(), "key time") +
            (cubicSpline ? " (CUBICSPLINE needs 3 per key)" : " (needs one per key)"));
      std::vector<glm::dvec4> values(out.count, glm::dvec4(0));
      const size_t comps = rotation ? 4 : 3;
      forEachElement(out, [&](size_t i, const unsigned char* p) {
        float f[4] = {0, 0, 0, 0};
        std::memcpy(f, p, comps * 4);
        values[i] = glm::dvec4(f[0], f[1], f[2], f[3]);
      });
      for (size_t k = 0; k < c.times.size(); ++k) {
        const glm::dvec4 v = values[k * perKey + (cubicSpline ? 1 : 0)];  // CUBICSPLINE: in-tangent, value, out-tangent
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z) || !std::isfinite(v.w))
          bad(sname + " output has a non-finite value at key " + std::to_string(k));
        if (rotation && !(glm::length(v) > 0)) bad(sname + " output has a zero rotation at key " + std::to_string(k));
        c.values.push_back(v);
      }
      a.start = a.channels.empty() ? c.times.front() : std::min(a.start, c.times.front());
      a.end = a.channels.empty() ? c.times.back() : std::max(a.end, c.times.back());
      a.channels.push_back(std::move(c));
    }
  }
  if (weights)
    warn_ << path_ << ": ignored " << counted(weights, "morph-target weights channel")
          << " (only rigid node animation is applied)\n";
  if (cubic)
    warn_ << path_ << ": " << counted(cubic, "CUBICSPLINE channel")
          << " sampled as LINEAR through the keyframe values (tangents ignored)\n";
}

AnimatedScene Loader::loadAnimated() {
  AnimatedScene a;
  anim_ = &a;
  a.rest = load();  // every vertex lies in one range, in order: localPositions matches rest.positions
  readAnimations();
  anim_ = nullptr;
  return a;
}

std::string Loader::uniqueName(std::string name, bool camera) const {
  auto taken = [&](const std::string& s) {
    if (camera)
      return std::any_of(scene_.cameras.begin(), scene_.cameras.end(), [&](const Camera& c) { return c.name == s; });
    return std::any_of(scene_.lights.begin(), scene_.lights.end(), [&](const PointLight& l) { return l.name == s; });
  };
  if (!taken(name)) return name;
  for (int k = 2;; ++k)
    if (!taken(name + "_" + std::to_string(k))) return name + "_" + std::to_string(k);
}

void Loader::addLight(int index, const glm::dmat4& world) {
  const tinygltf::Light& l = model_.lights[size_t(index)];
  if (l.type != "point") {
    ++skippedLights_;
    return;
  }
  PointLight light;
  light.name = uniqueName(l.name.empty() ? "light" + std::to_string(index) : l.name, false);
  light.position = glm::vec3(world[3]);
  if (!l.color.empty()) {
    if (l.color.size() != 3) bad("light " + std::to_string(index) + " color must have 3 components");
    light.color = glm::vec3(l.color[0], l.color[1], l.color[2]);
  }
  light.intensity = float(l.intensity);
  if (!std::isfinite(light.intensity) || light.intensity < 0 ||
      !(glm::all(glm::greaterThanEqual(light.color, glm::vec3(0)))) ||
      !std::isfinite(light.color.x + light.color.y + light.color.z))
    bad("light " + std::to_string(index) + " has a negative or non-finite color or intensity");
  scene_.lights.push_back(light);
}

// Cameras come after the geometry: an infinite far plane is replaced by one from the scene's bounds.
void Loader::addCameras() {
  const glm::vec3 centre = 0.5f * (scene_.boundsMin + scene_.boundsMax);
  for (const CameraUse& use : cameraUses_) {
    const tinygltf::Camera& c = model_.cameras[size_t(use.camera)];
    const std::string name = "camera " + std::to_string(use.camera);
    if (c.type != "perspective") {
      ++skippedOrtho_;
      continue;
    }
    const tinygltf::PerspectiveCamera& p = c.perspective;
    if (!(p.yfov > 0 && p.yfov < glm::pi<double>()))
      bad(name + " has yfov " + std::to_string(p.yfov) + " outside (0, pi)");
    if (!(p.znear > 0) || !std::isfinite(p.znear))
      bad(name + " has znear " + std::to_string(p.znear) + " (must be > 0)");
    if (p.zfar != 0 && !(p.zfar > p.znear && std::isfinite(p.zfar)))
      bad(name + " has zfar " + std::to_string(p.zfar) + " not beyond znear " + std::to_string(p.znear));

    // The camera looks down its node's -Z with +Y up (glTF 2.0 §3.10.1); scale is ignored.
    const glm::dmat3 axes(use.world);
    const glm::dvec3 forward = -axes[2], upHint = axes[1];
    const glm::dvec3 side = glm::cross(forward, upHint);
    if (!(glm::length(forward) > 0) || !(glm::length(side) > 0))
      bad("the node of " + name + " has a degenerate transform (no view direction)");
    Camera cam;
    cam.name = uniqueName(c.name.empty() ? "camera" + std::to_string(use.camera) : c.name, true);
    cam.eye = glm::vec3(use.world[3]);
    const float toCentre = glm::length(centre - cam.eye);
    const float reach = toCentre + scene_.diagonal();  // beyond the farthest point of the bounds
    cam.target = cam.eye + glm::vec3(glm::normalize(forward)) * std::max(toCentre, 1e-3f);
    cam.up = glm::vec3(glm::normalize(glm::cross(side, forward)));
    cam.yfov = float(p.yfov);
    cam.znear = float(p.znear);
    cam.zfar = p.zfar != 0 ? float(p.zfar) : std::max(reach, cam.znear * 2);
    // The scene's farthest point from the eye: a corner of the bounds.
    double farthest = 0;
    for (int k = 0; k < 8; ++k) {
      const glm::dvec3 corner((k & 1) ? scene_.boundsMax.x : scene_.boundsMin.x, (k & 2) ? scene_.boundsMax.y : scene_.boundsMin.y,
                              (k & 4) ? scene_.boundsMax.z : scene_.boundsMin.z);
      farthest = std::max(farthest, glm::length(corner - glm::dvec3(cam.eye)));
    }
    checkFileCamera(cam, path_, name + (c.name.empty() ? "" : " (" + quoteInput(c.name) + ")"), farthest);
    scene_.cameras.push_back(cam);
  }
}

Scene Loader::load() {
  validateBuffers();
  validateAccessors();
  validateReferences();
  scene_.name = std::filesystem::path(path_).stem().string();
  traverse(sceneRoots());
  if (scene_.indices.empty())
    throw Error(
        "no triangles in the scene" +
            (skippedNonTriangle_ ? " (" + counted(skippedNonTriangle_, "point/line primitive") + " skipped)" : ""),
        path_, "coneshadow needs triangle meshes to cast shadows");
  scene_.computeBounds();
  addCameras();

  // One line per kind of thing left out, however many there are.
  if (skippedNonTriangle_)
    warn_ << path_ << ": skipped " << counted(skippedNonTriangle_, "point/line primitive")
          << " (only triangles are drawn and cast shadows)\n";
  if (repairedNormals_)
    warn_ << path_ << ": " << counted(repairedNormals_, "primitive")
          << " with zero or non-finite normals got flat normals instead\n";
  if (skippedOrtho_)
    warn_ << path_ << ": skipped " << counted(skippedOrtho_, "orthographic camera")
          << " (only perspective cameras are supported)\n";
  if (skippedLights_)
    warn_ << path_ << ": skipped " << counted(skippedLights_, "spot/directional light")
          << " (only point lights are supported)\n";
  if (skinned_)
    warn_ << path_ << ": " << counted(skinned_, "skinned mesh instance")
          << " drawn in bind pose, placed by its node (skins are not applied)\n";
  if (std::find(model_.extensionsUsed.begin(), model_.extensionsUsed.end(), "EXT_mesh_gpu_instancing") !=
      model_.extensionsUsed.end())
    warn_ << path_ << ": EXT_mesh_gpu_instancing is not applied; each instanced mesh is drawn once\n";
  return std::move(scene_);
}

}  // namespace

AnimatedScene loadAnimatedGltf(const std::string& path, std::ostream& warn) {
  try {
    return Loader(path, warn).loadAnimated();
  } catch (const Error& e) {
    throw clippedError(e);
  } catch (const std::bad_alloc&) {
    throw Error("out of memory while loading", path, "the file is too large or malformed");
  }
}

Scene loadGltf(const std::string& path, std::ostream& warn) {
  try {
    return Loader(path, warn).load();
  } catch (const Error& e) {
    throw clippedError(e);
  } catch (const std::bad_alloc&) {  // e.g. an accessor count of billions with no buffer behind it
    throw Error("out of memory while loading", path, "the file is too large or malformed");
  }
}

}  // namespace cs
