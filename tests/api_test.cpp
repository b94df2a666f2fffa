// The public API (include/coneshadow/coneshadow.h) as a renderer uses it: on a Vulkan device the test
// creates itself (validation with synchronization validation on), a frame recorded into the test's own
// command buffer beside the test's own copies, submitted by the test. The masks must be bit-identical to
// the bench's cone method (what `coneshadow render --methods cone` runs) on the same samples; several
// lights in one frame bit-identical to one-light frames; the library submits nothing, waits for nothing
// and, once warm, allocates nothing.
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <sstream>

#include "api/internal.h"
#include "coneshadow/coneshadow.h"
#include "cone_test_support.h"
#include "core/heap_count.h"
#include "core/scene.h"
#include "test_context.h"
#include "traversal/cone_engine.h"
#include "traversal/cone_method.h"
#include "vk/context.h"

namespace cs::test {
namespace {

// A Vulkan instance and device of the test's own, as a renderer makes them. With `validate` (and the layer
// installed) under VK_LAYER_KHRONOS_validation with synchronization validation; without it for the host
// heap counts, which would include the layer's own allocations on the calling thread.
class OwnDevice {
 public:
  explicit OwnDevice(bool validate = true) {
    bool validation = false;
    uint32_t n = 0;
    vkEnumerateInstanceLayerProperties(&n, nullptr);
    std::vector<VkLayerProperties> layers(n);
    vkEnumerateInstanceLayerProperties(&n, layers.data());
    for (auto& l : layers) validation |= validate && std::strcmp(l.layerName, "VK_LAYER_KHRONOS_validation") == 0;
    VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.apiVersion = coneshadow::deviceRequirements().apiVersion;
    const char* layer = "VK_LAYER_KHRONOS_validation";
    const char* exts[] = {VK_EXT_DEBUG_UTILS_EXTENSION_NAME, VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME};
    VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
    VkValidationFeaturesEXT features{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
    features.enabledValidationFeatureCount = 1;
    features.pEnabledValidationFeatures = enables;
    VkInstanceCreateInfo ii{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    ii.pApplicationInfo = &app;
    if (validation) {
      ii.pNext = &features;
      ii.enabledLayerCount = 1;
      ii.ppEnabledLayerNames = &layer;
      ii.enabledExtensionCount = 2;
      ii.ppEnabledExtensionNames = exts;
    }
    check(vkCreateInstance(&ii, nullptr, &instance), "vkCreateInstance");
    validated = validation;
    if (validation) {
      auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
          vkGetInstanceProcAddr(instance, "vkCreateDebugUtilsMessengerEXT"));
      VkDebugUtilsMessengerCreateInfoEXT mi{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
      mi.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
      mi.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT;
      mi.pfnUserCallback = [](VkDebugUtilsMessageSeverityFlagBitsEXT, VkDebugUtilsMessageTypeFlagsEXT,
                              const VkDebugUtilsMessengerCallbackDataEXT* data, void* self) -> VkBool32 {
        auto* d = static_cast<OwnDevice*>(self);
        if (d->messages++ < 5) std::fprintf(stderr, "validation: %s\n", data->pMessage);
        return VK_FALSE;
      };
      mi.pUserData = this;
      check(create(instance, &mi, nullptr, &messenger), "vkCreateDebugUtilsMessengerEXT");
    }
    n = 0;
    vkEnumeratePhysicalDevices(instance, &n, nullptr);
    std::vector<VkPhysicalDevice> devs(n);
    vkEnumeratePhysicalDevices(instance, &n, devs.data());
    if (devs.empty()) throw std::runtime_error("no Vulkan device");
    physical = devs[0];
    for (VkPhysicalDevice d : devs) {  // the device the shared test context runs on
      VkPhysicalDeviceProperties p;
      vkGetPhysicalDeviceProperties(d, &p);
      if (std::string(p.deviceName) == context().deviceName()) physical = d;
    }
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &n, nullptr);
    std::vector<VkQueueFamilyProperties> q(n);
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &n, q.data());
    for (uint32_t i = 0; i < n; ++i)
      if (q[i].queueFlags & VK_QUEUE_COMPUTE_BIT) {
        family = i;
        break;
      }
    const coneshadow::DeviceRequirements req = coneshadow::deviceRequirements();
    VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
    f12.shaderBufferInt64Atomics = req.shaderBufferInt64Atomics;
    VkPhysicalDeviceFeatures2 f{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
    f.pNext = &f12;
    f.features.shaderInt64 = req.shaderInt64;
    float priority = 1;
    VkDeviceQueueCreateInfo qi{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    qi.queueFamilyIndex = family;
    qi.queueCount = 1;
    qi.pQueuePriorities = &priority;
    VkDeviceCreateInfo di{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
    di.pNext = &f;
    di.queueCreateInfoCount = 1;
    di.pQueueCreateInfos = &qi;
    di.enabledExtensionCount = uint32_t(req.extensions.size());
    di.ppEnabledExtensionNames = req.extensions.data();
    check(vkCreateDevice(physical, &di, nullptr, &device), "vkCreateDevice");
    vkGetDeviceQueue(device, family, 0, &queue);
    VkCommandPoolCreateInfo pi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    pi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pi.queueFamilyIndex = family;
    check(vkCreateCommandPool(device, &pi, nullptr, &pool), "vkCreateCommandPool");
    VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    ai.commandPool = pool;
    ai.commandBufferCount = 1;
    check(vkAllocateCommandBuffers(device, &ai, &cb), "vkAllocateCommandBuffers");
    VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    check(vkCreateFence(device, &fi, nullptr, &fence), "vkCreateFence");
  }
  ~OwnDevice() {
    vkDeviceWaitIdle(device);
    for (auto& [h, m] : owned) {
      if (h.image) vkDestroyImage(device, h.image, nullptr);
      if (h.buffer) vkDestroyBuffer(device, h.buffer, nullptr);
      vkFreeMemory(device, m, nullptr);
    }
    vkDestroyFence(device, fence, nullptr);
    vkDestroyCommandPool(device, pool, nullptr);
    vkDestroyDevice(device, nullptr);
    if (messenger) {
      auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
          vkGetInstanceProcAddr(instance, "vkDestroyDebugUtilsMessengerEXT"));
      destroy(instance, messenger, nullptr);
    }
    vkDestroyInstance(instance, nullptr);
  }

  coneshadow::DeviceDesc desc() const { return {instance, physical, device, family, vkGetInstanceProcAddr}; }

  VkImage image(VkFormat format, uint32_t w, uint32_t h, uint32_t layers) {
    VkImageCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    ci.imageType = VK_IMAGE_TYPE_2D;
    ci.format = format;
    ci.extent = {w, h, 1};
    ci.mipLevels = 1;
    ci.arrayLayers = layers;
    ci.samples = VK_SAMPLE_COUNT_1_BIT;
    ci.tiling = VK_IMAGE_TILING_OPTIMAL;
    ci.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    VkImage img;
    check(vkCreateImage(device, &ci, nullptr, &img), "vkCreateImage");
    VkMemoryRequirements r;
    vkGetImageMemoryRequirements(device, img, &r);
    VkDeviceMemory mem = allocate(r, 0);
    check(vkBindImageMemory(device, img, mem, 0), "vkBindImageMemory");
    owned.push_back({{img, VK_NULL_HANDLE}, mem});
    return img;
  }
  // A host-visible buffer and its mapping.
  std::pair<VkBuffer, void*> hostBuffer(VkDeviceSize bytes) {
    VkBufferCreateInfo ci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    ci.size = bytes;
    ci.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    VkBuffer b;
    check(vkCreateBuffer(device, &ci, nullptr, &b), "vkCreateBuffer");
    VkMemoryRequirements r;
    vkGetBufferMemoryRequirements(device, b, &r);
    VkDeviceMemory mem = allocate(r, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    check(vkBindBufferMemory(device, b, mem, 0), "vkBindBufferMemory");
    void* p;
    check(vkMapMemory(device, mem, 0, bytes, 0, &p), "vkMapMemory");
    owned.push_back({{VK_NULL_HANDLE, b}, mem});
    return {b, p};
  }
  void begin() {
    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    check(vkBeginCommandBuffer(cb, &bi), "vkBeginCommandBuffer");
  }
  void submitAndWait() {
    check(vkEndCommandBuffer(cb), "vkEndCommandBuffer");
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cb;
    check(vkResetFences(device, 1, &fence), "vkResetFences");
    check(vkQueueSubmit(queue, 1, &si, fence), "vkQueueSubmit");
    check(vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    check(vkResetCommandBuffer(cb, 0), "vkResetCommandBuffer");
  }
  // A barrier between the test's transfers and the library's (and back).
  void transferBarrier() {
    VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    mb.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT;
    mb.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_HOST_BIT,
                         0, 1, &mb, 0, nullptr, 0, nullptr);
  }
  void toGeneral(VkImage img, uint32_t layers) {
    VkImageMemoryBarrier b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
    b.srcAccessMask = 0;
    b.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT;
    b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    b.newLayout = VK_IMAGE_LAYOUT_GENERAL;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = img;
    b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, layers};
    vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr,
                         1, &b);
  }

  VkInstance instance = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t family = 0;
  VkCommandPool pool = VK_NULL_HANDLE;
  VkCommandBuffer cb = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  bool validated = false;
  std::atomic<int> messages{0};

 private:
  struct Handle {
    VkImage image;
    VkBuffer buffer;
  };
  std::vector<std::pair<Handle, VkDeviceMemory>> owned;
  static void check(VkResult r, const char* call) {
    if (r != VK_SUCCESS) throw std::runtime_error(std::string(call) + " failed: " + std::to_string(int(r)));
  }
  VkDeviceMemory allocate(const VkMemoryRequirements& r, VkMemoryPropertyFlags want) {
    VkPhysicalDeviceMemoryProperties mp;
    vkGetPhysicalDeviceMemoryProperties(physical, &mp);
    for (uint32_t i = 0; i < mp.memoryTypeCount; ++i)
      if ((r.memoryTypeBits & (1u << i)) && (mp.memoryTypes[i].propertyFlags & want) == want) {
        VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
        ai.allocationSize = r.size;
        ai.memoryTypeIndex = i;
        VkDeviceMemory m;
        check(vkAllocateMemory(device, &ai, nullptr, &m), "vkAllocateMemory");
        return m;
      }
    throw std::runtime_error("no memory type");
  }
};

// The renderer's side of a frame: its G-buffer images filled from host samples, the library's frame,
// the visibility layers read back -- one command buffer, one submission, by the test.
class Renderer {
 public:
  Renderer(OwnDevice& d, uint32_t w, uint32_t h, uint32_t maxLights) : d_(d), w_(w), h_(h), layers_(maxLights) {
    position_ = d.image(VK_FORMAT_R32G32B32A32_SFLOAT, w, h, 1);
    normal_ = d.image(VK_FORMAT_R32G32B32A32_SFLOAT, w, h, 1);
    visibility_ = d.image(VK_FORMAT_R32_SFLOAT, w, h, maxLights);
    std::tie(upload_, uploadMap_) = d.hostBuffer(uint64_t(w) * h * 32);
    std::tie(readback_, readbackMap_) = d.hostBuffer(uint64_t(w) * h * 4 * maxLights);
    d.begin();
    d.toGeneral(position_, 1);
    d.toGeneral(normal_, 1);
    d.toGeneral(visibility_, maxLights);
    d.submitAndWait();
  }

