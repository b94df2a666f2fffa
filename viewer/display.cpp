// The viewer's window and device: see display.h.
#include "viewer/display.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include "core/error.h"
#include "vk/context.h"

namespace cs::viewer {

namespace {

[[noreturn]] void noWindowSystem(const std::string& what) {
  throw Error("no window system: " + what, "view",
              "run it on a desktop session, or under Xvfb: xvfb-run -a coneshadow view ...");
}

}  // namespace

Display::~Display() {
  if (device) {
    vkDeviceWaitIdle(device);
    for (VkImageView v : views) vkDestroyImageView(device, v, nullptr);
    if (swapchain) vkDestroySwapchainKHR(device, swapchain, nullptr);
    vkDestroyDevice(device, nullptr);
  }
  if (surface) vkDestroySurfaceKHR(instance, surface, nullptr);
  if (instance) vkDestroyInstance(instance, nullptr);
  if (window) glfwDestroyWindow(window);
  glfwTerminate();
}

void openDisplay(Display& d, uint32_t width, uint32_t height, const std::string& deviceName, const std::string& title) {
  const char* x11 = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((!x11 || !*x11) && (!wayland || !*wayland)) noWindowSystem("DISPLAY is not set");
  glfwSetErrorCallback(nullptr);
  if (!glfwInit()) {
    const char* why = nullptr;
    glfwGetError(&why);
    noWindowSystem(std::string("GLFW cannot start") + (why ? std::string(" (") + why + ")" : ""));
  }
  if (!glfwVulkanSupported()) noWindowSystem("the Vulkan loader offers no window surfaces");

  uint32_t glfwExtCount = 0;
  const char** glfwExts = glfwGetRequiredInstanceExtensions(&glfwExtCount);
  if (!glfwExts) noWindowSystem("the Vulkan driver has no surface extensions for this window system");
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "coneshadow view";
  app.apiVersion = VK_API_VERSION_1_2;
  VkInstanceCreateInfo ii{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ii.pApplicationInfo = &app;
  ii.enabledExtensionCount = glfwExtCount;
  ii.ppEnabledExtensionNames = glfwExts;
  VK_CHECK(vkCreateInstance(&ii, nullptr, &d.instance));

  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  d.window = glfwCreateWindow(int(width), int(height), title.c_str(), nullptr, nullptr);
  if (!d.window) noWindowSystem("GLFW cannot open a window");
  if (glfwCreateWindowSurface(d.instance, d.window, nullptr, &d.surface) != VK_SUCCESS)
    noWindowSystem("the Vulkan driver cannot make a surface for the window");

  // The device: the best-ranked one whose family does graphics, compute and presents to the surface.
  uint32_t n = 0;
  VK_CHECK(vkEnumeratePhysicalDevices(d.instance, &n, nullptr));
  std::vector<VkPhysicalDevice> devs(n);
  VK_CHECK(vkEnumeratePhysicalDevices(d.instance, &n, devs.data()));
  int bestRank = -1;
  std::string seen;
  for (uint32_t i = 0; i < n; ++i) {
    VkPhysicalDeviceProperties p;
    vkGetPhysicalDeviceProperties(devs[i], &p);
    seen += (seen.empty() ? "" : "; ") + std::string(p.deviceName);
    const bool byIndex = !deviceName.empty() && std::all_of(deviceName.begin(), deviceName.end(), ::isdigit);
    if (!deviceName.empty() && (byIndex ? std::stoul(deviceName) != i : std::string(p.deviceName).find(deviceName) == std::string::npos))
      continue;
    if (!vk::hasDeviceExtension(devs[i], VK_KHR_SWAPCHAIN_EXTENSION_NAME)) continue;
    bool reqs = true;
    for (const char* e : vk::deviceRequirements().extensions) reqs = reqs && vk::hasDeviceExtension(devs[i], e);
    if (!reqs) continue;
    uint32_t qn = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(devs[i], &qn, nullptr);
    std::vector<VkQueueFamilyProperties> q(qn);
    vkGetPhysicalDeviceQueueFamilyProperties(devs[i], &qn, q.data());
    for (uint32_t f = 0; f < qn; ++f) {
      VkBool32 present = VK_FALSE;
      VK_CHECK(vkGetPhysicalDeviceSurfaceSupportKHR(devs[i], f, d.surface, &present));
      const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
      if (present && (q[f].queueFlags & need) == need && vk::deviceTypeRank(p.deviceType) > bestRank) {
        bestRank = vk::deviceTypeRank(p.deviceType);
        d.physical = devs[i];
        d.queueFamily = f;
        break;
      }
    }
  }
  if (!d.physical)
    noWindowSystem("no Vulkan device" + (deviceName.empty() ? std::string() : " matching '" + deviceName + "'") +
                   " presents to this window (devices: " + (seen.empty() ? "none" : seen) + ")");

  VkPhysicalDeviceVulkan12Features have12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  VkPhysicalDeviceFeatures2 have{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  have.pNext = &have12;
  vkGetPhysicalDeviceFeatures2(d.physical, &have);
  if (!have12.hostQueryReset || !have.features.shaderInt64 || !have12.shaderBufferInt64Atomics)
    throw Error("the device lacks hostQueryReset, shaderInt64 or 64-bit buffer atomics", "view", "pick another with --device");
  // What the project's own contexts enable (vk/context.cpp), so every method runs here as it does there.
  VkPhysicalDeviceVulkan12Features want12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  want12.hostQueryReset = VK_TRUE;
  want12.shaderBufferInt64Atomics = VK_TRUE;
  want12.storageBuffer8BitAccess = have12.storageBuffer8BitAccess;
  VkPhysicalDeviceFeatures2 want{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  want.pNext = &want12;
  want.features.shaderInt64 = VK_TRUE;
  want.features.fragmentStoresAndAtomics = have.features.fragmentStoresAndAtomics;
  want.features.vertexPipelineStoresAndAtomics = have.features.vertexPipelineStoresAndAtomics;
  want.features.geometryShader = have.features.geometryShader;
  want.features.robustBufferAccess = have.features.robustBufferAccess;
  d.geometryShader = have.features.geometryShader == VK_TRUE;
  d.robustBufferAccess = have.features.robustBufferAccess == VK_TRUE;

  std::vector<const char*> exts = vk::deviceRequirements().extensions;
  exts.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
  float priority = 1.0f;
  VkDeviceQueueCreateInfo qi{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qi.queueFamilyIndex = d.queueFamily;
  qi.queueCount = 1;
  qi.pQueuePriorities = &priority;
  VkDeviceCreateInfo di{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  di.pNext = &want;
  di.queueCreateInfoCount = 1;
  di.pQueueCreateInfos = &qi;
  di.enabledExtensionCount = uint32_t(exts.size());
  di.ppEnabledExtensionNames = exts.data();
  VK_CHECK(vkCreateDevice(d.physical, &di, nullptr, &d.device));
  vkGetDeviceQueue(d.device, d.queueFamily, 0, &d.queue);
  createSwapchain(d);
}

void createSwapchain(Display& d) {
  VK_CHECK(vkDeviceWaitIdle(d.device));
  VkSurfaceCapabilitiesKHR caps;
  VK_CHECK(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(d.physical, d.surface, &caps));
  uint32_t n = 0;
  VK_CHECK(vkGetPhysicalDeviceSurfaceFormatsKHR(d.physical, d.surface, &n, nullptr));
  std::vector<VkSurfaceFormatKHR> formats(n);
  VK_CHECK(vkGetPhysicalDeviceSurfaceFormatsKHR(d.physical, d.surface, &n, formats.data()));
  VkSurfaceFormatKHR chosen{VK_FORMAT_UNDEFINED, VK_COLOR_SPACE_SRGB_NONLINEAR_KHR};
  for (const VkSurfaceFormatKHR& f : formats)
    if (f.format == VK_FORMAT_B8G8R8A8_UNORM || f.format == VK_FORMAT_R8G8B8A8_UNORM) {
      chosen = f;
      break;
    }
  if (chosen.format == VK_FORMAT_UNDEFINED)
    throw Error("the surface offers no 8-bit UNORM format", "view", "the viewer writes the images' bytes unchanged");
  int fw = 0, fh = 0;
  glfwGetFramebufferSize(d.window, &fw, &fh);
  VkExtent2D extent = caps.currentExtent;
  if (extent.width == UINT32_MAX) extent = {uint32_t(std::max(fw, 1)), uint32_t(std::max(fh, 1))};
  extent.width = std::clamp(extent.width, caps.minImageExtent.width, caps.maxImageExtent.width);
  extent.height = std::clamp(extent.height, caps.minImageExtent.height, caps.maxImageExtent.height);
  if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT))
    throw Error("the swapchain's images cannot be copied from", "view", "screenshots read the window's image back");

  VkSwapchainCreateInfoKHR si{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
  si.surface = d.surface;
  si.minImageCount = std::max(caps.minImageCount, 2u);
  if (caps.maxImageCount) si.minImageCount = std::min(si.minImageCount, caps.maxImageCount);
  si.imageFormat = chosen.format;
  si.imageColorSpace = chosen.colorSpace;
  si.imageExtent = extent;
  si.imageArrayLayers = 1;
  si.imageUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  si.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  si.preTransform = caps.currentTransform;
  si.compositeAlpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
  si.presentMode = VK_PRESENT_MODE_FIFO_KHR;  // the one mode every surface has
  si.clipped = VK_TRUE;
  si.oldSwapchain = d.swapchain;
  VkSwapchainKHR next = VK_NULL_HANDLE;
  VK_CHECK(vkCreateSwapchainKHR(d.device, &si, nullptr, &next));
  for (VkImageView v : d.views) vkDestroyImageView(d.device, v, nullptr);
  if (d.swapchain) vkDestroySwapchainKHR(d.device, d.swapchain, nullptr);
  d.swapchain = next;
  d.format = chosen.format;
  d.extent = extent;
  VK_CHECK(vkGetSwapchainImagesKHR(d.device, d.swapchain, &n, nullptr));
  d.images.resize(n);
  VK_CHECK(vkGetSwapchainImagesKHR(d.device, d.swapchain, &n, d.images.data()));
  d.views.assign(n, VK_NULL_HANDLE);
  for (uint32_t i = 0; i < n; ++i) {
    VkImageViewCreateInfo vi{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vi.image = d.images[i];
    vi.viewType = VK_IMAGE_VIEW_TYPE_2D;
    vi.format = d.format;
    vi.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    VK_CHECK(vkCreateImageView(d.device, &vi, nullptr, &d.views[i]));
  }
}

}  // namespace cs::viewer
