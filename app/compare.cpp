// `coneshadow compare`: see compare.h.
#include "app/compare.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "app/commands.h"
#include "app/dynamic.h"
#include "app/frame_runner.h"
#include "app/scaling.h"
#include "app/svg_plot.h"
#include "core/image_io.h"
#include "eval/frame_output.h"
#include "eval/metrics.h"
#include "harness/harness.h"
#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "eval/epsilon.h"
#include "vk/context.h"

namespace fs = std::filesystem;

namespace cs {

std::vector<CompareSetting> compareSettings(const Options& o) {
  std::vector<CompareSetting> out;
  for (const MethodInfo* m : chosenMethods(o))
    for (SweepPoint& p : sweepOf(*m, settingsFor(o, *m))) out.push_back({m, p.label, std::move(p.settings)});
  return out;
}

CropWindow boundaryWindow(const GBuffer& gb, const std::vector<float>& reference) {
  const uint32_t W = gb.width, H = gb.height;
  CropWindow c;
  c.width = std::max(1u, W / 4);
  c.height = std::max(1u, H / 4);
  c.x = (W - c.width) / 2;
  c.y = (H - c.height) / 2;
  if (W == 0 || H == 0 || reference.size() != gb.size()) return c;
  // Summed-area table of boundary pixels, one row and column of zeros in front.
  std::vector<uint32_t> sat(size_t(W + 1) * (H + 1), 0);
  auto at = [&](uint32_t x, uint32_t y) -> uint32_t& { return sat[size_t(y) * (W + 1) + x]; };
  auto lit = [&](size_t i) { return gb.isLit(i); };
  auto dark = [&](size_t i) { return reference[i] < 0.5f; };
  for (uint32_t y = 0; y < H; ++y)
    for (uint32_t x = 0; x < W; ++x) {
      size_t i = size_t(y) * W + x;
      bool edge = false;
      if (lit(i)) {
        if (x + 1 < W && lit(i + 1) && dark(i + 1) != dark(i)) edge = true;
        if (y + 1 < H && lit(i + W) && dark(i + W) != dark(i)) edge = true;
      }
      at(x + 1, y + 1) = uint32_t(edge) + at(x, y + 1) + at(x + 1, y) - at(x, y);
    }
  uint32_t best = 0;
  for (uint32_t y = 0; y + c.height <= H; ++y)
    for (uint32_t x = 0; x + c.width <= W; ++x) {
      uint32_t n = at(x + c.width, y + c.height) - at(x, y + c.height) - at(x + c.width, y) + at(x, y);
      if (n > best) {
        best = n;
        c.x = x;
        c.y = y;
      }
    }
  return c;
}

std::vector<uint8_t> closeupStrip(const std::vector<std::vector<uint8_t>>& images, uint32_t width, CropWindow crop,
                                  uint32_t scale, uint32_t gap, uint32_t& stripWidth, uint32_t& stripHeight) {
  const uint32_t n = uint32_t(images.size()), tw = crop.width * scale;
  stripWidth = n ? n * tw + (n - 1) * gap : 0;
  stripHeight = crop.height * scale;
  std::vector<uint8_t> rgb(size_t(stripWidth) * stripHeight * 3, 0);  // black gaps
  for (uint32_t k = 0; k < n; ++k)
    for (uint32_t y = 0; y < stripHeight; ++y)
      for (uint32_t x = 0; x < tw; ++x) {
        size_t src = (size_t(crop.y + y / scale) * width + crop.x + x / scale) * 3;
        size_t dst = (size_t(y) * stripWidth + k * (tw + gap) + x) * 3;
        for (int ch = 0; ch < 3; ++ch) rgb[dst + ch] = images[k][src + ch];
      }
  return rgb;
}

namespace {

struct Row {
  FrameResult result;
  std::string setting;
  std::string stem;  // the view's file-name stem (fileStem, unique in the run)
  double msMin = 0, msMax = 0;
};

// The close-up strip of one view, as the reports describe it.
struct Closeup {
  std::string view, file;
  CropWindow crop;
  uint32_t scale = 1;
  std::vector<std::string> order;  // tiles left to right
};

std::string closeupText(const Closeup& c) {
  std::string order;
  for (auto& l : c.order) order += (order.empty() ? "" : ", ") + l;
  return "close-ups (shaded, pixels " + std::to_string(c.crop.x) + "," + std::to_string(c.crop.y) + " size " +
         std::to_string(c.crop.width) + "x" + std::to_string(c.crop.height) + ", enlarged " + std::to_string(c.scale) +
         "x nearest-neighbour; the window with the most reference shadow-boundary pixels), left to right: " + order;
}

std::string num(double v, int prec) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}

std::string pct(double fraction) { return num(fraction * 100.0, 4) + "%"; }

std::string imageName(const Row& r, const std::string& kind) {
  return r.stem + "_" + r.setting + "_" + kind + ".png";
}

// "name ms, ..." of a row's stages, in execution order.
std::string stagesCell(const Row& r) {
  std::string out;
  for (const StageTime& st : r.result.stages) out += (out.empty() ? "" : ", ") + st.name + " " + num(st.ms, 2);
  return out;
}

// The method's own measure of its work (MethodOutput::work): nodes visited, pages, faces, rays.
std::string workCell(const Row& r) {
  const nlohmann::json& s = r.result.stats;
  return s.contains("work") && s["work"].is_string() ? s["work"].get<std::string>() : "—";
}

// The table cells of one row, shared by report.md and report.html.
std::vector<std::string> cells(const Row& r) {
  const ErrorStats& e = r.result.error;
  return {r.setting,
          num(r.result.totalMs, 3) + " (" + num(r.msMin, 3) + "–" + num(r.msMax, 3) + ")",
          stagesCell(r),
          pct(e.misclassifiedFraction) + " (" + pct(e.misclassifiedFractionOutsideBand) + ")",
          std::to_string(e.falseShadow) + " / " + std::to_string(e.falseLight) + " (" +
              std::to_string(e.falseShadowOutsideBand) + " / " + std::to_string(e.falseLightOutsideBand) + ")",
          num(e.meanAbsError, 6) + " (" + num(e.meanAbsErrorOutsideBand, 6) + ")",
          num(double(r.result.bytes) / (1024.0 * 1024.0), 2),
          workCell(r)};
}

const std::vector<std::string> kHeader = {"method/setting",
                                          "ms median (min–max)",
                                          "ms per stage",
                                          "misclassified % (outside band)",
                                          "false shadow / false light (outside band)",
                                          "MAE (outside band)",
                                          "MiB",
                                          "work"};

std::vector<std::string> viewOrder(const std::vector<Row>& rows) {
  std::vector<std::string> views;
  for (auto& r : rows)
    if (std::find(views.begin(), views.end(), r.result.view) == views.end()) views.push_back(r.result.view);
  return views;
}

bool anyProgressive(const std::vector<Row>& rows) {
  return std::any_of(rows.begin(), rows.end(), [](const Row& r) { return r.result.stats.contains("per_frame"); });
}

// Progressive methods frame by frame (the warm-up is frame 1): per view, each frame's misclassified
// fraction and the time spent up to it.
std::string convergenceMd(const std::vector<Row>& rows) {
  std::ostringstream os;
  os << "\n## Convergence of progressive methods\n\nEach frame of a static view refines the method's structure; "
        "frame 1 is the warm-up. Cells: misclassified (cumulative ms). The one-frame methods' answers stand beside "
        "them in the plot at frame 1.\n\n![convergence](convergence.png)\n\n(vector: convergence.svg)\n";
  for (const Row& r : rows) {
    if (!r.result.stats.contains("per_frame")) continue;
    os << "\n" << r.result.view << " / " << r.setting << ":";
    for (const auto& f : r.result.stats["per_frame"])
      os << " " << f["frame"].get<int>() + 1 << ": " << pct(f["misclassified_fraction"].get<double>()) << " ("
         << num(f["cumulative_ms"].get<double>(), 4) << " ms);";
    os << "\n";
  }
  return os.str();
}

// Per view, error against frame index and against cumulative time: one curve per progressive row of the
// view, every other non-reference row of the view a point at frame 1 and its own time (what it answers
// with no iteration). Two panels a view, so every legend stays short.
std::string convergenceSvg(const std::vector<Row>& rows) {
  std::vector<LogPanel> panels;
  for (const std::string& view : viewOrder(rows)) {
    LogPanel byFrame, byTime;
    byFrame.xLabel = view + ": frame (log scale; 1 = the warm-up)";
    byTime.xLabel = view + ": cumulative shadow time, ms (log scale)";
    for (LogPanel* p : {&byFrame, &byTime}) {
      p->yLabel = "misclassified fraction (log; 0 at the floor)";
      p->yFloor = 1e-7;
      p->fixedY = true;
      p->yMinDecade = -7;
      p->yMaxDecade = 0;
    }
    PlotSeries oneFrame{"one-frame methods", {}, false}, oneFrameTime{"one-frame methods", {}, false};
    for (const Row& r : rows) {
      if (r.result.view != view || r.result.method == referenceMethod().name) continue;
      if (!r.result.stats.contains("per_frame")) {
        const double e = r.result.error.misclassifiedFraction;
        oneFrame.points.push_back({1.0, e, r.setting + ": " + pct(e)});
        oneFrameTime.points.push_back({std::max(r.result.totalMs, 1e-3), e, r.setting + ": " + pct(e)});
        continue;
      }
      PlotSeries a{r.setting, {}, true}, b{r.setting, {}, true};
      for (const auto& f : r.result.stats["per_frame"]) {
        const double e = f["misclassified_fraction"].get<double>();
        const int k = f["frame"].get<int>() + 1;
        a.points.push_back({double(k), e, r.setting + " frame " + std::to_string(k) + ": " + pct(e)});
        b.points.push_back({std::max(f["cumulative_ms"].get<double>(), 1e-3), e, r.setting + " frame " + std::to_string(k)});
      }
      byFrame.series.push_back(std::move(a));
      byTime.series.push_back(std::move(b));
    }
    if (byFrame.series.empty()) continue;
    byFrame.series.push_back(std::move(oneFrame));
    byTime.series.push_back(std::move(oneFrameTime));
    panels.push_back(std::move(byFrame));
    panels.push_back(std::move(byTime));
  }
  return logPlotSvg(panels, 760, 320);
}

std::string reportMd(const std::string& sceneName, const std::string& device, uint32_t w, uint32_t h,
                     uint32_t frames, const std::vector<Row>& rows, const std::vector<Closeup>& closeups) {
  std::ostringstream os;
  os << "# coneshadow compare: " << sceneName << "\n\n"
     << "device: " << device << "\n\n"
     << w << "x" << h << ", median of " << frames
     << " frame(s) after one warm-up; misclassified over lit samples against Embree (in parentheses: outside "
        "the ambiguity band); false shadow / false light in samples; MiB allocated by the method; work: the method's own "
        "measure of what it did (for the cone path, nodes visited = (triangle, cone) pairs tested).\n";
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
    for (auto& c : closeups)
      if (c.view == v) os << "\n" << closeupText(c) << "\n\n![" << v << " close-ups](" << c.file << ")\n";
  }
  os << "\n## Speed against error\n\n![speed vs error](speed_vs_error.png)\n\n(vector: speed_vs_error.svg)\n";
  if (anyProgressive(rows)) os << convergenceMd(rows);
  return os.str();
}

