// The extension coneshadow._coneshadow (python/: `import coneshadow`): the module, its errors, the one
// Vulkan context of the process, and the argument checks and numpy conversions its parts share
// (bindings.h). The parts: scenes.cpp (Scene, Camera, Light), frames.cpp (render, compare on the
// harness's one run entry), samples.cpp (visibility of samples of the caller's own, on the engine).
#include "python/bindings.h"

#include <cmath>
#include <sstream>

#include "core/scene.h"
#include "method/epsilon.h"
#include "method/registry.h"
#include "traversal/cone_engine.h"
#include "vk/context.h"

namespace cs::python {

namespace {

struct DeviceState {
  std::mutex mutex;
  std::unique_ptr<vk::Context> ctx;
  SampleEngine engine;  // ended before ctx
  std::string device;
  bool validation = false;
};

DeviceState& state() {
  static DeviceState* s = new DeviceState;  // never destroyed: releaseDevice() ends the context at exit
  return *s;
}

// "list", "float64 array of shape (4, 2)": what the caller passed, for a message.
std::string described(py::handle a) {
  if (py::isinstance<py::array>(a)) {
    py::array arr = py::reinterpret_borrow<py::array>(a);
    std::string shape = "(";
    for (py::ssize_t i = 0; i < arr.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(arr.shape(i));
    shape += arr.ndim() == 1 ? ",)" : ")";
    return std::string(py::str(arr.dtype())) + " array of shape " + shape;
  }
  return std::string(py::str(py::type::of(a).attr("__name__")));
}

template <class T>
py::array_t<T, py::array::c_style> rowsOf(py::handle a, const std::string& what, const char* dtype) {
  const std::string expected = std::string("expected a ") + dtype + " array of shape (" +
                               (std::string(dtype) == "uint32" ? "M" : "N") + ", 3)";
  if (!py::isinstance<py::array>(a)) usage(what + ": " + expected + ", got " + described(a));
  py::array arr = py::reinterpret_borrow<py::array>(a);
  if (!arr.dtype().is(py::dtype::of<T>()) || arr.ndim() != 2 || arr.shape(1) != 3)
    usage(what + ": " + expected + ", got " + described(a));
  return py::array_t<T, py::array::c_style>::ensure(arr);
}

}  // namespace

std::unique_lock<std::mutex> lockDevice() { return std::unique_lock<std::mutex>(state().mutex); }

vk::Context& device() {
  DeviceState& s = state();
  if (!s.ctx) {
    vk::ContextOptions o;
    o.device = s.device;
    o.validation = s.validation;
    o.quiet = true;
    s.ctx = vk::createContext(o);
  }
  return *s.ctx;
}

void chooseDevice(const std::string& name, bool validation) {
  py::gil_scoped_release release;
  auto lock = lockDevice();
  DeviceState& s = state();
  s.engine = {};
  s.ctx.reset();
  s.device = name;
  s.validation = validation;
}

std::string deviceDescription() {
  py::gil_scoped_release release;
  auto lock = lockDevice();
  return device().driverDescription();
}

void releaseDevice() {
  py::gil_scoped_release release;
  auto lock = lockDevice();
  state().engine = {};
  state().ctx.reset();
}

SampleEngine& engineSlot() { return state().engine; }

void usage(const std::string& message) { throw UsageError(message); }

py::array_t<float, py::array::c_style> floatRows(py::handle a, const std::string& what) {
  return rowsOf<float>(a, what, "float32");
}

py::array_t<uint32_t, py::array::c_style> indexRows(py::handle a, const std::string& what) {
  return rowsOf<uint32_t>(a, what, "uint32");
}

glm::vec3 vec3Of(py::handle v, const std::string& what) {
  py::array arr;
  try {
    arr = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(v);
  } catch (const py::error_already_set&) {
  }
  if (!arr || arr.ndim() != 1 || arr.shape(0) != 3 || py::isinstance<py::str>(v))
    usage(what + ": expected three numbers (x, y, z), got " + described(v));
  const double* d = static_cast<const double*>(arr.data());
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(d[i]) || std::fabs(d[i]) > 3.4e38) usage(what + ": expected three finite numbers, got " + std::string(py::repr(v)));
  return {float(d[0]), float(d[1]), float(d[2])};
}

std::vector<glm::vec3> lightsOf(py::handle v, const std::string& what) {
  py::array arr;
  try {
    arr = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(v);
  } catch (const py::error_already_set&) {
  }
  const bool one = arr && arr.ndim() == 1 && arr.shape(0) == 3;
  if (!arr || py::isinstance<py::str>(v) || !(one || (arr.ndim() == 2 && arr.shape(1) == 3 && arr.shape(0) >= 1)))
    usage(what + ": expected one light (x, y, z) or several, shape (L, 3) with L >= 1, got " + described(v));
  const double* d = static_cast<const double*>(arr.data());
  std::vector<glm::vec3> out(one ? 1 : size_t(arr.shape(0)));
  for (size_t l = 0; l < out.size(); ++l) {
    for (int i = 0; i < 3; ++i) {
      const double x = d[l * 3 + i];
      if (!std::isfinite(x) || std::fabs(x) > 3.4e38)
        usage(what + ": light " + std::to_string(l) + " is not three finite numbers");
      out[l][i] = float(x);
    }
  }
  return out;
}

py::object toPython(const nlohmann::json& j) {
  static py::object* loads = new py::object(py::module_::import("json").attr("loads"));  // kept past finalization
  return (*loads)(j.dump());
}

void warnLines(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line))
    if (!line.empty() && PyErr_WarnEx(PyExc_UserWarning, line.c_str(), 2) != 0) throw py::error_already_set();
}

