// Log–log scatter/line plots as SVG (compare's speed-vs-error plot, the scaling sweeps) and the SVG → PNG
// conversion, in process through librsvg and cairo.
#pragma once
#include <string>
#include <vector>

namespace cs {

struct PlotPoint {
  double x = 0, y = 0;
  std::string title;  // hover text
  double radius = 5;  // marker radius in px (compare draws marker area proportional to bytes)
};

struct PlotSeries {
  std::string name;  // legend entry
  std::vector<PlotPoint> points;
  bool connect = false;  // draw a polyline through the points in order
};

// One log–log panel. Axis ranges are whole decades around the data unless fixed. With yFloor > 0, values
// below it are drawn on the floor and the floor decade is labelled "0" (exact zeros on a log axis).
struct LogPanel {
  std::string xLabel, yLabel;
  std::vector<PlotSeries> series;
  double yFloor = 0;
  bool fixedY = false;
  int yMinDecade = 0, yMaxDecade = 0;  // used when fixedY
  std::string title;                   // drawn above the panel, when set
};

// Panels in a grid of `columns` (row by row), each `width` / columns wide and `panelHeight` tall, one
// legend per panel (series colours by index).
std::string logPlotSvg(const std::vector<LogPanel>& panels, double width = 760, double panelHeight = 480,
                       size_t columns = 1);

// Converts an SVG file to PNG with librsvg and cairo, in process, written atomically. Throws cs::Error with
// librsvg's message and leaves no file at pngPath on failure.
void svgToPng(const std::string& svgPath, const std::string& pngPath);

// "<" ">" "&" "\"" escaped for HTML/SVG text and attributes.
std::string htmlEscape(const std::string& s);

}  // namespace cs
