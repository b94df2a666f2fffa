// Command-line parsing for the coneshadow CLI: plain data in, a usage error (exit 2) out.
#pragma once
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace cs {

// Exit codes, documented in --help and the README.
enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitUsage = 2 };

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Options {
  std::string command;               // info | render | compare | devices | help
  std::string scene;                 // empty = built-in scene
  std::string method = "embree";
  uint32_t width = 512, height = 512;
  std::string view;                  // camera name; empty = scene's first camera
  std::optional<glm::vec3> light;    // overrides the scene's first point light
  std::optional<double> sceneTime;   // --time T: where a BART (.aff) scene is placed in its animation
  std::string out = "out";
  std::string dump;                  // empty = no dump
  std::string device;                // --device: index or name substring
  uint32_t frames = 3;               // timed frames (after one warm-up); the median is reported
  bool validation = false;           // --validation: VK_LAYER_KHRONOS_validation on
  bool quiet = false;
  bool unsorted = false;             // --ray-order screen: cone tree over screen order (paper 002's unsorted variants)
  uint64_t traversalMemory = 0;
  // shadow maps (0 / false = the method's default)
  uint32_t smResolution = 0;         // --sm-resolution: cube SM texels per face side
  bool smNoPcf = false;              // --sm-no-pcf: cube SM single tap
  bool smPlaneBias = false;          // --plane-bias: receiver-plane bias instead of slope-scaled (cubesm, rmsm)
  uint64_t rmsmPool = 0;             // --rmsm-pool BYTES
  uint32_t rmsmPage = 0;             // --rmsm-page N
  uint32_t rmsmMaxRes = 0;           // --rmsm-max-res N
  float rmsmLodBias = 0.0f;          // --rmsm-lod-bias L: levels finer than the resolution-matched one
  uint32_t rmsmAnalysis = 1;         // --rmsm-analysis K: pages requested by every K-th pixel in x and y
  bool rmsmCached = false;           // --rmsm-cached
  // dynamic scenes (compare): N animation frames, each a new scene state every method pays for (0 = static)
  uint32_t animateFrames = 0;        // --animate N
  bool movingCamera = false;         // --moving-camera: static scene, the camera moves (rmsm cached vs rebuilt)
  // scaling runs (compare --scaling): resolution and triangle-count sweeps, behind the flag
  bool scaling = false;              // --scaling
  uint64_t scalingMaxTriangles = 0;  // --scaling-max-triangles N (0 = the sweep's default)
  std::vector<double> lightDistances;  // compare --light-distances D1,D2: the light sweep, in scene diagonals
  std::vector<std::string> methods;  // compare --methods a,b (empty = all registered)
  std::vector<std::string> views;    // compare --views v1,v2 (empty = all views of the scene)
  std::vector<std::string> extra;    // method-specific --key=value settings, passed through
};

Options parseArgs(int argc, char** argv);  // throws UsageError
std::string usageText();

}  // namespace cs