  // One frame of `lights` on the samples; returns a mask per light. `recorded` runs between the recording
  // and the submission.
  std::vector<std::vector<float>> frame(coneshadow::Context& cs, const GBuffer& g, const std::vector<glm::vec3>& lights,
                                        const std::function<void(uint64_t frame)>& recorded = {}) {
    const size_t n = size_t(w_) * h_;
    std::memcpy(uploadMap_, g.position.data(), n * 16);
    std::memcpy(static_cast<char*>(uploadMap_) + n * 16, g.normal.data(), n * 16);
    d_.begin();
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {w_, h_, 1};
    vkCmdCopyBufferToImage(d_.cb, upload_, position_, VK_IMAGE_LAYOUT_GENERAL, 1, &region);
    region.bufferOffset = n * 16;
    vkCmdCopyBufferToImage(d_.cb, upload_, normal_, VK_IMAGE_LAYOUT_GENERAL, 1, &region);
    d_.transferBarrier();
    coneshadow::FrameDesc f;
    f.commandBuffer = d_.cb;
    f.frame = frame_++;
    f.positionImage = position_;
    f.normalImage = normal_;
    f.width = w_;
    f.height = h_;
    f.lights = &lights[0].x;
    f.lightCount = uint32_t(lights.size());
    f.visibilityImage = visibility_;
    const uint64_t heapBefore = heapNow();
    cs.recordFrame(f);
    heapInRecordFrame += heapNow() - heapBefore;
    d_.transferBarrier();
    VkBufferImageCopy out{};
    out.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, uint32_t(lights.size())};
    out.imageExtent = {w_, h_, 1};
    vkCmdCopyImageToBuffer(d_.cb, visibility_, VK_IMAGE_LAYOUT_GENERAL, readback_, 1, &out);
    d_.transferBarrier();
    if (recorded) recorded(f.frame);
    d_.submitAndWait();
    std::vector<std::vector<float>> masks(lights.size(), std::vector<float>(n));
    for (size_t l = 0; l < lights.size(); ++l)
      std::memcpy(masks[l].data(), static_cast<const float*>(readbackMap_) + l * n, n * 4);
    lastFrame = f.frame;
    return masks;
  }
  uint64_t lastFrame = 0;
  // Heap allocations (operator new) on this thread inside recordFrame, summed over the frames
  // (core/heap_count.h; 0 where the binary does not count them).
  uint64_t heapInRecordFrame = 0;
  static uint64_t heapNow() { return threadHeapAllocations ? threadHeapAllocations() : 0; }

