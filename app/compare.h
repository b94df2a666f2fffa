// `coneshadow compare`: every method (and a small sweep of each one's quality/memory knob) on every view
// of a scene, all judged against one Embree reference on one shared raster pass per view. Writes
// results.json/.csv, per-setting images, per-view close-up strips, report.md, report.html and
// speed_vs_error.svg/.png.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "app/cli.h"
#include "raster/gbuffer.h"

namespace cs {

// One entry of compare's sweep: a registered method with the settings for one point of its sweep.
struct CompareSetting {
  const MethodInfo* method = nullptr;
  std::string label;   // "cubesm@512", "rmsm@16M", "cone@64M", "embree"
  Settings settings;
  bool defaults = false;  // SweepPoint::defaults
};

// The sweeps of the chosen methods (MethodInfo::sweep), in the registry's order.
std::vector<CompareSetting> compareSettings(const Options& options);

// A pixel rectangle of an image, row 0 at the top.
struct CropWindow {
  uint32_t x = 0, y = 0, width = 0, height = 0;
};

// The close-up crop of a view: the window of a quarter of the image's width and height (at least 1x1)
// holding the most shadow-boundary pixels of the reference — lit samples whose right or lower neighbour
// is a lit sample the reference classifies the other way (visibility thresholded at 0.5). Ties go to the
// topmost, then leftmost window; a view without any boundary gets the centre window.
CropWindow boundaryWindow(const GBuffer& gbuffer, const std::vector<float>& reference);

// The same crop of each RGB image (width x height x 3 bytes each), enlarged `scale` times with nearest
// neighbour (every source pixel a scale x scale block, so aliasing stays visible) and laid side by side
// left to right in the given order, separated by `gap` black columns. Writes the strip's size to
// stripWidth/stripHeight.
std::vector<uint8_t> closeupStrip(const std::vector<std::vector<uint8_t>>& images, uint32_t width, CropWindow crop,
                                  uint32_t scale, uint32_t gap, uint32_t& stripWidth, uint32_t& stripHeight);

int runCompare(const Options& options);

}  // namespace cs
