// Log–log SVG plots and SVG → PNG: see svg_plot.h.
#include "app/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iomanip>
#include <sstream>

#include <cairo.h>
#include <librsvg/rsvg.h>

#include "core/error.h"
#include "core/image_io.h"

namespace cs {

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

namespace {

const char* kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"};

std::string decadeLabel(int e) {
  std::ostringstream os;
  os << std::pow(10.0, e);
  return os.str();
}

void panelSvg(std::ostream& os, const LogPanel& p, double W, double H, double x0px, double y0px) {
  const double left = x0px + 80, right = 170, top = 30, bottom = 60;
  const double pw = W - 80 - right, ph = H - top - bottom, ptop = y0px + top;
  auto clampY = [&](double y) { return p.yFloor > 0 ? std::max(y, p.yFloor) : y; };
  double xlo = 1e300, xhi = 0, ylo = 1e300, yhi = 0;
  for (auto& s : p.series)
    for (auto& pt : s.points) {
      if (pt.x > 0) xlo = std::min(xlo, pt.x), xhi = std::max(xhi, pt.x);
      double y = clampY(pt.y);
      if (y > 0) ylo = std::min(ylo, y), yhi = std::max(yhi, y);
    }
  if (xhi <= 0) xlo = xhi = 1;
  if (yhi <= 0) ylo = yhi = 1;
  int x0 = int(std::floor(std::log10(xlo))), x1 = int(std::ceil(std::log10(xhi)));
  if (x1 <= x0) x1 = x0 + 1;
  int y0 = int(std::floor(std::log10(ylo))), y1 = int(std::ceil(std::log10(yhi)));
  if (p.fixedY) y0 = p.yMinDecade, y1 = p.yMaxDecade;
  if (y1 <= y0) y1 = y0 + 1;
  const double xmin = std::pow(10.0, x0), ymin = std::pow(10.0, y0);
  auto px = [&](double x) { return left + (std::log10(std::max(x, xmin)) - x0) / (x1 - x0) * pw; };
  if (!p.title.empty())
    os << "<text x=\"" << left << "\" y=\"" << ptop - 10 << "\" font-weight=\"bold\">" << htmlEscape(p.title)
       << "</text>\n";
  auto py = [&](double y) { return ptop + ph - (std::log10(std::max(clampY(y), ymin)) - y0) / (y1 - y0) * ph; };

  os << "<rect x=\"" << left << "\" y=\"" << ptop << "\" width=\"" << pw << "\" height=\"" << ph
     << "\" fill=\"none\" stroke=\"black\"/>\n";
  for (int e = x0; e <= x1; ++e) {
    double x = px(std::pow(10.0, e));
    os << "<line x1=\"" << x << "\" y1=\"" << ptop << "\" x2=\"" << x << "\" y2=\"" << ptop + ph
       << "\" stroke=\"#ddd\"/>\n<text x=\"" << x << "\" y=\"" << ptop + ph + 16 << "\" text-anchor=\"middle\">"
       << decadeLabel(e) << "</text>\n";
  }
  const int floorDecade = p.yFloor > 0 ? int(std::round(std::log10(p.yFloor))) : y0 - 1;
  for (int e = y0; e <= y1; ++e) {
    double y = py(std::pow(10.0, e));
    std::string label = e == floorDecade ? "0 (exact)" : e == 0 ? "1" : p.fixedY ? "1e" + std::to_string(e) : decadeLabel(e);
    os << "<line x1=\"" << left << "\" y1=\"" << y << "\" x2=\"" << left + pw << "\" y2=\"" << y
       << "\" stroke=\"#ddd\"/>\n<text x=\"" << left - 6 << "\" y=\"" << y + 4 << "\" text-anchor=\"end\">" << label
       << "</text>\n";
  }
  os << "<text x=\"" << left + pw / 2 << "\" y=\"" << y0px + H - 18 << "\" text-anchor=\"middle\">"
     << htmlEscape(p.xLabel) << "</text>\n"
     << "<text transform=\"translate(" << x0px + 18 << "," << ptop + ph / 2 << ") rotate(-90)\" text-anchor=\"middle\">"
     << htmlEscape(p.yLabel) << "</text>\n";
  for (size_t si = 0; si < p.series.size(); ++si) {
    const PlotSeries& s = p.series[si];
    const char* colour = kPalette[si % 8];
    if (s.connect && s.points.size() > 1) {
      os << "<polyline fill=\"none\" stroke=\"" << colour << "\" stroke-width=\"1.5\" points=\"";
      for (auto& pt : s.points) os << px(pt.x) << "," << py(pt.y) << " ";
      os << "\"/>\n";
    }
    for (auto& pt : s.points)
      os << "<circle cx=\"" << px(pt.x) << "\" cy=\"" << py(pt.y) << "\" r=\"" << pt.radius << "\" fill=\"" << colour
         << "\" fill-opacity=\"0.75\" stroke=\"black\"><title>" << htmlEscape(pt.title) << "</title></circle>\n";
    double y = ptop + 10 + 20.0 * double(si);
    os << "<rect x=\"" << left + pw + 16 << "\" y=\"" << y - 6 << "\" width=\"12\" height=\"12\" fill=\"" << colour
       << "\"/>\n<text x=\"" << left + pw + 34 << "\" y=\"" << y + 4 << "\">" << htmlEscape(s.name) << "</text>\n";
  }
}

}  // namespace

std::string logPlotSvg(const std::vector<LogPanel>& panels, double width, double panelHeight, size_t columns) {
  columns = std::max<size_t>(1, std::min(columns, std::max<size_t>(panels.size(), 1)));
  const size_t rows = (std::max<size_t>(panels.size(), 1) + columns - 1) / columns;
  const double H = panelHeight * double(rows), panelWidth = width / double(columns);
  std::ostringstream os;
  os << std::fixed << std::setprecision(2);
  os << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << H << "\" viewBox=\"0 0 "
     << width << " " << H << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
     << "<rect x=\"0\" y=\"0\" width=\"" << width << "\" height=\"" << H << "\" fill=\"white\"/>\n";
  for (size_t i = 0; i < panels.size(); ++i)
    panelSvg(os, panels[i], panelWidth, panelHeight, panelWidth * double(i % columns), panelHeight * double(i / columns));
  os << "</svg>\n";
  return os.str();
}

void svgToPng(const std::string& svgPath, const std::string& pngPath) {
  GError* error = nullptr;
  auto failure = [&](const std::string& what) {
    std::string why = what;
    if (error) {
      why += std::string(": ") + error->message;
      g_error_free(error);
      error = nullptr;
    }
    return Error("cannot render the plot to PNG with librsvg: " + why, pngPath);
  };
  RsvgHandle* handle = rsvg_handle_new_from_file(svgPath.c_str(), &error);
  if (!handle) throw failure("cannot read " + svgPath);
  gdouble w = 0, h = 0;
  if (!rsvg_handle_get_intrinsic_size_in_pixels(handle, &w, &h) || !(w >= 1 && h >= 1 && w <= 16384 && h <= 16384)) {
    g_object_unref(handle);
    throw failure(svgPath + " has no usable width and height");
  }
  cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, int(std::ceil(w)), int(std::ceil(h)));
  cairo_t* cr = cairo_create(surface);
  const RsvgRectangle viewport{0, 0, w, h};
  const bool drawn = rsvg_handle_render_document(handle, cr, &viewport, &error);
  cairo_destroy(cr);
  g_object_unref(handle);
  std::string png;
  const cairo_status_t status =
      drawn ? cairo_surface_write_to_png_stream(
                  surface,
                  [](void* closure, const unsigned char* data, unsigned int length) {
                    static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
                    return CAIRO_STATUS_SUCCESS;
                  },
                  &png)
            : CAIRO_STATUS_SUCCESS;
  cairo_surface_destroy(surface);
  if (!drawn) throw failure("cannot draw " + svgPath);
  if (status != CAIRO_STATUS_SUCCESS) throw failure(std::string("cannot encode the PNG: ") + cairo_status_to_string(status));
  writeFileAtomic(pngPath, png);
}

}  // namespace cs
