// Frames for Python (python/: `import coneshadow`): render() and compare() on the harness's one run entry
// (harness/run.h), as the CLI's render and compare call it, so a frame's rows hold the keys and numbers of
// the CLI's results.json for the same scene, view, light, size and settings. The methods and their
// settings are checked as the CLI checks them (a wrong one is a ValueError before any work); the GIL is
// released while the device and Embree work.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>


#include "app/cli.h"
#include "app/compare.h"
#include "app/frame_runner.h"
#include "harness/run.h"
#include "judge/frame_output.h"
#include "python/bindings.h"
#include "vk/context.h"

namespace cs::python {

namespace {

// The methods asked for: None -> `fallback` (render: none but the reference, as the CLI's render; compare:
// every registered method), a name, or a list of names.
std::vector<std::string> methodNames(py::handle methods, bool all) {
  std::vector<std::string> names;
  if (methods.is_none()) {
    if (!all) names.push_back(referenceMethod().name);
    return names;  // empty: every method (chosenMethods)
  }
  if (py::isinstance<py::str>(methods)) return {methods.cast<std::string>()};
  if (!py::isinstance<py::sequence>(methods)) usage("methods: expected a method name or a list of them (coneshadow.methods())");
  for (py::handle m : methods) {
    if (!py::isinstance<py::str>(m)) usage("methods: expected a list of method names (coneshadow.methods())");
    names.push_back(m.cast<std::string>());
  }
  if (names.empty()) usage("methods: the list names no method; give one, e.g. ['cone'] (coneshadow.methods())");
  return names;
}

// settings={'sm-resolution': 2048, 'sorted': False}: each as the CLI's --name VALUE (a switch: True given,
// False left out; True/False elsewhere: on/off), in the order given.
std::vector<std::pair<std::string, std::string>> settingPairs(py::handle settings) {
  std::vector<std::pair<std::string, std::string>> out;
  if (settings.is_none()) return out;
  if (!py::isinstance<py::dict>(settings)) usage("settings: expected a dict of setting name -> value, e.g. {'sm-resolution': 2048}");
  for (auto [k, v] : settings.cast<py::dict>()) {
    if (!py::isinstance<py::str>(k)) usage("settings: the names are strings, as the CLI's flags without the dashes");
    std::string name = k.cast<std::string>();
    if (name.rfind("--", 0) == 0) name = name.substr(2);
    const SettingSpec* spec = nullptr;
    for (const MethodInfo& m : registeredMethods())
      for (const SettingSpec& s : m.settings)
        if (s.name == name) spec = &s;
    if (!spec) {
      std::vector<std::string> all;
      for (const MethodInfo& m : registeredMethods())
        for (const SettingSpec& s : m.settings) all.push_back(s.name);
      usage("settings: no method takes a setting '" + name + "'" + didYouMean(name, all) + " (see `coneshadow render --help`)");
    }
    if (py::isinstance<py::bool_>(v)) {
      const bool on = v.cast<bool>();
      if (spec->value.empty()) {
        if (on) out.emplace_back(name, "");
        continue;
      }
      out.emplace_back(name, on ? "on" : "off");
    } else if (py::isinstance<py::int_>(v) || py::isinstance<py::float_>(v) || py::isinstance<py::str>(v)) {
      out.emplace_back(name, py::str(v).cast<std::string>());
    } else {
      usage("settings: '" + name + "' wants a number, a string or a bool, got " +
            std::string(py::str(py::type::of(v).attr("__name__"))));
    }
  }
  return out;
}

// The run's options as the CLI would hold them: the methods, their settings checked as parseArgs checks them.
Options runOptions(py::handle methods, py::handle settings, bool all, const std::string& call) {
  Options o;
  o.commandLine = "python: coneshadow." + call;
  o.settings = settingPairs(settings);
  for (const std::string& n : methodNames(methods, all)) o.methods.push_back(methodOrUsageError(n).name);
  const std::vector<const MethodInfo*> chosen = chosenMethods(o);
  for (const auto& [name, value] : o.settings) {
    const bool taken = std::any_of(chosen.begin(), chosen.end(), [&, n = name](const MethodInfo* m) {
      return std::any_of(m->settings.begin(), m->settings.end(), [&](const SettingSpec& s) { return s.name == n; });
    });
    if (!taken) {
      std::string owners, names;
      for (const MethodInfo& m : registeredMethods())
        for (const SettingSpec& s : m.settings)
          if (s.name == name) owners += (owners.empty() ? "" : " and ") + m.name;
      for (const MethodInfo* m : chosen) names += (names.empty() ? "" : ", ") + m->name;
      usage("settings: '" + name + "' is a setting of " + owners + ", which this run does not use (methods: " + names + ")");
    }
  }
  for (const MethodInfo* m : chosen)
    if (m->check) m->check(settingsFor(o, *m));
  return o;
}

uint32_t sizeOf(int64_t v, const char* what) {
  if (v < 1 || v > 16384) usage(std::string(what) + ": expected 1 to 16384 pixels, got " + std::to_string(v));
  return uint32_t(v);
}

uint32_t framesOf(int64_t v) {
  if (v < 1 || v > 1000) usage("frames: expected 1 to 1000 timed frames, got " + std::to_string(v));
  return uint32_t(v);
}

// A row as results.json holds it, with the provenance the CLI gives it (the scene given as arrays names none).
py::object rowOf(FrameResult r, const Options& o, const Scene& scene, const harness::Frame& f) {
  r.provenance = runProvenance(o, scene, f.lightPosition, f.camera);
  if (scene.sourcePath.empty() && scene.name != "builtin") r.provenance["scene_path"] = scene.name;
  return toPython(toJson(r));
}

template <class T>
py::array_t<T> array(std::vector<py::ssize_t> shape) {
  return py::array_t<T>(shape);
}

// The prepared frames' samples and answers as arrays: position and normal (H, W, 3) of the first frame
// (NaN where there is no geometry; the normal turned toward the camera), and per light lit, reference
// and band (L, H, W).
void frameArrays(py::dict& out, const std::vector<const PreparedFrame*>& frames) {
  const GBuffer& g0 = frames.front()->gbuffer;
  const py::ssize_t H = g0.height, W = g0.width, L = py::ssize_t(frames.size()), n = H * W;
  auto position = array<float>({H, W, 3}), normal = array<float>({H, W, 3});
  float* p = position.mutable_data();
  float* q = normal.mutable_data();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (py::ssize_t i = 0; i < n; ++i) {
    const bool geometry = g0.hasGeometry(size_t(i));
    for (int k = 0; k < 3; ++k) {
      p[i * 3 + k] = geometry ? g0.position[i][k] : nan;
      q[i * 3 + k] = geometry ? g0.normal[i][k] : nan;
    }
  }
  auto lit = array<bool>({L, H, W}), band = array<bool>({L, H, W});
  auto reference = array<float>({L, H, W});
  for (py::ssize_t l = 0; l < L; ++l) {
    const PreparedFrame& f = *frames[size_t(l)];
    bool* li = lit.mutable_data() + l * n;
    bool* bi = band.mutable_data() + l * n;
    for (py::ssize_t i = 0; i < n; ++i) {
      li[i] = f.gbuffer.isLit(size_t(i));
      bi[i] = !f.band.empty() && f.band[size_t(i)] != 0;
    }
    std::copy_n(f.reference.output.visibility.data(), n, reference.mutable_data() + l * n);
  }
  out["position"] = position;
  out["normal"] = normal;
  out["lit"] = lit;
  out["reference"] = reference;
  out["band"] = band;
}

// render(): the reference's row first, then each method's, on one view under each light.
py::dict render(std::shared_ptr<Scene> scene, py::handle camera, py::handle lights, int64_t width, int64_t height,
                py::handle methods, py::handle settings, int64_t frames) {
  const Options o = runOptions(methods, settings, false, "render");
  const Camera cam = frameCamera(*scene, camera);
  const std::vector<glm::vec3> ls = framesLights(*scene, lights);
  const MethodInfo* reference = &referenceMethod();
  harness::RunSpec spec;
  spec.scene = scene.get();
  spec.views = {{cam, cam.name.empty() ? "auto" : cam.name}};
  spec.lights = ls;
  spec.width = sizeOf(width, "width");
  spec.height = sizeOf(height, "height");
  spec.frames = framesOf(frames);
  spec.keepFrames = true;
  spec.methods.push_back({reference, reference->name, settingsFor(o, *reference)});
  for (const MethodInfo* m : chosenMethods(o))
    if (!m->reference) spec.methods.push_back({m, m->name, settingsFor(o, *m)});

  harness::Results ran;
  {
    py::gil_scoped_release release;
    auto lock = lockDevice();
    ran = harness::run(device(), spec);
  }

  py::dict out;
  out["device"] = ran.device;
  out["camera"] = cam;
  out["view"] = spec.views.front().name;
  py::list rows;
  py::dict visibility;
  std::vector<const PreparedFrame*> prepared;
  const py::ssize_t L = py::ssize_t(ran.frames.size()), H = spec.height, W = spec.width, n = H * W;
  std::map<std::string, py::array_t<float>> masks;
  for (const harness::RunMethod& m : spec.methods) masks.emplace(m.info->name, array<float>({L, H, W}));
  for (py::ssize_t l = 0; l < L; ++l) {
    const harness::Frame& f = ran.frames[size_t(l)];
    py::list light;
    for (const harness::Row& r : f.rows) {
      light.append(rowOf(r.result, o, *scene, f));
      const std::vector<float>& v = r.judged.runs.output.visibility;
      CS_CHECK(py::ssize_t(v.size()) == n, "render: " << r.result.method << " kept no mask");
      std::copy_n(v.data(), n, masks.at(r.result.method).mutable_data() + l * n);
    }
    rows.append(light);
    prepared.push_back(f.prepared.get());
  }
  for (auto& [name, a] : masks) visibility[py::str(name)] = a;
  out["rows"] = rows;
  out["visibility"] = visibility;
  auto lightArray = array<float>({L, 3});
  for (py::ssize_t l = 0; l < L; ++l)
    for (int k = 0; k < 3; ++k) lightArray.mutable_data()[l * 3 + k] = ls[size_t(l)][k];
  out["lights"] = lightArray;
  frameArrays(out, prepared);
  return out;
}

// compare(): every chosen method's sweep (MethodInfo::sweep) on each view under each light; the rows the
// CLI's compare writes to results.json (stats "timing" and the provenance included), and, given `out`,
// results.json and results.csv there.
py::list compare(std::shared_ptr<Scene> scene, py::handle views, py::handle lights, int64_t width, int64_t height,
                 py::handle methods, py::handle settings, int64_t frames, bool interleave, py::handle outDir) {
  Options o = runOptions(methods, settings, true, "compare");
  o.interleave = interleave;
  std::vector<CompareSetting> sweep = compareSettings(o);
  std::vector<Camera> cameras;
  if (views.is_none()) {
    cameras = scene->cameras.empty() ? std::vector<Camera>{frameCamera(*scene, views)} : scene->cameras;
  } else {
    if (py::isinstance<py::str>(views) || py::isinstance<Camera>(views)) usage("views: expected a list of Camera or view names");
    if (!py::isinstance<py::sequence>(views)) usage("views: expected a list of Camera or view names");
    for (py::handle v : views) cameras.push_back(frameCamera(*scene, v));
    if (cameras.empty()) usage("views: the list names no view");
  }
  const std::vector<glm::vec3> ls = framesLights(*scene, lights);
  std::string out;
  if (!outDir.is_none()) out = py::str(outDir).cast<std::string>();

  harness::RunSpec spec;
  spec.scene = scene.get();
  spec.views = harness::viewsOf(cameras);
  spec.lights = ls;
  spec.width = sizeOf(width, "width");
  spec.height = sizeOf(height, "height");
  spec.frames = framesOf(frames);
  spec.interleave = interleave;
  std::vector<std::string> skipped;
  std::vector<FrameResult> results;
  harness::Results ran;
  {
    py::gil_scoped_release release;
    auto lock = lockDevice();
    vk::Context& ctx = device();
    // The sweep points the device cannot run are skipped, as compare skips them (each named in a warning).
    for (const CompareSetting& s : sweep) {
      if (const std::string why = unsupportedOn(*s.method, ctx, s.settings); !why.empty()) {
        skipped.push_back("skipping " + s.label + ": " + why);
        continue;
      }
      spec.methods.push_back({s.method, s.label, s.settings, s.defaults});
    }
    if (spec.methods.empty()) throw Error("no setting of the chosen methods runs on this device", ctx.deviceName());
    ran = harness::run(ctx, spec);
  }
  for (const std::string& s : skipped) warnLines(s);
  py::list rows;
  for (const harness::Frame& f : ran.frames)
    for (const harness::Row& r : f.rows) {
      FrameResult row = r.result;
      row.stats["timing"] = interleave ? "interleaved" : "sequential";
      row.provenance = runProvenance(o, *scene, f.lightPosition, f.camera);
      if (scene->sourcePath.empty() && scene->name != "builtin") row.provenance["scene_path"] = scene->name;
      results.push_back(row);
      rows.append(toPython(toJson(row)));
    }
  if (!out.empty()) {
    py::gil_scoped_release release;
    writeResults(out, results);
  }
  return rows;
}

}  // namespace

void bindFrames(py::module_& m) {
  m.def("_render", &render, py::arg("scene"), py::arg("camera"), py::arg("lights"), py::arg("width"), py::arg("height"),
        py::arg("methods"), py::arg("settings"), py::arg("frames"),
        "render() without its Python wrapper: a dict of the frame's rows and arrays (coneshadow.render).");
  m.def("_compare", &compare, py::arg("scene"), py::arg("views"), py::arg("lights"), py::arg("width"), py::arg("height"),
        py::arg("methods"), py::arg("settings"), py::arg("frames"), py::arg("interleave"), py::arg("out"),
        "compare() without its Python wrapper (coneshadow.compare).");
}

}  // namespace cs::python
