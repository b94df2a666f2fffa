// `coneshadow view`: every registered method live in a window, the Embree truth beside it. The frame is
// drawn on the viewer's own Vulkan device: the cone path through the public API (include/coneshadow/)
// recorded into the viewer's one command buffer a frame, the other methods through the registry on a
// context sharing that device (vk::shareDevice). docs/ARCHITECTURE.md, "The viewer".
#pragma once
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "core/heap_count.h"
#include "core/scene.h"
#include "method/registry.h"

namespace cs::viewer {

inline constexpr const char* kDisplayNames[3] = {"shaded", "mask", "diff"};
// The lights the viewer holds at most (the public API takes up to 64 a frame; each is a layer of the
// visibility image and of its host copy, so the viewer keeps fewer).
inline constexpr uint32_t kMaxLights = 16;

// A moving scene's motion: pose(t, scene) places the scene at time t in [start, end].
struct Animation {
  std::function<void(double t, Scene& scene)> pose;
  double start = 0, end = 0;
  bool cyclic = false;  // end is start again (the built-in motion)
};

struct ViewerSpec {
  Scene scene;                         // with an animation: its rest pose
  std::optional<Animation> animation;  // the scene moves: play, pause, step
  std::string view;   // the camera shown first ("" = the scene's first, or an automatic one)
  // The run's lights (--light, each; --all-lights: the scene's point lights; else the scene's first), all
  // shown at once on the cone path. The scene's other point lights can be added in the window.
  std::vector<glm::vec3> lights;
  // The methods offered, each with its settings as given; the first is shown (a second: the split screen's
  // right half).
  std::vector<std::pair<const MethodInfo*, Settings>> methods;
  uint32_t width = 512, height = 512;  // the frame's size (the window's, at first)
  std::string script;                  // --script FILE
  std::string screenshot;              // --screenshot FILE: the last frame's image, then exit
  uint32_t frames = 0;                 // --frames N: exit after N frames (0: when the window closes)
  bool hideUi = false;
  bool stats = false;                  // print the frame loop's counters at exit
  uint32_t display = 0;                // index into kDisplayNames
  std::string device;
  std::string commandLine;             // for the results rows' provenance
};

// Runs the window until it is closed, the script quits or spec.frames have been drawn. cs::Error for a
// missing window system (one line, the CLI exits 1), UsageError for an unknown view.
int runViewer(ViewerSpec spec);

}  // namespace cs::viewer