 private:
  OwnDevice& d_;
  uint32_t w_, h_, layers_;
  VkImage position_, normal_, visibility_;
  VkBuffer upload_, readback_;
  void *uploadMap_, *readbackMap_;
  uint64_t frame_ = 0;
};

uint32_t addScene(coneshadow::Context& cs, const Scene& s) {
  return cs.createInstance(cs.createMesh(&s.positions[0].x, s.positions.size(), s.indices.data(), s.indices.size()),
                           coneshadow::kIdentity);
}

// The bench's cone method on a prepared frame (the mask `render --methods cone` writes).
std::vector<float> benchMask(ReferenceFrame& f, const ConeOptions& o) {
  return makeConeMethod(context(), o)->run(f.input).visibility;
}

struct Variant {
  const char* name;
  coneshadow::Options options;
};
std::vector<Variant> oneVariants() {
  std::vector<Variant> v;
  for (const char* name : {"PreciseSorted", "Precise", "SpheresSorted", "Spheres", "PreciseSEA"}) {
    ConeOptions o;
    EXPECT_TRUE(applyConeVariant(name, o));
    coneshadow::Options a;
    a.sortRays = o.sorted;
    a.sphereTest = o.test == ConeTest::Sphere;
    a.earlyAccept = o.earlyAccept;
    v.push_back({name, a});
  }
  return v;
}

TEST(Api, AFrameInTheCallersCommandBufferEqualsTheBenchsConeMaskAndCostsTheHostNothing) {
  OwnDevice device;
  Scene scene = builtinScene();
  const Camera* cam = scene.findCamera(builtinViewNames()[0]);
  ASSERT_NE(cam, nullptr);
  const glm::vec3 light = scene.lights[0].position;
  const uint32_t size = 64;
  ReferenceFrame f(scene, *cam, light, size);
  const std::vector<float> bench = benchMask(f, ConeOptions{});

  coneshadow::Options options;
  options.framesInFlight = 1;
  auto cs = coneshadow::Context::create(device.desc(), options);
  addScene(*cs, scene);
  Renderer renderer(device, size, size, options.maxLights);
  vk::Context& inner = coneshadow::ContextAccess::vulkan(*cs);
  const vk::HostCost start = inner.cost;
  std::vector<float> first = renderer.frame(*cs, f.host, {light})[0];
  EXPECT_TRUE(sameBits(first, bench)) << "the library's mask differs from the bench's cone mask";
  const vk::HostCost warm = inner.cost;
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(sameBits(renderer.frame(*cs, f.host, {light})[0], bench)) << "frame " << k + 1;
  const vk::HostCost after = inner.cost;
  EXPECT_EQ((after - start).submits, 0u);
  EXPECT_EQ((after - start).hostSyncs, 0u);
  EXPECT_EQ((after - start).readbackBytes, 0u);
  EXPECT_EQ((after - warm).allocations, 0u) << "allocations after the first frame";
  const coneshadow::FrameStats st = cs->frameStats(renderer.lastFrame);
  ASSERT_TRUE(st.available);
  ASSERT_EQ(st.lights.size(), 1u);
  EXPECT_EQ(st.lights[0].litSamples, f.host.litCount());
  EXPECT_GT(st.lights[0].pairsTested, 0u);
  EXPECT_TRUE(st.lights[0].complete);
  EXPECT_FALSE(cs->frameStats(renderer.lastFrame + 5).available);
  // The normal image's w is not read (each kernel computes the light's term): -1 and NaN there change nothing.
  GBuffer garbled = f.host;
  for (size_t i = 0; i < garbled.normal.size(); ++i) garbled.normal[i].w = i % 2 ? -1.0f : std::nanf("");
  EXPECT_TRUE(sameBits(renderer.frame(*cs, garbled, {light})[0], bench)) << "the normal image's w changed the mask";
  cs.reset();
  EXPECT_TRUE(device.validated) << "VK_LAYER_KHRONOS_validation is not installed";
  EXPECT_EQ(device.messages.load(), 0) << "validation (synchronization validation on) reported messages";
}

// Several lights of one frame against one-light frames, and one-light frames against the bench.
void expectLightsMatch(const Scene& scene, const Camera& cam, const std::vector<glm::vec3>& lights, uint32_t size,
                       const std::string& what) {
  OwnDevice device;
  std::vector<std::unique_ptr<ReferenceFrame>> frames;
  for (glm::vec3 l : lights) frames.push_back(std::make_unique<ReferenceFrame>(scene, cam, l, size));
  for (const Variant& v : oneVariants()) {
    ConeOptions o;
    applyConeVariant(v.name, o);
    coneshadow::Options options = v.options;
    options.maxLights = 8;
    auto cs = coneshadow::Context::create(device.desc(), options);
    addScene(*cs, scene);
    Renderer renderer(device, size, size, 8);
    auto bench = makeConeMethod(context(), o);  // one method for every light: its geometry uploaded once
    std::vector<std::vector<float>> single;
    for (size_t l = 0; l < lights.size(); ++l) {
      single.push_back(renderer.frame(*cs, frames[l]->host, {lights[l]})[0]);
      EXPECT_TRUE(sameBits(single.back(), bench->run(frames[l]->input).visibility))
          << what << " " << v.name << " light " << l << ": library vs bench";
    }
    for (size_t count : {size_t(2), size_t(4), size_t(8)}) {
      if (count > lights.size()) break;
      const std::vector<glm::vec3> some(lights.begin(), lights.begin() + count);
      const auto masks = renderer.frame(*cs, frames[0]->host, some);
      for (size_t l = 0; l < count; ++l)
        EXPECT_TRUE(sameBits(masks[l], single[l])) << what << " " << v.name << ": light " << l << " of " << count;
    }
    cs.reset();
  }
  EXPECT_EQ(device.messages.load(), 0) << what << ": validation reported messages";
}

std::vector<glm::vec3> eightLights(const Scene& s) {
  const glm::vec3 lo = s.boundsMin, hi = s.boundsMax, c = 0.5f * (lo + hi), e = hi - lo;
  std::vector<glm::vec3> out;
  for (const PointLight& l : s.lights) out.push_back(l.position);
  const glm::vec3 offsets[] = {{0.3f, 0.35f, 0.2f}, {-0.3f, 0.4f, 0.1f}, {0.1f, 0.45f, -0.3f}, {-0.2f, 0.3f, -0.25f},
                               {0.0f, 0.2f, 0.0f},  {0.35f, 0.1f, 0.35f}, {-0.35f, 0.25f, 0.3f}, {0.2f, 0.4f, 0.0f}};
  for (glm::vec3 o : offsets) {
    if (out.size() == 8) break;
    out.push_back(c + o * e);
  }
  return out;
}

// The GPU times of a frame, read once it has completed. Where the queue family's timestamps are valid
// (lavapipe's are), every stage of every light is timed, none negative, and the lights' stages add up to at
// most the frame's span, which is positive; reading them submits nothing and waits for nothing, the frame
// before is still readable, and synchronization validation stays silent.
TEST(Api, FrameStatsGiveEachLightsStageTimesWithinTheFramesGpuTime) {
  OwnDevice device;
  Scene scene = builtinScene();
  const Camera* cam = scene.findCamera(builtinViewNames()[0]);
  ASSERT_NE(cam, nullptr);
  const uint32_t size = 64;
  const std::vector<glm::vec3> lights = {scene.lights[0].position, eightLights(scene)[1]};
  ReferenceFrame f(scene, *cam, lights[0], size);
  auto cs = coneshadow::Context::create(device.desc());  // two frames in flight
  ASSERT_EQ(coneshadow::Options{}.framesInFlight, 2u);
  addScene(*cs, scene);
  Renderer renderer(device, size, size, uint32_t(lights.size()));
  vk::Context& inner = coneshadow::ContextAccess::vulkan(*cs);
  const vk::HostCost start = inner.cost;
  for (int k = 0; k < 3; ++k) renderer.frame(*cs, f.host, lights);
  const coneshadow::FrameStats st = cs->frameStats(renderer.lastFrame);
  const coneshadow::FrameStats before = cs->frameStats(renderer.lastFrame - 1);
  const vk::HostCost after = inner.cost;
  EXPECT_EQ((after - start).submits, 0u);
  EXPECT_EQ((after - start).hostSyncs, 0u);
  ASSERT_TRUE(st.available);
  ASSERT_EQ(st.lights.size(), lights.size());

  uint32_t n = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(device.physical, &n, nullptr);
  std::vector<VkQueueFamilyProperties> families(n);
  vkGetPhysicalDeviceQueueFamilyProperties(device.physical, &n, families.data());
  const bool timestamps = families[device.family].timestampValidBits > 0;
  EXPECT_EQ(st.gpuTimes, timestamps) << "GPU times where the queue family has valid timestamps, and only there";
  EXPECT_EQ(before.gpuTimes, timestamps) << "the frame before, still in its slot";
  double sum = 0;
  for (size_t l = 0; l < st.lights.size(); ++l)
    for (uint32_t s = 0; s < coneshadow::kStageCount; ++s) {
      const double ms = st.lights[l].stageMs[s];
      const char* name = coneshadow::stageName(coneshadow::Stage(s));
      if (!timestamps) { EXPECT_EQ(ms, 0.0) << "light " << l << " " << name << " without timestamps"; }
      EXPECT_GE(ms, 0.0) << "light " << l << " " << name;
      if (coneshadow::Stage(s) == coneshadow::Stage::LightTerm) {
        EXPECT_EQ(ms, 0.0) << "light " << l << ": the light term is computed inside the compaction, no stage of its own";
      }
      sum += ms;
    }
  if (timestamps) {
    EXPECT_GT(st.gpuMs, 0.0);
    EXPECT_GT(sum, 0.0);
    EXPECT_LE(sum, st.gpuMs * (1 + 1e-9)) << "the lights' stages add up to more than the frame";
  } else {
    EXPECT_EQ(st.gpuMs, 0.0);
  }
  const coneshadow::FrameStats unrecorded = cs->frameStats(renderer.lastFrame + 5);
  EXPECT_FALSE(unrecorded.available);
  EXPECT_FALSE(unrecorded.gpuTimes);
  // A frame recorded but not yet run: its slot's queries still hold the frame before's times, which must
  // not pass for its own.
  bool pendingTimes = true, pendingAvailable = true;
  renderer.frame(*cs, f.host, lights, [&](uint64_t frame) {
    const coneshadow::FrameStats pending = cs->frameStats(frame);
    pendingTimes = pending.gpuTimes;
    pendingAvailable = pending.available;
  });
  EXPECT_FALSE(pendingTimes) << "a frame not yet submitted reported GPU times";
  EXPECT_FALSE(pendingAvailable) << "a frame not yet submitted reported its counters";
  EXPECT_EQ(cs->frameStats(renderer.lastFrame).gpuTimes, timestamps) << "the same frame once it completed";
  EXPECT_STREQ(coneshadow::stageName(coneshadow::Stage::LightTerm), "light term");
  EXPECT_STREQ(coneshadow::stageName(coneshadow::Stage::Undecided), "undecided");
  cs.reset();
  EXPECT_TRUE(device.validated) << "VK_LAYER_KHRONOS_validation is not installed";
  EXPECT_EQ(device.messages.load(), 0) << "validation (synchronization validation on) reported messages";
}

TEST(Api, EightLightsInOneFrameEqualOneLightFramesOnTheBuiltinScene) {
  Scene scene = builtinScene();
  const Camera* cam = scene.findCamera(builtinViewNames()[0]);
  ASSERT_NE(cam, nullptr);
  expectLightsMatch(scene, *cam, eightLights(scene), 40, "builtin");
}

TEST(Api, EightLightsInOneFrameEqualOneLightFramesOnTheBartMuseum) {
  const std::string bart = CONESHADOW_BART_SCENES;
  if (!std::filesystem::exists(bart + "/museum/museum5.aff")) GTEST_SKIP() << "no BART scenes at " << bart;
  std::ostringstream warn;
  Scene scene = loadAff(bart + "/museum/museum5.aff", warn, 2.0);
  ASSERT_FALSE(scene.cameras.empty());
  expectLightsMatch(scene, scene.cameras[0], eightLights(scene), 40, "museum");
}

// A box moved by setTransform: no triangle uploaded again (no allocation at all), and the mask is the
// bench's on the scene with the box already there (translations by exact binary fractions, so the
// device's transform and the host's flattening round alike).
// A unit box open at the bottom, standing on the origin.
Scene openBox() {
  Scene box;
  addQuad(box, {-0.5f, 0.0f, -0.5f}, {1, 0, 0}, {0, 1, 0});
  addQuad(box, {-0.5f, 0.0f, 0.5f}, {0, 1, 0}, {1, 0, 0});
  addQuad(box, {-0.5f, 0.0f, -0.5f}, {0, 1, 0}, {0, 0, 1});
  addQuad(box, {0.5f, 0.0f, -0.5f}, {0, 0, 1}, {0, 1, 0});
  addQuad(box, {-0.5f, 1.0f, -0.5f}, {0, 0, 1}, {1, 0, 0});
  return box;
}

std::array<float, 12> translation(glm::vec3 t) { return {1, 0, 0, t.x, 0, 1, 0, t.y, 0, 0, 1, t.z}; }

TEST(Api, MovingAnInstanceUpdatesItsTransformOnlyAndGivesTheMovedScenesMask) {
  OwnDevice device;
  Scene room = builtinScene();
  const Scene box = openBox();
  const glm::vec3 light = room.lights[0].position;
  const Camera* view = room.findCamera(builtinViewNames()[0]);
  ASSERT_NE(view, nullptr);
  // between the light and what the camera looks at, then moved across that line
  const glm::vec3 from = light + 0.4f * (view->target - light), to = from + glm::vec3(0.75f, 0.0f, -0.5f);
  auto placed = [&](glm::vec3 at) {
    Scene s = room;
    const uint32_t base = uint32_t(s.positions.size());
    for (glm::vec3 p : box.positions) s.positions.push_back(p + at);
    for (glm::vec3 n : box.normals) s.normals.push_back(n);
    for (uint32_t i : box.indices) s.indices.push_back(base + i);
    s.computeBounds();
    return s;
  };
  const Scene moved = placed(to);
  ReferenceFrame f(moved, *view, light, 48);
  const std::vector<float> bench = benchMask(f, ConeOptions{});

  coneshadow::Options options;
  options.framesInFlight = 2;
  auto cs = coneshadow::Context::create(device.desc(), options);
  addScene(*cs, room);
  const uint32_t boxMesh = cs->createMesh(&box.positions[0].x, box.positions.size(), box.indices.data(), box.indices.size());
  const uint32_t boxInstance = cs->createInstance(boxMesh, translation(from).data());
  Renderer renderer(device, 48, 48, options.maxLights);
  const std::vector<float> before = renderer.frame(*cs, f.host, {light})[0];
  renderer.frame(*cs, f.host, {light});  // both frame slots warm
  vk::Context& inner = coneshadow::ContextAccess::vulkan(*cs);
  const vk::HostCost warm = inner.cost;
  const uint64_t bytes = cs->deviceBytes();
  cs->setTransform(boxInstance, translation(to).data());
  const std::vector<float> after = renderer.frame(*cs, f.host, {light})[0];
  EXPECT_TRUE(sameBits(after, bench)) << "the moved box's mask differs from the bench's on the scene with it there";
  EXPECT_FALSE(sameBits(before, after)) << "moving the box changed nothing: the test proves nothing";
  EXPECT_EQ((inner.cost - warm).allocations, 0u) << "moving an instance allocated (its triangles were uploaded again)";
  EXPECT_EQ(cs->deviceBytes(), bytes);
  cs.reset();
  EXPECT_EQ(device.messages.load(), 0) << "validation reported messages";
}

// Once warm, recordFrame makes no host heap allocation: 1 and 4 lights (one far: the far-light frame),
// frames whose geometry did not change and frames after setTransform, in the one-pass variants the options
// offer. Counted on this thread around recordFrame alone (core/heap_count.h), on a device without the
// validation layer, which allocates in the calls it checks.
TEST(Api, AfterWarmUpRecordFrameMakesNoHostHeapAllocation) {
  ASSERT_NE(threadHeapAllocations, nullptr) << "the test binary counts operator new (app/heap_count.cpp)";
  OwnDevice device(/*validate=*/false);
  Scene scene = builtinScene();
  const Camera* cam = scene.findCamera(builtinViewNames()[0]);
  ASSERT_NE(cam, nullptr);
  const uint32_t size = 64;
  const std::vector<glm::vec3> eight = eightLights(scene);
  // one of the four far enough for the far-light frame (its triangles in that frame, made per light)
  const glm::vec3 far = scene.boundsMax + 100.0f * (scene.boundsMax - scene.boundsMin);
  const std::vector<glm::vec3> four = {eight[0], eight[1], far, eight[2]}, one = {eight[0]};
  ReferenceFrame f(scene, *cam, one[0], size);
  const Scene box = openBox();
  const glm::vec3 at = one[0] + 0.4f * (cam->target - one[0]);
  struct Case {
    const char* name;
    void (*set)(coneshadow::Options&);
  };
  const Case cases[] = {
      {"defaults", [](coneshadow::Options&) {}},
      {"sortRays off", [](coneshadow::Options& o) { o.sortRays = false; }},
      {"earlyAccept", [](coneshadow::Options& o) { o.earlyAccept = true; }},
      {"sphereTest", [](coneshadow::Options& o) { o.sphereTest = true; }},
      {"frontFaceCulling", [](coneshadow::Options& o) { o.frontFaceCulling = true; }},
  };
  for (const Case& c : cases) {
    coneshadow::Options options;
    c.set(options);
    options.framesInFlight = 2;
    options.maxLights = 4;
    auto cs = coneshadow::Context::create(device.desc(), options);
    addScene(*cs, scene);
    const uint32_t moving = cs->createInstance(
        cs->createMesh(&box.positions[0].x, box.positions.size(), box.indices.data(), box.indices.size()),
        translation(at).data());
    Renderer renderer(device, size, size, options.maxLights);
    // The warm-up: each frame slot has seen 4 lights, 1 light and a moved instance.
    for (int k = 0; k < 4; ++k) renderer.frame(*cs, f.host, k % 2 ? one : four);
    cs->setTransform(moving, translation(at + glm::vec3(0.25f, 0, 0)).data());
    renderer.frame(*cs, f.host, four);
    renderer.frame(*cs, f.host, one);
    const uint64_t warm = renderer.heapInRecordFrame;
    EXPECT_GT(warm, 0u) << c.name << ": the warm-up's first frame allocates; the count sees nothing";
    for (int k = 0; k < 6; ++k) {
      if (k % 3 == 2) cs->setTransform(moving, translation(at + glm::vec3(0.125f * float(k), 0, 0)).data());
      renderer.frame(*cs, f.host, k % 2 ? one : four);
    }
    EXPECT_EQ(renderer.heapInRecordFrame - warm, 0u) << c.name << ": heap allocations in 6 warm frames";
  }
}

TEST(Api, HostileCallsAreOneClearErrorAndRecordNothing) {
  OwnDevice device;
  auto cs = coneshadow::Context::create(device.desc());
  const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const uint32_t bad[3] = {0, 1, 3};
  auto expectError = [](auto&& call, const std::string& needle) {
    try {
      call();
      ADD_FAILURE() << "no error; expected one naming " << needle;
    } catch (const coneshadow::Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(needle), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << "one line: " << what;
    }
  };
  expectError([&] { cs->createMesh(p, 3, bad, 3); }, "past the 3 vertices");
  expectError([&] { cs->createMesh(p, 3, bad, 2); }, "whole number of triangles");
  expectError([&] { cs->createInstance(7, coneshadow::kIdentity); }, "no mesh 7");
  const uint32_t ok[3] = {0, 1, 2};
  const uint32_t mesh = cs->createMesh(p, 3, ok, 3);
  float nan[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, std::nanf("")};
  expectError([&] { cs->createInstance(mesh, nan); }, "not finite");
  coneshadow::FrameDesc f;
  expectError([&] { cs->recordFrame(f); }, "commandBuffer is null");
  coneshadow::Options o;
  o.framesInFlight = 9;
  expectError([&] { coneshadow::Context::create(device.desc(), o); }, "framesInFlight");
  coneshadow::DeviceDesc none;
  expectError([&] { coneshadow::Context::create(none); }, "must all be given");
}

// The engine records the one-pass variants only: two-pass decides its update on the host between the
// passes, which a frame in the caller's command buffer cannot do.
TEST(Api, TheEngineRefusesTheTwoPassVariantsInOneLine) {
  for (const char* name : {"PreciseEATP", "PreciseSEATP"}) {
    ConeOptions o;
    ASSERT_TRUE(applyConeVariant(name, o));
    try {
      makeConeEngine(context(), o, 1, 1);
      ADD_FAILURE() << name << ": the engine took a two-pass variant";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("two-pass variants"), std::string::npos) << what;
      EXPECT_NE(what.find("one-pass variants only"), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << "one line: " << what;
    }
  }
}

// An arena so small that the frame's batches pass what one recording holds (256): the engine refuses the
// frame in one line before it records a single command (the bench would traverse it chunked, submitting).
TEST(Api, TheEngineRefusesAFrameWhoseBatchesPassOneRecordingBeforeRecordingAnything) {
  Scene scene = builtinScene();
  const Camera* cam = scene.findCamera(builtinViewNames()[0]);
  ASSERT_NE(cam, nullptr);
  const glm::vec3 light = scene.lights[0].position;
  ReferenceFrame f(scene, *cam, light, 32);
  ConeOptions o;
  o.arena.pairCapacity = 64;  // batches of one triangle: thousands of them
  o.arena.chunkCapacity = 1;
  auto engine = makeConeEngine(context(), o, 1, 1);
  engine->setGeometry(scene, geometryRevision(scene));
  vk::Commands cmd(context());
  const vk::HostCost before = context().cost;
  const glm::vec3 lights[1] = {light};
  try {
    engine->record(cmd, f.dev, lights, f.input.epsilon, 0, [](uint32_t, const vk::Buffer&) {});
    ADD_FAILURE() << "the engine recorded a frame of batches of one triangle";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("holds too few pairs to record the frame"), std::string::npos) << what;
    EXPECT_NE(what.find("batches of 1 triangles"), std::string::npos) << what;
    EXPECT_NE(what.find("give a larger memory budget"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << "one line: " << what;
  }
  EXPECT_EQ((context().cost - before).dispatches, 0u) << "the refused frame recorded dispatches";
  EXPECT_TRUE(engine->stats(0).empty()) << "the refused frame holds a stats slot";
}

// The same refusal through the public API: a memory budget that leaves the traversal an arena too small for
// one recording is one coneshadow::Error line. The budget is found by bisection between one that cannot
// hold the frame and one that records it (the window is the arena's ~1 KB over the frame's other buffers).
TEST(Api, ABudgetThatLeavesTooFewPairsForOneRecordingIsOneClearError) {
  OwnDevice device;
  Scene scene = builtinScene();
  const Camera* cam = scene.findCamera(builtinViewNames()[0]);
  ASSERT_NE(cam, nullptr);
  const glm::vec3 light = scene.lights[0].position;
  const uint32_t size = 16;
  ReferenceFrame f(scene, *cam, light, size);
  Renderer renderer(device, size, size, 1);
  auto attempt = [&](uint64_t budget) -> std::string {  // the error, or "" when the frame was recorded
    coneshadow::Options o;
    o.memoryBudgetBytes = budget;
    o.framesInFlight = 1;
    o.maxLights = 1;
    auto cs = coneshadow::Context::create(device.desc(), o);
    addScene(*cs, scene);
    try {
      renderer.frame(*cs, f.host, {light});
      return "";
    } catch (const coneshadow::Error& e) {
      EXPECT_EQ(vkResetCommandBuffer(device.cb, 0), VK_SUCCESS);  // the frame's recording, abandoned
      const std::string what = e.what();
      EXPECT_EQ(what.find('\n'), std::string::npos) << "one line: " << what;
      return what;
    }
  };
  const std::string tooSmall = attempt(1024);
  ASSERT_NE(tooSmall.find("cannot hold this frame"), std::string::npos) << tooSmall;
  EXPECT_NE(tooSmall.find("or more"), std::string::npos) << "the bytes it needs: " << tooSmall;
  uint64_t lo = 1024, hi = uint64_t(1) << 20;
  ASSERT_EQ(attempt(hi), "");
  std::string tooFew;
  while (tooFew.empty() && hi - lo > 16) {
    const uint64_t mid = lo + (hi - lo) / 2;
    const std::string what = attempt(mid);
    if (what.find("holds too few pairs to record the frame") != std::string::npos) tooFew = what;
    else if (what.empty()) hi = mid;
    else {
      EXPECT_NE(what.find("cannot hold this frame"), std::string::npos) << what;
      lo = mid;
    }
  }
  ASSERT_FALSE(tooFew.empty()) << "no budget between " << lo << " and " << hi << " bytes left too few pairs";
  EXPECT_EQ(tooFew.rfind("coneshadow: ", 0), 0u) << tooFew;
  EXPECT_NE(tooFew.find("give a larger memory budget"), std::string::npos) << tooFew;
}

}  // namespace
}  // namespace cs::test
