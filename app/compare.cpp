// `coneshadow compare`: see compare.h.
#include "app/compare.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "app/commands.h"
#include "app/frame_runner.h"
#include "app/methods.h"
#include "core/image_io.h"
#include "eval/frame_output.h"
#include "eval/metrics.h"
#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "reference/epsilon.h"
#include "vk/context.h"
#ifdef CONESHADOW_HAS_CONE
#include "traversal/traversal.h"
#endif

namespace fs = std::filesystem;

namespace cs {

std::string bytesLabel(uint64_t bytes) {
  auto fmt = [](double v, const char* suffix) {
    std::ostringstream os;
    if (v == std::floor(v)) os << uint64_t(v) << suffix;
    else os << std::fixed << std::setprecision(1) << v << suffix;
    return os.str();
  };
  if (bytes >= (1ull << 30) && bytes % (1ull << 30) == 0) return fmt(double(bytes >> 30), "G");
  if (bytes >= (1ull << 20)) return fmt(std::round(double(bytes) / (1 << 20) * 10) / 10, "M");
  if (bytes >= 1024) return fmt(std::round(double(bytes) / 1024 * 10) / 10, "K");
  return std::to_string(bytes);
}

std::vector<CompareSetting> compareSettings(const std::vector<std::string>& methods, const Options& base) {
  std::vector<CompareSetting> out;
  for (auto& m : methods) {
    if (m == "cubesm") {
      for (uint32_t r : {512u, 2048u}) {
        Options o = base;
        o.smResolution = r;
        out.push_back({m, m + "@" + std::to_string(r), o});
      }
    } else if (m == "rmsm") {
      for (uint64_t pool : {4ull << 20, 16ull << 20}) {
        Options o = base;
        o.rmsmPool = pool;
        out.push_back({m, m + "@" + bytesLabel(pool), o});
      }
#ifdef CONESHADOW_HAS_CONE
    } else if (m == "cone") {
      uint64_t def = base.traversalMemory ? base.traversalMemory : traversal::kDefaultMemoryBytes;
      // 1/1000 of the default, kept well above the smallest budget planArena accepts (kMinPairs pairs
      // plus one chunk's scratch).
      uint64_t low = std::max<uint64_t>(def / 1000, 4096);
      for (uint64_t mem : {def, low}) {
        Options o = base;
        o.traversalMemory = mem;
        out.push_back({m, m + "@" + bytesLabel(mem), o});
      }
#endif
    } else {
      out.push_back({m, m, base});
    }
  }
  return out;
}

namespace {

struct Row {
  FrameResult result;
  std::string setting;
  double msMin = 0, msMax = 0;
};

std::string htmlEscape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else if (c == '"') o += "&quot;";
    else o += c;
  }
  return o;
}

std::string num(double v, int prec) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}

std::string pct(double fraction) { return num(fraction * 100.0, 4) + "%"; }

std::string imageName(const Row& r, const std::string& kind) {
  return r.result.view + "_" + r.setting + "_" + kind + ".png";
}

// The table cells of one row, shared by report.md and report.html.
std::vector<std::string> cells(const Row& r) {
  const ErrorStats& e = r.result.error;
  return {r.setting,
          num(r.result.totalMs, 3) + " (" + num(r.msMin, 3) + "–" + num(r.msMax, 3) + ")",
          pct(e.misclassifiedFraction) + " (" + pct(e.misclassifiedFractionOutsideBand) + ")",
          std::to_string(e.falseShadow) + " / " + std::to_string(e.falseLight),
          num(e.meanAbsError, 6),
          num(double(r.result.bytes) / (1024.0 * 1024.0), 2)};
}

const std::vector<std::string> kHeader = {"method/setting", "ms median (min–max)", "misclassified % (outside band)",
                                          "false shadow / false light", "MAE", "MiB"};

std::vector<std::string> viewOrder(const std::vector<Row>& rows) {
  std::vector<std::string> views;
  for (auto& r : rows)
    if (std::find(views.begin(), views.end(), r.result.view) == views.end()) views.push_back(r.result.view);
  return views;
}

