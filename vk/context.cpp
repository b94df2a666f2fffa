// Headless Vulkan context: see context.h.
#include "vk/context.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <csignal>
#include <mutex>
#include <cstring>
#include <iostream>

#include <cstdlib>
#include <functional>
#include <sstream>
#include <map>
#include <errno.h>
#include <sys/resource.h>
#include <unistd.h>

namespace cs::vk {

const char* resultName(VkResult r) {
  switch (r) {
#define CS_CASE(x) case x: return #x;
    CS_CASE(VK_SUCCESS) CS_CASE(VK_NOT_READY) CS_CASE(VK_TIMEOUT) CS_CASE(VK_INCOMPLETE)
    CS_CASE(VK_ERROR_OUT_OF_HOST_MEMORY) CS_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    CS_CASE(VK_ERROR_INITIALIZATION_FAILED) CS_CASE(VK_ERROR_DEVICE_LOST) CS_CASE(VK_ERROR_MEMORY_MAP_FAILED)
    CS_CASE(VK_ERROR_LAYER_NOT_PRESENT) CS_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
    CS_CASE(VK_ERROR_FEATURE_NOT_PRESENT) CS_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
    CS_CASE(VK_ERROR_TOO_MANY_OBJECTS) CS_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
    CS_CASE(VK_ERROR_FRAGMENTED_POOL) CS_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
    CS_CASE(VK_ERROR_INVALID_SHADER_NV) CS_CASE(VK_ERROR_UNKNOWN)
#undef CS_CASE
    default: return "VkResult(unknown)";
  }
}

void fail(VkResult r, const char* call, const char* file, int line) {
  std::string hint;
  if (r == VK_ERROR_OUT_OF_DEVICE_MEMORY || r == VK_ERROR_OUT_OF_HOST_MEMORY)
    hint = "lower the resolution or the memory bounds";
  else if (r == VK_ERROR_INCOMPATIBLE_DRIVER || r == VK_ERROR_INITIALIZATION_FAILED)
    hint = "no Vulkan driver could start: is one installed (apt-get install mesa-vulkan-drivers), and does the "
           "process have the memory a driver needs (ulimit -v)?";
  else if (r == VK_ERROR_DEVICE_LOST)
    hint = "the GPU reset; try again or pick another device with --device";
  else if (r == VK_ERROR_UNKNOWN)
    hint = "the driver failed without saying why; drivers do when they cannot get memory or start their "
           "threads: raise the process's limits (ulimit -v, -u), or try another device with --device";
  throw Error(std::string(call) + " returned " + resultName(r),
              sourceWhere("Vulkan", file, line), hint);
}

namespace {

VKAPI_ATTR VkBool32 VKAPI_CALL debugCallback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                             VkDebugUtilsMessageTypeFlagsEXT,
                                             const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  auto* ctx = static_cast<Context*>(user);
  if (severity < VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) return VK_FALSE;
  std::string msg = data && data->pMessage ? data->pMessage : "(no message)";
  ctx->validationMessages++;
  ctx->lastValidationMessage = msg;
  if (ctx->onValidationMessage)
    ctx->onValidationMessage(msg);
  else
    std::cerr << "coneshadow: Vulkan validation: " << msg << "\n";
  return VK_FALSE;
}

bool hasLayer(const char* name) {
  uint32_t n = 0;
  VK_CHECK(vkEnumerateInstanceLayerProperties(&n, nullptr));
  std::vector<VkLayerProperties> layers(n);
  VK_CHECK(vkEnumerateInstanceLayerProperties(&n, layers.data()));
  for (auto& l : layers)
    if (std::strcmp(l.layerName, name) == 0) return true;
  return false;
}

const char* typeName(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "CPU";
    default: return "other";
  }
}

VkInstance createInstance(bool validation, bool debugUtils) {
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "coneshadow";
  app.apiVersion = VK_API_VERSION_1_2;
  std::vector<const char*> layers, exts;
  if (validation) layers.push_back("VK_LAYER_KHRONOS_validation");
  if (debugUtils) exts.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  VkInstanceCreateInfo ci{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ci.pApplicationInfo = &app;
  ci.enabledLayerCount = uint32_t(layers.size());
  ci.ppEnabledLayerNames = layers.data();
  ci.enabledExtensionCount = uint32_t(exts.size());
  ci.ppEnabledExtensionNames = exts.data();
  VkInstance instance = VK_NULL_HANDLE;
  VK_CHECK(vkCreateInstance(&ci, nullptr, &instance));
  return instance;
}

std::vector<VkPhysicalDevice> physicalDevices(VkInstance instance) {
  uint32_t n = 0;
  VK_CHECK(vkEnumeratePhysicalDevices(instance, &n, nullptr));
  std::vector<VkPhysicalDevice> devs(n);
  VK_CHECK(vkEnumeratePhysicalDevices(instance, &n, devs.data()));
  return devs;
}

uint32_t findMemoryType(const Context& ctx, uint32_t bits, VkMemoryPropertyFlags want) {
  for (uint32_t i = 0; i < ctx.memory.memoryTypeCount; ++i)
    if ((bits & (1u << i)) && (ctx.memory.memoryTypes[i].propertyFlags & want) == want) return i;
  return UINT32_MAX;
}

}  // namespace

bool hasDeviceExtension(VkPhysicalDevice pd, const char* name) {
  uint32_t n = 0;
  VK_CHECK(vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, nullptr));
  std::vector<VkExtensionProperties> ext(n);
  VK_CHECK(vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, ext.data()));
  for (auto& e : ext)
    if (std::strcmp(e.extensionName, name) == 0) return true;
  return false;
}

int deviceTypeRank(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
  }
}

HostCost operator-(const HostCost& a, const HostCost& b) {
  return {a.submits - b.submits, a.hostSyncs - b.hostSyncs, a.readbackBytes - b.readbackBytes,
          a.allocations - b.allocations, a.dispatches - b.dispatches};
}

Context::~Context() {
  if (!ownsDevice) {  // shareDevice: the caller's device, this context's pool and fence
    if (fence) vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX);
    pendingUploads.clear();
    staging.reset();
    if (fence) vkDestroyFence(device, fence, nullptr);
    if (commandPool) vkDestroyCommandPool(device, commandPool, nullptr);
    return;
  }
  if (adopted) {  // the caller's device: only what this context made, and no wait
    pendingUploads.clear();
    staging.reset();
    return;
  }
  if (device) {
    vkDeviceWaitIdle(device);
    staging.reset();
    if (fence) vkDestroyFence(device, fence, nullptr);
    if (commandPool) vkDestroyCommandPool(device, commandPool, nullptr);
    vkDestroyDevice(device, nullptr);
  }
  if (messenger) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance, "vkDestroyDebugUtilsMessengerEXT"));
    if (destroy) destroy(instance, messenger, nullptr);
  }
  if (instance) vkDestroyInstance(instance, nullptr);
}

std::string Context::deviceTypeName() const { return typeName(properties.deviceType); }

