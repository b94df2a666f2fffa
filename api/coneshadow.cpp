// The public API (include/coneshadow/coneshadow.h) over the engine (traversal/cone_engine.h): the
// caller's handles adopted, meshes and instances flattened into the engine's world-space triangles, the
// caller's images copied in and out around the engine's recording. docs/ARCHITECTURE.md, "The engine".
#include "coneshadow/coneshadow.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>
#include <string>

#include "api/internal.h"
#include "core/error.h"
#include "core/scene.h"
#include "method/epsilon.h"
#include "raster/raster.h"
#include "traversal/cone_engine.h"
#include "vk/context.h"

namespace coneshadow {

struct Context::Impl {
  std::unique_ptr<cs::vk::Context> vk;
  std::unique_ptr<cs::ConeEngine> engine;
  Options options;
  struct Mesh {
    bool alive = false;
    std::vector<glm::vec3> positions;
    std::vector<uint32_t> indices;
    glm::vec3 lo{INFINITY}, hi{-INFINITY};  // of every vertex (the epsilon policy's box)
  };
  struct Instance {
    bool alive = false;
    uint32_t mesh = 0;
    float m[12] = {};
  };
  std::vector<Mesh> meshes;
  std::vector<Instance> instances;
  bool layoutDirty = true;      // a mesh or the set of instances changed: the engine's layout again
  bool transformsDirty = false;  // only transforms changed: the engine keeps its triangles
  // The engine's view of the live meshes and instances, rebuilt in place when they change (a moved
  // instance's frame reuses their storage: recordFrame allocates nothing once warm).
  std::vector<cs::EngineMesh> engineMeshes;
  std::vector<uint32_t> engineMeshIndex;  // per mesh handle: its index in engineMeshes, or UINT32_MAX
  std::vector<cs::EngineInstance> engineInstances;
  float eps = 0;  // the along-ray epsilon of the scene's policy (method/epsilon.h), as the bench's harness uses
  cs::DeviceGBuffer samples;
  std::vector<glm::vec3> lights;  // the frame's lights, kept to reuse its storage

  ~Impl() {
    samples = {};  // buffers before the engine, the engine before the context
    engine.reset();
    vk.reset();
  }
};

namespace {

// Runs f, turning the project's errors into the API's one channel.
template <class F>
auto guarded(const char* where, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const Error&) {
    throw;
  } catch (const cs::Error& e) {
    throw Error(std::string("coneshadow: ") + e.what());
  } catch (const std::bad_alloc&) {
    throw Error(std::string("coneshadow: ") + where + ": out of host memory");
  } catch (const std::exception& e) {
    throw Error(std::string("coneshadow: ") + where + ": " + e.what());
  }
}

[[noreturn]] void refuse(const std::string& where, const std::string& what, const std::string& todo) {
  throw Error("coneshadow: " + where + ": " + what + " (" + todo + ")");
}

void checkMesh(const char* where, const float* positions, size_t vertexCount, const uint32_t* indices,
               size_t indexCount) {
  if (vertexCount > 0 && !positions) refuse(where, "positions is null with " + std::to_string(vertexCount) + " vertices", "pass the xyz array");
  if (indexCount > 0 && !indices) refuse(where, "indices is null with " + std::to_string(indexCount) + " indices", "pass the index array");
  if (indexCount % 3 != 0) refuse(where, std::to_string(indexCount) + " indices is not a whole number of triangles", "pass three indices a triangle");
  if (vertexCount > UINT32_MAX) refuse(where, std::to_string(vertexCount) + " vertices", "at most 2^32 - 1 a mesh");
  for (size_t i = 0; i < indexCount; ++i)
    if (indices[i] >= vertexCount)
      refuse(where, "index " + std::to_string(i) + " is " + std::to_string(indices[i]) + ", past the " +
                        std::to_string(vertexCount) + " vertices",
             "every index names a vertex of the mesh");
}

void checkTransform(const char* where, const float* m) {
  if (!m) refuse(where, "the transform is null", "pass 12 floats, row-major 3x4 (coneshadow::kIdentity)");
  for (int i = 0; i < 12; ++i)
    if (!std::isfinite(m[i])) refuse(where, "transform element " + std::to_string(i) + " is not finite", "pass a finite 3x4 matrix");
}

bool isIdentity(const float* m) {
  for (int i = 0; i < 12; ++i)
    if (m[i] != kIdentity[i]) return false;
  return true;
}

}  // namespace

