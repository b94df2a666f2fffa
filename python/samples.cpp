// visibility() for Python (python/: `import coneshadow`): the exact shadow visibility of samples of the
// caller's own from 1..L point lights, through harness/samples.h (the cone engine, and with reference=True
// Embree's answer and the band). This file checks and converts the numpy arguments.
#include <algorithm>
#include <cmath>

#include "core/scene.h"
#include "harness/samples.h"
#include "method/epsilon.h"
#include "python/bindings.h"

namespace cs::python {

namespace {

py::object visibility(std::shared_ptr<Scene> scene, py::handle points, py::handle normals, py::handle lights, bool reference) {
  auto p = floatRows(points, "points");
  auto n = floatRows(normals, "normals");
  const size_t count = size_t(p.shape(0));
  if (size_t(n.shape(0)) != count)
    usage("normals: expected a float32 array of shape (N, 3) with the N = " + std::to_string(count) + " of points, got (" +
          std::to_string(n.shape(0)) + ", 3)");
  if (count == 0) usage("points: expected at least one sample, shape (N, 3) with N >= 1, got (0, 3)");
  if (count > (1u << 26)) usage("points: at most 2^26 samples a call, got " + std::to_string(count));
  std::vector<glm::vec3> ls = lightsOf(lights, "lights");
  for (size_t l = 0; l < ls.size(); ++l)
    if (std::string why = lightRangeProblem(ls[l], scene->boundsMin, scene->boundsMax); !why.empty())
      usage("lights: light " + std::to_string(l) + ": " + why);

  std::vector<glm::vec3> xs(count), vs(count);
  const float* pd = p.data();
  const float* nd = n.data();
  for (size_t i = 0; i < count; ++i) {
    xs[i] = glm::vec3(pd[i * 3], pd[i * 3 + 1], pd[i * 3 + 2]);
    vs[i] = glm::vec3(nd[i * 3], nd[i * 3 + 1], nd[i * 3 + 2]);
    if (!std::isfinite(xs[i].x) || !std::isfinite(xs[i].y) || !std::isfinite(xs[i].z))
      usage("points: sample " + std::to_string(i) + " is not finite");
    const float len = glm::length(vs[i]);
    if (!std::isfinite(len) || !(len > 0)) usage("normals: normal " + std::to_string(i) + " is zero or not finite");
  }
  const SampleGrid grid = sampleGrid(xs, vs);

  SampleAnswers a;
  {
    py::gil_scoped_release release;
    auto lock = lockDevice();
    a = sampleVisibility(device(), engineSlot(), *scene, grid, ls, reference);
  }
  const py::ssize_t L = py::ssize_t(ls.size()), N = py::ssize_t(count);
  auto answer = [&](const std::vector<uint8_t>& v) {
    py::array_t<bool> out({L, N});
    std::copy(v.begin(), v.end(), out.mutable_data());
    return out;
  };
  if (!reference) return answer(a.visible);
  return py::make_tuple(answer(a.visible), answer(a.reference), answer(a.band));
}

}  // namespace

void bindSamples(py::module_& m) {
  m.def("_visibility", &visibility, py::arg("scene"), py::arg("points"), py::arg("normals"), py::arg("lights"),
        py::arg("reference") = false, "visibility() without its Python wrapper (coneshadow.visibility).");
}

}  // namespace cs::python
