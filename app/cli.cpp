// Command-line parsing for the coneshadow CLI: see cli.h.
#include "app/cli.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <sstream>

#include <CLI/CLI.hpp>

#include "viewer/viewer.h"

namespace cs {

namespace {

const std::vector<std::string> kCommands = {"render", "compare", "view", "visibility", "info", "results-table", "devices", "help"};

std::vector<std::string> splitList(const std::string& flag, const std::string& v) {
  std::vector<std::string> items;
  std::stringstream ss(v);
  std::string part;
  while (std::getline(ss, part, ','))
    if (!part.empty()) items.push_back(part);
  if (items.empty()) throw UsageError(flag + " wants a comma-separated list, got '" + v + "'");
  return items;
}

glm::vec3 parseVec3(const std::string& flag, const std::string& v) {
  glm::vec3 out;
  std::stringstream ss(v);
  std::string part;
  int i = 0;
  while (std::getline(ss, part, ',')) {
    char* end = nullptr;
    errno = 0;
    const float x = std::strtof(part.c_str(), &end);
    // ERANGE with a finite result is an underflow to a denormal or zero: a finite number all the same.
    if (i >= 3 || part.empty() || *end != '\0' || (errno && errno != ERANGE) || !std::isfinite(x))
      throw UsageError(flag + " wants three finite numbers X,Y,Z, got '" + v + "'");
    out[i++] = x;
  }
  if (i != 3) throw UsageError(flag + " wants three finite numbers X,Y,Z, got '" + v + "'");
  return out;
}

double parseNumber(const std::string& flag, const std::string& v, double lo, double hi, const std::string& what) {
  char* end = nullptr;
  errno = 0;
  const double x = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || (errno && errno != ERANGE) || !std::isfinite(x) || !(x >= lo && x <= hi))
    throw UsageError(flag + " wants " + what + ", got '" + v + "'");
  return x;
}

// Every setting the registered methods declare, once, with the methods that take it.
struct SettingEntry {
  SettingSpec spec;
  std::vector<std::string> methods;
};

std::vector<SettingEntry> settingEntries() {
  std::vector<SettingEntry> entries;
  for (const MethodInfo& m : registeredMethods())
    for (const SettingSpec& s : m.settings) {
      auto it = std::find_if(entries.begin(), entries.end(), [&](const SettingEntry& e) { return e.spec.name == s.name; });
      if (it == entries.end()) entries.push_back({s, {m.name}});
      else it->methods.push_back(m.name);
    }
  return entries;
}

std::string joined(const std::vector<std::string>& items, const std::string& sep = ", ") {
  std::string out;
  for (const std::string& i : items) out += (out.empty() ? "" : sep) + i;
  return out;
}

// The raw text of the options converted after parsing (so a bad value is our one-line error).
struct Raw {
  std::string time, lightDistances, scalingSizes, methods, views, method;
  std::vector<std::string> lights;
  std::vector<std::string> extras;  // what CLI11 did not recognise
};

void addFrameOptions(CLI::App& sub, Options& o, Raw& raw) {
  sub.add_option("--width", o.width, "camera pass width (render default 512, compare 256)")->type_name("W")->check(CLI::Range(1u, 16384u));
  sub.add_option("--height", o.height, "camera pass height (render default 512, compare 256)")->type_name("H")->check(CLI::Range(1u, 16384u));
  sub.add_option("--light", raw.lights,
                 "point light position X,Y,Z; given again, one more light, each judged on its own (default: the scene's "
                 "first point light; automatic if none)")
      ->type_name("X,Y,Z")
      ->expected(1)
      ->allow_extra_args(false)  // one value each time: the next word is SCENE or another option
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sub.add_flag("--all-lights", o.allLights,
               "every point light of the scene, each judged on its own: one result per method and light");
  sub.add_option("--time", raw.time, "a BART .aff scene at scene time T (default: the start of its animation range)")->type_name("T");
  sub.add_option("--out", o.out, "output folder")->type_name("DIR");
  sub.add_option("--frames", o.frames, "timed frames after one warm-up; medians are reported (default 3)")
      ->type_name("N")
      ->check(CLI::Range(1u, 1000u));
  sub.add_option("--device", o.device, "Vulkan device by index or name substring (see `coneshadow devices`)")->type_name("D");
  sub.add_flag("--ground-plane", o.groundPlane,
               "add a receiver under the scene's bounds (normal +y), so a single model's shadow has somewhere to fall");
  sub.add_flag("--validation", o.validation, "enable VK_LAYER_KHRONOS_validation (slow; for debugging)");
  sub.add_flag("--quiet", o.quiet, "print only errors and the final summary line");
  sub.add_option("--methods", raw.methods, "shadow methods A,B,... (see `coneshadow help`)")->type_name("A,B");
}

// Every registered setting, grouped by method; the tuning knobs last, in a group of their own.
void addMethodSettings(CLI::App& sub, Options& o) {
  std::vector<SettingEntry> entries = settingEntries();
  std::stable_partition(entries.begin(), entries.end(), [](const SettingEntry& e) { return !e.spec.tuning; });
  for (const SettingEntry& e : entries) {
    const std::string name = e.spec.name;
    std::string help = joined(e.methods) + ": " + e.spec.help;
    if (!e.spec.choices.empty()) help += " {" + joined(e.spec.choices, ", ") + "}";
    const std::string group = e.spec.tuning             ? kTuningGroup
                              : e.methods.size() == 1 ? e.methods.front() + " settings"
                                                      : "shared method settings";
    if (e.spec.value.empty()) {
      sub.add_flag_callback("--" + name, [&o, name] { o.settings.emplace_back(name, ""); }, help)->group(group);
    } else {
      sub.add_option_function<std::string>("--" + name, [&o, name](const std::string& v) { o.settings.emplace_back(name, v); },
                                           help)
          ->type_name(e.spec.value)
          ->group(group)
          ->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
    }
  }
}

std::string methodsText() {
  std::string out;
  for (const MethodInfo& m : registeredMethods()) {
    out += "  " + m.name + std::string(m.name.size() < 10 ? 10 - m.name.size() : 1, ' ') + m.summary + "\n";
    if (m.sweep) {
      std::vector<std::string> labels;
      for (const SweepPoint& p : sweepOf(m, Settings(m.name))) labels.push_back(p.label);
      out += std::string(12, ' ') + "compare's sweep: " + joined(labels) + "\n";
    }
  }
  return out;
}

std::vector<std::string> flagsOf(const CLI::App& sub) {
  std::vector<std::string> flags;
  for (const CLI::Option* opt : sub.get_options())
    for (const std::string& n : opt->get_lnames()) flags.push_back("--" + n);
  return flags;
}

void refuseUnknown(const std::vector<std::string>& extras, const CLI::App& sub, const CLI::App& other) {
  const std::vector<std::string> flags = flagsOf(sub), others = flagsOf(other);
  for (const std::string& a : extras) {
    if (a.rfind("-", 0) == 0) {
      const std::string flag = a.substr(0, a.find('='));
      if (std::find(others.begin(), others.end(), flag) != others.end())
        throw UsageError(flag + " is an option of " + other.get_name() + ", not of " + sub.get_name());
      throw UsageError("unknown option '" + flag + "'" + didYouMean(flag, flags) + " (try: coneshadow " + sub.get_name() +
                       " --help)");
    }
    throw UsageError("unexpected argument '" + a + "' (one SCENE at most)");
  }
}

}  // namespace