std::string reportHtml(const std::string& sceneName, const std::string& device, uint32_t w, uint32_t h,
                       uint32_t frames, const std::vector<Row>& rows, const std::vector<Closeup>& closeups) {
  std::ostringstream os;
  os << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>coneshadow compare: " << htmlEscape(sceneName)
     << "</title>\n<style>body{font-family:sans-serif}table{border-collapse:collapse}td,th{border:1px solid #bbb;"
        "padding:3px 6px;text-align:right}td:first-child{text-align:left}img{image-rendering:pixelated;"
        "width:160px}img.closeup{width:auto;max-width:100%}</style></head><body>\n"
     << "<h1>coneshadow compare: " << htmlEscape(sceneName) << "</h1>\n<p>device: " << htmlEscape(device)
     << "</p>\n<p>" << w << "x" << h << ", median of " << frames
     << " frame(s) after one warm-up; misclassified over lit samples against Embree (in parentheses: outside the "
        "ambiguity band).</p>\n<p><a href=\"speed_vs_error.svg\"><img style=\"width:720px\" src=\"speed_vs_error.png\" "
        "alt=\"speed vs error\"></a></p>\n";
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
    for (auto& c : closeups)
      if (c.view == v)
        os << "<p>" << htmlEscape(closeupText(c)) << "</p>\n<p><img class=\"closeup\" src=\"" << htmlEscape(c.file)
           << "\" alt=\"" << htmlEscape(v) << " close-ups\"></p>\n";
  }
  os << "</body></html>\n";
  return os.str();
}

