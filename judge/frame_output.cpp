// Frame images, the PFM dump with meta.json, and the results table (JSON + CSV from one flattening).
#include "judge/frame_output.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>

#include "core/error.h"
#include "core/image_io.h"

namespace cs {

namespace {

constexpr float kAlbedo = 0.8f;
constexpr float kAmbient = 0.15f;

void checkSizes(const GBuffer& g, const std::vector<float>& visibility, const char* what) {
  CS_CHECK_EQ(g.position.size(), g.size());
  CS_CHECK_EQ(g.normal.size(), g.size());
  CS_CHECK(visibility.size() == g.size(),
           what << " has " << visibility.size() << " values, " << g.size() << " (one per pixel) expected");
}

uint8_t encodeGamma(float linear) {
  float c = std::clamp(linear, 0.0f, 1.0f);
  return uint8_t(std::pow(c, 1.0f / 2.2f) * 255.0f + 0.5f);
}

void put(std::vector<uint8_t>& img, size_t i, const uint8_t rgb[3]) {
  img[3 * i + 0] = rgb[0];
  img[3 * i + 1] = rgb[1];
  img[3 * i + 2] = rgb[2];
}

void shadePixel(const GBuffer& g, size_t i, float visibility, float dim, uint8_t rgb[3]) {
  if (!g.hasGeometry(i)) {
    for (int c = 0; c < 3; ++c) rgb[c] = uint8_t(float(kBackgroundRgb[c]) * dim + 0.5f);
    return;
  }
  // normal.w is 0 for samples facing away from the light: they get the ambient term only.
  float radiance = kAlbedo * (kAmbient + g.normal[i].w * std::clamp(visibility, 0.0f, 1.0f));
  uint8_t v = uint8_t(float(encodeGamma(radiance)) * dim + 0.5f);
  rgb[0] = rgb[1] = rgb[2] = v;
}

void createDirectory(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw Error("cannot create directory: " + ec.message(), dir);
}

std::string join(const std::string& dir, const std::string& name) {
  return (std::filesystem::path(dir) / name).string();
}

// Method names become file names: keep [A-Za-z0-9_-], replace anything else.
std::string fileSafe(const std::string& name) {
  std::string s = name;
  for (char& c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) c = '_';
  return s.empty() ? "unnamed" : s;
}

nlohmann::json vec3Json(glm::vec3 v) { return {v.x, v.y, v.z}; }

// results.csv columns come from flattening each JSON row, so CSV and JSON cannot drift apart.
void flatten(const nlohmann::json& value, const std::string& key, std::vector<std::pair<std::string, nlohmann::json>>& out) {
  if (value.is_object()) {
    for (auto it = value.begin(); it != value.end(); ++it) flatten(it.value(), key + "." + it.key(), out);
  } else if (value.is_array() && key == "stages") {
    for (const auto& stage : value) out.emplace_back("stage." + stage.at("name").get<std::string>() + ".ms", stage.at("ms"));
  } else {
    out.emplace_back(key, value);
  }
}

std::string csvCell(const nlohmann::json& v) {
  if (v.is_null()) return "";
  std::string s = v.is_string() ? v.get<std::string>() : v.dump();
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string quoted = "\"";
  for (char c : s) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}

}  // namespace

std::vector<uint8_t> shadedImage(const GBuffer& g, const std::vector<float>& visibility) {
  checkSizes(g, visibility, "visibility");
  std::vector<uint8_t> img(g.size() * 3);
  for (size_t i = 0; i < g.size(); ++i) shadePixel(g, i, visibility[i], 1.0f, &img[3 * i]);
  return img;
}

std::vector<uint8_t> maskImage(const GBuffer& g, const std::vector<float>& visibility) {
  checkSizes(g, visibility, "visibility");
  std::vector<uint8_t> img(g.size() * 3);
  for (size_t i = 0; i < g.size(); ++i) {
    uint8_t v = !g.isLit(i) ? kNotLitMaskGrey : visibility[i] >= kLitThreshold ? 255 : 0;
    img[3 * i] = img[3 * i + 1] = img[3 * i + 2] = v;
  }
  return img;
}

std::vector<uint8_t> diffImage(const GBuffer& g, const std::vector<float>& method, const std::vector<float>& reference,
                               const std::vector<uint8_t>& band) {
  checkSizes(g, method, "method visibility");
  checkSizes(g, reference, "reference visibility");
  CS_CHECK(band.empty() || band.size() == g.size(), "band has " << band.size() << " entries, " << g.size() << " expected");
  std::vector<uint8_t> img(g.size() * 3);
  for (size_t i = 0; i < g.size(); ++i) {
    const bool methodLit = method[i] >= kLitThreshold, referenceLit = reference[i] >= kLitThreshold;
    if (!g.isLit(i) || methodLit == referenceLit) {
      shadePixel(g, i, reference[i], 0.5f, &img[3 * i]);
    } else if (!band.empty() && band[i]) {
      put(img, i, kBandDisagreeRgb);
    } else {
      put(img, i, methodLit ? kFalseLightRgb : kFalseShadowRgb);
    }
  }
  return img;
}

uint32_t shrinkFactor(uint32_t width, uint32_t height, uint32_t side) {
  const uint32_t longer = std::max(width, height);
  return side == 0 || longer <= side ? 1u : (longer + side - 1) / side;
}

std::vector<uint8_t> shrinkKeepingErrors(const std::vector<uint8_t>& rgb, uint32_t width, uint32_t height, uint32_t factor,
                                         uint32_t& outWidth, uint32_t& outHeight) {
  CS_CHECK(rgb.size() == size_t(width) * height * 3, "image has " << rgb.size() << " bytes, " << width << "x" << height
                                                                  << " RGB expected");
  factor = std::max(factor, 1u);
  outWidth = (width + factor - 1) / factor;
  outHeight = (height + factor - 1) / factor;
  if (factor == 1) return rgb;
  auto is = [](const uint8_t* p, const uint8_t c[3]) { return p[0] == c[0] && p[1] == c[1] && p[2] == c[2]; };
  std::vector<uint8_t> out(size_t(outWidth) * outHeight * 3);
  for (uint32_t by = 0; by < outHeight; ++by)
    for (uint32_t bx = 0; bx < outWidth; ++bx) {
      uint64_t sum[3] = {0, 0, 0}, n = 0, shadow = 0, light = 0, band = 0;
      for (uint32_t y = by * factor; y < std::min(height, (by + 1) * factor); ++y)
        for (uint32_t x = bx * factor; x < std::min(width, (bx + 1) * factor); ++x) {
          const uint8_t* p = &rgb[(size_t(y) * width + x) * 3];
          shadow += is(p, kFalseShadowRgb);
          light += is(p, kFalseLightRgb);
          band += is(p, kBandDisagreeRgb);
          for (int c = 0; c < 3; ++c) sum[c] += p[c];
          ++n;
        }
      uint8_t* q = &out[(size_t(by) * outWidth + bx) * 3];
      const uint8_t* pick = shadow || light ? (shadow >= light ? kFalseShadowRgb : kFalseLightRgb)
                            : band          ? kBandDisagreeRgb
                                            : nullptr;
      for (int c = 0; c < 3; ++c) q[c] = pick ? pick[c] : uint8_t((sum[c] + n / 2) / n);
    }
  return out;
}

uint32_t writeFrameImages(const std::string& dir, const std::string& prefix, const GBuffer& g,
                          const std::vector<float>& visibility, const std::vector<float>& reference,
                          const std::vector<uint8_t>& band, uint32_t thumbnailSide) {
  createDirectory(dir);
  const uint32_t factor = shrinkFactor(g.width, g.height, thumbnailSide);
  auto write = [&](const std::string& kind, const std::vector<uint8_t>& rgb) {
    writePng(join(dir, prefix + "_" + kind + ".png"), g.width, g.height, rgb);
    if (factor == 1) return;
    uint32_t tw = 0, th = 0;
    std::vector<uint8_t> small = shrinkKeepingErrors(rgb, g.width, g.height, factor, tw, th);
    writePng(join(dir, prefix + "_" + kind + "_thumb.png"), tw, th, small);
  };
  write("shaded", shadedImage(g, visibility));
  write("mask", maskImage(g, visibility));
  if (!reference.empty()) write("diff", diffImage(g, visibility, reference, band));
  return factor;
}

void writeDump(const std::string& dir, const Scene& scene, const GBuffer& g, const Camera& camera, glm::vec3 light,
               const EpsilonPolicy& policy, const std::map<std::string, std::vector<float>>& visibility,
               const std::vector<uint8_t>& band) {
  CS_CHECK_EQ(g.position.size(), g.size());
  CS_CHECK_EQ(g.normal.size(), g.size());
  CS_CHECK(band.empty() || band.size() == g.size(), "band has " << band.size() << " entries, " << g.size() << " expected");
  createDirectory(dir);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const size_t n = g.size();

  std::vector<float> position(3 * n), normal(3 * n), lightTerm(n), inBand(n, 0.0f);
  for (size_t i = 0; i < n; ++i) {
    const bool geometry = g.hasGeometry(i);
    for (int c = 0; c < 3; ++c) {
      position[3 * i + c] = geometry ? g.position[i][c] : nan;
      normal[3 * i + c] = geometry ? g.normal[i][c] : nan;
    }
    lightTerm[i] = geometry ? g.normal[i].w : 0.0f;
    if (!band.empty() && band[i]) inBand[i] = 1.0f;
  }
  // Every image twice: PFM (bottom row first) and OpenEXR (top row first), the same floats.
  auto dump = [&](const std::string& stem, int channels, const std::vector<float>& data) {
    writePfm(join(dir, stem + ".pfm"), g.width, g.height, channels, data);
    writeExr(join(dir, stem + ".exr"), g.width, g.height, channels, data);
  };
  dump("position", 3, position);
  dump("normal", 3, normal);
  dump("light", 1, lightTerm);
  dump("band", 1, inBand);

  nlohmann::json files = {{"position", "position.pfm"}, {"normal", "normal.pfm"}, {"light", "light.pfm"},
                          {"band", "band.pfm"}};
  nlohmann::json visibilityFiles = nlohmann::json::object();
  for (const auto& [method, vis] : visibility) {
    CS_CHECK(vis.size() == n, "visibility of '" << method << "' has " << vis.size() << " values, " << n << " expected");
    const std::string stem = "visibility_" + fileSafe(method);
    dump(stem, 1, vis);
    visibilityFiles[method] = stem + ".pfm";
  }
  files["visibility"] = visibilityFiles;

  glm::vec3 lo(0), hi(0);
  if (!scene.positions.empty()) {
    lo = hi = scene.positions[0];
    for (const glm::vec3& v : scene.positions) {
      lo = glm::min(lo, v);
      hi = glm::max(hi, v);
    }
  }
  nlohmann::json meta = {
      {"scene", scene.name},
      {"triangles", scene.triangleCount()},
      {"bounds", {{"min", vec3Json(lo)}, {"max", vec3Json(hi)}}},
      {"width", g.width},
      {"height", g.height},
      {"light", vec3Json(light)},
      {"camera",
       {{"name", camera.name},
        {"eye", vec3Json(camera.eye)},
        {"target", vec3Json(camera.target)},
        {"up", vec3Json(camera.up)},
        {"yfov", camera.yfov},
        {"znear", camera.znear},
        {"zfar", camera.zfar}}},
      {"epsilon", toJson(policy)},
      {"band_computed", !band.empty()},
      {"files", files},
      {"row_order",
       "PFM rows are stored bottom row first (PFM convention): pixel (x, y) with y = 0 the top row of the "
       "image is file row height-1-y; floats little-endian (scale -1.0). Every .pfm has an .exr twin with the "
       "same floats (32-bit, channels Y or R,G,B), rows top first as EXR stores them"},
      {"lit_rule", "a sample is lit when position is not NaN and light > 0; only lit samples are judged"},
      {"visibility_rule", "1 = lit, 0 = shadowed, thresholded at 0.5; 1 where the sample is not lit"},
  };
  writeFileAtomic(join(dir, "meta.json"), meta.dump(2) + "\n");
}

FrameResult makeFrameResult(const std::string& scene, const std::string& view, const std::string& method,
                            const GBuffer& gbuffer, const std::string& device, const MethodOutput& output,
                            const ErrorStats& error) {
  FrameResult r;
  r.scene = scene;
  r.view = view;
  r.method = method;
  r.width = gbuffer.width;
  r.height = gbuffer.height;
  r.device = device;
  r.stages = output.stages;
  r.totalMs = output.totalMs;
  r.bytes = output.bytesAllocated;
  r.peakBytes = output.peakBytes;
  r.stats = output.stats;
  r.error = error;
  return r;
}

nlohmann::json toJson(const FrameResult& r) {
  nlohmann::json stages = nlohmann::json::array();
  for (const StageTime& s : r.stages) stages.push_back({{"name", s.name}, {"ms", s.ms}, {"kind", stageKindName(s.kind)}});
  return {{"scene", r.scene},       {"view", r.view},     {"method", r.method},
          {"width", r.width},       {"height", r.height}, {"device", r.device},
          {"total_ms", r.totalMs},  {"bytes", r.bytes},   {"peak_bytes", r.peakBytes},
          {"stages", stages},       {"stats", r.stats.is_null() ? nlohmann::json::object() : r.stats},
          {"error", toJson(r.error)},
          {"provenance", r.provenance.is_null() ? nlohmann::json::object() : r.provenance}};
}

nlohmann::json resultsJson(const std::vector<FrameResult>& results) {
  nlohmann::json rows = nlohmann::json::array();
  for (const FrameResult& r : results) rows.push_back(toJson(r));
  return rows;
}

std::string resultsCsv(const std::vector<FrameResult>& results) {
  static const std::vector<std::string> kLeading = {"scene", "view",  "method", "width",     "height",
                                                    "device", "total_ms", "bytes", "peak_bytes"};
  std::vector<std::vector<std::pair<std::string, nlohmann::json>>> rows;
  for (const FrameResult& r : results) {
    nlohmann::json j = toJson(r);
    std::vector<std::pair<std::string, nlohmann::json>> cells;
    for (const std::string& k : kLeading) cells.emplace_back(k, j.at(k));
    flatten(j.at("stages"), "stages", cells);
    flatten(j.at("error"), "error", cells);
    flatten(j.at("stats"), "stats", cells);
    flatten(j.at("provenance"), "provenance", cells);
    rows.push_back(std::move(cells));
  }
  // Columns: union over rows in first-seen order (leading, stages, error, stats for the first row, then
  // whatever later rows add).
  std::vector<std::string> columns;
  for (const auto& cells : rows)
    for (const auto& [key, value] : cells)
      if (std::find(columns.begin(), columns.end(), key) == columns.end()) columns.push_back(key);
  if (rows.empty()) columns = kLeading;

  std::string csv;
  for (size_t c = 0; c < columns.size(); ++c) {
    if (c) csv += ",";
    csv += csvCell(columns[c]);
  }
  csv += "\n";
  for (const auto& cells : rows) {
    for (size_t c = 0; c < columns.size(); ++c) {
      if (c) csv += ",";
      auto it = std::find_if(cells.begin(), cells.end(), [&](const auto& kv) { return kv.first == columns[c]; });
      if (it != cells.end()) csv += csvCell(it->second);
    }
    csv += "\n";
  }
  return csv;
}

void writeResults(const std::string& dir, const std::vector<FrameResult>& results) {
  createDirectory(dir);
  writeFileAtomic(join(dir, "results.json"), resultsJson(results).dump(2) + "\n");
  writeFileAtomic(join(dir, "results.csv"), resultsCsv(results));
}

}  // namespace cs