std::string versionText() {
  std::string v = std::string("coneshadow ") + CONESHADOW_VERSION;
  if (std::string(CONESHADOW_GIT_REVISION).size()) v += " (git " + std::string(CONESHADOW_GIT_REVISION) + ")";
  return v;
}

std::string usageText() {
  return "coneshadow — alias-free hard shadows from point lights, judged against an Embree reference\n"
         "\n"
         "usage:\n"
         "  coneshadow render [SCENE] [options]   one frame with one or more methods, each against Embree\n"
         "  coneshadow compare [SCENE] [options]  every method's sweep on every view, against one Embree\n"
         "                                        reference per view; writes a report (also --animate N,\n"
         "                                        --scaling, --light-distances D1,D2: separate runs)\n"
"  coneshadow view [SCENE] [options]     every method live in a window, Embree beside it (keys: H in the window)\n"
         "  coneshadow visibility [SCENE] --samples FILE [--light X,Y,Z]... [--reference]\n"
         "                                        the exact visibility of your own samples (x y z nx ny nz a\n"
         "                                        line) from each light, as a CSV (Embree's beside it)\n"
         "  coneshadow info SCENE                 triangles (flattened over node instances), bounds, cameras, lights\n"
         "  coneshadow results-table [--host-cost] DIR...\n"
         "                                        markdown table of the compare results in each DIR (docs/RESULTS.md's)\n"
         "  coneshadow devices                    list the Vulkan devices\n"
         "  coneshadow help [COMMAND]             this text, or a command's options (also COMMAND --help)\n"
         "  coneshadow --version\n"
         "\n"
         "SCENE is a glTF 2.0 file (.gltf or .glb; point lights from KHR_lights_punctual), a BART scene (.aff, with\n"
         "the files it includes; e.g. the museum, robots and kitchen of the BART benchmark), or any other format\n"
         "assimp reads (.obj, .ply, .stl, .fbx, .dae, .3ds, ...). Without SCENE the built-in scene is used (a lit\n"
         "room with clutter and a furball; views: wall, fur, room, ceiling); `info builtin` describes it.\n"
         "A single model has nothing to cast its shadow on: --ground-plane adds a floor under it.\n"
         "\n"
         "methods (--methods A,B; each method's settings are listed in `coneshadow render --help`, the knobs\n"
         "that never change a mask apart, under \"Tuning\"):\n" +
         methodsText() +
         "\n"
         "Options take their value as --opt V or --opt=V; method names and enumerated values are matched\n"
         "without regard to case. A method setting that no chosen method takes is a usage error.\n"
         "\n"
         "exit codes:\n"
         "  0  success\n"
         "  1  failure: a malformed scene, an unusable device, a write error (one line on stderr says which)\n"
         "  2  usage error: an unknown command or option, a bad value, a setting no chosen method takes\n"
         "\n"
         "examples:\n"
         "  coneshadow render --view fur --width 1024 --height 1024 --methods cone,rmsm,cubesm\n"
         "  coneshadow render /usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb "
         "--methods cone --out engine\n"
         "  coneshadow compare --views fur,room --methods cone,cubesm\n";
}

