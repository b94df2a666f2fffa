// What the Python module's parts share (python/: `import coneshadow`): the one Vulkan context of the
// process and its lock, the checks that turn a wrong argument into a ValueError naming what was expected,
// and the numpy conversions. The errors: cs::UsageError and a wrong argument -> ValueError; cs::Error (a
// scene or the device) -> RuntimeError; each with the CLI's one-line message.
#pragma once
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "core/error.h"
#include "harness/samples.h"

namespace cs {
struct Scene;
struct Camera;
namespace vk {
struct Context;
}
}  // namespace cs

namespace cs::python {

namespace py = pybind11;

// The process's Vulkan context, made on first use with the device chosen by set_device ("" = automatic,
// as the CLI's --device). Take the lock (with the GIL released) before device(), and hold it while the
// context is used: one frame at a time, whichever Python thread asks.
std::unique_lock<std::mutex> lockDevice();
vk::Context& device();
// The cone engine visibility() records with (harness/samples.h: made on first use), on the context of
// device(), ended with it. Hold the lock.
SampleEngine& engineSlot();
// set_device(): the next device() makes a context on `device` (index or name substring).
void chooseDevice(const std::string& device, bool validation);
// The context's driver description (making it if needed).
std::string deviceDescription();
// Destroys the context (at interpreter exit, before the Vulkan loader unloads).
void releaseDevice();

// A wrong argument: ValueError with this message.
[[noreturn]] void usage(const std::string& message);

// `a` as a C-contiguous float32 (N, 3) array (copied only when not contiguous). Anything else -> ValueError:
// "<what>: expected a float32 array of shape (N, 3), got <its type, dtype and shape>".
py::array_t<float, py::array::c_style> floatRows(py::handle a, const std::string& what);
// The same for a uint32 (M, 3) array.
py::array_t<uint32_t, py::array::c_style> indexRows(py::handle a, const std::string& what);
// Three finite numbers (a tuple, a list, an array of any real dtype) or ValueError naming `what`.
glm::vec3 vec3Of(py::handle v, const std::string& what);
// One light (3,) or several (L, 3), as numbers; L >= 1, each finite; ValueError otherwise.
std::vector<glm::vec3> lightsOf(py::handle v, const std::string& what);
// A JSON value as Python objects (dict, list, float, int, str, bool, None): through Python's json, so the
// numbers are the digits results.json holds.
py::object toPython(const nlohmann::json& j);
// Python warnings (UserWarning), one per non-empty line of `text` (the loaders' and the CLI's warnings).
void warnLines(const std::string& text);

// The parts of the module.
void bindScenes(py::module_& m);
void bindFrames(py::module_& m);
void bindSamples(py::module_& m);

// The lights of a run, each a frame, as the CLI's chooseLights (app/frame_runner.h): the lights given
// ((3,) or (L, 3)); 'all', every point light of the scene (--all-lights); None, the scene's first point
// light, else an automatic one (a warning). A given light too far for fp32 ray lengths is a ValueError,
// the scene's own a RuntimeError.
std::vector<glm::vec3> framesLights(const Scene& scene, py::handle lights);
// The camera of a frame: a Camera, a view name of the scene, or None (the scene's first camera, else an
// automatic one, with a warning).
Camera frameCamera(const Scene& scene, py::handle camera);

}  // namespace cs::python
