// coneshadow: exact hard shadows from point lights, recorded into your renderer's Vulkan command buffer.
//
// For every lit pixel of your G-buffer and every point light you pass, the library decides whether the
// segment from the pixel's world position to the light is blocked by a triangle of your geometry, and
// writes 1 (lit) or 0 (shadowed) into a layer of your visibility image. It builds no hierarchy over the
// scene: each frame, the lit samples become rays sorted along a Hilbert curve into a cone hierarchy, and
// every triangle goes through it (docs/ARCHITECTURE.md, "The engine"). Moving geometry costs nothing extra.
//
//   auto req = coneshadow::deviceRequirements();          // enable these when you create your VkDevice
//   auto cs = coneshadow::Context::create({instance, physicalDevice, device, queueFamily, vkGetInstanceProcAddr});
//   uint32_t mesh = cs->createMesh(positions, vertexCount, indices, indexCount);
//   cs->createInstance(mesh, coneshadow::kIdentity);
//   ...each frame, inside your command buffer:
//   coneshadow::FrameDesc f;  f.commandBuffer = cmd;  f.frame = frameNumber;
//   f.positionImage = gbufferPosition;  f.normalImage = gbufferNormal;  f.width = w;  f.height = h;
//   f.lights = lightXYZ;  f.lightCount = n;  f.visibilityImage = shadowLayers;
//   cs->recordFrame(f);                                    // records; submits nothing, waits for nothing
//
// Errors: every function reports failure by throwing coneshadow::Error, whose what() is one line: what
// went wrong, where, and what to do. A function that throws has recorded nothing and changed nothing.
// Threads: a Context is used from one thread at a time.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#if defined(_WIN32)
#define CONESHADOW_API
#else
#define CONESHADOW_API __attribute__((visibility("default")))
#endif