// The engine times the public stages, in the same order.
static_assert(kStageCount == cs::kEngineStages);
static_assert(uint32_t(Stage::LightTerm) == uint32_t(cs::EngineStage::LightTerm) &&
              uint32_t(Stage::Compact) == uint32_t(cs::EngineStage::Compact) &&
              uint32_t(Stage::Order) == uint32_t(cs::EngineStage::Order) &&
              uint32_t(Stage::Keys) == uint32_t(cs::EngineStage::Keys) &&
              uint32_t(Stage::Sort) == uint32_t(cs::EngineStage::Sort) &&
              uint32_t(Stage::Build) == uint32_t(cs::EngineStage::Build) &&
              uint32_t(Stage::Traversal) == uint32_t(cs::EngineStage::Traversal) &&
              uint32_t(Stage::Leaves) == uint32_t(cs::EngineStage::Leaves) &&
              uint32_t(Stage::Undecided) == uint32_t(cs::EngineStage::Undecided));

const char* stageName(Stage stage) { return cs::engineStageName(cs::EngineStage(uint32_t(stage))); }

DeviceRequirements deviceRequirements() {
  const cs::vk::DeviceRequirements r = cs::vk::deviceRequirements();
  DeviceRequirements out;
  out.apiVersion = r.apiVersion;
  out.extensions = r.extensions;
  out.shaderInt64 = r.shaderInt64;
  out.shaderBufferInt64Atomics = r.shaderBufferInt64Atomics;
  return out;
}