std::string Context::driverDescription() const {
  VkPhysicalDeviceDriverProperties driver{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
  VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  p2.pNext = &driver;
  vkGetPhysicalDeviceProperties2(physical, &p2);
  uint32_t v = properties.apiVersion;
  return std::string(properties.deviceName) + " (" + typeName(properties.deviceType) + "), driver " +
         driver.driverName + " " + driver.driverInfo + ", Vulkan " + std::to_string(VK_API_VERSION_MAJOR(v)) +
         "." + std::to_string(VK_API_VERSION_MINOR(v)) + "." + std::to_string(VK_API_VERSION_PATCH(v));
}

std::vector<std::string> listDevices() {
  VkInstance instance = createInstance(false, false);
  std::vector<std::string> out;
  auto devs = physicalDevices(instance);
  for (size_t i = 0; i < devs.size(); ++i) {
    VkPhysicalDeviceProperties p;
    vkGetPhysicalDeviceProperties(devs[i], &p);
    VkPhysicalDeviceFeatures f;
    vkGetPhysicalDeviceFeatures(devs[i], &f);
    out.push_back(std::to_string(i) + ": " + p.deviceName + " (" + typeName(p.deviceType) + ")" +
                  (f.robustBufferAccess ? ", robust buffer access" : ", no robust buffer access") +
                  (f.geometryShader ? "" : ", no geometry shader (rtw needs one)"));
  }
  vkDestroyInstance(instance, nullptr);
  return out;
}

namespace {

std::atomic<int> gInDriver{0};
std::atomic<const char*> gDriverCall{nullptr};
std::atomic<void (*)()> gDriverCrashCleanup{nullptr};
constexpr int kCrashSignals[] = {SIGSEGV, SIGBUS, SIGILL, SIGFPE};
struct sigaction gPreviousHandlers[4];  // what was installed before (the default, or a sanitizer's)

void onDriverCrash(int sig) {
  if (gInDriver.load() <= 0) {  // not the driver's: the previous handler takes it (a crash stays a crash)
    for (int i = 0; i < 4; ++i)
      if (kCrashSignals[i] == sig) sigaction(sig, &gPreviousHandlers[i], nullptr);
    return;  // the faulting instruction runs again, under the previous handler
  }
  const char* name = program_invocation_short_name;
  const char* call = gDriverCall.load();
  const char a[] = ": error: the Vulkan driver crashed in ";
  const char b[] = " (drivers crash where they run out of memory: raise the process's memory limit (ulimit -v) or "
                   "lower the resolution; otherwise update mesa-vulkan-drivers)\n";
  [[maybe_unused]] ssize_t n = ::write(STDERR_FILENO, name, std::strlen(name));
  n = ::write(STDERR_FILENO, a, sizeof a - 1);
  n = ::write(STDERR_FILENO, call ? call : "a driver call", std::strlen(call ? call : "a driver call"));
  n = ::write(STDERR_FILENO, b, sizeof b - 1);
  if (void (*cleanup)() = gDriverCrashCleanup.load()) cleanup();
  _exit(1);
}

}  // namespace

DriverCall::DriverCall(const char* call) {
  static std::once_flag once;
  std::call_once(once, [] {
    struct sigaction sa {};
    sa.sa_handler = &onDriverCrash;
    sigemptyset(&sa.sa_mask);
    for (int i = 0; i < 4; ++i) sigaction(kCrashSignals[i], &sa, &gPreviousHandlers[i]);
  });
  previous_ = gDriverCall.exchange(call);
  gInDriver.fetch_add(1);
}

DriverCall::~DriverCall() {
  gInDriver.fetch_sub(1);
  gDriverCall.store(previous_);
}

void setDriverCrashCleanup(void (*cleanup)()) { gDriverCrashCleanup.store(cleanup); }

// Below this address-space limit (ulimit -v) lavapipe's device start runs out of memory in ways it does
// not survive (a double free in vkCreateDevice at ~550 MB, a deadlock a little above): refused first.
// A 96x96 frame of the cone path and the cube map completes at ~1.3 GB.
constexpr uint64_t kMinAddressSpace = uint64_t(1) << 30;

void checkAddressSpaceLimit() {
  struct rlimit limit {};
  if (getrlimit(RLIMIT_AS, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY || limit.rlim_cur >= kMinAddressSpace) return;
  throw Error("the process's address-space limit is " + std::to_string(uint64_t(limit.rlim_cur) >> 20) +
                  " MB, below the " + std::to_string(kMinAddressSpace >> 20) +
                  " MB the Vulkan driver needs to start (out of memory)",
              "Vulkan device", "raise the limit: ulimit -v unlimited, or at least ulimit -v " +
                                   std::to_string(kMinAddressSpace >> 10));
}

// The physical device's properties, memory and subgroup size into ctx; cs::Error when it lacks the
// subgroup operations the kernels use.
static void describeDevice(Context& ctx) {
  vkGetPhysicalDeviceProperties(ctx.physical, &ctx.properties);
  vkGetPhysicalDeviceMemoryProperties(ctx.physical, &ctx.memory);
  VkPhysicalDeviceSubgroupProperties sub{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
  VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  p2.pNext = &sub;
  vkGetPhysicalDeviceProperties2(ctx.physical, &p2);
  ctx.subgroupSize = sub.subgroupSize;
  // The traversal appends its survivors with subgroup sums and one atomic per subgroup (traverse_test.comp).
  const VkSubgroupFeatureFlags subgroupOps =
      VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT | VK_SUBGROUP_FEATURE_BALLOT_BIT;
  if (!(sub.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) || (sub.supportedOperations & subgroupOps) != subgroupOps)
    throw Error("the device lacks subgroup basic, arithmetic or ballot operations in compute shaders", ctx.deviceName(),
                "use a Vulkan 1.2 driver that supports them (lavapipe and desktop GPUs do)");
  for (uint32_t i = 0; i < ctx.memory.memoryTypeCount; ++i) {
    auto f = ctx.memory.memoryTypes[i].propertyFlags;
    if ((f & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) && (f & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) &&
        (f & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT) &&
        ctx.memory.memoryHeaps[ctx.memory.memoryTypes[i].heapIndex].size >= (VkDeviceSize(1) << 30) &&
        ctx.properties.deviceType != VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU)
      ctx.hostVisibleDeviceLocal = true;
  }
}

std::unique_ptr<Context> createContext(const ContextOptions& options) {
  checkAddressSpaceLimit();
  DriverCall guard("the driver's start (vkCreateInstance, vkCreateDevice)");
  auto ctx = std::make_unique<Context>();
  bool validation = options.validation;
  if (validation && !hasLayer("VK_LAYER_KHRONOS_validation"))
    throw Error("VK_LAYER_KHRONOS_validation is not installed", "Vulkan instance",
                "apt-get install vulkan-validationlayers, or run without validation");
  ctx->instance = createInstance(validation, validation);
  if (validation) {
    auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(ctx->instance, "vkCreateDebugUtilsMessengerEXT"));
    if (!create) throw Error("vkCreateDebugUtilsMessengerEXT is unavailable", "Vulkan instance");
    VkDebugUtilsMessengerCreateInfoEXT mi{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
    mi.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    mi.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                     VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    mi.pfnUserCallback = debugCallback;
    mi.pUserData = ctx.get();
    VK_CHECK(create(ctx->instance, &mi, nullptr, &ctx->messenger));
  }

  // Pick: an explicit --device (index or name substring), else the best-ranked type that has a
  // graphics+compute queue and the extensions we need.
  auto devs = physicalDevices(ctx->instance);
  if (devs.empty())
    throw Error("no Vulkan device found", "Vulkan", "apt-get install mesa-vulkan-drivers (lavapipe)");
  auto usable = [&](VkPhysicalDevice pd, uint32_t* family) {
    if (!hasDeviceExtension(pd, VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME)) return false;
    uint32_t n = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, nullptr);
    std::vector<VkQueueFamilyProperties> q(n);
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, q.data());
    for (uint32_t i = 0; i < n; ++i)
      if ((q[i].queueFlags & VK_QUEUE_GRAPHICS_BIT) && (q[i].queueFlags & VK_QUEUE_COMPUTE_BIT) &&
          q[i].timestampValidBits > 0) {
        *family = i;
        return true;
      }
    return false;
  };
  int best = -1, bestRank = -1;
  uint32_t bestFamily = 0;
  std::vector<std::string> names;
  for (size_t i = 0; i < devs.size(); ++i) {
    VkPhysicalDeviceProperties p;
    vkGetPhysicalDeviceProperties(devs[i], &p);
    names.push_back(std::to_string(i) + ": " + p.deviceName);
    uint32_t family = 0;
    if (!usable(devs[i], &family)) continue;
    bool match;
    if (options.device.empty()) {
      match = true;
    } else {
      bool isIndex = std::all_of(options.device.begin(), options.device.end(), ::isdigit);
      match = isIndex ? std::stoul(options.device) == i
                      : std::string(p.deviceName).find(options.device) != std::string::npos;
    }
    if (!match) continue;
    int rank = deviceTypeRank(p.deviceType);
    if (rank > bestRank) best = int(i), bestRank = rank, bestFamily = family;
  }
  if (best < 0) {
    std::string all;
    for (auto& n : names) all += (all.empty() ? "" : "; ") + n;
    throw Error("no usable Vulkan device matches '" + options.device + "'", "--device",
                "devices: " + all + " (a device needs graphics+compute, timestamps and VK_KHR_push_descriptor)");
  }
  ctx->physical = devs[best];
  ctx->queueFamily = bestFamily;
  describeDevice(*ctx);

  // Features we rely on; each is checked so a device without it fails with a clear line.
  VkPhysicalDeviceVulkan12Features have12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  VkPhysicalDeviceFeatures2 have{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  have.pNext = &have12;
  vkGetPhysicalDeviceFeatures2(ctx->physical, &have);
  if (!have12.hostQueryReset || !have.features.shaderInt64 || !have12.shaderBufferInt64Atomics)
    throw Error("the device lacks hostQueryReset, shaderInt64 or 64-bit buffer atomics", ctx->deviceName());

  VkPhysicalDeviceVulkan12Features want12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  want12.hostQueryReset = VK_TRUE;
  want12.shaderBufferInt64Atomics = VK_TRUE;
  want12.storageBuffer8BitAccess = have12.storageBuffer8BitAccess;
  want12.shaderFloat16 = VK_FALSE;
  VkPhysicalDeviceFeatures2 want{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  want.pNext = &want12;
  want.features.shaderInt64 = VK_TRUE;
  want.features.fragmentStoresAndAtomics = have.features.fragmentStoresAndAtomics;
  want.features.vertexPipelineStoresAndAtomics = have.features.vertexPipelineStoresAndAtomics;
  // CONESHADOW_HIDE_FEATURES=geometryShader: behave as a device without it (MoltenVK has none), to see
  // what a run does there on a machine that has one.
  bool hideGeometryShader = false;
  if (const char* hide = std::getenv("CONESHADOW_HIDE_FEATURES")) {
    std::stringstream list(hide);
    for (std::string name; std::getline(list, name, ',');) {
      if (name == "geometryShader") hideGeometryShader = true;
      else if (!name.empty())
        throw Error("CONESHADOW_HIDE_FEATURES names '" + name + "'", "Vulkan context",
                    "the one feature it can hide is geometryShader");
    }
  }
  want.features.geometryShader = hideGeometryShader ? VK_FALSE : have.features.geometryShader;
  ctx->geometryShader = want.features.geometryShader == VK_TRUE;
  want.features.robustBufferAccess = have.features.robustBufferAccess;
  ctx->robustBufferAccess = have.features.robustBufferAccess == VK_TRUE;

  float priority = 1.0f;
  VkDeviceQueueCreateInfo qi{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qi.queueFamilyIndex = ctx->queueFamily;
  qi.queueCount = 1;
  qi.pQueuePriorities = &priority;
  const char* exts[] = {VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME};
  VkDeviceCreateInfo di{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  di.pNext = &want;
  di.queueCreateInfoCount = 1;
  di.pQueueCreateInfos = &qi;
  di.enabledExtensionCount = 1;
  di.ppEnabledExtensionNames = exts;
  VK_CHECK(vkCreateDevice(ctx->physical, &di, nullptr, &ctx->device));
  vkGetDeviceQueue(ctx->device, ctx->queueFamily, 0, &ctx->queue);
  ctx->cmdPushDescriptorSet = reinterpret_cast<PFN_vkCmdPushDescriptorSetKHR>(
      vkGetDeviceProcAddr(ctx->device, "vkCmdPushDescriptorSetKHR"));
  if (!ctx->cmdPushDescriptorSet) throw Error("vkCmdPushDescriptorSetKHR is unavailable", ctx->deviceName());

  VkCommandPoolCreateInfo pi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pi.queueFamilyIndex = ctx->queueFamily;
  VK_CHECK(vkCreateCommandPool(ctx->device, &pi, nullptr, &ctx->commandPool));
  VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VK_CHECK(vkCreateFence(ctx->device, &fi, nullptr, &ctx->fence));

  if (!options.quiet) std::cout << "device: " << ctx->driverDescription() << "\n";
  return ctx;
}

DeviceRequirements deviceRequirements() {
  DeviceRequirements r;
  r.extensions = {VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME};
  return r;
}

std::unique_ptr<Context> adoptDevice(const AdoptedDevice& d) {
  if (!d.instance || !d.physical || !d.device || !d.getInstanceProcAddr)
    throw Error("the instance, physical device, device and vkGetInstanceProcAddr must all be given", "coneshadow context",
                "pass the handles your renderer created");
  auto ctx = std::make_unique<Context>();
  ctx->adopted = true;
  ctx->instance = d.instance;
  ctx->physical = d.physical;
  ctx->device = d.device;
  ctx->queueFamily = d.queueFamily;
  describeDevice(*ctx);
  const std::string name = ctx->deviceName();
  if (VK_API_VERSION_MINOR(ctx->properties.apiVersion) < 2 && VK_API_VERSION_MAJOR(ctx->properties.apiVersion) == 1)
    throw Error("the device supports Vulkan " + std::to_string(VK_API_VERSION_MAJOR(ctx->properties.apiVersion)) + "." +
                    std::to_string(VK_API_VERSION_MINOR(ctx->properties.apiVersion)) + ", the library needs 1.2",
                name, "use a Vulkan 1.2 driver");
  uint32_t n = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(ctx->physical, &n, nullptr);
  std::vector<VkQueueFamilyProperties> q(n);
  vkGetPhysicalDeviceQueueFamilyProperties(ctx->physical, &n, q.data());
  if (d.queueFamily >= n || !(q[d.queueFamily].queueFlags & VK_QUEUE_COMPUTE_BIT))
    throw Error("queue family " + std::to_string(d.queueFamily) + " has no compute queues (the device has " +
                    std::to_string(n) + " families)",
                name, "record the frames on a compute or graphics+compute family");
  for (const char* ext : deviceRequirements().extensions)
    if (!hasDeviceExtension(ctx->physical, ext))
      throw Error(std::string("the device lacks ") + ext, name, "the library needs it enabled at vkCreateDevice");
  VkPhysicalDeviceVulkan12Features have12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  VkPhysicalDeviceFeatures2 have{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  have.pNext = &have12;
  vkGetPhysicalDeviceFeatures2(ctx->physical, &have);
  if (!have.features.shaderInt64 || !have12.shaderBufferInt64Atomics)
    throw Error("the device lacks shaderInt64 or 64-bit buffer atomics", name,
                "the library needs both enabled at vkCreateDevice (coneshadow::deviceRequirements)");
  auto getDeviceProcAddr =
      reinterpret_cast<PFN_vkGetDeviceProcAddr>(d.getInstanceProcAddr(d.instance, "vkGetDeviceProcAddr"));
  if (!getDeviceProcAddr) throw Error("vkGetDeviceProcAddr is unavailable", name);
  ctx->cmdPushDescriptorSet =
      reinterpret_cast<PFN_vkCmdPushDescriptorSetKHR>(getDeviceProcAddr(d.device, "vkCmdPushDescriptorSetKHR"));
  if (!ctx->cmdPushDescriptorSet)
    throw Error("vkCmdPushDescriptorSetKHR is unavailable", name,
                "enable VK_KHR_push_descriptor at vkCreateDevice (coneshadow::deviceRequirements)");
  return ctx;
}

std::unique_ptr<Context> shareDevice(const AdoptedDevice& d, VkQueue queue) {
  if (!queue) throw Error("no queue given", "shared Vulkan context", "pass a queue of the device's queueFamily");
  std::unique_ptr<Context> ctx = adoptDevice(d);
  ctx->adopted = false;
  ctx->ownsDevice = false;
  ctx->queue = queue;
  VkCommandPoolCreateInfo pi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pi.queueFamilyIndex = ctx->queueFamily;
  VK_CHECK(vkCreateCommandPool(ctx->device, &pi, nullptr, &ctx->commandPool));
  VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  fi.flags = VK_FENCE_CREATE_SIGNALED_BIT;  // the destructor's wait returns at once when nothing was submitted
  VK_CHECK(vkCreateFence(ctx->device, &fi, nullptr, &ctx->fence));
  return ctx;
}

std::vector<std::unique_ptr<Buffer>> recordPendingUploads(Context& ctx, Commands& cmd) {
  std::vector<std::unique_ptr<Buffer>> staged;
  if (ctx.pendingUploads.empty()) return staged;
  for (Context::PendingUpload& u : ctx.pendingUploads) {
    VkBufferCopy region{0, u.offset, u.bytes};
    vkCmdCopyBuffer(cmd.handle(), u.staging->buffer, u.dst, 1, &region);
    staged.push_back(std::move(u.staging));
  }
  ctx.pendingUploads.clear();
  cmd.barrier();
  return staged;
}

// ---- buffers ------------------------------------------------------------------------------------

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this != &o) {
    reset();
    ctx = o.ctx, buffer = o.buffer, memory = o.memory, size = o.size, mapped = o.mapped;
    views = std::move(o.views);
    o.views.clear();
    o.buffer = VK_NULL_HANDLE, o.memory = VK_NULL_HANDLE, o.mapped = nullptr, o.size = 0;
  }
  return *this;
}

void Buffer::reset() {
  if (ctx && buffer) {
    for (auto& [format, view] : views) vkDestroyBufferView(ctx->device, view, nullptr);
    if (mapped) vkUnmapMemory(ctx->device, memory);
    vkDestroyBuffer(ctx->device, buffer, nullptr);
    vkFreeMemory(ctx->device, memory, nullptr);
  }
  views.clear();
  buffer = VK_NULL_HANDLE, memory = VK_NULL_HANDLE, mapped = nullptr, size = 0;
}

BufferRange uniforms(const Buffer& b, VkDeviceSize bytes) {
  CS_CHECK(b.ctx && b.buffer, "uniforms(): not a buffer");
  CS_CHECK(bytes > 0 && bytes <= b.size, "uniforms(): " << bytes << " bytes of a buffer of " << b.size);
  const VkDeviceSize limit = b.ctx->properties.limits.maxUniformBufferRange;
  if (bytes > limit)
    throw Error("a uniform buffer of " + std::to_string(bytes) + " bytes, above the device's maxUniformBufferRange of " +
                    std::to_string(limit),
                b.ctx->deviceName(), "report it: the words a kernel reads as uniforms are a fixed few hundred");
  BufferRange r(b, 0, bytes);
  r.uniform = true;
  return r;
}

BufferRange texels(const Buffer& b, VkFormat format) {
  CS_CHECK(b.ctx && b.buffer, "texels(): not a buffer");
  const bool word = format == VK_FORMAT_R32_UINT;
  CS_CHECK(word || format == VK_FORMAT_R32G32B32A32_SFLOAT || format == VK_FORMAT_R32G32B32A32_UINT,
           "texels(): RGBA32F, RGBA32UI or R32UI only");
  const uint32_t texelBytes = word ? 4 : 16;
  BufferRange r(b);
  for (auto& [f, view] : b.views)
    if (f == format) {
      r.view = view;
      return r;
    }
  const uint64_t elements = b.size / texelBytes;
  const uint64_t limit = b.ctx->properties.limits.maxTexelBufferElements;
  if (elements > limit)
    throw Error("a texel buffer of " + std::to_string(elements) + (word ? " 4-byte" : " 16-byte") +
                    " texels, above the device's maxTexelBufferElements of " + std::to_string(limit),
                b.ctx->deviceName(), "lower the resolution or the scene's triangles per buffer");
  VkBufferViewCreateInfo vi{VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO};
  vi.buffer = b.buffer;
  vi.format = format;
  vi.offset = 0;
  vi.range = elements * texelBytes;
  VkBufferView view = VK_NULL_HANDLE;
  VK_CHECK(vkCreateBufferView(b.ctx->device, &vi, nullptr, &view));
  b.views.emplace_back(format, view);
  r.view = view;
  return r;
}

Buffer createBuffer(Context& ctx, VkDeviceSize size, Memory memory, VkBufferUsageFlags extraUsage) {
  Buffer b;
  b.ctx = &ctx;
  b.size = std::max<VkDeviceSize>(16, (size + 15) & ~VkDeviceSize(15));
  VkBufferCreateInfo bi{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bi.size = b.size;
  bi.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT | VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT |
             VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | extraUsage;
  VK_CHECK(vkCreateBuffer(ctx.device, &bi, nullptr, &b.buffer));
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(ctx.device, b.buffer, &req);
  uint32_t type = UINT32_MAX;
  // Unified memory: everything host visible (lavapipe). Otherwise device local, or host visible
  // (cached if possible) for staging/readback.
  if (memory == Memory::Device && !ctx.hostVisibleDeviceLocal) {
    type = findMemoryType(ctx, req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  } else {
    VkMemoryPropertyFlags hv = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    type = findMemoryType(ctx, req.memoryTypeBits, hv | VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
    if (type == UINT32_MAX) type = findMemoryType(ctx, req.memoryTypeBits, hv);
  }
  if (type == UINT32_MAX) {
    vkDestroyBuffer(ctx.device, b.buffer, nullptr);
    b.buffer = VK_NULL_HANDLE;
    throw Error("no memory type fits a buffer of " + std::to_string(size) + " bytes", ctx.deviceName());
  }
  VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  ai.allocationSize = req.size;
  ai.memoryTypeIndex = type;
  VkResult r;
  {
    DriverCall guard("vkAllocateMemory");
    r = vkAllocateMemory(ctx.device, &ai, nullptr, &b.memory);
  }
  ctx.cost.allocations++;
  if (r != VK_SUCCESS) {
    vkDestroyBuffer(ctx.device, b.buffer, nullptr);
    b.buffer = VK_NULL_HANDLE;
    throw Error("cannot allocate a buffer of " + std::to_string(size) + " bytes (" + resultName(r) + ")",
                ctx.deviceName(), "lower the resolution or the memory bounds");
  }
  VK_CHECK(vkBindBufferMemory(ctx.device, b.buffer, b.memory, 0));
  if (ctx.memory.memoryTypes[type].propertyFlags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT)
    VK_CHECK(vkMapMemory(ctx.device, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped));
  return b;
}

// The context's staging buffer, grown (one allocation) when `bytes` do not fit.
static Buffer& stagingFor(Context& ctx, VkDeviceSize bytes) {
  if (!ctx.staging || ctx.staging->size < bytes) {
    ctx.staging.reset();
    ctx.staging = std::make_unique<Buffer>(createBuffer(ctx, std::max<VkDeviceSize>(bytes, 1 << 16), Memory::HostVisible));
  }
  return *ctx.staging;
}

void upload(Context& ctx, Buffer& dst, const void* data, VkDeviceSize bytes, VkDeviceSize offset) {
  uploadInPlace(ctx, dst, bytes, offset, [&](void* p) { std::memcpy(p, data, bytes); });
}

void uploadInPlace(Context& ctx, Buffer& dst, VkDeviceSize bytes, VkDeviceSize offset,
                   const std::function<void(void*)>& fill) {
  CS_CHECK(offset + bytes <= dst.size, "upload of " << bytes << " bytes at " << offset << " past buffer of " << dst.size);
  if (bytes == 0) return;
  if (dst.mapped) {
    fill(static_cast<char*>(dst.mapped) + offset);
    return;
  }
  if (ctx.adopted) {  // no submit on the caller's device: staged for the next recorded frame
    auto staged = std::make_unique<Buffer>(createBuffer(ctx, bytes, Memory::HostVisible));
    fill(staged->mapped);
    ctx.pendingUploads.push_back({std::move(staged), dst.buffer, offset, bytes});
    return;
  }
  Buffer& staging = stagingFor(ctx, bytes);
  fill(staging.mapped);
  Commands cmd(ctx);
  cmd.copy(staging, dst, bytes, 0, offset);
  cmd.submit();
}

void download(Context& ctx, const Buffer& src, void* data, VkDeviceSize bytes, VkDeviceSize offset) {
  CS_CHECK(offset + bytes <= src.size, "download of " << bytes << " bytes at " << offset << " past buffer of " << src.size);
  if (bytes == 0) return;
  ctx.cost.readbackBytes += bytes;
  if (src.mapped) {
    std::memcpy(data, static_cast<const char*>(src.mapped) + offset, bytes);
    return;
  }
  CS_CHECK(!ctx.adopted, "a download from device memory on the caller's device (the library reads back nothing "
                         "it cannot map)");
  Buffer& staging = stagingFor(ctx, bytes);
  Commands cmd(ctx);
  cmd.copy(src, staging, bytes, offset, 0);
  cmd.submit();
  std::memcpy(data, staging.mapped, bytes);
}

uint32_t Readback::add(const Buffer& src, VkDeviceSize bytes, VkDeviceSize srcOffset) {
  CS_CHECK(srcOffset + bytes <= src.size, "readback of " << bytes << " bytes at " << srcOffset << " past a buffer of "
                                                         << src.size);
  const VkDeviceSize hostOffset = slots_.empty() ? 0 : (slots_.back().hostOffset + slots_.back().bytes + 15) & ~VkDeviceSize(15);
  slots_.push_back({&src, bytes, srcOffset, hostOffset});
  return uint32_t(slots_.size() - 1);
}

void Readback::record(Commands& cmd) {
  if (slots_.empty()) return;
  bool copies = false;
  for (const Slot& s : slots_) copies = copies || !s.src->mapped;
  if (!copies) return;
  const VkDeviceSize need = slots_.back().hostOffset + slots_.back().bytes;
  if (!host_ || host_->size < need) {
    host_.reset();
    host_ = std::make_unique<Buffer>(createBuffer(ctx_, need, Memory::HostVisible));
  }
  for (const Slot& s : slots_)
    if (!s.src->mapped) cmd.copy(*s.src, *host_, s.bytes, s.srcOffset, s.hostOffset);
  cmd.barrier();
}

void Readback::readBytes(uint32_t slot, void* data, size_t capacity) const {
  const Slot& s = slots_.at(slot);
  if (s.bytes == 0) return;
  CS_CHECK(s.bytes <= capacity, "readback slot " << slot << " holds " << s.bytes << " bytes, its destination only "
                                                  << capacity);
  ctx_.cost.readbackBytes += s.bytes;
  if (s.src->mapped) {
    std::memcpy(data, static_cast<const char*>(s.src->mapped) + s.srcOffset, s.bytes);
    return;
  }
  CS_CHECK(host_ && host_->size >= s.hostOffset + s.bytes, "readback read before it was recorded");
  std::memcpy(data, static_cast<const char*>(host_->mapped) + s.hostOffset, s.bytes);
}

uint64_t Readback::bytesAllocated() const { return host_ ? host_->size : 0; }

// ---- images ------------------------------------------------------------------------------------

Image& Image::operator=(Image&& o) noexcept {
  if (this != &o) {
    reset();
    ctx = o.ctx, image = o.image, memory = o.memory, view = o.view, bytes = o.bytes;
    o.image = VK_NULL_HANDLE, o.memory = VK_NULL_HANDLE, o.view = VK_NULL_HANDLE, o.bytes = 0;
  }
  return *this;
}

void Image::reset() {
  if (ctx) {
    if (view) vkDestroyImageView(ctx->device, view, nullptr);
    if (image) vkDestroyImage(ctx->device, image, nullptr);
    if (memory) vkFreeMemory(ctx->device, memory, nullptr);
  }
  image = VK_NULL_HANDLE, memory = VK_NULL_HANDLE, view = VK_NULL_HANDLE, bytes = 0;
}

Image createImage(Context& ctx, uint32_t width, uint32_t height, VkFormat format, VkImageUsageFlags usage,
                  VkImageAspectFlags aspect, const std::string& hint) {
  Image t;
  t.ctx = &ctx;
  VkImageCreateInfo ii{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ii.imageType = VK_IMAGE_TYPE_2D;
  ii.format = format;
  ii.extent = {width, height, 1};
  ii.mipLevels = 1;
  ii.arrayLayers = 1;
  ii.samples = VK_SAMPLE_COUNT_1_BIT;
  ii.tiling = VK_IMAGE_TILING_OPTIMAL;
  ii.usage = usage;
  ii.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VK_CHECK(vkCreateImage(ctx.device, &ii, nullptr, &t.image));
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(ctx.device, t.image, &req);
  uint32_t type = findMemoryType(ctx, req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  if (type == UINT32_MAX) type = findMemoryType(ctx, req.memoryTypeBits, 0);
  if (type == UINT32_MAX) throw Error("no memory type for a render target", ctx.deviceName());
  VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  ai.allocationSize = req.size;
  ai.memoryTypeIndex = type;
  VkResult r;
  {
    DriverCall guard("vkAllocateMemory");
    r = vkAllocateMemory(ctx.device, &ai, nullptr, &t.memory);
  }
  ctx.cost.allocations++;
  if (r != VK_SUCCESS)
    throw Error("cannot allocate a " + std::to_string(width) + "x" + std::to_string(height) + " render target (" +
                    resultName(r) + ")",
                ctx.deviceName(), hint);
  VK_CHECK(vkBindImageMemory(ctx.device, t.image, t.memory, 0));
  t.bytes = req.size;
  VkImageViewCreateInfo vi{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  vi.image = t.image;
  vi.viewType = VK_IMAGE_VIEW_TYPE_2D;
  vi.format = format;
  vi.subresourceRange = {aspect, 0, 1, 0, 1};
  VK_CHECK(vkCreateImageView(ctx.device, &vi, nullptr, &t.view));
  return t;
}

VkShaderModule createShaderModule(Context& ctx, const uint32_t* spirv, size_t spirvBytes) {
  VkShaderModuleCreateInfo mi{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  mi.codeSize = spirvBytes;
  mi.pCode = spirv;
  VkShaderModule module = VK_NULL_HANDLE;
  VK_CHECK(vkCreateShaderModule(ctx.device, &mi, nullptr, &module));
  return module;
}

VkPipeline createTrianglePipeline(Context& ctx, const TrianglePipelineDesc& desc) {
  CS_CHECK(desc.vertexStreams <= 4 && desc.colorAttachments <= 4,
           "triangle pipeline: " << desc.vertexStreams << " streams, " << desc.colorAttachments << " attachments");
  VkPipelineShaderStageCreateInfo stages[3]{};
  stages[0] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_VERTEX_BIT, desc.vert, "main", nullptr};
  stages[1] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_FRAGMENT_BIT, desc.frag, "main", nullptr};
  if (desc.geom) {
    CS_CHECK(ctx.geometryShader, "triangle pipeline: a geometry stage on a device without the geometryShader feature");
    stages[2] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_GEOMETRY_BIT, desc.geom, "main", nullptr};
  }
  VkVertexInputBindingDescription bindings[4];
  VkVertexInputAttributeDescription attrs[4];
  for (uint32_t i = 0; i < desc.vertexStreams; ++i) {
    bindings[i] = {i, 3 * sizeof(float), VK_VERTEX_INPUT_RATE_VERTEX};
    attrs[i] = {i, i, VK_FORMAT_R32G32B32_SFLOAT, 0};
  }
  VkPipelineVertexInputStateCreateInfo vi{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  vi.vertexBindingDescriptionCount = desc.vertexStreams;
  vi.pVertexBindingDescriptions = bindings;
  vi.vertexAttributeDescriptionCount = desc.vertexStreams;
  vi.pVertexAttributeDescriptions = attrs;
  VkPipelineInputAssemblyStateCreateInfo ia{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  ia.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkPipelineViewportStateCreateInfo vp{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  vp.viewportCount = 1;
  vp.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo rs{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  rs.polygonMode = VK_POLYGON_MODE_FILL;
  rs.cullMode = VK_CULL_MODE_NONE;  // open meshes are seen, and cast, from both sides
  rs.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  rs.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo ms{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo ds{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  ds.depthTestEnable = VK_TRUE;
  ds.depthWriteEnable = VK_TRUE;
  ds.depthCompareOp = desc.depthCompare;
  VkPipelineColorBlendAttachmentState blend[4]{};
  for (auto& b : blend) b.colorWriteMask = desc.colorWriteMask;
  VkPipelineColorBlendStateCreateInfo cb{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  cb.attachmentCount = desc.colorAttachments;
  cb.pAttachments = blend;
  VkDynamicState dyn[2] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dy{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dy.dynamicStateCount = 2;
  dy.pDynamicStates = dyn;
  VkGraphicsPipelineCreateInfo pi{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
  pi.stageCount = desc.geom ? 3 : 2;
  pi.pStages = stages;
  pi.pVertexInputState = &vi;
  pi.pInputAssemblyState = &ia;
  pi.pViewportState = &vp;
  pi.pRasterizationState = &rs;
  pi.pMultisampleState = &ms;
  pi.pDepthStencilState = desc.depth ? &ds : nullptr;
  pi.pColorBlendState = &cb;
  pi.pDynamicState = &dy;
  pi.layout = desc.layout;
  pi.renderPass = desc.renderPass;
  VkPipeline pipeline = VK_NULL_HANDLE;
  {
    DriverCall guard("vkCreateGraphicsPipelines (compiling a shader)");
    VK_CHECK(vkCreateGraphicsPipelines(ctx.device, VK_NULL_HANDLE, 1, &pi, nullptr, &pipeline));
  }
  return pipeline;
}

// ---- kernels ------------------------------------------------------------------------------------

Kernel& Kernel::operator=(Kernel&& o) noexcept {
  if (this != &o) {
    reset();
    ctx = o.ctx, name = std::move(o.name), module = o.module, setLayout = o.setLayout, layout = o.layout;
    pipeline = o.pipeline, bindings = o.bindings, types = std::move(o.types), pushBytes = o.pushBytes;
    o.module = VK_NULL_HANDLE, o.setLayout = VK_NULL_HANDLE, o.layout = VK_NULL_HANDLE, o.pipeline = VK_NULL_HANDLE;
  }
  return *this;
}

void Kernel::reset() {
  if (!ctx) return;
  if (pipeline) vkDestroyPipeline(ctx->device, pipeline, nullptr);
  if (layout) vkDestroyPipelineLayout(ctx->device, layout, nullptr);
  if (setLayout) vkDestroyDescriptorSetLayout(ctx->device, setLayout, nullptr);
  if (module) vkDestroyShaderModule(ctx->device, module, nullptr);
  pipeline = VK_NULL_HANDLE, layout = VK_NULL_HANDLE, setLayout = VK_NULL_HANDLE, module = VK_NULL_HANDLE;
}

const char* descriptorTypeName(VkDescriptorType type) {
  switch (type) {
    case VK_DESCRIPTOR_TYPE_STORAGE_BUFFER: return "a storage buffer";
    case VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER: return "a uniform buffer";
    case VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER: return "a uniform texel buffer";
    case VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER: return "a storage texel buffer";
    case VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE: return "a sampled image";
    case VK_DESCRIPTOR_TYPE_STORAGE_IMAGE: return "a storage image";
    case VK_DESCRIPTOR_TYPE_SAMPLER: return "a sampler";
    case VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER: return "an image with its sampler";
    case VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT: return "an input attachment";
    default: return "a descriptor of another type";
  }
}

SpirvInterface spirvInterface(const uint32_t* spirv, size_t spirvBytes) {
  // Opcodes, decorations, storage classes and image dimensions this reads (SPIR-V specification, section 3).
  constexpr uint32_t kMagic = 0x07230203, kOpExecutionMode = 16, kOpTypeInt = 21, kOpTypeFloat = 22,
                     kOpTypeVector = 23, kOpTypeMatrix = 24, kOpTypeImage = 25, kOpTypeSampler = 26,
                     kOpTypeSampledImage = 27, kOpTypeArray = 28, kOpTypeRuntimeArray = 29, kOpTypeStruct = 30,
                     kOpTypePointer = 32, kOpConstant = 43, kOpVariable = 59, kOpDecorate = 71,
                     kOpMemberDecorate = 72, kLocalSize = 17, kBinding = 33, kBlock = 2, kBufferBlock = 3,
                     kArrayStride = 6, kMatrixStride = 7, kOffset = 35, kUniformConstant = 0, kUniform = 2,
                     kPushConstant = 9, kStorageBuffer = 12, kDimBuffer = 5, kDimSubpassData = 6;
  struct Type {
    uint32_t op = 0, a = 0, b = 0;    // int/float: a = width; vector/matrix: a = element, b = count;
                                      // array: a = element, b = length's constant; pointer: a = pointee,
                                      // b = storage class; image: a = Dim, b = Sampled; sampled image: a = image
    std::vector<uint32_t> members;    // struct member types
  };
  SpirvInterface out;
  const size_t words = spirvBytes / 4;
  CS_CHECK(words >= 5 && spirv[0] == kMagic, "not a SPIR-V module (" << spirvBytes << " bytes)");
  std::map<uint32_t, Type> types;
  std::map<uint32_t, uint32_t> constants, arrayStride;
  std::map<std::pair<uint32_t, uint32_t>, uint32_t> offsets, matrixStride;  // (struct, member)
  std::map<uint32_t, uint32_t> bindingOf, blockOf, variableType;  // variable -> binding, struct -> Block or
                                                                  // BufferBlock, variable -> its pointer type
  uint32_t pushPointer = 0;
  for (size_t at = 5; at < words;) {
    const uint32_t count = spirv[at] >> 16, op = spirv[at] & 0xFFFF;
    CS_CHECK(count > 0 && at + count <= words, "malformed SPIR-V at word " << at);
    const uint32_t* w = spirv + at;
    if (op == kOpDecorate && count >= 4 && w[2] == kBinding) bindingOf[w[1]] = w[3];
    if (op == kOpDecorate && count >= 3 && (w[2] == kBlock || w[2] == kBufferBlock)) blockOf[w[1]] = w[2];
    if (op == kOpDecorate && count >= 4 && w[2] == kArrayStride) arrayStride[w[1]] = w[3];
    if (op == kOpMemberDecorate && count >= 5 && w[3] == kOffset) offsets[{w[1], w[2]}] = w[4];
    if (op == kOpMemberDecorate && count >= 5 && w[3] == kMatrixStride) matrixStride[{w[1], w[2]}] = w[4];
    if (op == kOpExecutionMode && count >= 6 && w[2] == kLocalSize)
      for (int d = 0; d < 3; ++d) out.localSize[d] = w[3 + d];
    if ((op == kOpTypeInt || op == kOpTypeFloat) && count >= 3) types[w[1]] = {op, w[2], 0, {}};
    if ((op == kOpTypeVector || op == kOpTypeMatrix || op == kOpTypeArray) && count >= 4)
      types[w[1]] = {op, w[2], w[3], {}};
    if (op == kOpTypeStruct && count >= 2) types[w[1]] = {op, 0, 0, std::vector<uint32_t>(w + 2, w + count)};
    if (op == kOpTypePointer && count >= 4) types[w[1]] = {op, w[3], w[2], {}};
    if (op == kOpTypeImage && count >= 9) types[w[1]] = {op, w[3], w[7], {}};
    if ((op == kOpTypeSampledImage || op == kOpTypeRuntimeArray) && count >= 3) types[w[1]] = {op, w[2], 0, {}};
    if (op == kOpTypeSampler && count >= 2) types[w[1]] = {op, 0, 0, {}};
    if (op == kOpConstant && count >= 4) constants[w[2]] = w[3];
    if (op == kOpVariable && count >= 4) variableType[w[2]] = w[1];
    if (op == kOpVariable && count >= 4 && w[3] == kPushConstant) pushPointer = w[1];
    at += count;
  }
  // Each bound variable's descriptor type, from its storage class and the type it points to.
  for (const auto& [variable, binding] : bindingOf) {
    auto v = variableType.find(variable);
    auto p = v == variableType.end() ? types.end() : types.find(v->second);
    CS_CHECK(p != types.end() && p->second.op == kOpTypePointer, "SPIR-V binding " << binding << ": no variable's type");
    auto t = types.find(p->second.a);
    CS_CHECK(t != types.end(), "SPIR-V binding " << binding << ": unreadable type %" << p->second.a);
    CS_CHECK(t->second.op != kOpTypeArray && t->second.op != kOpTypeRuntimeArray,
             "SPIR-V binding " << binding << " is an array of descriptors; kernels here bind one descriptor a binding");
    const Type& ty = t->second;
    const auto sampled = [&](const Type& image) {  // an image as a sampled image / texel buffer would read it
      return image.a == kDimBuffer ? VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER : VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE;
    };
    VkDescriptorType type = VK_DESCRIPTOR_TYPE_MAX_ENUM;
    const uint32_t storage = p->second.b;
    if (storage == kStorageBuffer) type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    else if (storage == kUniform && ty.op == kOpTypeStruct && blockOf.count(p->second.a))
      type = blockOf[p->second.a] == kBufferBlock ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER : VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    else if (storage == kUniformConstant && ty.op == kOpTypeSampler) type = VK_DESCRIPTOR_TYPE_SAMPLER;
    else if (storage == kUniformConstant && ty.op == kOpTypeImage && ty.a == kDimSubpassData)
      type = VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT;
    else if (storage == kUniformConstant && ty.op == kOpTypeImage)  // Sampled 2: read and written as storage
      type = ty.b == 2 ? (ty.a == kDimBuffer ? VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_IMAGE)
                       : sampled(ty);
    else if (storage == kUniformConstant && ty.op == kOpTypeSampledImage && types.count(ty.a))
      type = types[ty.a].a == kDimBuffer ? sampled(types[ty.a]) : VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    CS_CHECK(type != VK_DESCRIPTOR_TYPE_MAX_ENUM,
             "SPIR-V binding " << binding << ": storage class " << storage << ", type op " << ty.op << " is no descriptor");
    auto [it, fresh] = out.bindings.emplace(binding, type);
    CS_CHECK(fresh || it->second == type, "SPIR-V binding " << binding << " is declared as two descriptor types");
  }
  if (pushPointer == 0) return out;
  // Sizes as the block's explicit layout gives them; `stride`: a matrix member's MatrixStride.
  std::function<uint64_t(uint32_t, uint32_t, int)> sizeOf = [&](uint32_t id, uint32_t stride, int depth) -> uint64_t {
    auto t = types.find(id);
    CS_CHECK(t != types.end() && depth < 16, "SPIR-V push-constant block: unreadable type %" << id);
    const Type& ty = t->second;
    switch (ty.op) {
      case kOpTypeInt:
      case kOpTypeFloat: return ty.a / 8;
      case kOpTypeVector: return ty.b * sizeOf(ty.a, 0, depth + 1);
      case kOpTypeMatrix: return ty.b * (stride ? stride : sizeOf(ty.a, 0, depth + 1));
      case kOpTypeArray: {
        auto s = arrayStride.find(id);
        return uint64_t(constants[ty.b]) * (s != arrayStride.end() ? s->second : sizeOf(ty.a, 0, depth + 1));
      }
      case kOpTypeStruct: {
        uint64_t end = 0;
        for (uint32_t m = 0; m < ty.members.size(); ++m) {
          auto ms = matrixStride.find({id, m});
          end = std::max<uint64_t>(end, offsets[{id, m}] +
                                            sizeOf(ty.members[m], ms != matrixStride.end() ? ms->second : 0, depth + 1));
        }
        return end;
      }
      default: CS_CHECK(false, "SPIR-V push-constant block: unexpected type op " << ty.op); return 0;
    }
  };
  auto p = types.find(pushPointer);
  CS_CHECK(p != types.end() && p->second.op == kOpTypePointer, "SPIR-V push-constant variable without its type");
  out.pushBytes = uint32_t(sizeOf(p->second.a, 0, 0));
  return out;
}

Kernel createKernel(Context& ctx, const char* name, const uint32_t* spirv, size_t spirvBytes, uint32_t bindings,
                    uint32_t pushBytes, std::initializer_list<SpecConstant> spec) {
  // The host's binding count against what the kernel declares: a kernel reading a binding the host never
  // pushes, or a host pushing buffers the kernel does not declare, is a bug to stop here, not a wrong
  // answer or a driver crash later.
  const SpirvInterface iface = spirvInterface(spirv, spirvBytes);
  const uint32_t declared = iface.bindings.empty() ? 0 : iface.bindings.rbegin()->first + 1;
  CS_CHECK(declared == bindings && iface.bindings.size() == bindings,
           name << ": the host binds " << bindings << " buffers, the kernel declares " << iface.bindings.size()
                << " bindings (highest " << (declared ? int(declared) - 1 : -1) << ")");
  // The push struct the host fills against the kernel's block: one struct per kernel, declared once in
  // the shared layout headers, so a size mismatch means the two sides read different structs.
  CS_CHECK(iface.pushBytes == pushBytes, name << ": the host pushes " << pushBytes << " bytes of constants, the kernel's "
                                               << "push-constant block is " << iface.pushBytes << " bytes");
  Kernel k;
  for (int d = 0; d < 3; ++d) k.localSize[d] = iface.localSize[d];
  k.ctx = &ctx;
  k.name = name;
  k.bindings = bindings;
  // The descriptor types as the kernel declares them: Commands pushes buffers, so a binding of any other
  // kind is refused here rather than by the driver at the first dispatch.
  for (const auto& [binding, type] : iface.bindings) {
    CS_CHECK(type == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER || type == VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER ||
                 type == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER,
             name << ": binding " << binding << " is " << descriptorTypeName(type)
                  << "; kernels bind storage buffers, uniform buffers and uniform texel buffers only");
    k.types.push_back(type);
  }
  k.pushBytes = pushBytes;
  CS_CHECK(pushBytes <= ctx.properties.limits.maxPushConstantsSize,
           name << ": push constants of " << pushBytes << " bytes exceed the device's "
                << ctx.properties.limits.maxPushConstantsSize);
  k.module = createShaderModule(ctx, spirv, spirvBytes);

  std::vector<VkDescriptorSetLayoutBinding> b(bindings);
  for (uint32_t i = 0; i < bindings; ++i) b[i] = {i, k.types[i], 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  VkDescriptorSetLayoutCreateInfo li{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  li.flags = VK_DESCRIPTOR_SET_LAYOUT_CREATE_PUSH_DESCRIPTOR_BIT_KHR;
  li.bindingCount = bindings;
  li.pBindings = b.data();
  VK_CHECK(vkCreateDescriptorSetLayout(ctx.device, &li, nullptr, &k.setLayout));

  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, pushBytes};
  VkPipelineLayoutCreateInfo pli{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  pli.setLayoutCount = 1;
  pli.pSetLayouts = &k.setLayout;
  pli.pushConstantRangeCount = pushBytes ? 1 : 0;
  pli.pPushConstantRanges = &range;
  VK_CHECK(vkCreatePipelineLayout(ctx.device, &pli, nullptr, &k.layout));

  std::vector<VkSpecializationMapEntry> entries;
  std::vector<uint32_t> values;
  for (auto& s : spec) {
    entries.push_back({s.id, uint32_t(values.size() * 4), 4});
    values.push_back(s.value);
  }
  VkSpecializationInfo si{uint32_t(entries.size()), entries.data(), values.size() * 4, values.data()};
  VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  ci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  ci.stage.module = k.module;
  ci.stage.pName = "main";
  ci.stage.pSpecializationInfo = entries.empty() ? nullptr : &si;
  ci.layout = k.layout;
  {
    DriverCall guard("vkCreateComputePipelines (compiling a kernel)");
    VK_CHECK(vkCreateComputePipelines(ctx.device, VK_NULL_HANDLE, 1, &ci, nullptr, &k.pipeline));
  }
  return k;
}

// ---- timestamps ---------------------------------------------------------------------------------

Timer& Timer::operator=(Timer&& o) noexcept {
  if (this != &o) {
    reset();
    ctx = o.ctx, pool = o.pool, capacity = o.capacity, names = std::move(o.names);
    o.pool = VK_NULL_HANDLE;
  }
  return *this;
}

void Timer::reset() {
  if (ctx && pool) vkDestroyQueryPool(ctx->device, pool, nullptr);
  pool = VK_NULL_HANDLE;
  names.clear();
}

void Timer::restart() {
  if (ctx && pool) vkResetQueryPool(ctx->device, pool, 0, capacity);
  names.clear();
}

Timer createTimer(Context& ctx, uint32_t capacity) {
  Timer t;
  t.ctx = &ctx;
  t.capacity = capacity;
  VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
  qi.queryCount = capacity;
  VK_CHECK(vkCreateQueryPool(ctx.device, &qi, nullptr, &t.pool));
  vkResetQueryPool(ctx.device, t.pool, 0, capacity);
  return t;
}

std::vector<std::pair<std::string, double>> Timer::intervals() const {
  std::vector<std::pair<std::string, double>> out;
  if (names.size() < 2) return out;
  std::vector<uint64_t> ticks(names.size());
  VK_CHECK(vkGetQueryPoolResults(ctx->device, pool, 0, uint32_t(names.size()), ticks.size() * 8, ticks.data(), 8,
                                 VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
  double period = ctx->timestampPeriodNs();
  for (size_t i = 1; i < names.size(); ++i)
    out.push_back({names[i], double(ticks[i] - ticks[i - 1]) * period * 1e-6});
  return out;
}

std::vector<std::pair<std::string, double>> Timer::intervalsOr(const std::string& whole, double wallMs) const {
  if (ctx && ctx->timestampsTrusted()) return intervals();
  return {{whole, wallMs}};
}

// ---- commands -----------------------------------------------------------------------------------

Commands::Commands(Context& ctx, Timer* timer) : ctx_(ctx), timer_(timer) {
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = ctx.commandPool;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  VK_CHECK(vkAllocateCommandBuffers(ctx.device, &ai, &cb_));
  begin();
}

Commands::Commands(Context& ctx, VkCommandBuffer recordInto)
    : ctx_(ctx), timer_(nullptr), cb_(recordInto), recording_(true), external_(true) {
  CS_CHECK(recordInto != VK_NULL_HANDLE, "no command buffer to record into");
}

Commands::~Commands() {
  if (external_) return;
  if (recording_) vkEndCommandBuffer(cb_);
  vkFreeCommandBuffers(ctx_.device, ctx_.commandPool, 1, &cb_);
}

void Commands::begin() {
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  VK_CHECK(vkBeginCommandBuffer(cb_, &bi));
  recording_ = true;
}

static void pushBuffers(Context& ctx, VkCommandBuffer cb, const Kernel& kernel,
                        std::initializer_list<BufferRange> buffers) {
  CS_CHECK(buffers.size() == kernel.bindings,
           kernel.name << ": " << buffers.size() << " buffers given, kernel has " << kernel.bindings << " bindings");
  VkDescriptorBufferInfo infos[16];
  VkBufferView views[16];
  VkWriteDescriptorSet writes[16];
  CS_CHECK(buffers.size() <= 16, kernel.name << ": too many bindings");
  uint32_t i = 0;
  for (auto& b : buffers) {
    CS_CHECK(b.buffer != VK_NULL_HANDLE, kernel.name << ": binding " << i << " is a null buffer");
    // A storage binding past maxStorageBufferRange is undefined behaviour on a GPU (reads wrap or fault):
    // refused here, before it is recorded, with the sizes. Callers that can exceed it split their data
    // per binding (the cone path's triangle buffers) or check it up front (sort/, raster/).
    const VkDeviceSize bound = b.range == VK_WHOLE_SIZE ? b.bufferSize - std::min(b.offset, b.bufferSize) : b.range;
    if (bound > ctx.maxStorageBufferRange())
      throw Error(kernel.name + ": binding " + std::to_string(i) + " would expose " + std::to_string(bound) +
                      " bytes, above the device's maxStorageBufferRange of " + std::to_string(ctx.maxStorageBufferRange()),
                  ctx.deviceName(), "lower the resolution or the memory bounds");
    infos[i] = {b.buffer, b.offset, b.range};
    views[i] = b.view;
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    if (kernel.types[i] == VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER) {
      CS_CHECK(b.view != VK_NULL_HANDLE, kernel.name << ": binding " << i << " is a texel buffer: pass vk::texels()");
      writes[i].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
      writes[i].pTexelBufferView = &views[i];
    } else if (kernel.types[i] == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER) {
      CS_CHECK(b.uniform, kernel.name << ": binding " << i << " is a uniform buffer: pass vk::uniforms()");
      writes[i].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
      writes[i].pBufferInfo = &infos[i];
    } else {
      CS_CHECK(!b.uniform, kernel.name << ": binding " << i << " is a storage buffer, given vk::uniforms()");
      writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[i].pBufferInfo = &infos[i];
    }
    ++i;
  }
  vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, kernel.pipeline);
  if (i) ctx.cmdPushDescriptorSet(cb, VK_PIPELINE_BIND_POINT_COMPUTE, kernel.layout, 0, i, writes);
}

namespace {
// CONESHADOW_PROFILE_DISPATCHES=1 (a developer's switch; docs/DEVELOPING.md, "Where a frame's time goes"):
// every dispatch of a command buffer this process owns is submitted on its own after a barrier, and the
// wall clock of that submission (what was recorded since the last one included) and the process's CPU
// time over it are added to its kernel's row; at exit the rows go to stderr, slowest first. A pipeline's first dispatch, which compiles its
// shader on lavapipe, is counted apart. Command buffers of a caller (the engine's) are left alone.
struct DispatchProfile {
  struct Row {
    double ms = 0, cpuMs = 0, firstMs = 0;
    uint64_t calls = 0;
  };
  std::map<std::string, Row> rows;
  std::map<VkPipeline, bool> seen;
  std::mutex mutex;
  ~DispatchProfile() {
    if (rows.empty()) return;
    std::vector<std::pair<std::string, Row>> sorted(rows.begin(), rows.end());
    std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) { return a.second.ms > b.second.ms; });
    double total = 0;
    for (const auto& r : sorted) total += r.second.ms;
    double cpu = 0;
    for (const auto& r : sorted) cpu += r.second.cpuMs;
    std::fprintf(stderr, "dispatch profile (a submission per dispatch; first dispatches of a pipeline apart):\n");
    std::fprintf(stderr, "%10s %10s %8s %12s  %s\n", "ms", "cpu ms", "calls", "first ms", "kernel");
    for (const auto& [name, r] : sorted)
      std::fprintf(stderr, "%10.2f %10.2f %8llu %12.2f  %s\n", r.ms, r.cpuMs, (unsigned long long)r.calls, r.firstMs,
                   name.c_str());
    std::fprintf(stderr, "%10.2f %10.2f %8s %12s  total\n", total, cpu, "", "");
  }
};
DispatchProfile* dispatchProfile() {
  static DispatchProfile* profile = [] {
    const char* on = std::getenv("CONESHADOW_PROFILE_DISPATCHES");
    return on && *on && std::string(on) != "0" ? new DispatchProfile : nullptr;
  }();
  return profile;
}
// Deletes the profile (printing it) at exit, after every context has gone.
struct DispatchProfileAtExit {
  ~DispatchProfileAtExit() { delete dispatchProfile(); }
} dispatchProfileAtExit;
}  // namespace

void Commands::profileDispatch(const Kernel& kernel) {
  DispatchProfile* profile = dispatchProfile();
  if (!profile || external_) return;
  barrier();
  // The process's CPU time too: the driver's threads' work, which a loaded machine's other processes
  // stretch in wall clock but not in CPU time (steadier there; with LP_NUM_THREADS=1, one thread's).
  auto cpuNow = [] {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return (u.ru_utime.tv_sec + u.ru_stime.tv_sec) * 1e3 + (u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-3;
  };
  const double c0 = cpuNow();
  const auto t0 = std::chrono::steady_clock::now();
  submit();
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const double cpuMs = cpuNow() - c0;
  std::lock_guard<std::mutex> lock(profile->mutex);
  DispatchProfile::Row& row = profile->rows[kernel.name];
  if (profile->seen.emplace(kernel.pipeline, true).second) {
    row.firstMs += ms;
  } else {
    row.ms += ms;
    row.cpuMs += cpuMs;
    ++row.calls;
  }
}

void Commands::dispatch(const Kernel& kernel, std::initializer_list<BufferRange> buffers, const void* push,
                        uint32_t pushBytes, uint32_t gx, uint32_t gy, uint32_t gz) {
  CS_CHECK(pushBytes == kernel.pushBytes,
           kernel.name << ": push constants of " << pushBytes << " bytes, kernel expects " << kernel.pushBytes);
  const auto& lim = ctx_.properties.limits.maxComputeWorkGroupCount;
  CS_CHECK(gx <= lim[0] && gy <= lim[1] && gz <= lim[2],
           kernel.name << ": dispatch " << gx << "x" << gy << "x" << gz << " exceeds the device limit");
  if (gx == 0 || gy == 0 || gz == 0) return;
  pushBuffers(ctx_, cb_, kernel, buffers);
  if (pushBytes) vkCmdPushConstants(cb_, kernel.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, pushBytes, push);
  vkCmdDispatch(cb_, gx, gy, gz);
  ctx_.cost.dispatches++;
  profileDispatch(kernel);
}

void Commands::dispatchIndirect(const Kernel& kernel, std::initializer_list<BufferRange> buffers, const void* push,
                                uint32_t pushBytes, VkBuffer args, VkDeviceSize offset) {
  CS_CHECK(pushBytes == kernel.pushBytes,
           kernel.name << ": push constants of " << pushBytes << " bytes, kernel expects " << kernel.pushBytes);
  pushBuffers(ctx_, cb_, kernel, buffers);
  if (pushBytes) vkCmdPushConstants(cb_, kernel.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, pushBytes, push);
  vkCmdDispatchIndirect(cb_, args, offset);
  ctx_.cost.dispatches++;
  profileDispatch(kernel);
}

void Commands::fill(const Buffer& b, uint32_t value, VkDeviceSize offset, VkDeviceSize size) {
  vkCmdFillBuffer(cb_, b.buffer, offset, size, value);
}

void Commands::copy(const Buffer& src, const Buffer& dst, VkDeviceSize bytes, VkDeviceSize srcOffset,
                    VkDeviceSize dstOffset) {
  if (bytes == 0) return;
  VkBufferCopy region{srcOffset, dstOffset, bytes};
  vkCmdCopyBuffer(cb_, src.buffer, dst.buffer, 1, &region);
}

void Commands::barrier() {
  VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_UNIFORM_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT |
                     VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_HOST_READ_BIT;
  vkCmdPipelineBarrier(cb_, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                       VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT |
                           VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_HOST_BIT,
                       0, 1, &mb, 0, nullptr, 0, nullptr);
}

void Commands::mark(const std::string& name) {
  if (!timer_) return;
  CS_CHECK(timer_->names.size() < timer_->capacity, "timer full: " << timer_->capacity << " marks");
  vkCmdWriteTimestamp(cb_, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timer_->pool, uint32_t(timer_->names.size()));
  timer_->names.push_back(name);
}

void Commands::submit() {
  CS_CHECK(!external_, "a submit while recording into the caller's command buffer (the library submits nothing)");
  VK_CHECK(vkEndCommandBuffer(cb_));
  recording_ = false;
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cb_;
  VK_CHECK(vkResetFences(ctx_.device, 1, &ctx_.fence));
  VK_CHECK(vkQueueSubmit(ctx_.queue, 1, &si, ctx_.fence));
  ctx_.cost.submits++;
  VK_CHECK(vkWaitForFences(ctx_.device, 1, &ctx_.fence, VK_TRUE, UINT64_MAX));
  ctx_.cost.hostSyncs++;
  VK_CHECK(vkResetCommandBuffer(cb_, 0));
  begin();
}

Grid gridFor(uint64_t count, uint32_t groupSize, uint32_t maxPerDim) {
  uint64_t groups = (count + groupSize - 1) / groupSize;
  Grid g;
  if (groups == 0) return {0, 1};
  if (groups <= maxPerDim) return {uint32_t(groups), 1};
  g.y = uint32_t((groups + maxPerDim - 1) / maxPerDim);
  g.x = uint32_t((groups + g.y - 1) / g.y);
  CS_CHECK(g.y <= maxPerDim, "dispatch of " << count << " items is too large");
  return g;
}

}  // namespace cs::vk
