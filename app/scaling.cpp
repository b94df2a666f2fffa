// `coneshadow compare --scaling`: see scaling.h.
#include "app/scaling.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>

#include "app/commands.h"
#include "app/frame_runner.h"
#include "app/svg_plot.h"
#include "core/image_io.h"
#include "judge/frame_output.h"
#include "judge/metrics.h"
#include "harness/harness.h"
#include "harness/run.h"
#include "method/epsilon.h"
#include "vk/context.h"

namespace fs = std::filesystem;

namespace cs {

std::vector<uint32_t> scalingCopies(uint64_t sceneTriangles, uint64_t maxTriangles) {
  std::vector<uint32_t> ks = {1};
  for (uint64_t k = 4; sceneTriangles > 0 && k * sceneTriangles <= maxTriangles && k <= (1u << 30); k *= 4)
    ks.push_back(uint32_t(k));
  return ks;
}

Scene instancedScene(const Scene& scene, uint32_t copies) {
  Scene out;
  out.name = copies == 1 ? scene.name : scene.name + " x" + std::to_string(copies);
  out.cameras = scene.cameras;
  out.lights = scene.lights;
  const uint32_t cols = uint32_t(std::ceil(std::sqrt(double(copies))));
  const glm::vec3 extent = scene.boundsMax - scene.boundsMin;
  const float dx = std::max(extent.x, 1e-3f) * 1.1f, dz = std::max(extent.z, 1e-3f) * 1.1f;
  const size_t nv = scene.positions.size();
  out.positions.reserve(nv * copies);
  out.normals.reserve(scene.normals.size() * copies);
  out.indices.reserve(scene.indices.size() * copies);
  for (uint32_t c = 0; c < copies; ++c) {
    const glm::vec3 offset(float(c % cols) * dx, 0.0f, float(c / cols) * dz);
    const uint32_t base = uint32_t(out.positions.size());
    for (auto& p : scene.positions) out.positions.push_back(p + offset);
    out.normals.insert(out.normals.end(), scene.normals.begin(), scene.normals.end());
    for (uint32_t i : scene.indices) out.indices.push_back(base + i);
  }
  out.computeBounds();
  return out;
}

namespace {

// One method at one point of a sweep; failed points carry the reason and no numbers.
struct ScalingRow {
  std::string sweep;  // "resolution" | "triangles" | "light_distance"
  uint32_t width = 0, height = 0, copies = 1;
  double lightDiagonals = 0;  // light_distance: the light's distance from the scene's centre, in diagonals
  glm::vec3 light{0};
  uint64_t pairsTested = 0;   // the cone path's (triangle, node) pairs, when the method reports them
  uint64_t triangles = 0;
  std::string method;
  std::string status = "ok";  // "ok" or "failed: <reason>"
  double msMedian = 0, msMin = 0, msMax = 0;
  uint64_t bytes = 0, peakBytes = 0;
  uint64_t lit = 0, band = 0, misclassified = 0, misclassifiedOutsideBand = 0;
  double misclassifiedPct = 0, misclassifiedOutsideBandPct = 0;
  double bandFraction = 0;
  bool undecided = false;  // the band covers more than kUndecidedBandFraction of the lit samples
  bool ok() const { return status == "ok"; }
};

// Columns of scaling.csv, in order; scaling.json rows carry the same keys (numbers null when failed).
const std::vector<std::string> kColumns = {
    "sweep", "width", "height", "pixels", "copies", "triangles", "light_distance_diagonals", "light_x", "light_y",
    "light_z", "method", "status", "ms_median", "ms_min", "ms_max", "pairs_tested",
    "bytes_allocated", "peak_bytes", "lit_samples", "band_samples", "misclassified", "misclassified_pct",
    "misclassified_outside_band", "misclassified_outside_band_pct", "band_fraction", "undecided"};

nlohmann::ordered_json toJson(const ScalingRow& r) {
  nlohmann::ordered_json j;
  j["sweep"] = r.sweep;
  j["width"] = r.width;
  j["height"] = r.height;
  j["pixels"] = uint64_t(r.width) * r.height;
  j["copies"] = r.copies;
  j["triangles"] = r.triangles;
  const bool distance = r.sweep == "light_distance";
  j["light_distance_diagonals"] = distance ? nlohmann::ordered_json(r.lightDiagonals) : nlohmann::ordered_json();
  j["light_x"] = r.light.x;
  j["light_y"] = r.light.y;
  j["light_z"] = r.light.z;
  j["method"] = r.method;
  j["status"] = r.status;
  const bool ok = r.ok();
  auto num = [&](const char* key, auto v) { j[key] = ok ? nlohmann::ordered_json(v) : nlohmann::ordered_json(); };
  num("ms_median", r.msMedian);
  num("ms_min", r.msMin);
  num("ms_max", r.msMax);
  j["pairs_tested"] = ok && r.pairsTested ? nlohmann::ordered_json(r.pairsTested) : nlohmann::ordered_json();
  num("bytes_allocated", r.bytes);
  num("peak_bytes", r.peakBytes);
  num("lit_samples", r.lit);
  num("band_samples", r.band);
  num("misclassified", r.misclassified);
  num("misclassified_pct", r.misclassifiedPct);
  num("misclassified_outside_band", r.misclassifiedOutsideBand);
  num("misclassified_outside_band_pct", r.misclassifiedOutsideBandPct);
  num("band_fraction", r.bandFraction);
  num("undecided", r.undecided);
  return j;
}

std::string csvCell(const nlohmann::ordered_json& v) {
  if (v.is_null()) return "";
  std::string s = v.is_string() ? v.get<std::string>() : v.dump();  // numbers: the JSON serializer's digits
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

std::string fixed(double v, int prec) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}

std::string mib(uint64_t bytes) { return fixed(double(bytes) / (1024.0 * 1024.0), 2); }

// Time (top panel) and bytes allocated (bottom) against x, one line per method, failed points left out.
std::string sweepSvg(const std::vector<ScalingRow>& rows, const std::string& sweep, const std::string& xLabel,
                     const std::vector<std::string>& methods) {
  LogPanel time{xLabel, "shadow time per frame, ms (median)", {}};
  LogPanel bytes{xLabel, "bytes allocated per frame", {}};
  for (auto& m : methods) {
    PlotSeries ts{m, {}, true}, bs{m, {}, true};
    for (auto& r : rows) {
      if (r.sweep != sweep || r.method != m || !r.ok()) continue;
      double x = sweep == "resolution" ? double(r.width) * r.height : double(r.triangles);
      std::string where = sweep == "resolution" ? std::to_string(r.width) + "x" + std::to_string(r.height)
                                                : std::to_string(r.triangles) + " triangles";
      ts.points.push_back({x, std::max(r.msMedian, 1e-3), m + " " + where + ": " + fixed(r.msMedian, 2) + " ms"});
      bs.points.push_back({x, double(std::max<uint64_t>(r.bytes, 1)), m + " " + where + ": " + mib(r.bytes) + " MiB"});
    }
    time.series.push_back(ts);
    bytes.series.push_back(bs);
  }
  return logPlotSvg({time, bytes});
}

// Light sweep: time (top) and misclassified samples outside the band (bottom, exact results on the
// floor labelled 0) against the light's distance, one line per method.
std::string distanceSvg(const std::vector<ScalingRow>& rows, const std::vector<std::string>& methods) {
  LogPanel time{"light distance from the scene's centre, scene diagonals (log scale)",
                "shadow time per frame, ms (median)", {}};
  LogPanel error{"light distance from the scene's centre, scene diagonals (log scale)",
                 "misclassified outside the band, % of lit samples", {}};
  error.yFloor = 1e-4;
  for (auto& m : methods) {
    PlotSeries ts{m, {}, true}, es{m, {}, true};
    for (auto& r : rows) {
      if (r.sweep != "light_distance" || r.method != m || !r.ok()) continue;
      const std::string where = m + " at " + fixed(r.lightDiagonals, 0) + " diagonals: ";
      ts.points.push_back({r.lightDiagonals, std::max(r.msMedian, 1e-3), where + fixed(r.msMedian, 2) + " ms"});
      es.points.push_back({r.lightDiagonals, std::max(r.misclassifiedOutsideBandPct, 1e-4),
                           where + fixed(r.misclassifiedOutsideBandPct, 4) + " % (" +
                               std::to_string(r.misclassifiedOutsideBand) + ")"});
    }
    time.series.push_back(ts);
    error.series.push_back(es);
  }
  return logPlotSvg({time, error});
}

std::string distanceMd(const std::string& sceneName, const std::string& view, const std::string& device,
                       const Options& o, const std::vector<ScalingRow>& rows) {
  std::ostringstream os;
  os << "# coneshadow light distances: " << sceneName << " / " << view << "\n\n"
     << "device: " << device << "\n\n"
     << o.width << "x" << o.height << ", median of " << o.frames << " frame(s) after one warm-up per point. The "
     << "light moved out along its own direction from the centre of the scene's bounds to the given number of "
     << "bounding-box diagonals; every method judged against Embree on the same samples. Band: samples whose "
     << "reference answer flips under the epsilon policy's perturbations (its light nudge is floored at 4 ulp of "
     << "the light's coordinates, so the band widens with the distance); where it covers over 1 % of the lit samples the "
     << "point is undecided: no count outside the band judges it. Pairs: the cone path's (triangle, node) "
     << "tests.\n\n"
     << "| light distance (diagonals) | method | ms median (min-max) | misclassified outside band | misclassified "
     << "(all) | band | pairs tested | status |\n"
     << "| ---: | --- | ---: | ---: | ---: | ---: | ---: | --- |\n";
  for (auto& r : rows) {
    if (r.sweep != "light_distance") continue;
    os << "| " << fixed(r.lightDiagonals, 0) << " | " << r.method << " | ";
    if (r.ok())
      os << fixed(r.msMedian, 2) << " (" << fixed(r.msMin, 2) << "-" << fixed(r.msMax, 2) << ") | "
         << fixed(r.misclassifiedOutsideBandPct, 4) << " % (" << r.misclassifiedOutsideBand << ") | "
         << fixed(r.misclassifiedPct, 4) << " % | " << r.band << " (" << fixed(100.0 * r.bandFraction, 2) << " %"
         << (r.undecided ? ", undecided" : "") << ") | "
         << (r.pairsTested ? std::to_string(r.pairsTested) : std::string("-")) << " | ok |\n";
    else
      os << "- | - | - | - | - | " << r.status << " |\n";
  }
  os << "\n![light distance sweep](light_distances.png)\n\n(vector: light_distances.svg)\n";
  return os.str();
}

std::string scalingMd(const std::string& sceneName, const std::string& view, const std::string& device,
                      const Options& o, const std::vector<ScalingRow>& rows) {
  std::ostringstream os;
  os << "# coneshadow scaling: " << sceneName << " / " << view << "\n\n"
     << "device: " << device << "\n\n"
     << "Median of " << o.frames << " frame(s) after one warm-up per point. Misclassified: lit samples against "
     << "Embree on the same samples, outside the ambiguity band. MiB: bytes the method allocated for the frame "
     << "(peak: its peak working set).\n\n"
     << "Triangle sweep at " << o.width << "x" << o.height << ": the scene instanced as k translated copies side "
     << "by side on a grid in the x-z plane beyond its bounds (copy 0 in place; camera, light and epsilon of the "
     << "original), so the picture stays the same and every method still pays for every triangle.\n";
  for (const char* sweep : {"resolution", "triangles"}) {
    os << "\n## " << (std::string(sweep) == "resolution" ? "Resolution sweep" : "Triangle sweep") << "\n\n"
       << "| " << (std::string(sweep) == "resolution" ? "size" : "copies / triangles")
       << " | method | ms median (min-max) | MiB | peak MiB | misclassified outside band | status |\n"
       << "| --- | --- | ---: | ---: | ---: | ---: | --- |\n";
    for (auto& r : rows) {
      if (r.sweep != sweep) continue;
      std::string where = r.sweep == "resolution" ? std::to_string(r.width) + "x" + std::to_string(r.height)
                                                  : std::to_string(r.copies) + " / " + std::to_string(r.triangles);
      if (r.ok())
        os << "| " << where << " | " << r.method << " | " << fixed(r.msMedian, 2) << " (" << fixed(r.msMin, 2) << "-"
           << fixed(r.msMax, 2) << ") | " << mib(r.bytes) << " | " << mib(r.peakBytes) << " | "
           << fixed(r.misclassifiedOutsideBandPct, 4) << " % (" << r.misclassifiedOutsideBand << ") | ok |\n";
      else
        os << "| " << where << " | " << r.method << " | - | - | - | - | " << r.status << " |\n";
    }
    os << "\n![" << sweep << " sweep](scaling_" << sweep << ".png)\n\n(vector: scaling_" << sweep << ".svg)\n";
  }
  return os.str();
}

}  // namespace

int runScaling(const Options& base) {
  ProgressLog progressLog(base.quiet);
  std::ostream& log = progressLog.stream();
  const Options& o = base;
  const std::vector<uint32_t> sizes = o.scalingSizes.empty() ? std::vector<uint32_t>{256, 512, 1024, 2048} : o.scalingSizes;
  std::vector<const MethodInfo*> methods = chosenMethods(o);  // parseArgs checked them and their settings
  const uint64_t maxTriangles = o.scalingMaxTriangles ? o.scalingMaxTriangles : kDefaultScalingMaxTriangles;

  Scene scene = loadSceneArg(o, std::cerr);
  Options viewOptions = o;
  if (viewOptions.views.empty() && !o.view.empty()) viewOptions.views = {o.view};
  const Camera camera = selectViews(scene, viewOptions).front();  // the first of --views, else the first camera
  const std::string view = camera.name.empty() ? "auto" : camera.name;
  const glm::vec3 light = chooseLight(scene, o);
  const bool distances = !o.lightDistances.empty();
  // The light sweep's direction: from the scene's centre through the chosen light.
  const glm::vec3 centre = 0.5f * (scene.boundsMin + scene.boundsMax);
  const float diagonal = scene.diagonal();
  glm::vec3 away = glm::vec3(light) - centre;
  away = glm::length(away) > 1e-6f * diagonal ? glm::normalize(away) : glm::normalize(glm::vec3(0.3f, 1.0f, 0.2f));
  const EpsilonPolicy policy = EpsilonPolicy::forScene(scene);  // the original's, at every point
  const std::vector<uint32_t> copies = scalingCopies(scene.triangleCount(), maxTriangles);

  auto ctx = commandContext(o);
  const std::string device = ctx->driverDescription();
  // Methods this device cannot run (MethodInfo::unsupported) are left out, each said once.
  std::erase_if(methods, [&](const MethodInfo* m) {
    const std::string why = unsupportedOn(*m, *ctx, settingsFor(o, *m));
    if (!why.empty()) log << "skipping " << m->name << ": " << why << std::endl;
    return !why.empty();
  });
  std::vector<std::string> methodNames;
  for (const MethodInfo* m : methods) methodNames.push_back(m->name);
  log << "scaling " << scene.name << " / " << view << ": " << sizes.size() << " resolution point(s), "
      << copies.size() << " triangle point(s) up to " << copies.back() * scene.triangleCount() << " triangles, "
      << methods.size() << " method(s); device: " << device << std::endl;

  StagedDir out(o.out, runInputs(o));
  std::vector<ScalingRow> rows;
  auto failAll = [&](const ScalingRow& proto, const std::string& tag, const std::string& why) {
    for (const MethodInfo* m : methods) {
      ScalingRow r = proto;
      r.method = m->name;
      r.status = "failed: " + why;
      log << tag << m->name << " " << r.status << std::endl;
      rows.push_back(r);
    }
  };
  auto runPoint = [&](const std::string& sweep, const Scene& s, uint32_t k, uint32_t w, uint32_t h,
                      glm::vec3 pointLight, double lightDiagonals) {
    ScalingRow proto;
    proto.sweep = sweep;
    proto.width = w;
    proto.height = h;
    proto.copies = k;
    proto.triangles = s.triangleCount();
    proto.light = pointLight;
    proto.lightDiagonals = lightDiagonals;
    const std::string tag = "[" + sweep + " " + std::to_string(w) + "x" + std::to_string(h) + ", " +
                            std::to_string(proto.triangles) + " triangles" +
                            (sweep == "light_distance" ? ", light " + fixed(lightDiagonals, 0) + " diagonals" : "") +
                            "] ";
    // The shared part: raster, reference, band. If it fails, every method fails at this point; a method
    // that fails fails alone.
    harness::RunSpec spec;
    spec.scene = &s;
    spec.views = {{camera, view}};
    spec.lights = {pointLight};
    spec.width = w;
    spec.height = h;
    spec.frames = o.frames;
    spec.policy = policy;
    spec.catchFailures = true;
    for (const MethodInfo* m : methods) spec.methods.push_back({m, m->name, settingsFor(o, *m)});
    harness::Events events;
    events.step = [&](const harness::Frame&, const std::string& step) {
      if (step == "raster") log << tag << "raster, reference, band" << std::endl;
    };
    events.judged = [&](const harness::Frame&, const harness::Row& row) {
      ScalingRow r = proto;
      r.method = spec.methods[row.method].info->name;
      if (!row.failure.empty()) {
        r.status = "failed: " + row.failure;
        log << tag << r.method << " " << r.status << std::endl;
        rows.push_back(r);
        return;
      }
      const Judged& j = row.judged;
      const ErrorStats& err = j.error;
      r.msMedian = j.runs.medianMs;
      r.msMin = j.runs.minMs;
      r.msMax = j.runs.maxMs;
      r.bytes = j.runs.output.bytesAllocated;
      r.peakBytes = j.runs.output.peakBytes;
      r.lit = err.litSamples;
      r.band = err.bandSamples;
      r.misclassified = err.misclassified;
      r.misclassifiedPct = err.misclassifiedFraction * 100.0;
      r.misclassifiedOutsideBand = err.misclassifiedOutsideBand;
      r.misclassifiedOutsideBandPct = err.misclassifiedFractionOutsideBand * 100.0;
      r.bandFraction = err.bandFraction;
      r.undecided = err.undecided;
      const auto& stats = j.runs.output.stats;
      if (stats.contains("pairs_tested") && stats["pairs_tested"].is_number_integer())
        r.pairsTested = stats["pairs_tested"].get<uint64_t>();
      log << tag << r.method << ": " << fixed(r.msMedian, 2) << " ms, " << mib(r.bytes) << " MiB, "
          << r.misclassifiedOutsideBand << " misclassified outside band"
          << (r.undecided ? ", UNDECIDED: " + err.undecidedReason() : std::string()) << std::endl;
      rows.push_back(r);
    };
    const harness::Results point = harness::run(*ctx, spec, events);
    if (!point.frames.front().failure.empty()) failAll(proto, tag, point.frames.front().failure);
  };

  for (double d : o.lightDistances) {
    const glm::vec3 far = centre + float(d * double(diagonal)) * away;
    if (std::string why = lightRangeProblem(far, scene.boundsMin, scene.boundsMax); !why.empty())
      throw UsageError("--light-distances: " + fixed(d, 0) + " diagonals: " + why);
    runPoint("light_distance", scene, 1, o.width, o.height, far, d);
  }
  for (uint32_t n : sizes) {
    if (distances) break;
    runPoint("resolution", scene, 1, n, n, light, 0);
  }
  for (uint32_t k : copies) {
    if (distances) break;
    if (k == 1) {
      runPoint("triangles", scene, 1, o.width, o.height, light, 0);
      continue;
    }
    Scene big;
    try {
      big = instancedScene(scene, k);
    } catch (const std::exception& e) {  // std::bad_alloc on the host
      ScalingRow proto;
      proto.sweep = "triangles";
      proto.width = o.width;
      proto.height = o.height;
      proto.copies = k;
      proto.triangles = uint64_t(scene.triangleCount()) * k;
      failAll(proto, "[triangles, " + std::to_string(k) + " copies] ", e.what());
      continue;
    }
    runPoint("triangles", big, k, o.width, o.height, light, 0);
  }

  log << "writing scaling reports" << std::endl;
  const fs::path dir = out.path();
  nlohmann::ordered_json json = nlohmann::ordered_json::array();
  std::string csv;
  for (size_t c = 0; c < kColumns.size(); ++c) {
    if (c) csv += ',';
    csv += kColumns[c];
  }
  csv += "\n";
  for (auto& r : rows) {
    auto j = toJson(r);
    for (size_t c = 0; c < kColumns.size(); ++c) {
      if (c) csv += ',';
      csv += csvCell(j.at(kColumns[c]));
    }
    csv += "\n";
    json.push_back(j);
  }
  nlohmann::ordered_json doc;
  doc["scene"] = scene.name;
  doc["view"] = view;
  doc["device"] = device;
  doc["frames"] = o.frames;
  doc["provenance"] = runProvenance(o, scene, light, camera);  // the run's (docs/RESULTS_FORMAT.md); each point's light is in its row
  doc["rows"] = json;
  if (distances) {
    doc["light_direction"] = {away.x, away.y, away.z};
    doc["scene_centre"] = {centre.x, centre.y, centre.z};
    doc["scene_diagonal"] = diagonal;
    writeFileAtomic((dir / "light_distances.json").string(), doc.dump(2) + "\n");
    writeFileAtomic((dir / "light_distances.csv").string(), csv);
    writeFileAtomic((dir / "light_distances.md").string(), distanceMd(scene.name, view, device, o, rows));
    writeFileAtomic((dir / "light_distances.svg").string(), distanceSvg(rows, methodNames));
    svgToPng((dir / "light_distances.svg").string(), (dir / "light_distances.png").string());
    out.commit();
    size_t failed = size_t(std::count_if(rows.begin(), rows.end(), [](const ScalingRow& r) { return !r.ok(); }));
    std::cout << "result: light distances of " << scene.name << " / " << view << ": " << rows.size()
              << " point(s), " << failed << " failed; wrote " << o.out
              << "/ (light_distances.md, .json, .csv, .svg, .png)\n";
    return kExitOk;
  }
  writeFileAtomic((dir / "scaling.json").string(), doc.dump(2) + "\n");
  writeFileAtomic((dir / "scaling.csv").string(), csv);
  writeFileAtomic((dir / "scaling.md").string(), scalingMd(scene.name, view, device, o, rows));
  writeFileAtomic((dir / "scaling_resolution.svg").string(),
                  sweepSvg(rows, "resolution", "pixels (log scale)", methodNames));
  writeFileAtomic((dir / "scaling_triangles.svg").string(),
                  sweepSvg(rows, "triangles", "triangles (log scale)", methodNames));
  for (const char* name : {"scaling_resolution", "scaling_triangles"})
    svgToPng((dir / (std::string(name) + ".svg")).string(), (dir / (std::string(name) + ".png")).string());
  out.commit();

  size_t failed = size_t(std::count_if(rows.begin(), rows.end(), [](const ScalingRow& r) { return !r.ok(); }));
  std::cout << "result: scaling of " << scene.name << " / " << view << ": " << rows.size() << " point(s), " << failed
            << " failed; wrote " << o.out << "/ (scaling.md, scaling.json, scaling.csv, scaling_resolution.svg/.png, "
            << "scaling_triangles.svg/.png)\n";
  return kExitOk;
}

}  // namespace cs