// Speed (x, log ms) against error (y, log misclassified fraction, exact zeros at a floor labelled "0"),
// one colour per method.
std::string speedVsErrorSvg(const std::vector<Row>& rows) {
  LogPanel panel;
  panel.xLabel = "shadow time per frame, ms (log scale)";
  panel.yLabel = "misclassified fraction of lit samples (log; 0 at the floor)";
  panel.yFloor = 1e-7;
  panel.fixedY = true;
  panel.yMinDecade = -7;
  panel.yMaxDecade = 0;
  for (auto& r : rows) {
    auto it = std::find_if(panel.series.begin(), panel.series.end(),
                           [&](const PlotSeries& s) { return s.name == r.result.method; });
    if (it == panel.series.end()) it = panel.series.insert(panel.series.end(), PlotSeries{r.result.method, {}, false});
    it->points.push_back({std::max(r.result.totalMs, 1e-3), r.result.error.misclassifiedFraction,
                          r.result.view + " " + r.setting + ": " + num(r.result.totalMs, 3) + " ms, " +
                              pct(r.result.error.misclassifiedFraction) + " misclassified"});
  }
  return logPlotSvg({panel});
}

// Steps done of a known total, and the time left at the mean step so far.
class Eta {
 public:
  explicit Eta(size_t total) : total_(total), start_(std::chrono::steady_clock::now()) {}
  void step() { ++done_; }
  // " (step k of N, about T left)", or "" before the first step is done.
  std::string text() const {
    if (done_ == 0 || done_ >= total_) return "";
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const double left = elapsed / double(done_) * double(total_ - done_);
    const std::string t = left < 90 ? std::to_string(int(std::ceil(left))) + " s" : std::to_string(int(std::ceil(left / 60))) + " min";
    return " (step " + std::to_string(done_ + 1) + " of " + std::to_string(total_) + ", about " + t + " left)";
  }

