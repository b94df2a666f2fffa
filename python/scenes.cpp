// Scenes, cameras and lights for Python (python/: `import coneshadow`): Scene.load reads what the CLI's
// SCENE reads (app/commands.h, loadSceneArg: glTF, BART, assimp's formats, heightfield:N, builtin),
// Scene.from_arrays takes the caller's triangles, Scene.builtin is the built-in room. A Scene is not
// changed after it is made (the frames key their caches on its geometry); its arrays come out as copies.
#include <cmath>
#include <sstream>

#include <glm/gtc/constants.hpp>

#include "app/cli.h"
#include "app/commands.h"
#include "core/scene.h"
#include "method/epsilon.h"
#include "python/bindings.h"

namespace cs::python {

namespace {

py::tuple tupleOf(glm::vec3 v) { return py::make_tuple(v.x, v.y, v.z); }

std::string text(glm::vec3 v) {
  std::ostringstream os;
  os << "(" << v.x << ", " << v.y << ", " << v.z << ")";
  return os.str();
}

// A camera as the raster pass can use it, else ValueError naming the field.
Camera makeCamera(py::handle eye, py::handle target, py::handle up, double yfov, const std::string& name, double znear,
                  double zfar) {
  Camera c;
  c.name = name;
  c.eye = vec3Of(eye, "Camera eye");
  c.target = vec3Of(target, "Camera target");
  c.up = vec3Of(up, "Camera up");
  if (c.target == c.eye) usage("Camera: target equals eye; the camera has no view direction");
  const glm::vec3 forward = c.target - c.eye;
  if (glm::length(glm::cross(forward, c.up)) <= 1e-6f * glm::length(forward) * glm::length(c.up))
    usage("Camera: up " + text(c.up) + " is zero or parallel to the view direction; give one across it");
  if (!(yfov > 0 && yfov < glm::pi<double>()))
    usage("Camera: yfov is " + std::to_string(yfov) + " radians; expected the vertical field of view in (0, pi)");
  if (!(znear > 0) || !std::isfinite(znear)) usage("Camera: znear is " + std::to_string(znear) + "; expected > 0");
  if (!(zfar > znear) || !std::isfinite(zfar))
    usage("Camera: zfar is " + std::to_string(zfar) + "; expected finite and beyond znear (" + std::to_string(znear) + ")");
  c.yfov = float(yfov);
  c.znear = float(znear);
  c.zfar = float(zfar);
  return c;
}

std::shared_ptr<Scene> load(const std::string& path, std::optional<double> time, bool groundPlane) {
  if (path.empty()) usage("Scene.load: the path is empty (Scene.builtin() is the built-in scene)");
  if (time && !std::isfinite(*time)) usage("Scene.load: time must be a finite number");
  Options o;
  o.scene = path;
  o.sceneTime = time;
  o.groundPlane = groundPlane;
  std::ostringstream warnings;
  auto scene = std::make_shared<Scene>();
  {
    py::gil_scoped_release release;
    *scene = loadSceneArg(o, warnings);
  }
  warnLines(warnings.str());
  return scene;
}

std::shared_ptr<Scene> fromArrays(py::handle positions, py::handle indices, py::handle normals, py::handle lights,
                                  py::handle cameras, const std::string& name, bool groundPlane) {
  auto p = floatRows(positions, "positions");
  auto t = indexRows(indices, "indices");
  const size_t n = size_t(p.shape(0)), m = size_t(t.shape(0));
  if (m == 0) usage("indices: expected at least one triangle, shape (M, 3) with M >= 1, got (0, 3)");
  const float* pd = p.data();
  for (size_t i = 0; i < n * 3; ++i)
    if (!std::isfinite(pd[i])) usage("positions: vertex " + std::to_string(i / 3) + " is not finite");
  const uint32_t* td = t.data();
  for (size_t i = 0; i < m * 3; ++i)
    if (td[i] >= n)
      usage("indices: triangle " + std::to_string(i / 3) + " names vertex " + std::to_string(td[i]) + ", past the " +
            std::to_string(n) + " positions");
  auto scene = std::make_shared<Scene>();
  scene->name = name;
  auto vertex = [&](size_t i) { return glm::vec3(pd[i * 3], pd[i * 3 + 1], pd[i * 3 + 2]); };
  if (!normals.is_none()) {  // smooth: the vertices shared, one normal each
    auto nn = floatRows(normals, "normals");
    if (size_t(nn.shape(0)) != n)
      usage("normals: expected a float32 array of shape (N, 3) with the N = " + std::to_string(n) + " of positions, got (" +
            std::to_string(nn.shape(0)) + ", 3)");
    const float* nd = nn.data();
    for (size_t i = 0; i < n; ++i) {
      const glm::vec3 v(nd[i * 3], nd[i * 3 + 1], nd[i * 3 + 2]);
      const float len = glm::length(v);
      if (!std::isfinite(len) || !(len > 0)) usage("normals: normal " + std::to_string(i) + " is zero or not finite");
      scene->positions.push_back(vertex(i));
      scene->normals.push_back(v / len);
    }
    scene->indices.assign(td, td + m * 3);
  } else {  // flat, as the loaders give a file without normals: three vertices of its own a triangle
    for (size_t k = 0; k < m; ++k) {
      const glm::vec3 a = vertex(td[k * 3]), b = vertex(td[k * 3 + 1]), c = vertex(td[k * 3 + 2]);
      const glm::vec3 x = glm::cross(glm::dvec3(b - a), glm::dvec3(c - a));
      const float len = glm::length(x);
      const glm::vec3 normal = std::isfinite(len) && len > 0 ? x / len : glm::vec3(0, 1, 0);  // degenerate: any
      for (const glm::vec3& v : {a, b, c}) {
        scene->indices.push_back(uint32_t(scene->positions.size()));
        scene->positions.push_back(v);
        scene->normals.push_back(normal);
      }
    }
  }
  scene->computeBounds();
  if (!lights.is_none()) {
    const std::vector<glm::vec3> ls = lightsOf(lights, "lights");
    for (size_t l = 0; l < ls.size(); ++l) {
      if (std::string why = lightRangeProblem(ls[l], scene->boundsMin, scene->boundsMax); !why.empty())
        usage("lights: light " + std::to_string(l) + ": " + why);
      scene->lights.push_back({"light" + std::to_string(l), ls[l]});
    }
  }
  if (!cameras.is_none()) {
    if (!py::isinstance<py::sequence>(cameras) || py::isinstance<py::str>(cameras))
      usage("cameras: expected a list of Camera");
    for (py::handle c : cameras) {
      if (!py::isinstance<Camera>(c)) usage("cameras: expected a list of Camera, got an element of another type");
      scene->cameras.push_back(c.cast<Camera>());
    }
  }
  if (groundPlane) addGroundPlane(*scene);
  return scene;
}

py::array_t<float> positionsOf(const Scene& s) {
  py::array_t<float> a({py::ssize_t(s.positions.size()), py::ssize_t(3)});
  std::copy_n(&s.positions.data()->x, s.positions.size() * 3, a.mutable_data());
  return a;
}

py::array_t<uint32_t> indicesOf(const Scene& s) {
  py::array_t<uint32_t> a({py::ssize_t(s.indices.size() / 3), py::ssize_t(3)});
  std::copy_n(s.indices.data(), s.triangleCount() * 3, a.mutable_data());
  return a;
}

}  // namespace

void bindScenes(py::module_& m) {
  py::class_<Camera>(m, "Camera", "A pinhole camera: eye, target, up, vertical field of view (radians), near and far planes.")
      .def(py::init(&makeCamera), py::arg("eye"), py::arg("target"), py::arg("up") = py::make_tuple(0.0, 1.0, 0.0),
           py::arg("yfov") = 0.8, py::arg("name") = "", py::arg("znear") = 0.01, py::arg("zfar") = 1000.0,
           "Camera(eye, target, up=(0, 1, 0), yfov=0.8, name='', znear=0.01, zfar=1000.0). ValueError when target\n"
           "equals eye, up is parallel to the view, yfov is outside (0, pi) or the planes are not 0 < znear < zfar.")
      .def_property_readonly("name", [](const Camera& c) { return c.name; })
      .def_property_readonly("eye", [](const Camera& c) { return tupleOf(c.eye); })
      .def_property_readonly("target", [](const Camera& c) { return tupleOf(c.target); })
      .def_property_readonly("up", [](const Camera& c) { return tupleOf(c.up); })
      .def_property_readonly("yfov", [](const Camera& c) { return c.yfov; })
      .def_property_readonly("znear", [](const Camera& c) { return c.znear; })
      .def_property_readonly("zfar", [](const Camera& c) { return c.zfar; })
      .def("__repr__", [](const Camera& c) {
        std::ostringstream os;
        os << "Camera(eye=" << text(c.eye) << ", target=" << text(c.target) << ", up=" << text(c.up) << ", yfov=" << c.yfov
           << (c.name.empty() ? "" : ", name='" + c.name + "'") << ")";
        return os.str();
      });

  py::class_<PointLight>(m, "Light", "A point light of a scene file: name, position, colour and intensity.")
      .def_property_readonly("name", [](const PointLight& l) { return l.name; })
      .def_property_readonly("position", [](const PointLight& l) { return tupleOf(l.position); })
      .def_property_readonly("color", [](const PointLight& l) { return tupleOf(l.color); })
      .def_property_readonly("intensity", [](const PointLight& l) { return l.intensity; })
      .def("__repr__", [](const PointLight& l) { return "Light('" + l.name + "', position=" + text(l.position) + ")"; });

  py::class_<Scene, std::shared_ptr<Scene>>(m, "Scene",
                                            "One flat world-space triangle soup with the cameras and point lights of its file.")
      .def_static("load", &load, py::arg("path"), py::kw_only(), py::arg("time") = py::none(), py::arg("ground_plane") = false,
                  "Reads a scene as the CLI's SCENE: .gltf/.glb, a BART .aff (at scene time `time`, default its start),\n"
                  "any format assimp reads (.obj, .ply, .stl, .fbx, .dae, ...), 'heightfield:N' (a generated height\n"
                  "field of about N triangles, e.g. 'heightfield:1M') or 'builtin'. ground_plane adds a receiver under\n"
                  "the bounds. The loaders' warnings become Python warnings; a malformed file is a RuntimeError.")
      .def_static("builtin", [] { return std::make_shared<Scene>(builtinScene()); },
                  "The built-in scene: a lit room with clutter and a furball (views wall, fur, room, ceiling).")
      .def_static("from_arrays", &fromArrays, py::arg("positions"), py::arg("indices"), py::kw_only(),
                  py::arg("normals") = py::none(), py::arg("lights") = py::none(), py::arg("cameras") = py::none(), py::arg("name") = "arrays",
                  py::arg("ground_plane") = false,
                  "A scene of your triangles: positions (N, 3) float32 and indices (M, 3) uint32 (M >= 1, each < N),\n"
                  "world space, two-sided. Without normals each triangle gets a flat normal and three vertices of its\n"
                  "own (as a file without normals); normals (N, 3) float32 keeps the vertices shared, one normal each.\n"
                  "Optional point lights (3,) or (L, 3) and a list of Camera.")
      .def_property_readonly("name", [](const Scene& s) { return s.name; })
      .def_property_readonly("path", [](const Scene& s) { return s.sourcePath; }, "The file it was read from ('' otherwise).")
      .def_property_readonly("triangle_count", [](const Scene& s) { return s.triangleCount(); })
      .def_property_readonly("vertex_count", [](const Scene& s) { return s.positions.size(); })
      .def_property_readonly("positions", &positionsOf, "The vertices, (N, 3) float32 (a copy).")
      .def_property_readonly("indices", &indicesOf, "The triangles, (M, 3) uint32 (a copy).")
      .def_property_readonly("bounds", [](const Scene& s) { return py::make_tuple(tupleOf(s.boundsMin), tupleOf(s.boundsMax)); },
                             "(lo, hi) corners of the bounding box.")
      .def_property_readonly("diagonal", [](const Scene& s) { return s.diagonal(); })
      .def_property_readonly("epsilon", [](const Scene& s) { return EpsilonPolicy::forScene(s).eps; },
                             "The along-ray epsilon of the scene's policy (method/epsilon.h), as every method and Embree use it.")
      .def_property_readonly("cameras", [](const Scene& s) { return s.cameras; }, "The file's cameras, in file order.")
      .def_property_readonly("lights", [](const Scene& s) { return s.lights; }, "The file's point lights, in file order.")
      .def("__repr__", [](const Scene& s) {
        return "<coneshadow.Scene " + s.name + ": " + std::to_string(s.triangleCount()) + " triangles, " +
               std::to_string(s.cameras.size()) + " cameras, " + std::to_string(s.lights.size()) + " lights>";
      });
}

}  // namespace cs::python
