// `coneshadow compare`: every method (and a small sweep of each one's quality/memory knob) on every view
// of a scene, all judged against one Embree reference on one shared raster pass per view. Writes
// results.json/.csv, per-setting images, report.md, report.html and speed_vs_error.svg.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "app/cli.h"

namespace cs {

// One entry of the sweep: a registered method with the options for one of its settings.
struct CompareSetting {
  std::string method;  // registry name
  std::string label;   // "cubesm@512", "rmsm@16M", "cone@64M", "embree"
  Options options;     // the CLI options with this setting's knob applied
};

// The settings `compare` runs for these methods (registry names, already validated).
std::vector<CompareSetting> compareSettings(const std::vector<std::string>& methods, const Options& base);
// "64M", "4M", "65.5K", "512": bytes with a binary suffix, for setting labels.
std::string bytesLabel(uint64_t bytes);

int runCompare(const Options& options);

}  // namespace cs
