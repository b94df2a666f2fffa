// The viewer's window and its Vulkan device: a GLFW window, a surface, the device the viewer owns (with
// what coneshadow::deviceRequirements() lists and a swapchain), one graphics+compute+present queue and the
// swapchain over the window. docs/ARCHITECTURE.md, "The viewer".
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

struct GLFWwindow;

namespace cs::viewer {

struct Display {
  GLFWwindow* window = nullptr;
  VkInstance instance = VK_NULL_HANDLE;
  VkSurfaceKHR surface = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  uint32_t queueFamily = 0;
  VkQueue queue = VK_NULL_HANDLE;
  bool geometryShader = false, robustBufferAccess = false;  // the optional features enabled

  VkSwapchainKHR swapchain = VK_NULL_HANDLE;
  VkFormat format = VK_FORMAT_UNDEFINED;  // an 8-bit UNORM format: the frame's bytes reach the screen unchanged
  VkExtent2D extent{};
  std::vector<VkImage> images;
  std::vector<VkImageView> views;

  Display() = default;
  Display(const Display&) = delete;
  Display& operator=(const Display&) = delete;
  ~Display();
};

// Opens a width x height window on the device named by `device` ("" = the first that can present:
// discrete > integrated > virtual > cpu). No window system (no DISPLAY, GLFW cannot start, no Vulkan
// surface support): cs::Error whose line says so and what to do.
void openDisplay(Display& d, uint32_t width, uint32_t height, const std::string& device, const std::string& title);
// (Re)creates the swapchain at the window's framebuffer size; waits for the device first.
void createSwapchain(Display& d);

}  // namespace cs::viewer