Settings settingsFor(const Options& o, const MethodInfo& m) {
  Settings s(m.name);
  for (const auto& [name, value] : o.settings)
    if (std::any_of(m.settings.begin(), m.settings.end(), [&](const SettingSpec& spec) { return spec.name == name; }))
      s.set(name, value);
  return s;
}

std::vector<const MethodInfo*> chosenMethods(const Options& o) {
  std::vector<const MethodInfo*> out;
  if (o.methods.empty()) {
    for (const MethodInfo& m : registeredMethods()) out.push_back(&m);
    return out;
  }
  for (const std::string& name : o.methods) {
    const MethodInfo* m = &methodOrUsageError(name);
    if (std::find(out.begin(), out.end(), m) == out.end()) out.push_back(m);
  }
  return out;
}

Options parseArgs(int argc, char** argv) {
  registerBuiltinMethods();
  Options o;
  Raw raw;
  for (int i = 0; i < argc; ++i) o.commandLine += (i ? " " : "") + std::string(argv[i]);
  if (argc < 2) throw UsageError("no command given (try: coneshadow help)");

  CLI::App app{"coneshadow — alias-free hard shadows from point lights", "coneshadow"};
  app.set_help_flag("-h,--help", "this text");
  app.set_version_flag("--version", versionText(), "the version and the git revision it was built from");
  app.allow_extras();
  app.require_subcommand(0, 1);

  CLI::App* render = app.add_subcommand("render", "one frame with one or more methods, each judged against Embree");
  CLI::App* compare = app.add_subcommand("compare", "every method's sweep on every view, against one Embree reference");
  CLI::App* view = app.add_subcommand("view", "every method live in a window, the Embree reference beside it");
  CLI::App* visibility =
      app.add_subcommand("visibility", "the exact shadow visibility of your own samples (x y z nx ny nz a line) from the lights");
  CLI::App* info = app.add_subcommand("info", "triangles, bounds, cameras and lights of a scene");
  CLI::App* table = app.add_subcommand("results-table", "markdown table of the compare results in each folder");
  CLI::App* devices = app.add_subcommand("devices", "list the Vulkan devices");
  CLI::App* help = app.add_subcommand("help", "the overview, or a command's options");
  std::string helpTopic;
  help->add_option("command", helpTopic, "a command");

  for (CLI::App* sub : {render, compare, view}) {
    sub->allow_extras();
    sub->add_option("scene", o.scene,
                    "a glTF 2.0 (.gltf/.glb), BART (.aff) or other 3-D file assimp reads (.obj, .ply, .stl, .fbx, .dae, "
                    "...), or heightfield:N for a generated wavy height field of N triangles (e.g. heightfield:1M), or family:SEED for a member of the generated scene family (e.g. family:7); "
                    "default: the "
                    "built-in scene");
    addFrameOptions(*sub, o, raw);
    addMethodSettings(*sub, o);
  }
  render->add_option("--method", raw.method, "a shadow method (the same as --methods M)")->type_name("M");
  render->add_option("--view", o.view, "camera by name (default: the scene's first camera; automatic when it has none)")->type_name("NAME");
  render->add_option("--dump", o.dump,
                     "also write position.pfm, normal.pfm, visibility_<m>.pfm, band.pfm, meta.json to this folder")->type_name("DIR");
  render->footer("writes into --out DIR (default out): <m>_shaded.png, <m>_mask.png, <m>_diff.png for Embree and each\n"
                 "method, results.json and results.csv (one row per method, all on the same samples)");

  view->add_option("--view", o.view, "the camera shown first, by name (default: the scene's first camera)")->type_name("NAME");
  view->add_option("--script", o.script,
                   "replay input from FILE, one command a line: method M, set NAME [VALUE], light X Y Z, move-light DX DY DZ, "
                   "lights all|I,J, show-light K, camera NAME, orbit YAW PITCH, display shaded|mask|diff, split M|off, time T, wait N, wait-reference, "
                   "screenshot FILE, quit")
      ->type_name("FILE");
  view->add_option("--screenshot", o.screenshot, "write the window's last frame to FILE (PNG, and its results row as .json); "
                                                 "with --frames N, after N frames")->type_name("FILE");
  view->add_flag("--hide-ui", o.hideUi, "no panels over the image (screenshots)");
  view->add_flag("--stats", o.stats, "print the frame loop's counters at exit: submissions, presents, host syncs, "
                                      "device allocations (the project's and the UI's) and host allocations a frame");
  view->add_option("--display", o.display, "shaded, mask or diff (against Embree, in the CLI's colours)")
      ->type_name("MODE")
      ->check(CLI::IsMember({"shaded", "mask", "diff"}));
  view->footer("the window: left drag orbits, shift + left drag moves the light, W A S D Q E fly, Tab next method,\n"
               "1 2 3 shaded / mask / diff, P screenshot, R reset, U panels, H help. --frames N: exit after N frames.\n"
               "--light several times or --all-lights: the cone path shows them all at once (the panel picks them).\n"
               "Needs a window system (DISPLAY; under Xvfb: xvfb-run -a coneshadow view ...).");

  compare->add_option("--views", raw.views, "cameras by name V1,V2 (default: every camera of the scene)")->type_name("V1,V2");
  compare->add_option("--animate", o.animateFrames,
                      "dynamic scene instead: N frames over the scene's motion, each method kept across frames; "
                      "writes dynamic.md, results.json, results.csv")
      ->type_name("N")
      ->check(CLI::Range(1u, 100000u));
  compare->add_flag("--interleave", o.interleave,
                    "time the view's methods round-robin, a frame of each in turn after all their warm-ups, so a slow "
                    "spell of a shared machine falls on every method alike (every setting's method, and two masks of each, "
                    "are held at once)")
      ->group(kTuningGroup);
  compare->add_flag("--moving-camera", o.movingCamera, "with --animate: the camera orbits its target");
  compare->add_flag("--scaling", o.scaling,
                    "scaling runs instead: one view at 256², 512², 1024², 2048², then the scene as 1, 4, 16, ... "
                    "copies; writes scaling.md/.json/.csv and plots");
  compare->add_option("--scaling-max-triangles", o.scalingMaxTriangles, "bound of the triangle sweep (default 10000000)")
      ->type_name("N")
      ->check(CLI::Range(1ull, 200000000ull));
  compare->add_option("--scaling-sizes", raw.scalingSizes, "the resolution sweep's sizes N1,N2 (quick runs)")->group("");
  compare->add_option("--light-distances", raw.lightDistances,
                      "light sweep instead: the light moved out to D1,D2,... scene diagonals from the scene's centre; "
                      "writes light_distances.md/.json/.csv and plots")->type_name("D1,D2");
  compare->footer("writes into --out DIR (default compare, 256x256): results.json, results.csv, per-setting images,\n"
                  "<view>_closeups.png, report.md, report.html, speed_vs_error.svg/.png");

  visibility->add_option("scene", o.scene, "the scene, as for render (default: the built-in scene)");
  visibility->add_option("--samples", o.samples, "a text file, a sample a line: x y z nx ny nz (spaces, tabs or commas; # comments)")
      ->type_name("FILE")
      ->required();
  visibility->add_option("--light", raw.lights,
                         "point light position X,Y,Z; given again, one more light (default: the scene's first point light)")
      ->type_name("X,Y,Z")
      ->expected(1)
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  visibility->add_flag("--all-lights", o.allLights, "every point light of the scene");
  visibility->add_option("--time", raw.time, "a BART .aff scene at scene time T")->type_name("T");
  visibility->add_flag("--ground-plane", o.groundPlane, "add a receiver under the scene's bounds (normal +y)");
  visibility->add_flag("--reference", o.reference, "also Embree's answer and the ambiguity band, in columns of their own");
  visibility->add_option("--out", o.samplesOut,
                         "the CSV file (default: standard output); an existing file is replaced only when this command wrote it")
      ->type_name("FILE");
  visibility->add_option("--device", o.device, "Vulkan device by index or name substring (see `coneshadow devices`)")->type_name("D");
  visibility->add_flag("--validation", o.validation, "enable VK_LAYER_KHRONOS_validation (slow; for debugging)");
  visibility->footer("writes a CSV: a comment line, a header, then a row a sample in the file's order: facing_<l> for each\n"
                     "light l (1: the sample faces it), then visible_<l> (1: facing it and nothing between), then with\n"
                     "--reference embree_<l> (Embree's visible_<l>) and band_<l> (1: in the ambiguity band); a summary on stderr");

  info->add_option("scene", o.scene, "a .gltf/.glb, .aff or other file assimp reads, builtin, heightfield:N (a generated height field of N triangles) or family:SEED (a generated scene)");
  table->add_option("folders", o.folders, "folders written by coneshadow compare");
  table->add_flag("--host-cost", o.hostCost,
                  "instead: the first method's time over the reference's and every other method's (default "
                  "settings, same run), and each method's host cost a frame (submissions / host syncs / KiB "
                  "read back / allocations / dispatches)");
  (void)devices;

  std::vector<std::string> args(argv + 1, argv + argc);
  std::reverse(args.begin(), args.end());  // CLI11 takes the arguments back to front
  try {
    app.parse(args);
  } catch (const CLI::CallForHelp&) {
    o.command = "help";
    o.text = app.get_subcommands().empty() ? usageText() : app.help();
    return o;
  } catch (const CLI::CallForAllHelp&) {
    o.command = "help";
    o.text = usageText();
    return o;
  } catch (const CLI::CallForVersion&) {
    o.command = "version";
    o.text = versionText() + "\n";
    return o;
  } catch (const CLI::ParseError& e) {
    const std::vector<CLI::App*> subs = app.get_subcommands();
    throw UsageError(std::string(e.what()) + " (try: coneshadow " + (subs.empty() ? "help" : subs.front()->get_name() + " --help") + ")");
  }

  if (app.get_subcommands().empty()) {
    const std::vector<std::string> extras = app.remaining();
    const std::string first = extras.empty() ? "" : extras.front();
    throw UsageError("unknown command '" + first + "'" + didYouMean(first, kCommands) + " (commands: " + joined(kCommands) + ")");
  }
  CLI::App* sub = app.get_subcommands().front();
  o.command = sub->get_name();
  if (sub == help) {
    o.text = usageText();
    if (!helpTopic.empty()) {
      CLI::App* topic = nullptr;
      for (CLI::App* s : {render, compare, view, visibility, info, table, devices})
        if (s->get_name() == helpTopic) topic = s;
      if (!topic) throw UsageError("help: unknown command '" + helpTopic + "'" + didYouMean(helpTopic, kCommands));
      o.text = topic->help("coneshadow");
    }
    return o;
  }
  if (sub == render || sub == compare || sub == view) refuseUnknown(sub->remaining(), *sub, sub == render ? *compare : *render);
  if (sub == info && o.scene.empty()) throw UsageError("info needs a SCENE (a .gltf/.glb file, or builtin)");
  if ((sub == info || sub == devices) && !sub->remaining().empty())
    throw UsageError(sub->get_name() + " takes " + (sub == info ? "one SCENE" : "no arguments") + "; '" +
                     sub->remaining().front().substr(0, 60) + "' is one too many");
  if (sub == table && o.folders.empty()) throw UsageError("results-table needs one or more folders written by coneshadow compare");
  if (sub == visibility) {
    if (!sub->remaining().empty())
      throw UsageError("visibility takes one SCENE; '" + sub->remaining().front().substr(0, 60) + "' is one too many");
    for (const std::string& light : raw.lights) o.lights.push_back(parseVec3("--light", light));
    if (!raw.time.empty()) o.sceneTime = parseNumber("--time", raw.time, -1e300, 1e300, "a finite number (scene time)");
    if (o.allLights && !o.lights.empty())
      throw UsageError("--all-lights takes the scene's point lights and --light gives them: give one or the other");
    return o;
  }
  if (sub != render && sub != compare && sub != view) return o;

  // Values converted here, so each bad one is a one-line error naming its flag.
  for (const std::string& light : raw.lights) o.lights.push_back(parseVec3("--light", light));
  if (!raw.time.empty()) o.sceneTime = parseNumber("--time", raw.time, -1e300, 1e300, "a finite number (scene time)");
  if (!raw.views.empty()) o.views = splitList("--views", raw.views);
  // Given but empty (--method ''): a run of nothing is a mistake, not a request for the default.
  for (const char* flag : {"--method", "--methods"})
    if (const CLI::Option* opt = sub->get_option_no_throw(flag); opt && opt->count() > 0 &&
        (std::string(flag) == "--method" ? raw.method : raw.methods).empty())
      throw UsageError(std::string(flag) + " names no method: give one, e.g. " + flag + " cone (see `coneshadow help`)");
  if (!raw.method.empty()) o.methods.push_back(raw.method);
  if (!raw.methods.empty())
    for (const std::string& m : splitList("--methods", raw.methods)) o.methods.push_back(m);
  if (!raw.lightDistances.empty())
    for (const std::string& item : splitList("--light-distances", raw.lightDistances))
      o.lightDistances.push_back(
          parseNumber("--light-distances", item, 1e-300, 1e15, "distances in scene diagonals in (0, 1e15] separated by commas"));
  if (!raw.scalingSizes.empty())
    for (const std::string& item : splitList("--scaling-sizes", raw.scalingSizes))
      o.scalingSizes.push_back(uint32_t(parseNumber("--scaling-sizes", item, 1, 16384, "whole sizes in [1, 16384] separated by commas")));
  if (sub == compare) {
    if (compare->count("--width") == 0) o.width = 256;
    if (compare->count("--height") == 0) o.height = 256;
    if (compare->count("--out") == 0) o.out = "compare";
  }
  if (o.movingCamera && !o.animateFrames) throw UsageError("--moving-camera needs --animate N");
  if (o.interleave && (o.animateFrames || o.scaling || !raw.lightDistances.empty()))
    throw UsageError("--interleave times a view's methods side by side; --animate, --scaling and --light-distances run "
                     "their own sweeps: drop one of them");
  if (o.animateFrames && o.scaling) throw UsageError("--animate and --scaling are separate runs; give one of them");
  if (o.allLights && !o.lights.empty())
    throw UsageError("--all-lights takes the scene's point lights and --light gives them: give one or the other");
  if ((o.lights.size() > 1 || o.allLights) && (o.animateFrames || o.scaling || !o.lightDistances.empty()))
    throw UsageError("--animate, --scaling and --light-distances run under one light: give at most one --light and "
                     "no --all-lights");
  if (!o.lightDistances.empty() && (o.animateFrames || o.scaling))
    throw UsageError("--light-distances is a run of its own; give it without --animate and --scaling");

  // Methods: render runs the reference alone when none is named.
  if (sub == render && o.methods.empty()) o.methods = {referenceMethod().name};
  if (sub == view) {  // the cone path first; its frames count from 1 and are not timed repeats
    if (o.methods.empty()) o.methods = {"cone"};
    if (view->count("--frames") == 0) o.frames = 0;
    if (o.lights.size() > viewer::kMaxLights)
      throw UsageError("view shows up to " + std::to_string(viewer::kMaxLights) + " lights at once: give fewer --light");
    for (const char* flag : {"--out", "--validation", "--quiet"})
      if (view->count(flag)) throw UsageError(std::string("view writes no folder and prints no progress: drop ") + flag);
    if (!o.screenshot.empty() && o.frames == 0 && o.script.empty())
      throw UsageError("--screenshot writes the last frame of a run that ends by itself: give --frames N or a --script");
  }
  std::vector<const MethodInfo*> chosen = chosenMethods(o);
  o.methods.clear();
  for (const MethodInfo* m : chosen) o.methods.push_back(m->name);
  for (const auto& [name, value] : o.settings) {
    const bool taken = std::any_of(chosen.begin(), chosen.end(), [&](const MethodInfo* m) {
      return std::any_of(m->settings.begin(), m->settings.end(), [&](const SettingSpec& s) { return s.name == name; });
    });
    if (taken) continue;
    std::vector<std::string> owners;
    for (const MethodInfo& m : registeredMethods())
      for (const SettingSpec& s : m.settings)
        if (s.name == name) owners.push_back(m.name);
    throw UsageError("--" + name + " is a setting of " + joined(owners, " and ") + ", which this run does not use (methods: " +
                     joined(o.methods) + "; add one with --methods)");
  }
  for (const MethodInfo* m : chosen)
    if (m->check) m->check(settingsFor(o, *m));
  return o;
}

std::vector<std::string> runInputs(const Options& options) {
  std::error_code ec;
  if (options.scene.empty() || !std::filesystem::exists(options.scene, ec)) return {};
  return {options.scene};
}

}  // namespace cs
