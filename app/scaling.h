// `coneshadow compare --scaling`: how each method's time and memory grow with the number of pixels and
// the number of triangles, every point judged against Embree on its own samples. Writes scaling.md,
// scaling.json, scaling.csv, scaling_resolution.svg/.png and scaling_triangles.svg/.png.
//
// Resolution sweep: one view of the scene at 256², 512², 1024², 2048² (the hidden setting
// --scaling-sizes=N1,N2,... replaces the list, for quick runs and tests).
// Triangle sweep: at --width x --height, the scene instanced as k translated copies, k = 1, 4, 16, ...
// while k times the scene's triangles stays within --scaling-max-triangles (default 10M; k = 1 always).
// Copies sit side by side on a grid in the x–z plane beyond the scene's bounds (instancedScene); the
// camera, light and epsilon stay those of the original, so the picture is the same and only the
// triangle count grows.
// A method that fails at a point (out of device memory, a device limit, ...) gives
// that point "failed: <reason>"; the sweep goes on.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "app/cli.h"
#include "core/scene.h"

namespace cs {

inline constexpr uint64_t kDefaultScalingMaxTriangles = 10'000'000;

// k = 1, 4, 16, ... with k * sceneTriangles <= maxTriangles; always at least {1}.
std::vector<uint32_t> scalingCopies(uint64_t sceneTriangles, uint64_t maxTriangles);

// `copies` translated copies of the scene's geometry on a ceil(sqrt(copies))-wide grid in the x–z plane,
// copy 0 in place, neighbours spaced by the scene's extent plus 10 %. Cameras and lights are the
// original's; bounds are recomputed.
Scene instancedScene(const Scene& scene, uint32_t copies);

int runScaling(const Options& options);

}  // namespace cs
