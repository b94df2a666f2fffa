// Command-line parsing for the coneshadow CLI (CLI11): plain data in, a usage error (exit 2) out. The
// methods' own settings come from the method registry (method/registry.h): the CLI offers every registered
// setting on render and compare, refuses one no chosen method takes, and lets each chosen method check
// its own before any work.
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "core/error.h"
#include "method/registry.h"

namespace cs {

// Exit codes, documented in help and the README.
enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitUsage = 2 };

struct Options {
  std::string command;               // info | render | compare | visibility | results-table | devices | help | version
  std::string text;                  // help and version: what to print
  std::string scene;                 // empty = built-in scene
  bool groundPlane = false;          // --ground-plane: a receiver under the scene's bounds
  std::string commandLine;           // the arguments as given, for the results' provenance
  std::vector<std::string> methods;  // registry names; render: embree when none given; compare: all when none
  uint32_t width = 512, height = 512;
  std::string view;                  // render: camera name; empty = scene's first camera
  std::vector<std::string> views;    // compare: cameras by name (empty = all views of the scene)
  std::vector<glm::vec3> lights;     // --light, in the order given (each a frame); overrides the scene's first point light
  bool allLights = false;            // --all-lights: every point light of the scene, each a frame
  std::optional<double> sceneTime;   // --time T: where a BART (.aff) scene is placed in its animation
  std::string out = "out";
  std::string dump;                  // empty = no dump
  std::string device;                // --device: index or name substring
  uint32_t frames = 3;               // timed frames (after one warm-up); the median is reported
  bool validation = false;           // --validation: VK_LAYER_KHRONOS_validation on
  bool quiet = false;
  // compare's separate runs
  uint32_t animateFrames = 0;        // --animate N (0 = static)
  bool movingCamera = false;         // --moving-camera
  bool interleave = false;           // compare --interleave: the methods' frames round-robin
  bool scaling = false;              // --scaling
  uint64_t scalingMaxTriangles = 0;  // --scaling-max-triangles N (0 = the sweep's default)
  std::vector<uint32_t> scalingSizes;  // --scaling-sizes N1,N2 (hidden): the resolution sweep's sizes
  std::vector<double> lightDistances;  // --light-distances D1,D2: the light sweep, in scene diagonals
  std::vector<std::string> folders;  // results-table DIR...
  bool hostCost = false;             // results-table --host-cost
  // visibility: the samples file (--samples), where the CSV goes (--out; empty or "-": standard output),
  // and --reference (Embree's answer and the band beside the engine's)
  std::string samples, samplesOut;
  bool reference = false;
  // The methods' settings as given, in order: name without the dashes, value ("" for a switch).
  std::vector<std::pair<std::string, std::string>> settings;
};

// The given settings that `method` declares (the value given last wins).
Settings settingsFor(const Options& options, const MethodInfo& method);
// The chosen methods' registry entries (all registered when none were chosen).
std::vector<const MethodInfo*> chosenMethods(const Options& options);
// The files a run reads that an output folder may never hold (the scene file, when SCENE names one).
std::vector<std::string> runInputs(const Options& options);

// Registers the built-in methods, then parses; throws UsageError. help/--help and --version come back as
// command "help"/"version" with `text` to print.
Options parseArgs(int argc, char** argv);
std::string usageText();
std::string versionText();

}  // namespace cs
