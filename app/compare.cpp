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
#include "judge/frame_output.h"
#include "judge/metrics.h"
#include "harness/harness.h"
#include "harness/run.h"
#include "method/epsilon.h"
#include "vk/context.h"

namespace fs = std::filesystem;

namespace cs {

std::vector<CompareSetting> compareSettings(const Options& o) {
  std::vector<CompareSetting> out;
  for (const MethodInfo* m : chosenMethods(o))
    for (SweepPoint& p : sweepOf(*m, settingsFor(o, *m))) out.push_back({m, p.label, std::move(p.settings), p.defaults});
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
  std::string view;  // the report's view: the camera's name, and its light when the run has several ("wall, light 1")
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

// Report thumbnails: images with a longer side above this are shown shrunk (judge/frame_output.h: shrinkKeepingErrors).
constexpr uint32_t kThumbnailSide = 256;

std::string imageName(const Row& r, const std::string& kind) {
  return r.stem + "_" + r.setting + "_" + kind + ".png";
}

// "name ms, ..." of a row's stages, in execution order.
std::string stagesCell(const Row& r) {
  std::string out;
  for (const StageTime& st : r.result.stages) out += (out.empty() ? "" : ", ") + st.name + " " + num(st.ms, 2);
  return out;
}

double mib(const Row& r) { return double(r.result.bytes) / (1024.0 * 1024.0); }

// The method's own measure of its work (MethodOutput::work): nodes visited, pages, faces, rays.
std::string workCell(const Row& r) {
  const nlohmann::json& s = r.result.stats;
  return s.contains("work") && s["work"].is_string() ? s["work"].get<std::string>() : "—";
}

// The table cells of one row, shared by report.md and report.html (stages have a table of their own).
std::vector<std::string> cells(const Row& r) {
  const ErrorStats& e = r.result.error;
  return {r.setting,
          num(r.result.totalMs, 3) + " (" + num(r.msMin, 3) + "–" + num(r.msMax, 3) + ")",
          pct(e.misclassifiedFractionOutsideBand) + " (" + pct(e.misclassifiedFraction) + ")",
          std::to_string(e.falseShadowOutsideBand) + " / " + std::to_string(e.falseLightOutsideBand) + " (" +
              std::to_string(e.falseShadow) + " / " + std::to_string(e.falseLight) + ")",
          num(e.meanAbsErrorOutsideBand, 6) + " (" + num(e.meanAbsError, 6) + ")",
          num(mib(r), 2),
          workCell(r)};
}

const std::vector<std::string> kHeader = {"method/setting",
                                          "ms median (min–max)",
                                          "misclassified % outside band (all)",
                                          "false shadow / false light outside band (all)",
                                          "MAE outside band (all)",
                                          "MiB",
                                          "work"};

std::vector<std::string> viewOrder(const std::vector<Row>& rows) {
  std::vector<std::string> views;
  for (auto& r : rows)
    if (std::find(views.begin(), views.end(), r.view) == views.end()) views.push_back(r.view);
  return views;
}

// The verdict of one view, among the methods (the reference is the ground truth, not a candidate): the
// fastest exact setting (nothing misclassified outside the ambiguity band), the fastest and the smallest
// in memory with at most kGoodFraction misclassified outside the band.
constexpr double kGoodFraction = 0.001;
struct Verdict {
  const Row* fastestExact = nullptr;
  const Row* fastestGood = nullptr;
  const Row* smallestGood = nullptr;
  std::string undecided;  // why the view is undecided (its band covers too many samples); "" when decided
};

Verdict verdictOf(const std::vector<Row>& rows, const std::string& view) {
  Verdict v;
  for (const Row& r : rows) {
    if (r.view != view || r.result.method == referenceMethod().name) continue;
    if (r.result.error.undecided) {  // the band swallowed the answer: no row is exact or good here
      v.undecided = r.result.error.undecidedReason();
      continue;
    }
    const double e = r.result.error.misclassifiedFractionOutsideBand;
    const bool exact = r.result.error.misclassifiedOutsideBand == 0;
    if (exact && (!v.fastestExact || r.result.totalMs < v.fastestExact->result.totalMs)) v.fastestExact = &r;
    if (e <= kGoodFraction) {
      if (!v.fastestGood || r.result.totalMs < v.fastestGood->result.totalMs) v.fastestGood = &r;
      if (!v.smallestGood || r.result.bytes < v.smallestGood->result.bytes) v.smallestGood = &r;
    }
  }
  return v;
}

std::string verdictCell(const Row* r) {
  if (!r) return "none";
  const ErrorStats& e = r->result.error;
  return r->setting + ": " + num(r->result.totalMs, 1) + " ms, " +
         (e.misclassifiedOutsideBand == 0 ? std::string("0 %") : pct(e.misclassifiedFractionOutsideBand)) +
         " outside the band, " + num(mib(*r), 1) + " MiB";
}

const std::vector<std::string> kVerdictHeader = {"view", "fastest exact (0 outside the band)",
                                                 "fastest at ≤ 0.1 % outside the band",
                                                 "least memory at ≤ 0.1 % outside the band", "reference (Embree) ms"};

std::vector<std::string> verdictCells(const std::vector<Row>& rows, const std::string& view) {
  const Verdict v = verdictOf(rows, view);
  std::string reference = "—";
  for (const Row& r : rows)
    if (r.view == view && r.result.method == referenceMethod().name) reference = num(r.result.totalMs, 1);
  if (!v.undecided.empty()) {
    const std::string cell = "undecided: " + v.undecided;
    return {view, cell, cell, cell, reference};
  }
  return {view, verdictCell(v.fastestExact), verdictCell(v.fastestGood), verdictCell(v.smallestGood), reference};
}

const char* kVerdictText =
    "Among the methods on these samples, per view: the fastest that misclassifies nothing outside the ambiguity band, "
    "the fastest and the smallest in memory that misclassify at most 0.1 % of the lit samples outside it (times are "
    "medians per frame; the reference, Embree, is the ground truth and not a candidate). A view whose ambiguity band "
    "covers more than 1 % of its lit samples is undecided: fp32 rounding can flip that many answers, so no method is "
    "called exact or good there.";

const char* kLegendMd =
    "Images, per setting: *shaded* (the method's shadows), *mask* (white: lit sample called lit; black: lit sample "
    "called shadowed; grey: not a lit sample), *diff* against Embree (red: false shadow; blue-cyan: false light; "
    "yellow: disagreement inside the ambiguity band; dimmed shading: agreement). Thumbnails of images larger than "
    "256 pixels are shrunk so that no error pixel disappears (a block with a red or blue pixel is red or blue); click "
    "for full size.";

// The stages of every row of a view, in execution order.
std::vector<std::string> stageHeader() { return {"method/setting", "ms per stage (execution order)"}; }

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
    os << "\n" << r.view << " / " << r.setting << ":";
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
      if (r.view != view || r.result.method == referenceMethod().name) continue;
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
                     uint32_t frames, const std::vector<Row>& rows, const std::vector<Closeup>& closeups,
                     const std::vector<std::string>& skipped) {
  std::ostringstream os;
  auto table = [&](const std::vector<std::string>& header) {
    os << "|";
    for (auto& hcell : header) os << " " << hcell << " |";
    os << "\n|";
    for (size_t i = 0; i < header.size(); ++i) os << (i ? " ---: |" : " --- |");
    os << "\n";
  };
  auto row = [&](const std::vector<std::string>& cellsOfRow) {
    os << "|";
    for (auto& c : cellsOfRow) os << " " << c << " |";
    os << "\n";
  };
  os << "# coneshadow compare: " << sceneName << "\n\n"
     << "device: " << device << "\n\n";
  if (!skipped.empty()) {
    os << "Not run on this device:\n\n";
    for (const std::string& s : skipped) os << "- " << s << "\n";
    os << "\n";
  }
  os
     << w << "x" << h << ", median of " << frames << " frame(s) after one warm-up.\n\n## Verdict\n\n"
     << kVerdictText << "\n\n";
  table(kVerdictHeader);
  for (auto& v : viewOrder(rows)) row(verdictCells(rows, v));
  os << "\n" << kLegendMd << "\n\n## Speed against error\n\n![speed vs error](speed_vs_error.png)\n\n"
     << "(vector: speed_vs_error.svg) One panel per view, one line per method through its settings in sweep order; y: "
        "misclassified outside the ambiguity band, exact results on the floor labelled 0; marker area: bytes.\n\n"
     << "## Error against memory\n\n![error vs memory](error_vs_bytes.png)\n\n(vector: error_vs_bytes.svg)\n\n"
     << "Cells below: misclassified over lit samples against Embree, outside the ambiguity band (in parentheses: all); "
        "false shadow / false light in samples; MiB allocated by the method; work: the method's own measure of what "
        "it did (for the cone path, nodes visited = (triangle, cone) pairs tested).\n";
  for (auto& v : viewOrder(rows)) {
    os << "\n## " << v << "\n\n";
    table(kHeader);
    for (auto& r : rows)
      if (r.view == v) row(cells(r));
    os << "\nStages:\n\n";
    table(stageHeader());
    for (auto& r : rows)
      if (r.view == v) row({r.setting, stagesCell(r)});
    for (auto& c : closeups)
      if (c.view == v) os << "\n" << closeupText(c) << "\n\n![" << v << " close-ups](" << c.file << ")\n";
  }
  if (anyProgressive(rows)) os << convergenceMd(rows);
  return os.str();
}

// A report image: thumbnails at 1:1 (shrunk keeping errors), small images enlarged by a whole factor with
// crisp pixels; every one links to its full-size file.
std::string htmlImage(const std::string& file, const std::string& thumb, uint32_t w, uint32_t h, const std::string& alt) {
  const uint32_t longer = std::max({w, h, 1u});
  const uint32_t scale = longer >= kThumbnailSide ? 1u : std::max(1u, kThumbnailSide / longer);
  return "<a href=\"" + htmlEscape(file) + "\"><img class=\"px\" src=\"" + htmlEscape(thumb) + "\" width=\"" +
         std::to_string(w * scale) + "\" height=\"" + std::to_string(h * scale) + "\" alt=\"" + htmlEscape(alt) + "\"></a>";
}

std::string swatch(const uint8_t rgb[3], const std::string& text) {
  std::ostringstream os;
  os << "<span class=\"sw\" style=\"background:rgb(" << int(rgb[0]) << "," << int(rgb[1]) << "," << int(rgb[2])
     << ")\"></span>" << htmlEscape(text);
  return os.str();
}

std::string reportHtml(const std::string& sceneName, const std::string& device, uint32_t w, uint32_t h,
                       uint32_t frames, const std::vector<Row>& rows, const std::vector<Closeup>& closeups,
                       const std::string& speedSvg, const std::string& bytesSvg, uint32_t thumbFactor,
                       const std::vector<std::string>& skipped) {
  std::ostringstream os;
  auto table = [&](const std::vector<std::string>& header, const std::string& cls) {
    os << "<table class=\"" << cls << "\">\n<tr>";
    for (auto& hcell : header) os << "<th>" << htmlEscape(hcell) << "</th>";
    os << "</tr>\n";
  };
  auto row = [&](const std::vector<std::string>& cellsOfRow) {
    os << "<tr>";
    for (auto& c : cellsOfRow) os << "<td>" << htmlEscape(c) << "</td>";
    os << "</tr>\n";
  };
  const uint8_t white[3] = {255, 255, 255}, black[3] = {0, 0, 0},
                grey[3] = {kNotLitMaskGrey, kNotLitMaskGrey, kNotLitMaskGrey}, dim[3] = {100, 100, 100};
  os << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>coneshadow compare: " << htmlEscape(sceneName)
     << "</title>\n<style>body{font-family:sans-serif;max-width:1360px;margin:8px auto;padding:0 12px}"
        "table{border-collapse:collapse;max-width:100%}td,th{border:1px solid #bbb;padding:3px 6px;text-align:right;"
        "overflow-wrap:break-word}td:first-child{text-align:left}table.verdict td{text-align:left}"
        "img.px{image-rendering:pixelated;image-rendering:crisp-edges;display:block}"
        "img.closeup{max-width:100%;height:auto;image-rendering:pixelated}svg{max-width:100%;height:auto}"
        ".sw{display:inline-block;width:14px;height:14px;border:1px solid #444;margin:0 4px 0 12px;"
        "vertical-align:middle}</style></head><body>\n"
     << "<h1>coneshadow compare: " << htmlEscape(sceneName) << "</h1>\n<p>device: " << htmlEscape(device)
     << "</p>\n";
  if (!skipped.empty()) {
    os << "<p>Not run on this device:</p>\n<ul>";
    for (const std::string& s : skipped) os << "<li>" << htmlEscape(s) << "</li>";
    os << "</ul>\n";
  }
  os << "<p>" << w << "x" << h << ", median of " << frames << " frame(s) after one warm-up.</p>\n<h2>Verdict</h2>\n<p>"
     << htmlEscape(kVerdictText) << "</p>\n";
  table(kVerdictHeader, "verdict");
  for (auto& v : viewOrder(rows)) row(verdictCells(rows, v));
  os << "</table>\n<p>Mask:" << swatch(white, "lit sample called lit") << swatch(black, "lit sample called shadowed")
     << swatch(grey, "not a lit sample") << "<br>Diff against Embree:" << swatch(kFalseShadowRgb, "false shadow")
     << swatch(kFalseLightRgb, "false light") << swatch(kBandDisagreeRgb, "disagreement inside the ambiguity band")
     << swatch(dim, "agreement (dimmed shading)") << "</p>\n<p>"
     << (thumbFactor > 1 ? "Images shrunk " + std::to_string(thumbFactor) +
                               "x so that no error pixel disappears (a block holding a red or blue pixel is red or "
                               "blue); click for full size."
                         : std::string("Images at 1:1 or enlarged by a whole factor; click for full size."))
     << "</p>\n<h2>Speed against error</h2>\n<p>One panel per view, one line per method through its settings in sweep "
        "order; y: misclassified outside the ambiguity band (exact results on the floor labelled 0); marker area: "
        "bytes; hover a marker for its numbers.</p>\n<div class=\"plot\">"
     << speedSvg << "</div>\n<h2>Error against memory</h2>\n<div class=\"plot\">" << bytesSvg << "</div>\n";
  for (auto& v : viewOrder(rows)) {
    os << "<h2>" << htmlEscape(v) << "</h2>\n";
    table(kHeader, "results");
    for (auto& r : rows)
      if (r.view == v) row(cells(r));
    os << "</table>\n<h3>Stages</h3>\n";
    table(stageHeader(), "stages");
    for (auto& r : rows)
      if (r.view == v) row({r.setting, stagesCell(r)});
    os << "</table>\n<h3>Images</h3>\n<table class=\"images\">\n<tr><th>method/setting</th><th>shaded</th><th>mask</th>"
          "<th>diff</th></tr>\n";
    for (auto& r : rows) {
      if (r.view != v) continue;
      os << "<tr><td>" << htmlEscape(r.setting) << "</td>";
      for (const char* kind : {"shaded", "mask", "diff"}) {
        const std::string file = imageName(r, kind), thumb = thumbFactor > 1 ? imageName(r, std::string(kind) + "_thumb") : file;
        os << "<td>" << htmlImage(file, thumb, (w + thumbFactor - 1) / thumbFactor, (h + thumbFactor - 1) / thumbFactor, kind)
           << "</td>";
      }
      os << "</tr>\n";
    }
    os << "</table>\n";
    for (auto& c : closeups)
      if (c.view == v)
        os << "<p>" << htmlEscape(closeupText(c)) << "</p>\n<p><a href=\"" << htmlEscape(c.file) << "\"><img class=\"closeup\" src=\""
           << htmlEscape(c.file) << "\" alt=\"" << htmlEscape(v) << " close-ups\"></a></p>\n";
  }
  os << "</body></html>\n";
  return os.str();
}

// Marker radius for `bytes` (area proportional to bytes, the largest of the run 14 px; at least 2.5 px).
double markerRadius(uint64_t bytes, uint64_t maxBytes) {
  return maxBytes ? std::max(2.5, 14.0 * std::sqrt(double(bytes) / double(maxBytes))) : 5.0;
}

// A floor one decade below the smallest nonzero value (1e-6 when all are zero): exact results sit on it.
double floorFor(const std::vector<double>& values) {
  double lo = 0;
  for (double v : values)
    if (v > 0 && (lo == 0 || v < lo)) lo = v;
  return lo > 0 ? std::pow(10.0, std::floor(std::log10(lo)) - 1.0) : 1e-6;
}

// Per view a panel: x = time (speed) or MiB (memory), y = misclassified fraction outside the band; one
// series per method through its settings in sweep order; marker area = bytes.
std::string tradeOffSvg(const std::vector<Row>& rows, bool memory) {
  std::vector<LogPanel> panels;
  uint64_t maxBytes = 0;
  for (const Row& r : rows) maxBytes = std::max(maxBytes, r.result.bytes);
  for (const std::string& view : viewOrder(rows)) {
    LogPanel panel;
    panel.title = view;
    panel.xLabel = memory ? "MiB allocated by the method (log scale)" : "shadow time per frame, ms (log scale)";
    panel.yLabel = "misclassified outside the band (log)";
    std::vector<double> errors;
    for (const Row& r : rows)
      if (r.view == view) errors.push_back(r.result.error.misclassifiedFractionOutsideBand);
    panel.yFloor = floorFor(errors);
    for (const Row& r : rows) {
      if (r.view != view) continue;
      if (memory && r.result.bytes == 0) continue;
      auto it = std::find_if(panel.series.begin(), panel.series.end(),
                             [&](const PlotSeries& s) { return s.name == r.result.method; });
      if (it == panel.series.end()) it = panel.series.insert(panel.series.end(), PlotSeries{r.result.method, {}, true});
      const double e = r.result.error.misclassifiedFractionOutsideBand;
      PlotPoint p{memory ? std::max(mib(r), 1e-3) : std::max(r.result.totalMs, 1e-3), e,
                  view + " " + r.setting + ": " + num(r.result.totalMs, 3) + " ms, " + pct(e) + " outside the band, " +
                      num(mib(r), 2) + " MiB"};
      p.radius = markerRadius(r.result.bytes, maxBytes);
      it->points.push_back(p);
    }
    panels.push_back(std::move(panel));
  }
  return logPlotSvg(panels, 1360, 360, 2);
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

// Removes the sweep points this device cannot run (MethodInfo::unsupported) and says why, in the log and
// in the lines returned for the report. A method the user named whose every point is unsupported is an
// error: nothing would answer what was asked.
std::vector<std::string> dropUnsupported(std::vector<CompareSetting>& settings, const vk::Context& ctx,
                                         const Options& o, std::ostream& log) {
  std::vector<std::string> skipped;
  std::vector<CompareSetting> kept;
  std::map<const MethodInfo*, std::string> reason;  // each method's first skipped point
  for (CompareSetting& s : settings) {
    const std::string why = unsupportedOn(*s.method, ctx, s.settings);
    if (why.empty()) {
      kept.push_back(std::move(s));
      continue;
    }
    skipped.push_back(s.label + ": " + why);
    reason.emplace(s.method, skipped.back());
    log << "skipping " << s.label << ": " << why << std::endl;
  }
  if (!o.methods.empty())
    for (const MethodInfo* m : chosenMethods(o)) {
      const bool any = std::any_of(kept.begin(), kept.end(), [&](const CompareSetting& s) { return s.method == m; });
      if (!any)
        throw Error("compare: no setting of " + m->name + " runs on this device (" +
                        (reason.count(m) ? reason[m] : std::string("it has none")) + ")",
                    ctx.deviceName(), "choose another --device, or leave " + m->name + " out of --methods");
    }
  settings = std::move(kept);
  return skipped;
}

}  // namespace

int runCompare(const Options& o) {
  if (o.animateFrames) return runDynamicCompare(o);
  if (o.scaling || !o.lightDistances.empty()) return runScaling(o);
  ProgressLog progressLog(o.quiet);
  std::ostream& log = progressLog.stream();

  std::vector<CompareSetting> settings = compareSettings(o);  // parseArgs checked the methods and settings

  Scene scene = loadSceneArg(o, std::cerr);
  std::vector<Camera> cameras = selectViews(scene, o);
  const std::vector<glm::vec3> lights = chooseLights(scene, o);
  // Several lights: each view under each, a frame of its own; its files and report section named by the
  // light's index.
  const bool several = lights.size() > 1;
  log << "scene " << scene.name << ": " << scene.triangleCount() << " triangles, " << cameras.size() << " view(s), "
      << settings.size() << " method setting(s), " << o.width << "x" << o.height << std::endl;

  auto ctx = commandContext(o);
  std::string device = ctx->driverDescription();
  log << "device: " << device << std::endl;
  const std::vector<std::string> skipped = dropUnsupported(settings, *ctx, o, log);

  StagedDir out(o.out, runInputs(o));
  std::vector<Row> rows;
  std::vector<Closeup> closeups;
  uint32_t thumbFactor = 1;
  Eta eta(cameras.size() * lights.size() * (settings.size() + 1));  // per frame: the reference, then each setting

  harness::RunSpec spec;
  spec.scene = &scene;
  spec.views = harness::viewsOf(cameras);
  spec.lights = lights;
  spec.width = o.width;
  spec.height = o.height;
  spec.frames = o.frames;
  spec.interleave = o.interleave;  // every setting's method made first, then their frames round-robin
  for (const CompareSetting& s : settings) spec.methods.push_back({s.method, s.label, s.settings, s.defaults});

  // File names from the view's name, made safe (a camera named "../../x" writes nothing outside --out)
  // and unique (two views that differ only in unsafe characters do not overwrite each other).
  std::vector<std::string> stems;
  for (const harness::RunView& v : spec.views) {
    std::string stem = fileStem(v.name);
    for (int k = 2; std::find(stems.begin(), stems.end(), stem) != stems.end(); ++k)
      stem = fileStem(v.name) + "-" + std::to_string(k);
    stems.push_back(stem);
  }
  auto viewOf = [&](const harness::Frame& f) {
    return several ? f.viewName + ", light " + std::to_string(f.light) : f.viewName;
  };
  auto tagOf = [&](const harness::Frame& f) {
    return "[view " + std::to_string(f.view + 1) + "/" + std::to_string(cameras.size()) + "] " + viewOf(f) + ": ";
  };
  const std::string referenceName = referenceMethod().name;
  harness::Events events;
  events.step = [&](const harness::Frame& f, const std::string& step) {
    if (step == "raster" || step == "band") log << tagOf(f) << (step == "band" ? "ambiguity band" : step) << std::endl;
    if (step == "methods") eta.step();  // the reference is done
  };
  // Progress: the step, and from the second step on the estimated time left (the mean step so far).
  events.progress = [&](const harness::Frame& f, size_t k) -> FrameProgress {
    const std::string label = k == harness::kReferenceRuns ? referenceName + " (reference)" : settings[k].label;
    return [&log, &eta, tag = tagOf(f), label](uint32_t fr, uint32_t n) {
      if (fr == 0) log << tag << label << " warm-up" << eta.text() << std::endl;
      else log << tag << label << " frame " << fr << "/" << n << std::endl;
    };
  };
  events.judged = [&](const harness::Frame&, const harness::Row&) { eta.step(); };
  // Each view's rows, images and close-up strip, while its frame is held.
  events.done = [&](const harness::Frame& f) {
    const PreparedFrame& frame = *f.prepared;
    const std::string stem = stems[f.view] + (several ? "_light" + std::to_string(f.light) : std::string());
    const std::vector<float>& reference = frame.reference.output.visibility;
    const nlohmann::json provenance = runProvenance(o, scene, f.lightPosition, f.camera);
    Closeup closeup;
    closeup.view = viewOf(f);
    closeup.file = stem + "_closeups.png";
    std::vector<std::vector<uint8_t>> shaded;
    auto show = [&](const std::string& label, const std::vector<float>& visibility) {
      shaded.push_back(shadedImage(frame.gbuffer, visibility));
      closeup.order.push_back(label);
    };
    show(referenceName, reference);
    for (const harness::Row& j : f.rows) {
      const CompareSetting& s = settings[j.method];
      const std::vector<float>& mask = j.judged.runs.output.visibility;
      if (!s.method->reference) show(s.label, mask);
      Row row;
      row.view = viewOf(f);
      row.setting = s.label;
      row.stem = stem;
      row.result = j.result;
      row.result.stats["timing"] = o.interleave ? "interleaved" : "sequential";
      row.result.provenance = provenance;
      row.msMin = j.judged.runs.minMs;
      row.msMax = j.judged.runs.maxMs;
      thumbFactor = writeFrameImages(out.path(), stem + "_" + s.label, frame.gbuffer, mask, reference, frame.band,
                                     kThumbnailSide);
      rows.push_back(std::move(row));
    }
    // Enlarged to about 256 pixels a tile, at least 2x, so single-pixel aliasing is visible.
    closeup.crop = boundaryWindow(frame.gbuffer, reference);
    closeup.scale = std::max(2u, (256 + closeup.crop.width - 1) / closeup.crop.width);
    uint32_t sw = 0, sh = 0;
    std::vector<uint8_t> strip = closeupStrip(shaded, frame.gbuffer.width, closeup.crop, closeup.scale, 4, sw, sh);
    writePng((fs::path(out.path()) / closeup.file).string(), sw, sh, strip);
    closeups.push_back(std::move(closeup));
  };
  harness::run(*ctx, spec, events);

  log << "writing reports" << std::endl;
  std::vector<FrameResult> results;
  for (auto& r : rows) results.push_back(r.result);
  writeResults(out.path(), results);
  std::string dir = out.path();
  const std::string speedSvg = tradeOffSvg(rows, false), bytesSvg = tradeOffSvg(rows, true);
  writeFileAtomic((fs::path(dir) / "report.md").string(),
                  reportMd(scene.name, device, o.width, o.height, o.frames, rows, closeups, skipped));
  writeFileAtomic((fs::path(dir) / "report.html").string(), reportHtml(scene.name, device, o.width, o.height, o.frames, rows,
                                                                      closeups, speedSvg, bytesSvg, thumbFactor, skipped));
  for (const auto& [name, svg] : {std::pair{"speed_vs_error", &speedSvg}, std::pair{"error_vs_bytes", &bytesSvg}}) {
    writeFileAtomic((fs::path(dir) / (std::string(name) + ".svg")).string(), *svg);
    svgToPng((fs::path(dir) / (std::string(name) + ".svg")).string(), (fs::path(dir) / (std::string(name) + ".png")).string());
  }
  if (anyProgressive(rows)) {
    writeFileAtomic((fs::path(dir) / "convergence.svg").string(), convergenceSvg(rows));
    svgToPng((fs::path(dir) / "convergence.svg").string(), (fs::path(dir) / "convergence.png").string());
  }
  out.commit();

  std::cout << "result: compared " << settings.size() << " method setting(s) on " << cameras.size() << " view(s) of "
            << scene.name << (several ? " under " + std::to_string(lights.size()) + " lights" : std::string()) << " at " << o.width << "x" << o.height << "; wrote " << o.out << "/ (report.md, report.html, "
            << "speed_vs_error.svg/.png, error_vs_bytes.svg/.png, results.json, results.csv, " << rows.size() * 3 << " images, "
            << closeups.size() << " close-up strip(s))\n";
  return kExitOk;
}

}  // namespace cs