 private:
  size_t total_, done_ = 0;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace

int runCompare(const Options& o) {
  if (o.animateFrames) return runDynamicCompare(o);
  if (o.scaling || !o.lightDistances.empty()) return runScaling(o);
  ProgressLog progressLog(o.quiet);
  std::ostream& log = progressLog.stream();

  std::vector<CompareSetting> settings = compareSettings(o);  // parseArgs checked the methods and settings

  Scene scene = loadSceneArg(o, std::cerr);
  std::vector<Camera> cameras = selectViews(scene, o);
  glm::vec3 light = chooseLight(scene, o);
  log << "scene " << scene.name << ": " << scene.triangleCount() << " triangles, " << cameras.size() << " view(s), "
      << settings.size() << " method setting(s), " << o.width << "x" << o.height << std::endl;

  auto ctx = commandContext(o);
  std::string device = ctx->driverDescription();
  log << "device: " << device << std::endl;

  StagedDir out(o.out);
  std::vector<Row> rows;
  std::vector<Closeup> closeups;
  std::vector<std::string> stems;
  Raster raster(*ctx, scene);
  Eta eta(cameras.size() * (settings.size() + 1));  // per view: the reference, then each setting
  for (size_t vi = 0; vi < cameras.size(); ++vi) {
    FrameSpec spec;
    spec.camera = cameras[vi];
    spec.view = spec.camera.name.empty() ? "auto" : spec.camera.name;
    spec.light = light;
    spec.width = o.width;
    spec.height = o.height;
    spec.frames = o.frames;
    const std::string& view = spec.view;
    // File names from the view's name, made safe (a camera named "../../x" writes nothing outside --out)
    // and unique (two views that differ only in unsafe characters do not overwrite each other).
    std::string stem = fileStem(view);
    for (int k = 2; std::find(stems.begin(), stems.end(), stem) != stems.end(); ++k)
      stem = fileStem(view) + "-" + std::to_string(k);
    stems.push_back(stem);
    std::string tag = "[view " + std::to_string(vi + 1) + "/" + std::to_string(cameras.size()) + "] " + view + ": ";

    // Progress: the step, and from the second step on the estimated time left (the mean step so far).
    auto progress = [&](const std::string& label) {
      return [&log, &eta, tag, label](uint32_t f, uint32_t n) {
        if (f == 0) log << tag << label << " warm-up" << eta.text() << std::endl;
        else log << tag << label << " frame " << f << "/" << n << std::endl;
      };
    };
    const std::string referenceName = referenceMethod().name;
    std::unique_ptr<PreparedFrame> frame = prepareFrame(
        *ctx, raster, scene, spec,
        [&](const std::string& step) {
          if (step != "reference") log << tag << (step == "band" ? "ambiguity band" : step) << std::endl;
        },
        progress(referenceName + " (reference)"));
    eta.step();
    const std::vector<float>& reference = frame->reference.output.visibility;
    const nlohmann::json provenance = runProvenance(o, scene, light, spec.camera);

    Closeup closeup;
    closeup.view = view;
    closeup.file = stem + "_closeups.png";
    std::vector<std::vector<uint8_t>> shaded;
    auto show = [&](const std::string& label, const std::vector<float>& visibility) {
      shaded.push_back(shadedImage(frame->gbuffer, visibility));
      closeup.order.push_back(label);
    };
    show(referenceName, reference);
    for (const CompareSetting& s : settings) {
      Judged j = judge(*s.method, s.settings, *ctx, *frame, o.frames, progress(s.label));
      eta.step();
      if (!s.method->reference) show(s.label, j.runs.output.visibility);
      Row row;
      row.setting = s.label;
      row.stem = stem;
      row.result = resultRow(*s.method, s.label, *frame, j);
      row.result.provenance = provenance;
      row.msMin = j.runs.minMs;
      row.msMax = j.runs.maxMs;
      writeFrameImages(out.path(), stem + "_" + s.label, frame->gbuffer, j.runs.output.visibility, reference, frame->band);
      rows.push_back(std::move(row));
    }
    // Enlarged to about 256 pixels a tile, at least 2x, so single-pixel aliasing is visible.
    closeup.crop = boundaryWindow(frame->gbuffer, reference);
    closeup.scale = std::max(2u, (256 + closeup.crop.width - 1) / closeup.crop.width);
    uint32_t sw = 0, sh = 0;
    std::vector<uint8_t> strip = closeupStrip(shaded, frame->gbuffer.width, closeup.crop, closeup.scale, 4, sw, sh);
    writePng((fs::path(out.path()) / closeup.file).string(), sw, sh, strip);
    closeups.push_back(std::move(closeup));
  }

  log << "writing reports" << std::endl;
  std::vector<FrameResult> results;
  for (auto& r : rows) results.push_back(r.result);
  writeResults(out.path(), results);
  std::string dir = out.path();
  writeFileAtomic((fs::path(dir) / "report.md").string(),
                  reportMd(scene.name, device, o.width, o.height, o.frames, rows, closeups));
  writeFileAtomic((fs::path(dir) / "report.html").string(),
                  reportHtml(scene.name, device, o.width, o.height, o.frames, rows, closeups));
  writeFileAtomic((fs::path(dir) / "speed_vs_error.svg").string(), speedVsErrorSvg(rows));
  svgToPng((fs::path(dir) / "speed_vs_error.svg").string(), (fs::path(dir) / "speed_vs_error.png").string());
  if (anyProgressive(rows)) {
    writeFileAtomic((fs::path(dir) / "convergence.svg").string(), convergenceSvg(rows));
    svgToPng((fs::path(dir) / "convergence.svg").string(), (fs::path(dir) / "convergence.png").string());
  }
  out.commit();

  std::cout << "result: compared " << settings.size() << " method setting(s) on " << cameras.size() << " view(s) of "
            << scene.name << " at " << o.width << "x" << o.height << "; wrote " << o.out << "/ (report.md, report.html, "
            << "speed_vs_error.svg/.png, results.json, results.csv, " << rows.size() * 3 << " images, "
            << closeups.size() << " close-up strip(s))\n";
  return kExitOk;
}

}  // namespace cs
