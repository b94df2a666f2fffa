// A JSON Schema validator for the keywords docs/results.schema.json uses (draft 2020-12): type, enum,
// required, properties, additionalProperties, items, minimum/maximum, minLength/maxLength,
// minItems/maxItems, local $ref into $defs, and the annotations. A keyword outside that set is an error,
// so the schema cannot use one this validator would silently skip.
#pragma once
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace cs::test {

class JsonSchema {
 public:
  explicit JsonSchema(nlohmann::json schema) : root_(std::move(schema)) {}

  static JsonSchema fromFile(const std::filesystem::path& path) {
    std::ifstream f(path);
    if (!f) throw std::runtime_error("cannot read the schema " + path.string());
    return JsonSchema(nlohmann::json::parse(std::string(std::istreambuf_iterator<char>(f), {})));
  }

  // Every violation, as "<JSON pointer>: what"; empty when `value` is valid.
  std::vector<std::string> validate(const nlohmann::json& value) const {
    std::vector<std::string> errors;
    check(root_, value, "", errors);
    return errors;
  }

 private:
  nlohmann::json root_;

  static bool hasType(const nlohmann::json& v, const std::string& type) {
    if (type == "object") return v.is_object();
    if (type == "array") return v.is_array();
    if (type == "string") return v.is_string();
    if (type == "boolean") return v.is_boolean();
    if (type == "null") return v.is_null();
    if (type == "number") return v.is_number();
    if (type == "integer") return v.is_number_integer() || (v.is_number_float() && v.get<double>() == double(int64_t(v.get<double>())));
    throw std::runtime_error("schema: unknown type " + type);
  }

  const nlohmann::json& resolve(const std::string& ref) const {
    const std::string prefix = "#/$defs/";
    if (ref.rfind(prefix, 0) != 0) throw std::runtime_error("schema: only local $defs references are supported: " + ref);
    return root_.at("$defs").at(ref.substr(prefix.size()));
  }

  void check(const nlohmann::json& s, const nlohmann::json& v, const std::string& at, std::vector<std::string>& errors) const {
    static const std::set<std::string> kKnown = {"$schema", "$id", "title", "description", "$defs", "$ref", "type", "enum",
                                                 "required", "properties", "additionalProperties", "items", "minimum",
                                                 "maximum", "minLength", "maxLength", "minItems", "maxItems"};
    for (auto it = s.begin(); it != s.end(); ++it)
      if (!kKnown.count(it.key())) throw std::runtime_error("schema: unsupported keyword " + it.key() + " at " + at);
    auto fail = [&](const std::string& what) { errors.push_back((at.empty() ? "/" : at) + ": " + what); };
    if (s.contains("$ref")) check(resolve(s["$ref"].get<std::string>()), v, at, errors);
    if (s.contains("type")) {
      std::vector<std::string> types = s["type"].is_array() ? s["type"].get<std::vector<std::string>>()
                                                             : std::vector<std::string>{s["type"].get<std::string>()};
      bool ok = false;
      for (auto& t : types) ok = ok || hasType(v, t);
      if (!ok) return fail("is " + std::string(v.type_name()) + ", expected " + s["type"].dump());
    }
    if (s.contains("enum")) {
      bool ok = false;
      for (auto& e : s["enum"]) ok = ok || e == v;
      if (!ok) fail(v.dump() + " is not one of " + s["enum"].dump());
    }
    if (v.is_number()) {
      if (s.contains("minimum") && v.get<double>() < s["minimum"].get<double>()) fail(v.dump() + " below the minimum");
      if (s.contains("maximum") && v.get<double>() > s["maximum"].get<double>()) fail(v.dump() + " above the maximum");
    }
    if (v.is_string()) {
      const size_t n = v.get<std::string>().size();
      if (s.contains("minLength") && n < s["minLength"].get<size_t>()) fail("string shorter than " + s["minLength"].dump());
      if (s.contains("maxLength") && n > s["maxLength"].get<size_t>()) fail("string longer than " + s["maxLength"].dump());
    }
    if (v.is_array()) {
      if (s.contains("minItems") && v.size() < s["minItems"].get<size_t>()) fail("fewer items than " + s["minItems"].dump());
      if (s.contains("maxItems") && v.size() > s["maxItems"].get<size_t>()) fail("more items than " + s["maxItems"].dump());
      if (s.contains("items"))
        for (size_t i = 0; i < v.size(); ++i) check(s["items"], v[i], at + "/" + std::to_string(i), errors);
    }
    if (v.is_object()) {
      if (s.contains("required"))
        for (auto& k : s["required"])
          if (!v.contains(k.get<std::string>())) fail("missing " + k.get<std::string>());
      for (auto it = v.begin(); it != v.end(); ++it) {
        if (s.contains("properties") && s["properties"].contains(it.key())) {
          check(s["properties"][it.key()], it.value(), at + "/" + it.key(), errors);
        } else if (s.contains("additionalProperties")) {
          const nlohmann::json& extra = s["additionalProperties"];
          if (extra.is_boolean()) {
            if (!extra.get<bool>()) fail("unexpected field " + it.key());
          } else {
            check(extra, it.value(), at + "/" + it.key(), errors);
          }
        }
      }
    }
  }
};

}  // namespace cs::test