std::string reportMd(const std::string& sceneName, const std::string& device, uint32_t w, uint32_t h,
                     uint32_t frames, const std::vector<Row>& rows) {
  std::ostringstream os;
  os << "# coneshadow compare: " << sceneName << "\n\n"
     << "device: " << device << "\n\n"
     << w << "x" << h << ", median of " << frames
     << " frame(s) after one warm-up; misclassified over lit samples against Embree (in parentheses: outside "
        "the ambiguity band); false shadow / false light in samples; MiB allocated by the method.\n";
  for (auto& v : viewOrder(rows)) {
    os << "\n## " << v << "\n\n|";
    for (auto& hcell : kHeader) os << " " << hcell << " |";
    os << "\n|";
    for (size_t i = 0; i < kHeader.size(); ++i) os << (i ? " ---: |" : " --- |");
    os << "\n";
    for (auto& r : rows) {
      if (r.result.view != v) continue;
      os << "|";
      for (auto& c : cells(r)) os << " " << c << " |";
      os << "\n";
    }
  }
  os << "\nplot: speed_vs_error.svg\n";
  return os.str();
}

std::string reportHtml(const std::string& sceneName, const std::string& device, uint32_t w, uint32_t h,
                       uint32_t frames, const std::vector<Row>& rows) {
  std::ostringstream os;
  os << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>coneshadow compare: " << htmlEscape(sceneName)
     << "</title>\n<style>body{font-family:sans-serif}table{border-collapse:collapse}td,th{border:1px solid #bbb;"
        "padding:3px 6px;text-align:right}td:first-child{text-align:left}img{image-rendering:pixelated;"
        "width:160px}</style></head><body>\n"
     << "<h1>coneshadow compare: " << htmlEscape(sceneName) << "</h1>\n<p>device: " << htmlEscape(device)
     << "</p>\n<p>" << w << "x" << h << ", median of " << frames
     << " frame(s) after one warm-up; misclassified over lit samples against Embree (in parentheses: outside the "
        "ambiguity band).</p>\n<p><img style=\"width:720px\" src=\"speed_vs_error.svg\" alt=\"speed vs error\"></p>\n";
  for (auto& v : viewOrder(rows)) {
    os << "<h2>" << htmlEscape(v) << "</h2>\n<table>\n<tr>";
    for (auto& hcell : kHeader) os << "<th>" << htmlEscape(hcell) << "</th>";
    os << "<th>shaded</th><th>mask</th><th>diff</th></tr>\n";
    for (auto& r : rows) {
      if (r.result.view != v) continue;
      os << "<tr>";
      for (auto& c : cells(r)) os << "<td>" << htmlEscape(c) << "</td>";
      for (const char* kind : {"shaded", "mask", "diff"})
        os << "<td><img src=\"" << htmlEscape(imageName(r, kind)) << "\" alt=\"" << kind << "\"></td>";
      os << "</tr>\n";
    }
    os << "</table>\n";
  }
  os << "</body></html>\n";
  return os.str();
}

