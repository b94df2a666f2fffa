// `coneshadow compare --animate N`: dynamic scenes. For N frames over the scene's animation (the built-in
// motion, or the file's node animation channels) and/or a camera orbiting its target (--moving-camera),
// every method runs on every frame's own scene state and samples, with method objects kept across
// frames, so each pays its per-frame cost: Embree rebuilds its BVH, the cone path re-uploads its
// triangles and rebuilds its ray tree, RMSM renders its pages again (and, for a static scene with a
// moving camera, also runs cached as a separate row). Writes dynamic.md, results.json and results.csv.
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "app/cli.h"
#include "method/method.h"
#include "harness/run.h"  // orbitCamera
#include "viewer/viewer.h"

namespace cs {

int runDynamicCompare(const Options& options);
// The scene of the command line and its motion for `coneshadow view` (rest pose into `rest`); none when
// nothing in it moves.
std::optional<viewer::Animation> viewerAnimation(const Options& options, Scene& rest);

}  // namespace cs