namespace coneshadow {

class CONESHADOW_API Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

// What your VkDevice must be created with, before you create it.
struct DeviceRequirements {
  uint32_t apiVersion = 0;              // VkApplicationInfo::apiVersion at least this (Vulkan 1.2)
  std::vector<const char*> extensions;  // device extensions to enable (VK_KHR_push_descriptor)
  // Features to enable: VkPhysicalDeviceFeatures::shaderInt64 and
  // VkPhysicalDeviceVulkan12Features::shaderBufferInt64Atomics. The device must also offer subgroup
  // basic, arithmetic and ballot operations in compute shaders (every Vulkan 1.2 desktop driver does).
  bool shaderInt64 = true;
  bool shaderBufferInt64Atomics = true;
};
CONESHADOW_API DeviceRequirements deviceRequirements();

// Your Vulkan objects. The library never destroys them, never submits to a queue and never waits for the
// device; it allocates its own buffers from `device`.
struct DeviceDesc {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physicalDevice = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  uint32_t queueFamily = 0;  // the family of the command buffers you record frames into (compute capable)
  PFN_vkGetInstanceProcAddr getInstanceProcAddr = nullptr;
};

// Paper 002's one-pass variants and the memory bound. Nothing here changes a decided pixel's answer but
// frontFaceCulling, which is exact only for closed, consistently wound meshes.
struct Options {
  bool sortRays = true;           // rays in Hilbert order of direction (PreciseSorted); false: screen order
  bool sphereTest = false;        // the triangles' bounding spheres instead of the precise cone test (Spheres*)
  bool earlyAccept = false;       // a cone every ray of which a triangle provably blocks stops there (PreciseSEA)
  bool frontFaceCulling = false;  // only triangles facing away from the light cast: closed meshes only
  // A cap on the device memory and the host working set the library holds (0: none). The traversal's
  // arena gets what the rest leaves; a budget that cannot hold a frame makes recordFrame throw with the
  // bytes it needs. A smaller arena is slower, never different -- unless a frame's pairs outgrow it: see
  // LightStats::complete.
  uint64_t memoryBudgetBytes = 0;
  uint32_t framesInFlight = 2;  // frames you record before the oldest of them has completed (1..4)
  uint32_t maxLights = 8;       // lights a frame (1..64)
};

// Row-major 3x4 transforms: world = M * (x, y, z, 1).
inline constexpr float kIdentity[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};

// One frame. Images are yours, in VK_IMAGE_LAYOUT_GENERAL, with one mip level.
//   positionImage  VK_FORMAT_R32G32B32A32_SFLOAT, usage TRANSFER_SRC: xyz the pixel's world position
//                  (fp32), w = 1 where the pixel has geometry and 0 where it has none.
//   normalImage    the same format and usage: xyz the unit normal turned towards the camera (w ignored).
//                  A pixel is lit by a light when it has geometry and N . (light - position) > 0, computed
//                  exactly as coneshadow's own camera pass does; only lit pixels are decided.
//   visibilityImage VK_FORMAT_R32_SFLOAT, 2D with at least lightCount array layers, usage TRANSFER_DST:
//                  layer l gets light l's answer for every pixel: 1 lit (and every pixel the light does not
//                  light), 0 shadowed, 0.5 undecided (only on a frame whose LightStats::complete is false).
// "Exact" means: the answer Embree's ray tracer gives for the same fp32 position and light, up to the
// rays whose hit is decided by rounding (a triangle edge or plane within a few ulp of the ray), which no
// fp32 method can call either way.
// Barriers. Before recordFrame's commands: your writes of the position and normal images made available
// to VK_PIPELINE_STAGE_TRANSFER_BIT / VK_ACCESS_TRANSFER_READ_BIT. After them: the visibility image has
// been written by transfer writes (VK_PIPELINE_STAGE_TRANSFER_BIT / VK_ACCESS_TRANSFER_WRITE_BIT); put
// your own barrier from there to whatever reads it. The library orders its own work against its earlier
// frames by itself, provided every frame is submitted to queues of `queueFamily` in recording order.
// Frames in flight: before recording frame n, frame n - framesInFlight must have completed on the device.
struct FrameDesc {
  VkCommandBuffer commandBuffer = VK_NULL_HANDLE;  // begun, outside a render pass, of DeviceDesc::queueFamily
  uint64_t frame = 0;                              // your frame number, +1 a frame
  VkImage positionImage = VK_NULL_HANDLE;
  VkImage normalImage = VK_NULL_HANDLE;
  uint32_t width = 0, height = 0;
  const float* lights = nullptr;  // lightCount points, xyz each, world space
  uint32_t lightCount = 0;
  VkImage visibilityImage = VK_NULL_HANDLE;
};

// The stages of one light's work, in the order a frame records them: the index of LightStats::stageMs.
enum class Stage : uint32_t {
  LightTerm,  // always 0: the light term, which decides the lit pixels, is computed inside Compact (and
              // wherever else a pixel's litness is asked); kept so the stages keep their indices
  Compact,    // the visibility set to lit, the lit pixels found (their light term computed) and compacted
              // (with their sort keys, where fused)
  Order,      // the ray order measured on the GPU (a screen-order tree built and judged)
  Keys,       // the rays' Hilbert keys (0 where the compaction made them)
  Sort,       // the rays' radix sort
  Build,      // the cone tree (and, for a far light, the triangles in its frame)
  Traversal,  // the triangles down the cone tree, every batch
  Leaves,     // the exact ray/triangle tests at the leaves, every batch, and the hits into the mask
  Undecided,  // the lit pixels a traversal that outgrew its memory left undecided, marked 0.5
};
inline constexpr uint32_t kStageCount = 9;
static_assert(uint32_t(Stage::Undecided) + 1 == kStageCount, "a Stage without its slot in stageMs");
CONESHADOW_API const char* stageName(Stage stage);  // "light term", "compact", ... ("?" for no stage)

struct LightStats {
  uint32_t litSamples = 0;     // pixels the light lights (the rays decided)
  uint64_t pairsTested = 0;    // (cone, triangle) pairs the traversal tested
  uint64_t leafTests = 0;      // exact ray/triangle tests at the leaves
  bool complete = true;        // false: the pairs outgrew the traversal's memory; the lit pixels no triangle
                               // had shadowed by then are 0.5 and later frames use smaller batches
  double stageMs[kStageCount] = {};  // GPU milliseconds of each Stage (FrameStats::gpuTimes); 0: not run
};
// GPU times come from timestamps the library writes into your command buffer (a query pool per frame in
// flight, made at create; timestampPeriod converts them). They are absent (gpuTimes false, every time 0)
// on a queue family whose timestampValidBits is 0 (a device with timestampComputeAndGraphics false may
// have one), and while that frame has not yet run to its end on the device: frameStats reads them
// without waiting. Inside one submission a driver may misattribute time between adjacent stages (lavapipe runs
// work behind the command stream: a stage can read ~0 while its neighbour absorbs it); gpuMs, the frame's
// whole span, is reliable, and all lights' stages together add up to at most gpuMs.
struct FrameStats {
  bool available = false;          // false: that frame is not among the last framesInFlight recorded, or
                                   // has not yet run to its end on the device (read it after your fence)
  std::vector<LightStats> lights;  // one per light, in FrameDesc order
  bool gpuTimes = false;           // the stage times and gpuMs below were measured
  double gpuMs = 0;                // the GPU time of everything recordFrame recorded, in milliseconds
};

struct ContextAccess;

class CONESHADOW_API Context {
 public:
  // Checks the device against deviceRequirements() (one clear Error naming what is missing).
  static std::unique_ptr<Context> create(const DeviceDesc& device, const Options& options = {});
  // Destroy only after the device has finished every frame recorded with this context.
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  // Geometry. Positions are xyz floats, indices three a triangle. A triangle with a non-finite vertex
  // casts nothing. Data is copied; the call returns a handle. Changes take effect at the next recordFrame.
  uint32_t createMesh(const float* positions, size_t vertexCount, const uint32_t* indices, size_t indexCount);
  void updateMesh(uint32_t mesh, const float* positions, size_t vertexCount, const uint32_t* indices,
                  size_t indexCount);
  void destroyMesh(uint32_t mesh);  // its instances go with it
  uint32_t createInstance(uint32_t mesh, const float transform[12]);
  void setTransform(uint32_t instance, const float transform[12]);
  void destroyInstance(uint32_t instance);

  // Records one frame into desc.commandBuffer (see FrameDesc). After the first frames at a resolution and
  // light count it allocates nothing, neither device memory nor host heap, moved instances (setTransform)
  // included; the frame after a mesh edit or a new set of instances allocates. It never submits or waits.
  void recordFrame(const FrameDesc& desc);
  // The counts and GPU times of a recorded frame (its lights in a vector: this call allocates). Call only
  // once that frame's command buffer has completed; it never waits for the device.
  FrameStats frameStats(uint64_t frame) const;
  // Device memory the library holds in its buffers, in bytes. Not counted: the timestamp query pools
  // (about 530 queries a light of Options::maxLights, per frame in flight), which the driver allocates.
  uint64_t deviceBytes() const;

  struct Impl;

 private:
  friend struct ContextAccess;  // the library's own tests
  explicit Context(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace coneshadow