// Speed (x, log ms) against error (y, log misclassified fraction, exact zeros at a floor labelled "0").
std::string speedVsErrorSvg(const std::vector<Row>& rows) {
  constexpr double kFloor = 1e-7;
  const double W = 760, H = 480, left = 80, right = 170, top = 30, bottom = 60;
  double pw = W - left - right, ph = H - top - bottom;
  double lo = 1e30, hi = 0;
  for (auto& r : rows) {
    double ms = std::max(r.result.totalMs, 1e-3);
    lo = std::min(lo, ms);
    hi = std::max(hi, ms);
  }
  if (rows.empty()) lo = hi = 1;
  int x0 = int(std::floor(std::log10(lo))), x1 = int(std::ceil(std::log10(hi)));
  if (x1 <= x0) x1 = x0 + 1;
  int y0 = -7, y1 = 0;
  auto px = [&](double ms) { return left + (std::log10(std::max(ms, 1e-3)) - x0) / (x1 - x0) * pw; };
  auto py = [&](double f) { return top + ph - (std::log10(std::max(f, kFloor)) - y0) / (y1 - y0) * ph; };
  const char* palette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"};
  std::map<std::string, std::string> colour;
  std::vector<std::string> methods;
  for (auto& r : rows)
    if (!colour.count(r.result.method)) {
      colour[r.result.method] = palette[methods.size() % 8];
      methods.push_back(r.result.method);
    }
  std::ostringstream os;
  os << std::fixed << std::setprecision(2);
  os << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H << "\" viewBox=\"0 0 " << W
     << " " << H << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
     << "<rect x=\"0\" y=\"0\" width=\"" << W << "\" height=\"" << H << "\" fill=\"white\"/>\n"
     << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << pw << "\" height=\"" << ph
     << "\" fill=\"none\" stroke=\"black\"/>\n";
  for (int e = x0; e <= x1; ++e) {
    double x = px(std::pow(10.0, e));
    std::ostringstream label;
    label << std::pow(10.0, e);
    os << "<line x1=\"" << x << "\" y1=\"" << top << "\" x2=\"" << x << "\" y2=\"" << top + ph
       << "\" stroke=\"#ddd\"/>\n<text x=\"" << x << "\" y=\"" << top + ph + 16 << "\" text-anchor=\"middle\">"
       << label.str() << "</text>\n";
  }
  for (int e = y0; e <= y1; ++e) {
    double y = py(std::pow(10.0, e));
    std::string label = e == y0 ? "0" : "1e" + std::to_string(e);
    if (e == 0) label = "1";
    os << "<line x1=\"" << left << "\" y1=\"" << y << "\" x2=\"" << left + pw << "\" y2=\"" << y
       << "\" stroke=\"#ddd\"/>\n<text x=\"" << left - 6 << "\" y=\"" << y + 4 << "\" text-anchor=\"end\">" << label
       << "</text>\n";
  }
  os << "<text x=\"" << left + pw / 2 << "\" y=\"" << H - 18
     << "\" text-anchor=\"middle\">shadow time per frame, ms (log scale)</text>\n"
     << "<text transform=\"translate(18," << top + ph / 2
     << ") rotate(-90)\" text-anchor=\"middle\">misclassified fraction of lit samples (log; 0 at the floor)</text>\n";
  for (auto& r : rows) {
    os << "<circle cx=\"" << px(r.result.totalMs) << "\" cy=\"" << py(r.result.error.misclassifiedFraction)
       << "\" r=\"5\" fill=\"" << colour[r.result.method] << "\" fill-opacity=\"0.75\" stroke=\"black\"><title>"
       << htmlEscape(r.result.view + " " + r.setting) << ": " << num(r.result.totalMs, 3) << " ms, "
       << pct(r.result.error.misclassifiedFraction) << " misclassified</title></circle>\n";
  }
  for (size_t i = 0; i < methods.size(); ++i) {
    double y = top + 10 + 20.0 * double(i);
    os << "<rect x=\"" << left + pw + 16 << "\" y=\"" << y - 6 << "\" width=\"12\" height=\"12\" fill=\""
       << colour[methods[i]] << "\"/>\n<text x=\"" << left + pw + 34 << "\" y=\"" << y + 4 << "\">"
       << htmlEscape(methods[i]) << "</text>\n";
  }
  os << "</svg>\n";
  return os.str();
}

}  // namespace

