// visibility() for Python (python/: `import coneshadow`): the exact shadow visibility of samples of the
// caller's own (points and normals from any renderer) from 1..L point lights, on the device through the
// cone path's engine (traversal/cone_engine.h) -- the samples laid out as a G-buffer of their own, up to
// kLightsAFrame lights recorded into one submission -- and, with reference=True, Embree's answer and the
// ambiguity band for the same samples, as the frame harness computes them (harness/harness.cpp).
//
// A sample is lit by a light when it faces it (the engine's light term max(0, N·L̂) > 0, computed on the
// device, the rule every method and the metric share: core/shared.h litSample) and nothing lies between;
// a sample facing away from a light is reported not visible (False), in the answer and the reference.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/scene.h"
#include "method/epsilon.h"
#include "python/bindings.h"
#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "traversal/cone_engine.h"
#include "vk/context.h"

namespace cs::python {

namespace {

constexpr uint32_t kLightsAFrame = 16;  // lights one engine frame records (its maxLights)
constexpr int kTries = 4;               // frames for a light batch whose traversal overflowed (each learns smaller batches)

struct Answers {
  uint32_t width = 0, height = 0;     // the samples' G-buffer: N samples row by row, the rest without geometry
  std::vector<float> masks;           // L x pixels: 1 lit, 0 shadowed (1 where not lit)
  std::vector<glm::vec4> normals;     // L x pixels: the normals with each light's term in w, as the engine wrote it
};

// The engine's answer for every light; called with the device lock held.
Answers runEngine(const Scene& scene, const std::vector<glm::vec4>& position, const std::vector<glm::vec4>& normal,
                  uint32_t width, uint32_t height, const std::vector<glm::vec3>& lights, float eps) {
  vk::Context& ctx = device();
  EngineSlot& slot = engineSlot();
  if (!slot.engine) slot.engine = makeConeEngine(ctx, ConeOptions{}, 1, kLightsAFrame);
  slot.engine->setGeometry(scene, geometryRevision(scene));
  const size_t pixels = size_t(width) * height;
  DeviceGBuffer g;
  g.width = width;
  g.height = height;
  g.position = vk::createBuffer(ctx, pixels * sizeof(glm::vec4));
  g.normal = vk::createBuffer(ctx, pixels * sizeof(glm::vec4));
  vk::upload(ctx, g.position, position.data(), pixels * sizeof(glm::vec4));
  Answers a;
  a.width = width;
  a.height = height;
  a.masks.resize(lights.size() * pixels);
  a.normals.resize(lights.size() * pixels);
  vk::Buffer masks = vk::createBuffer(ctx, kLightsAFrame * pixels * 4, vk::Memory::HostVisible);
  vk::Buffer terms = vk::createBuffer(ctx, kLightsAFrame * pixels * sizeof(glm::vec4), vk::Memory::HostVisible);
  for (size_t first = 0; first < lights.size(); first += kLightsAFrame) {
    const std::span<const glm::vec3> batch(lights.data() + first, std::min<size_t>(kLightsAFrame, lights.size() - first));
    for (int attempt = 1;; ++attempt) {
      vk::upload(ctx, g.normal, normal.data(), pixels * sizeof(glm::vec4));  // w: rewritten for each light
      vk::Commands cmd(ctx);
      const uint64_t frame = slot.frame++;
      slot.engine->record(cmd, g, batch, eps, frame, [&](uint32_t l, const vk::Buffer& mask) {
        cmd.copy(mask, masks, pixels * 4, 0, l * pixels * 4);
        cmd.copy(g.normal, terms, pixels * sizeof(glm::vec4), 0, l * pixels * sizeof(glm::vec4));
      });
      cmd.barrier();
      cmd.submit();
      const std::vector<EngineLightStats> stats = slot.engine->stats(frame);
      const bool complete = std::all_of(stats.begin(), stats.end(), [](const EngineLightStats& s) { return s.complete; });
      if (!complete && attempt < kTries) continue;
      if (!complete)
        throw Error("the traversal's memory held too few pairs for these samples in " + std::to_string(kTries) + " frames",
                    "visibility", "give fewer samples a call");
      std::memcpy(a.masks.data() + first * pixels, masks.mapped, batch.size() * pixels * 4);
      std::memcpy(a.normals.data() + first * pixels, terms.mapped, batch.size() * pixels * sizeof(glm::vec4));
      break;
    }
  }
  return a;
}

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

