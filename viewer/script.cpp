// The viewer's scripted input: see script.h.
#include "viewer/script.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace cs::viewer {

std::vector<ScriptStep> parseScript(const std::string& text, const std::string& file) {
  std::vector<ScriptStep> steps;
  std::istringstream in(text);
  std::string raw;
  int lineNo = 0;
  while (std::getline(in, raw)) {
    ++lineNo;
    if (const size_t hash = raw.find('#'); hash != std::string::npos) raw.resize(hash);
    std::istringstream line(raw);
    std::vector<std::string> w;
    for (std::string word; line >> word;) w.push_back(word);
    if (w.empty()) continue;
    const std::string where = file + ":" + std::to_string(lineNo);
    auto bad = [&](const std::string& wants) -> void {
      throw Error("'" + w[0] + "' wants " + wants, where, "see `coneshadow view --help` for the script's commands");
    };
    auto number = [&](size_t i) {
      char* end = nullptr;
      const float x = std::strtof(w[i].c_str(), &end);
      if (*end != '\0' || !std::isfinite(x)) bad("finite numbers, got '" + w[i] + "'");
      return x;
    };
    ScriptStep s;
    s.line = lineNo;
    const std::string& c = w[0];
    if (c == "method" || c == "camera" || c == "display" || c == "split" || c == "screenshot") {
      if (w.size() != 2) bad("one word");
      s.kind = c == "method"    ? ScriptStep::Method
               : c == "camera"  ? ScriptStep::Camera
               : c == "display" ? ScriptStep::Display
               : c == "split"   ? ScriptStep::Split
                                : ScriptStep::Screenshot;
      s.name = w[1];
      if (s.kind == ScriptStep::Display && s.name != "shaded" && s.name != "mask" && s.name != "diff") bad("shaded, mask or diff");
    } else if (c == "set") {
      if (w.size() != 2 && w.size() != 3) bad("a setting's name and its value");
      s.kind = ScriptStep::Set;
      s.name = w[1];
      if (w.size() == 3) s.value = w[2];
    } else if (c == "light" || c == "move-light") {
      if (w.size() != 4) bad("three numbers X Y Z");
      s.kind = c == "light" ? ScriptStep::Light : ScriptStep::MoveLight;
      s.v = {number(1), number(2), number(3)};
    } else if (c == "lights" || c == "show-light") {
      if (w.size() != 2) bad(c == "lights" ? "all or a list of light numbers I,J,..." : "a light number K");
      s.kind = c == "lights" ? ScriptStep::Lights : ScriptStep::ShowLight;
      if (s.kind == ScriptStep::ShowLight || w[1] != "all") {
        std::istringstream list(w[1]);
        for (std::string item; std::getline(list, item, ',');) {
          char* end = nullptr;
          const unsigned long k = std::strtoul(item.c_str(), &end, 10);
          if (item.empty() || *end != '\0' || item[0] == '-' || k >= 64) bad("light numbers from 0 to 63, got '" + w[1] + "'");
          s.lights.push_back(uint32_t(k));
        }
        if (s.lights.empty() || (s.kind == ScriptStep::ShowLight && s.lights.size() != 1))
          bad(c == "lights" ? "all or a list of light numbers I,J,..." : "one light number K");
      }
    } else if (c == "orbit") {
      if (w.size() != 3) bad("two angles YAW PITCH in radians");
      s.kind = ScriptStep::Orbit;
      s.v = {number(1), number(2), 0};
    } else if (c == "time") {
      if (w.size() != 2) bad("a scene time T");
      s.kind = ScriptStep::Time;
      s.v = {number(1), 0, 0};
    } else if (c == "wait") {
      if (w.size() != 2) bad("a number of frames");
      const float n = number(1);
      if (n < 0 || n > 1e6 || n != std::floor(n)) bad("a whole number of frames up to 10^6");
      s.kind = ScriptStep::Wait;
      s.frames = uint32_t(n);
    } else if (c == "wait-reference" || c == "quit") {
      if (w.size() != 1) bad("nothing after it");
      s.kind = c == "quit" ? ScriptStep::Quit : ScriptStep::WaitReference;
    } else {
      throw Error("unknown command '" + c + "'", where,
                  "commands: method, set, light, move-light, lights, show-light, camera, orbit, display, split, time, wait, wait-reference, screenshot, quit");
    }
    steps.push_back(s);
  }
  return steps;
}

std::vector<ScriptStep> loadScript(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error("cannot read the script", path, "give a readable file to --script");
  std::stringstream text;
  text << f.rdbuf();
  return parseScript(text.str(), path);
}

}  // namespace cs::viewer