int runCompare(const Options& o) {
  NullBuffer nullBuf;
  std::ostream quiet(&nullBuf);
  std::ostream& log = o.quiet ? quiet : std::cout;

  // Validate the method list before any heavy work (makeMethod throws UsageError naming an unknown one).
  auto registered = methodNames();
  std::vector<std::string> methods = o.methods.empty() ? registered : o.methods;
  for (auto& m : methods)
    if (std::find(registered.begin(), registered.end(), m) == registered.end()) makeMethod(m, nullptr, o);
  std::vector<CompareSetting> settings = compareSettings(methods, o);

  Scene scene = loadSceneArg(o.scene, std::cerr);
  std::vector<Camera> cameras;
  if (!o.views.empty()) {
    for (auto& v : o.views) {
      const Camera* c = scene.findCamera(v);
      if (!c) {
        std::string all;
        for (auto& cam : scene.cameras) all += (all.empty() ? "" : ", ") + cam.name;
        throw UsageError("scene " + scene.name + " has no view '" + v + "'" +
                         (all.empty() ? " (it has no cameras)" : " (views: " + all + ")"));
      }
      cameras.push_back(*c);
    }
  } else if (!scene.cameras.empty()) {
    cameras = scene.cameras;
  } else {
    cameras.push_back(automaticCamera(scene));
  }
  glm::vec3 light = chooseLight(scene, o, log);
  log << "scene " << scene.name << ": " << scene.triangleCount() << " triangles, " << cameras.size() << " view(s), "
      << settings.size() << " method setting(s), " << o.width << "x" << o.height << std::endl;

  vk::ContextOptions co;
  co.device = o.device;
  co.validation = o.validation;
  co.quiet = true;
  auto ctx = vk::createContext(co);
  std::string device = ctx->driverDescription();
  log << "device: " << device << std::endl;

  StagedDir out(o.out);
  std::vector<Row> rows;
  Raster raster(*ctx, scene);
  EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  for (size_t vi = 0; vi < cameras.size(); ++vi) {
    const Camera& camera = cameras[vi];
    std::string view = camera.name.empty() ? "auto" : camera.name;
    std::string tag = "[view " + std::to_string(vi + 1) + "/" + std::to_string(cameras.size()) + "] " + view + ": ";

    log << tag << "raster" << std::endl;
    DeviceGBuffer dev;
    GBuffer gb;
    raster.render(camera, light, o.width, o.height, dev, &gb);  // warm-up: pipeline compile
    RasterTiming rt = raster.render(camera, light, o.width, o.height, dev, &gb);
    size_t lit = gb.litCount();

    FrameInput frame = frameInput(scene, gb, dev, *ctx, light, policy.eps);

    auto progress = [&](const std::string& label) {
      return [&log, tag, label](uint32_t f, uint32_t n) {
        if (f == 0) log << tag << label << " warm-up" << std::endl;
        else log << tag << label << " frame " << f << "/" << n << std::endl;
      };
    };
    EmbreeReference reference;
    Timed ref = runTimed(reference, frame, o.frames, log, progress("embree (reference)"));
    log << tag << "ambiguity band" << std::endl;
    std::vector<uint8_t> band = reference.ambiguityBand(scene, gb, light, policy, {}, nullptr);
    size_t bandCount = size_t(std::count_if(band.begin(), band.end(), [](uint8_t b) { return b != 0; }));

    auto addRow = [&](const CompareSetting& s, Timed& t) {
      ErrorStats err = compareVisibility(gb, t.output.visibility, ref.output.visibility, band);
      Row row;
      row.setting = s.label;
      row.result = makeFrameResult(scene.name, view, s.method, gb, s.method == "embree" ? "cpu (embree)" : device,
                                   t.output, err);
      row.msMin = *std::min_element(t.totals.begin(), t.totals.end());
      row.msMax = *std::max_element(t.totals.begin(), t.totals.end());
      nlohmann::json& st = row.result.stats;
      st["setting"] = s.label;
      st["gpu"] = device;
      st["frames"] = o.frames;
      st["total_ms_min"] = row.msMin;
      st["total_ms_max"] = row.msMax;
      st["deterministic"] = t.deterministic;
      st["raster_ms"] = rt.gpuMs;
      st["lit_samples"] = lit;
      st["band_samples"] = bandCount;
      writeFrameImages(out.path(), view + "_" + s.label, gb, t.output.visibility, ref.output.visibility, band);
      rows.push_back(std::move(row));
    };

    for (auto& s : settings) {
      if (s.method == "embree") {
        addRow(s, ref);
        continue;
      }
      auto method = makeMethod(s.method, ctx.get(), s.options);
      Timed t = runTimed(*method, frame, o.frames, log, progress(s.label));
      addRow(s, t);
    }
  }

  log << "writing reports" << std::endl;
  std::vector<FrameResult> results;
  for (auto& r : rows) results.push_back(r.result);
  writeResults(out.path(), results);
  std::string dir = out.path();
  writeFileAtomic((fs::path(dir) / "report.md").string(),
                  reportMd(scene.name, device, o.width, o.height, o.frames, rows));
  writeFileAtomic((fs::path(dir) / "report.html").string(),
                  reportHtml(scene.name, device, o.width, o.height, o.frames, rows));
  writeFileAtomic((fs::path(dir) / "speed_vs_error.svg").string(), speedVsErrorSvg(rows));
  out.commit();

  std::cout << "result: compared " << settings.size() << " method setting(s) on " << cameras.size() << " view(s) of "
            << scene.name << " at " << o.width << "x" << o.height << "; wrote " << o.out << "/ (report.md, report.html, "
            << "speed_vs_error.svg, results.json, results.csv, " << rows.size() * 3 << " images)\n";
  return kExitOk;
}

}  // namespace cs