  // The samples as a G-buffer, near square: W x H >= N, the pixels past N without geometry.
  const uint32_t width = uint32_t(std::ceil(std::sqrt(double(count))));
  const uint32_t height = uint32_t((count + width - 1) / width);
  const size_t pixels = size_t(width) * height;
  std::vector<glm::vec4> position(pixels, glm::vec4(0)), normal(pixels, glm::vec4(0));
  const float* pd = p.data();
  const float* nd = n.data();
  for (size_t i = 0; i < count; ++i) {
    const glm::vec3 x(pd[i * 3], pd[i * 3 + 1], pd[i * 3 + 2]), v(nd[i * 3], nd[i * 3 + 1], nd[i * 3 + 2]);
    if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z))
      usage("points: sample " + std::to_string(i) + " is not finite");
    const float len = glm::length(v);
    if (!std::isfinite(len) || !(len > 0)) usage("normals: normal " + std::to_string(i) + " is zero or not finite");
    position[i] = glm::vec4(x, 1.0f);
    normal[i] = glm::vec4(v / len, 0.0f);
  }
  const EpsilonPolicy policy = EpsilonPolicy::forScene(*scene);

  Answers a;
  std::vector<std::vector<float>> refs;
  std::vector<std::vector<uint8_t>> bands;
  {
    py::gil_scoped_release release;
    {
      auto lock = lockDevice();
      a = runEngine(*scene, position, normal, width, height, ls, policy.eps);
    }
    if (reference) {
      // Embree on the same samples, each light's term as the engine computed it (the harness's reference).
      EmbreeReference embree;
      GBuffer gb;
      gb.width = width;
      gb.height = height;
      gb.position = position;
      for (size_t l = 0; l < ls.size(); ++l) {
        gb.normal.assign(a.normals.begin() + l * pixels, a.normals.begin() + (l + 1) * pixels);
        FrameInput in;
        in.scene = scene.get();
        in.gbuffer = &gb;
        in.light = ls[l];
        in.epsilon = policy.eps;
        refs.push_back(embree.run(in).visibility);
        bands.push_back(embree.ambiguityBand(*scene, gb, ls[l], policy));
      }
    }
  }

  const py::ssize_t L = py::ssize_t(ls.size()), N = py::ssize_t(count);
  auto answer = [&](auto&& value) {
    py::array_t<bool> out({L, N});
    bool* o = out.mutable_data();
    for (py::ssize_t l = 0; l < L; ++l)
      for (py::ssize_t i = 0; i < N; ++i) o[l * N + i] = value(size_t(l), size_t(i));
    return out;
  };
  auto lit = [&](size_t l, size_t i) { return litSample(position[i], a.normals[l * pixels + i]); };
  py::array_t<bool> visible = answer([&](size_t l, size_t i) { return lit(l, i) && a.masks[l * pixels + i] >= 0.5f; });
  if (!reference) return visible;
  return py::make_tuple(visible, answer([&](size_t l, size_t i) { return lit(l, i) && refs[l][i] >= 0.5f; }),
                        answer([&](size_t l, size_t i) { return lit(l, i) && bands[l][i] != 0; }));
}

}  // namespace

void bindSamples(py::module_& m) {
  m.def("_visibility", &visibility, py::arg("scene"), py::arg("points"), py::arg("normals"), py::arg("lights"),
        py::arg("reference") = false, "visibility() without its Python wrapper (coneshadow.visibility).");
}

}  // namespace cs::python