std::vector<glm::vec3> framesLights(const Scene& scene, py::handle lights) {
  if (py::isinstance<py::str>(lights)) {  // the CLI's --all-lights
    if (lights.cast<std::string>() != "all")
      usage("lights: expected one light (x, y, z), several (L, 3), 'all' or None, got '" + lights.cast<std::string>() + "'");
    if (scene.lights.empty())
      usage("lights='all': scene " + scene.name + " has no point light" +
            (scene.unusableLights.empty() ? std::string() : " (its light " + scene.unusableLights.front() + " is not a point light)") +
            "; give one or more as lights=");
    std::vector<glm::vec3> out;
    for (const PointLight& l : scene.lights) {
      if (std::string why = lightRangeProblem(l.position, scene.boundsMin, scene.boundsMax); !why.empty())
        throw Error(why, "scene " + scene.name + ", light '" + l.name + "'", "give a closer one with lights=");
      out.push_back(l.position);
    }
    return out;
  }
  if (!lights.is_none()) {
    std::vector<glm::vec3> out = lightsOf(lights, "lights");
    for (size_t l = 0; l < out.size(); ++l)
      if (std::string why = lightRangeProblem(out[l], scene.boundsMin, scene.boundsMax); !why.empty())
        usage("lights: light " + std::to_string(l) + ": " + why);
    return out;
  }
  if (!scene.lights.empty()) {
    const glm::vec3 l = scene.lights.front().position;
    if (std::string why = lightRangeProblem(l, scene.boundsMin, scene.boundsMax); !why.empty())
      throw Error(why, "scene " + scene.name + ", light '" + scene.lights.front().name + "'", "give a closer one with lights=");
    return {l};
  }
  if (!scene.unusableLights.empty())
    throw Error("the scene's light " + scene.unusableLights.front() + " is not a point light; the methods shadow point lights",
                "scene " + scene.name, "give one with lights=");
  const glm::vec3 l = automaticLight(scene).position;
  std::ostringstream os;
  os << "no point light in the scene: using an automatic one at " << l.x << "," << l.y << "," << l.z
     << " (give one with lights=)";
  warnLines(os.str());
  return {l};
}

Camera frameCamera(const Scene& scene, py::handle camera) {
  if (py::isinstance<Camera>(camera)) return camera.cast<Camera>();
  if (py::isinstance<py::str>(camera)) {
    const std::string name = camera.cast<std::string>();
    if (const Camera* c = scene.findCamera(name)) return *c;
    std::string all;
    for (const Camera& c : scene.cameras) all += (all.empty() ? "" : ", ") + c.name;
    usage("scene " + scene.name + " has no view '" + name + "'" + (all.empty() ? " (it has no cameras)" : " (views: " + all + ")"));
  }
  if (!camera.is_none()) usage("camera: expected a Camera, a view name or None, got " + described(camera));
  if (!scene.cameras.empty()) return scene.cameras.front();
  Camera c = automaticCamera(scene);
  std::ostringstream os;
  os << "no camera in the scene: using an automatic one (eye " << c.eye.x << "," << c.eye.y << "," << c.eye.z << ")";
  warnLines(os.str());
  return c;
}

}  // namespace cs::python

PYBIND11_MODULE(_coneshadow, m) {
  namespace py = pybind11;
  using namespace cs::python;
  m.doc() = "coneshadow's extension: scenes, frames judged against Embree, and the visibility of samples of your own.";
  cs::registerBuiltinMethods();

  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const cs::UsageError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const cs::Error& e) {
      PyErr_SetString(PyExc_RuntimeError, e.what());
    }
  });

  m.def("set_device", &chooseDevice, py::arg("device") = "", py::arg("validation") = false,
        "Chooses the Vulkan device the next frame runs on: an index or a name substring as `coneshadow devices`\n"
        "lists them ('' = automatic: discrete > integrated > virtual > cpu); validation turns on\n"
        "VK_LAYER_KHRONOS_validation. The context is made on first use.");
  m.def("device", &deviceDescription, "The Vulkan device frames run on, as the CLI's reports name it (making the context).");
  m.def("devices", [] { return cs::vk::listDevices(); }, "One line per Vulkan device, as `coneshadow devices` prints them.");
  m.def("methods", [] { return cs::registeredMethodNames(); }, "The registered shadow methods, in the registry's order.");
  m.def("_release_device", &releaseDevice, "Ends the Vulkan context (the package calls it at exit).");

  bindScenes(m);
  bindFrames(m);
  bindSamples(m);
}
