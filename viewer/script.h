// The viewer's scripted input (--script FILE): one command a line, replayed frame by frame, so a run of
// the window is repeatable (tests, the README's screenshot). docs/ARCHITECTURE.md, "The viewer".
//   method NAME            switch to a registered method (its default settings)
//   set NAME VALUE         a setting of the current method (VALUE omitted: a switch)
//   light X Y Z            the light, placed
//   move-light DX DY DZ    the light, dragged by that much
//   camera NAME            one of the scene's cameras or the built-in views
//   orbit YAW PITCH        the camera orbited about its target (radians)
//   lights all|I,J,...     the lights shown at once (the light table's entries: the run's lights, then the
//                          scene's other point lights); the cone path takes them all in one frame
//   show-light K           the light the mask, the diff, the light moves and the registry methods use
//                          (K: its place among the lights shown, from 0)
//   display shaded|mask|diff
//   time T                 an animated scene at time T (paused)
//   split NAME|off         the split screen: NAME's mask right of the frame's middle, or one method again
//   wait N                 N frames
//   wait-reference         frames until the Embree reference of the current view and light is shown
//   screenshot FILE        the window's image to FILE (PNG) and its results row to FILE's stem + .json
//   quit
// '#' starts a comment; blank lines are skipped.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace cs::viewer {

struct ScriptStep {
  enum Kind { Method, Set, Light, MoveLight, Lights, ShowLight, Camera, Orbit, Display, Split, Time, Wait, WaitReference, Screenshot, Quit };
  Kind kind = Wait;
  std::string name, value;  // Method, Set, Camera, Display, Split, Screenshot
  std::vector<uint32_t> lights;  // Lights: the table's entries (empty: all of them); ShowLight: {K}
  glm::vec3 v{0};           // Light, MoveLight; Orbit: (yaw, pitch, 0); Time: (T, 0, 0)
  uint32_t frames = 0;      // Wait
  int line = 0;
};

// cs::Error naming the file and line of the first bad command.
std::vector<ScriptStep> parseScript(const std::string& text, const std::string& file);
std::vector<ScriptStep> loadScript(const std::string& path);

}  // namespace cs::viewer