Context::Context(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Context::~Context() = default;

std::unique_ptr<Context> Context::create(const DeviceDesc& device, const Options& options) {
  return guarded("create", [&] {
    if (options.framesInFlight < 1 || options.framesInFlight > 4)
      refuse("create", "framesInFlight is " + std::to_string(options.framesInFlight), "give 1 to 4");
    if (options.maxLights < 1 || options.maxLights > 64)
      refuse("create", "maxLights is " + std::to_string(options.maxLights), "give 1 to 64");
    auto impl = std::make_unique<Impl>();
    impl->options = options;
    cs::vk::AdoptedDevice a;
    a.instance = device.instance;
    a.physical = device.physicalDevice;
    a.device = device.device;
    a.queueFamily = device.queueFamily;
    a.getInstanceProcAddr = device.getInstanceProcAddr;
    impl->vk = cs::vk::adoptDevice(a);
    cs::ConeOptions o;
    o.sorted = options.sortRays;
    o.test = options.sphereTest ? cs::ConeTest::Sphere : cs::ConeTest::Precise;
    o.earlyAccept = options.earlyAccept;
    o.frontFaceCulling = options.frontFaceCulling;
    o.memoryBudgetBytes = options.memoryBudgetBytes;
    impl->engine = cs::makeConeEngine(*impl->vk, o, options.framesInFlight, options.maxLights);
    return std::unique_ptr<Context>(new Context(std::move(impl)));
  });
}

uint32_t Context::createMesh(const float* positions, size_t vertexCount, const uint32_t* indices, size_t indexCount) {
  return guarded("createMesh", [&] {
    checkMesh("createMesh", positions, vertexCount, indices, indexCount);
    impl_->meshes.emplace_back();
    const uint32_t id = uint32_t(impl_->meshes.size() - 1);
    try {
      updateMesh(id, positions, vertexCount, indices, indexCount);
    } catch (...) {
      impl_->meshes.pop_back();
      throw;
    }
    return id;
  });
}

void Context::updateMesh(uint32_t mesh, const float* positions, size_t vertexCount, const uint32_t* indices,
                         size_t indexCount) {
  guarded("updateMesh", [&] {
    if (mesh >= impl_->meshes.size() || (!impl_->meshes[mesh].alive && mesh + 1 != impl_->meshes.size()))
      refuse("updateMesh", "no mesh " + std::to_string(mesh), "pass a handle createMesh returned");
    checkMesh("updateMesh", positions, vertexCount, indices, indexCount);
    Impl::Mesh m;
    m.alive = true;
    m.positions.resize(vertexCount);
    if (vertexCount) std::memcpy(m.positions.data(), positions, vertexCount * 3 * sizeof(float));
    m.indices.assign(indices, indices + indexCount);
    for (const glm::vec3& v : m.positions) m.lo = glm::min(m.lo, v), m.hi = glm::max(m.hi, v);
    impl_->meshes[mesh] = std::move(m);
    impl_->layoutDirty = true;
  });
}

void Context::destroyMesh(uint32_t mesh) {
  guarded("destroyMesh", [&] {
    if (mesh >= impl_->meshes.size() || !impl_->meshes[mesh].alive)
      refuse("destroyMesh", "no mesh " + std::to_string(mesh), "pass a handle createMesh returned");
    impl_->meshes[mesh] = {};
    for (Impl::Instance& i : impl_->instances)
      if (i.alive && i.mesh == mesh) i.alive = false;
    impl_->layoutDirty = true;
  });
}

uint32_t Context::createInstance(uint32_t mesh, const float transform[12]) {
  return guarded("createInstance", [&] {
    if (mesh >= impl_->meshes.size() || !impl_->meshes[mesh].alive)
      refuse("createInstance", "no mesh " + std::to_string(mesh), "pass a handle createMesh returned");
    checkTransform("createInstance", transform);
    Impl::Instance i;
    i.alive = true;
    i.mesh = mesh;
    std::memcpy(i.m, transform, sizeof(i.m));
    impl_->instances.push_back(i);
    impl_->layoutDirty = true;
    return uint32_t(impl_->instances.size() - 1);
  });
}

void Context::setTransform(uint32_t instance, const float transform[12]) {
  guarded("setTransform", [&] {
    if (instance >= impl_->instances.size() || !impl_->instances[instance].alive)
      refuse("setTransform", "no instance " + std::to_string(instance), "pass a handle createInstance returned");
    checkTransform("setTransform", transform);
    if (std::memcmp(impl_->instances[instance].m, transform, sizeof(float) * 12) == 0) return;
    std::memcpy(impl_->instances[instance].m, transform, sizeof(float) * 12);
    impl_->transformsDirty = true;
  });
}

void Context::destroyInstance(uint32_t instance) {
  guarded("destroyInstance", [&] {
    if (instance >= impl_->instances.size() || !impl_->instances[instance].alive)
      refuse("destroyInstance", "no instance " + std::to_string(instance), "pass a handle createInstance returned");
    impl_->instances[instance].alive = false;
    impl_->layoutDirty = true;
  });
}

void Context::recordFrame(const FrameDesc& d) {
  guarded("recordFrame", [&] {
    Impl& s = *impl_;
    const char* where = "recordFrame";
    if (!d.commandBuffer) refuse(where, "commandBuffer is null", "pass a command buffer you have begun");
    if (!d.positionImage || !d.normalImage || !d.visibilityImage)
      refuse(where, "an image is null", "pass the position, normal and visibility images");
    if (d.width == 0 || d.height == 0) refuse(where, "the size is " + std::to_string(d.width) + "x" + std::to_string(d.height), "pass the images' size");
    if (uint64_t(d.width) * d.height > (uint64_t(1) << 31))
      refuse(where, std::to_string(d.width) + "x" + std::to_string(d.height) + " pixels", "at most 2^31 pixels a frame");
    if (d.lightCount == 0 || d.lightCount > s.options.maxLights)
      refuse(where, std::to_string(d.lightCount) + " lights", "pass 1 to Options::maxLights (" + std::to_string(s.options.maxLights) + ")");
    if (!d.lights) refuse(where, "lights is null", "pass lightCount xyz points");
    for (uint32_t i = 0; i < 3 * d.lightCount; ++i)
      if (!std::isfinite(d.lights[i])) refuse(where, "light " + std::to_string(i / 3) + " is not finite", "pass finite positions");

    if (s.layoutDirty || s.transformsDirty) {
      // The live meshes and instances, compacted; the engine uploads the meshes once and transforms them.
      std::vector<cs::EngineMesh>& meshes = s.engineMeshes;
      std::vector<uint32_t>& meshIndex = s.engineMeshIndex;
      meshes.clear();
      meshIndex.assign(s.meshes.size(), UINT32_MAX);
      s.engineInstances.clear();
      glm::dvec3 lo(INFINITY), hi(-INFINITY);
      for (const Impl::Instance& inst : s.instances) {
        if (!inst.alive) continue;
        const Impl::Mesh& m = s.meshes[inst.mesh];
        if (meshIndex[inst.mesh] == UINT32_MAX) {
          meshIndex[inst.mesh] = uint32_t(meshes.size());
          meshes.push_back({m.positions.data(), m.positions.size(), m.indices.data(), m.indices.size()});
        }
        cs::EngineInstance e;
        e.mesh = meshIndex[inst.mesh];
        std::memcpy(e.transform, inst.m, sizeof(e.transform));
        s.engineInstances.push_back(e);
        if (m.positions.empty()) continue;
        for (int corner = 0; corner < 8; ++corner) {  // the epsilon policy's box: every vertex, transformed
          const glm::dvec3 p((corner & 1) ? m.lo.x : m.hi.x, (corner & 2) ? m.lo.y : m.hi.y, (corner & 4) ? m.lo.z : m.hi.z);
          const float* t = inst.m;
          const glm::dvec3 w = isIdentity(t) ? p
                                             : glm::dvec3(t[0] * p.x + t[1] * p.y + t[2] * p.z + t[3], t[4] * p.x + t[5] * p.y + t[6] * p.z + t[7],
                                                          t[8] * p.x + t[9] * p.y + t[10] * p.z + t[11]);
          lo = glm::min(lo, w), hi = glm::max(hi, w);
        }
      }
      for (int k = 0; k < 3; ++k)
        if (std::fabs(lo[k]) > 1e30 || std::fabs(hi[k]) > 1e30)
          refuse(where, "the instances reach coordinates past 1e30", "keep the scene within fp32 range");
      if (s.layoutDirty) s.engine->setInstances(meshes, s.engineInstances);
      else s.engine->setTransforms(s.engineInstances);
      s.eps = lo.x <= hi.x ? cs::EpsilonPolicy::forBounds(glm::vec3(lo), glm::vec3(hi)).eps
                           : cs::EpsilonPolicy::forBounds(glm::vec3(0), glm::vec3(0)).eps;
      s.layoutDirty = s.transformsDirty = false;
    }

    const uint64_t bytes = uint64_t(d.width) * d.height * 16;
    if (!s.samples.position || s.samples.width != d.width || s.samples.height != d.height) {
      s.samples = {};
      s.samples.width = d.width, s.samples.height = d.height;
      s.samples.position = cs::vk::createBuffer(*s.vk, bytes);
      s.samples.normal = cs::vk::createBuffer(*s.vk, bytes);
    }
    cs::vk::Commands cmd(*s.vk, d.commandBuffer);
    s.engine->beginFrame(cmd, d.frame);  // the frame's GPU time starts before the copies
    cmd.barrier();  // the last frame's reads of the sample buffers are done
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {d.width, d.height, 1};
    vkCmdCopyImageToBuffer(d.commandBuffer, d.positionImage, VK_IMAGE_LAYOUT_GENERAL, s.samples.position.buffer, 1, &region);
    vkCmdCopyImageToBuffer(d.commandBuffer, d.normalImage, VK_IMAGE_LAYOUT_GENERAL, s.samples.normal.buffer, 1, &region);
    s.lights.resize(d.lightCount);
    for (uint32_t l = 0; l < d.lightCount; ++l) s.lights[l] = {d.lights[3 * l], d.lights[3 * l + 1], d.lights[3 * l + 2]};
    // the engine's first command is a barrier: the copies are done before it reads the samples
    s.engine->record(cmd, s.samples, s.lights, s.eps, d.frame, [&](uint32_t l, const cs::vk::Buffer& mask) {
      VkBufferImageCopy out{};
      out.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, l, 1};
      out.imageExtent = {d.width, d.height, 1};
      vkCmdCopyBufferToImage(d.commandBuffer, mask.buffer, d.visibilityImage, VK_IMAGE_LAYOUT_GENERAL, 1, &out);
    });
  });
}

FrameStats Context::frameStats(uint64_t frame) const {
  return guarded("frameStats", [&] {
    FrameStats out;
    cs::EngineFrameTimes times;
    for (const cs::EngineLightStats& l : impl_->engine->stats(frame, &times)) {
      LightStats s;
      s.litSamples = l.litSamples;
      s.pairsTested = l.pairsTested;
      s.leafTests = l.leafTests;
      s.complete = l.complete;
      std::copy(std::begin(l.stageMs), std::end(l.stageMs), s.stageMs);
      out.lights.push_back(s);
    }
    out.available = !out.lights.empty();
    out.gpuTimes = out.available && times.available;
    out.gpuMs = out.gpuTimes ? times.totalMs : 0;
    return out;
  });
}

uint64_t Context::deviceBytes() const {
  return impl_->engine->bytesAllocated() + impl_->samples.position.size + impl_->samples.normal.size;
}

}  // namespace coneshadow

namespace coneshadow {
cs::vk::Context& ContextAccess::vulkan(Context& c) { return *c.impl_->vk; }
}  // namespace coneshadow
