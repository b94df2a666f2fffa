// What a frame leaves on disk: shaded / mask / diff images, the float dump an independent checker reads
// (PFM + meta.json), and the results table (results.json and results.csv holding the same numbers).
//
// Image colours (8-bit RGB, row 0 = top of the image, as in the G-buffer):
//   shaded : constant albedo 0.8, radiance = 0.8 · (0.15 ambient + direct term · visibility), gamma 2.2;
//            pixels without geometry: dark blue-grey (38, 42, 52).
//   mask   : white = lit sample the method calls lit (visibility >= 0.5), black = lit sample it calls
//            shadowed, mid grey (128) = not a lit sample (no geometry, or facing away from the light).
//   diff   : method against the reference, lit samples only —
//            agree                          -> the shaded image dimmed to half;
//            false shadow (method dark)     -> red (255, 0, 0);
//            false light (method lit)       -> blue-cyan (0, 170, 255);
//            disagree inside the band       -> yellow (255, 215, 0), either kind;
//            not-lit samples and background -> dimmed shaded, as "agree".
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "core/scene.h"
#include "method/method.h"
#include "judge/metrics.h"
#include "raster/gbuffer.h"
#include "method/epsilon.h"

namespace cs {

inline constexpr uint8_t kBackgroundRgb[3] = {38, 42, 52};
inline constexpr uint8_t kFalseShadowRgb[3] = {255, 0, 0};
inline constexpr uint8_t kFalseLightRgb[3] = {0, 170, 255};
inline constexpr uint8_t kBandDisagreeRgb[3] = {255, 215, 0};
inline constexpr uint8_t kNotLitMaskGrey = 128;

// Each returns width*height*3 bytes; visibility vectors hold one value per pixel.
std::vector<uint8_t> shadedImage(const GBuffer& gbuffer, const std::vector<float>& visibility);
std::vector<uint8_t> maskImage(const GBuffer& gbuffer, const std::vector<float>& visibility);
// band: one byte per pixel (nonzero = in band) or empty.
std::vector<uint8_t> diffImage(const GBuffer& gbuffer, const std::vector<float>& method,
                               const std::vector<float>& reference, const std::vector<uint8_t>& band);

// An RGB image shrunk by an integer `factor` (each output pixel one factor x factor block; partial blocks
// at the right and bottom edges) so that no error pixel disappears: a block holding a false-shadow or
// false-light pixel takes the colour of the more numerous of the two (false shadow on a tie), else a
// block holding a band disagreement is yellow, else the block's mean colour. factor 1 returns the image.
std::vector<uint8_t> shrinkKeepingErrors(const std::vector<uint8_t>& rgb, uint32_t width, uint32_t height, uint32_t factor,
                                         uint32_t& outWidth, uint32_t& outHeight);

// The smallest integer factor that brings the longer side of a width x height image to at most `side`.
uint32_t shrinkFactor(uint32_t width, uint32_t height, uint32_t side);

// <dir>/<prefix>_shaded.png, <prefix>_mask.png and, when `reference` is not empty, <prefix>_diff.png.
// Creates `dir` if needed.
// With thumbnailSide > 0 and an image larger than that, each also as <prefix>_<kind>_thumb.png, shrunk by
// shrinkFactor(width, height, thumbnailSide) through shrinkKeepingErrors; returns that factor (1: none).
uint32_t writeFrameImages(const std::string& dir, const std::string& prefix, const GBuffer& gbuffer,
                          const std::vector<float>& visibility, const std::vector<float>& reference,
                          const std::vector<uint8_t>& band, uint32_t thumbnailSide = 0);

// The dump for an independent checker, in `dir` (created if needed). Every image as PFM (rows bottom-first,
// the PFM convention, see core/image_io.h) and as OpenEXR beside it (<name>.exr, the same floats, rows
// top-first); meta.json says so and gives everything needed to re-trace:
//   position.pfm            3 floats per pixel: world position, NaN where there is no geometry
//   normal.pfm              3 floats: world unit normal (turned toward the camera), NaN where no geometry
//   light.pfm               1 float: direct-light term max(0, N·L̂); a sample is lit when it has
//                           geometry and this is > 0
//   visibility_<method>.pfm 1 float per pixel, per entry of `visibility` (file-name-safe method name)
//   band.pfm                1 float: 1 where the sample is in the ambiguity band, else 0
//   meta.json               light, camera, size, triangle count, bounds, epsilon policy, row order
void writeDump(const std::string& dir, const Scene& scene, const GBuffer& gbuffer, const Camera& camera,
               glm::vec3 light, const EpsilonPolicy& policy,
               const std::map<std::string, std::vector<float>>& visibility, const std::vector<uint8_t>& band);

// One row of the results table: one method on one view of one scene.
struct FrameResult {
  std::string scene, view, method;
  uint32_t width = 0, height = 0;
  std::string device;                     // where it ran ("cpu", the GPU's name, ...)
  std::vector<StageTime> stages;          // in execution order
  double totalMs = 0;
  uint64_t bytes = 0;                     // bytes allocated for the frame
  uint64_t peakBytes = 0;
  nlohmann::json stats = nlohmann::json::object();
  ErrorStats error;
  // Where the row comes from (docs/RESULTS_FORMAT.md): schema_version, tool, command_line, time, scene_path,
  // scene_hash, light, camera; empty: not written.
  nlohmann::json provenance = nlohmann::json::object();
};

// The results files' schema version (docs/RESULTS_FORMAT.md); bumped whenever a field changes meaning.
inline constexpr int kResultsSchemaVersion = 2;

FrameResult makeFrameResult(const std::string& scene, const std::string& view, const std::string& method,
                            const GBuffer& gbuffer, const std::string& device, const MethodOutput& output,
                            const ErrorStats& error);

// {"scene", "view", "method", "width", "height", "device", "total_ms", "bytes", "peak_bytes",
//  "stages": [{"name", "ms", "kind"}...], "stats": {...}, "error": toJson(ErrorStats), "provenance": {...}}
nlohmann::json toJson(const FrameResult& result);
nlohmann::json resultsJson(const std::vector<FrameResult>& results);  // array of toJson rows
// Header row, then one row per result. Columns: the scalar fields, then "stage.<name>.ms" (first-seen
// order), "error.<field>", "stats.<path>" (nested objects joined with '.', arrays as JSON text); a cell
// is empty where a row lacks the column. Numbers are printed by the same serializer as results.json,
// so both files carry the same digits.
std::string resultsCsv(const std::vector<FrameResult>& results);
// <dir>/results.json and <dir>/results.csv (dir created if needed).
void writeResults(const std::string& dir, const std::vector<FrameResult>& results);

}  // namespace cs
