// The visibility of the caller's own samples: see samples.h.
#include "harness/samples.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/error.h"
#include "core/scene.h"
#include "core/shared.h"
#include "method/epsilon.h"
#include "raster/raster.h"
#include "reference/embree_reference.h"
#include "traversal/cone_engine.h"
#include "vk/context.h"

namespace cs {

namespace {

constexpr uint32_t kLightsAFrame = 16;  // lights one engine frame records (its maxLights)
constexpr int kTries = 4;               // frames for a light batch whose traversal overflowed (each learns smaller batches)

}  // namespace

SampleEngine::SampleEngine() = default;
SampleEngine::~SampleEngine() = default;
SampleEngine::SampleEngine(SampleEngine&&) noexcept = default;
SampleEngine& SampleEngine::operator=(SampleEngine&&) noexcept = default;

SampleGrid sampleGrid(std::span<const glm::vec3> points, std::span<const glm::vec3> normals) {
  CS_CHECK(points.size() == normals.size() && !points.empty(), "samples: " << points.size() << " points, " << normals.size() << " normals");
  SampleGrid g;
  g.count = points.size();
  g.width = uint32_t(std::ceil(std::sqrt(double(g.count))));
  g.height = uint32_t((g.count + g.width - 1) / g.width);
  const size_t pixels = size_t(g.width) * g.height;
  g.position.assign(pixels, glm::vec4(0));
  g.normal.assign(pixels, glm::vec4(0));
  for (size_t i = 0; i < g.count; ++i) {
    const float len = glm::length(normals[i]);
    CS_CHECK(std::isfinite(len) && len > 0, "samples: normal " << i << " is zero or not finite");
    g.position[i] = glm::vec4(points[i], 1.0f);
    g.normal[i] = glm::vec4(normals[i] / len, 0.0f);
  }
  return g;
}

SampleAnswers sampleVisibility(vk::Context& ctx, SampleEngine& slot, const Scene& scene, const SampleGrid& grid,
                               std::span<const glm::vec3> lights, bool reference) {
  const float eps = EpsilonPolicy::forScene(scene).eps;
  if (!slot.engine) slot.engine = makeConeEngine(ctx, ConeOptions{}, 1, kLightsAFrame);
  slot.engine->setGeometry(scene, geometryRevision(scene));
  const size_t pixels = size_t(grid.width) * grid.height;
  DeviceGBuffer g;
  g.width = grid.width;
  g.height = grid.height;
  g.position = vk::createBuffer(ctx, pixels * sizeof(glm::vec4));
  g.normal = vk::createBuffer(ctx, pixels * sizeof(glm::vec4));
  vk::upload(ctx, g.position, grid.position.data(), pixels * sizeof(glm::vec4));
  vk::upload(ctx, g.normal, grid.normal.data(), pixels * sizeof(glm::vec4));  // w is not read

  // The engine's masks, and each light's term as the engine's kernels compute it (in the normals' w).
  std::vector<float> masks(lights.size() * pixels);
  std::vector<glm::vec4> terms(lights.size() * pixels);
  vk::Buffer maskOut = vk::createBuffer(ctx, kLightsAFrame * pixels * 4, vk::Memory::HostVisible);
  vk::Buffer termOut = vk::createBuffer(ctx, kLightsAFrame * pixels * sizeof(glm::vec4), vk::Memory::HostVisible);
  for (size_t first = 0; first < lights.size(); first += kLightsAFrame) {
    const std::span<const glm::vec3> batch = lights.subspan(first, std::min<size_t>(kLightsAFrame, lights.size() - first));
    for (int attempt = 1;; ++attempt) {
      vk::Commands cmd(ctx);
      const uint64_t frame = slot.frame++;
      slot.engine->record(cmd, g, batch, eps, frame, [&](uint32_t l, const vk::Buffer& mask) {
        cmd.copy(mask, maskOut, pixels * 4, 0, l * pixels * 4);
        slot.engine->recordLightTerms(cmd, g, batch[l], termOut, l * pixels * sizeof(glm::vec4));
      });
      cmd.barrier();
      cmd.submit();
      const std::vector<EngineLightStats> stats = slot.engine->stats(frame);
      const bool complete = std::all_of(stats.begin(), stats.end(), [](const EngineLightStats& s) { return s.complete; });
      if (!complete && attempt < kTries) continue;
      if (!complete)
        throw Error("the traversal's memory held too few pairs for these samples in " + std::to_string(kTries) + " frames",
                    "visibility", "give fewer samples a call");
      std::memcpy(masks.data() + first * pixels, maskOut.mapped, batch.size() * pixels * 4);
      std::memcpy(terms.data() + first * pixels, termOut.mapped, batch.size() * pixels * sizeof(glm::vec4));
      break;
    }
  }

  SampleAnswers a;
  a.count = grid.count;
  a.lights = lights.size();
  auto lit = [&](size_t l, size_t i) { return litSample(grid.position[i], terms[l * pixels + i]); };
  a.facing.resize(a.lights * a.count);
  a.visible.resize(a.lights * a.count);
  for (size_t l = 0; l < a.lights; ++l)
    for (size_t i = 0; i < a.count; ++i) {
      a.facing[l * a.count + i] = lit(l, i);
      a.visible[l * a.count + i] = lit(l, i) && masks[l * pixels + i] >= 0.5f;
    }
  if (!reference) return a;

  // Embree on the same samples, each light's term as the engine computed it (the harness's reference).
  EmbreeReference embree;
  GBuffer gb;
  gb.width = grid.width;
  gb.height = grid.height;
  gb.position = grid.position;
  a.reference.resize(a.lights * a.count);
  a.band.resize(a.lights * a.count);
  const EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  for (size_t l = 0; l < a.lights; ++l) {
    gb.normal.assign(terms.begin() + l * pixels, terms.begin() + (l + 1) * pixels);
    FrameInput in;
    in.scene = &scene;
    in.gbuffer = &gb;
    in.light = lights[l];
    in.epsilon = policy.eps;
    const std::vector<float> ref = embree.run(in).visibility;
    const std::vector<uint8_t> band = embree.ambiguityBand(scene, gb, lights[l], policy);
    for (size_t i = 0; i < a.count; ++i) {
      a.reference[l * a.count + i] = lit(l, i) && ref[i] >= 0.5f;
      a.band[l * a.count + i] = lit(l, i) && band[i] != 0;
    }
  }
  return a;
}

}  // namespace cs
