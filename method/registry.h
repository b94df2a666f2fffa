// The method registry: every shadow method declares itself here, next to its own code, and everything
// else -- the CLI, compare and its sweeps, --animate, --scaling, the reports, the benchmarks, the tests --
// iterates the registry and names no method. Adding a method is its folder plus one
// coneshadow_method(...) line in the top-level CMakeLists.txt (docs/ARCHITECTURE.md, "Adding a shadow
// method"); a test may register one more at run time with registerMethod.
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "method/method.h"
#include "method/settings.h"

namespace cs {

// One setting a method takes on the command line, as --name VALUE or --name=VALUE (or --name alone for
// a switch). Two methods may declare the same name (--plane-bias): a given value then reaches both.
struct SettingSpec {
  std::string name;                  // without the dashes: "sm-resolution"
  std::string value;                 // what the value looks like in help ("N", "BYTES", "on|off"); "" = a switch
  std::string help;
  std::vector<std::string> choices;  // an enumeration (matched without regard to case), shown in help
  // A knob that never changes the mask (speed, work split, profiling): for benchmarks and tests. Help
  // lists it apart, under the tuning group (kTuningGroup), not among the settings users choose.
  bool tuning = false;
};

// The help group of every setting and option that never changes a mask.
inline constexpr const char* kTuningGroup = "Tuning (benchmarks and tests; never changes the mask)";

// One point of a method's sweep (compare) or one row of a dynamic run: a label and the settings for it.
struct SweepPoint {
  std::string label;  // "cubesm@512", "rmsm (cached)"
  Settings settings;
  bool defaults = false;  // the point the method's default settings give (its row in summaries)
};

struct MethodInfo {
  std::string name;     // lower case, the CLI's name
  std::string summary;  // one line for help
  // The judge's own reference (Embree): its row is the reference run, not a second one.
  bool reference = false;
  // Runs on the Vulkan device (reports name the device); false: on the CPU.
  bool usesDevice = true;
  // Claims the reference's answer on every lit sample outside the ambiguity band (at its default
  // settings); the registry's contract test holds it to that on every view it runs.
  bool exact = false;
  // Its answer improves over frames of a static view (a tree refined frame by frame): a timed run's row
  // shows the last frame's mask, and every row lists each frame's time and error (harness.h).
  bool progressive = false;
  std::vector<SettingSpec> settings;
  // Parses every setting, throws UsageError naming the method and the setting. Runs before any work.
  std::function<void(const Settings&)> check;
  // The method, ready to run frames on `ctx` (null when usesDevice is false).
  std::function<std::unique_ptr<ShadowMethod>(vk::Context* ctx, const Settings&)> make;
  // compare's sweep of the method's quality or memory knob around the given settings; unset: one point,
  // the given settings, labelled with the name.
  std::function<std::vector<SweepPoint>(const Settings&)> sweep;
  // compare --animate's rows; staticGeometry: only the camera moves. Unset: one row, the given settings.
  std::function<std::vector<SweepPoint>(const Settings&, bool staticGeometry)> dynamicRows;
  // Why the device cannot run the method with these settings (a feature it lacks), or "" when it can.
  // Unset: every device can. compare skips such a sweep point with the reason in its log and report;
  // a method the user named whose every point is unsupported is an error before any work.
  std::function<std::string(const vk::Context& ctx, const Settings&)> unsupported;
};

// The reason the device cannot run `info` with `settings` ("" when it can).
std::string unsupportedOn(const MethodInfo& info, const vk::Context& ctx, const Settings& settings);

// Adds a method; Error when the name is taken. Methods are listed in the order they were registered.
void registerMethod(MethodInfo info);
// Removes a method registered at run time (tests); false when there is none by that name.
bool unregisterMethod(const std::string& name);
// The registered methods, in the order they were registered.
const std::vector<MethodInfo>& registeredMethods();
std::vector<std::string> registeredMethodNames();
// The method of that name (without regard to case), or null.
const MethodInfo* findMethod(const std::string& name);
// The method of that name, or UsageError listing the methods (with "did you mean").
const MethodInfo& methodOrUsageError(const std::string& name);

// The judge's reference (MethodInfo::reference); Error when none is registered.
const MethodInfo& referenceMethod();

std::vector<SweepPoint> sweepOf(const MethodInfo& info, const Settings& settings);
std::vector<SweepPoint> dynamicRowsOf(const MethodInfo& info, const Settings& settings, bool staticGeometry);

// Registers the built-in methods, once (later calls do nothing); generated at build time from the
// coneshadow_method lines (cmake/Methods.cmake) into the library cs_methods. Every program that uses the
// registry calls it first (the CLI when it parses its arguments), so the built-in methods come first.
void registerBuiltinMethods();

}  // namespace cs
