// raster/: the camera pass on Vulkan graphics. Per pixel: world position (fp32), normal and the point
// light's direct term (the light buffer). One pass, shared by every shadow method, so all methods are
// judged on the very same samples.
#pragma once
#include <cstdint>

#include "core/scene.h"
#include "raster/gbuffer.h"
#include "vk/context.h"

namespace cs {

// The G-buffer resident on the GPU: two arrays of vec4 in the layout of GBuffer (row 0 at the top), and
// the index of the scene triangle each pixel sees (uint per pixel, CS_NO_TRIANGLE where none) on
// devices with the geometryShader feature (a fragment stage's gl_PrimitiveID needs it); an empty buffer
// elsewhere. Only the GPU copy carries the IDs (ASM's ID + depth test reads them there).
struct DeviceGBuffer {
  uint32_t width = 0, height = 0;
  vk::Buffer position;  // vec4 per pixel
  vk::Buffer normal;    // vec4 per pixel
  vk::Buffer triangle;  // uint per pixel; empty without triangle IDs
};

struct RasterTiming {
  double gpuMs = 0;       // draw + copy to buffers, from timestamps
  double readbackMs = 0;  // GPU -> host copy of the G-buffer (wall clock)
};

// Largest square resolution the device can hold (each G-buffer array must fit one storage binding).
uint32_t maxRasterPixels(const vk::Context& ctx);

// World -> clip for a camera at an aspect ratio, Vulkan conventions (y down, depth in [0,1]).
glm::mat4 viewProjection(const Camera& camera, float aspect);

class Raster {
 public:
  // Uploads the scene's triangles; call setGeometry again when they move (dynamic scenes).
  Raster(vk::Context& ctx, const Scene& scene);
  ~Raster();
  Raster(const Raster&) = delete;
  Raster& operator=(const Raster&) = delete;

  void setGeometry(const Scene& scene);
  // Renders the view into `out` (resized as needed) and, when `host` is non-null, reads it back.
  RasterTiming render(const Camera& camera, glm::vec3 light, uint32_t width, uint32_t height,
                      DeviceGBuffer& out, GBuffer* host);
  uint64_t bytesAllocated() const;

 private:
  void createPipeline();
  void createTargets(uint32_t width, uint32_t height);
  void destroyTargets();

  vk::Context& ctx_;
  vk::Buffer vertices_, normals_, indices_;
  uint32_t indexCount_ = 0;
  VkRenderPass renderPass_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
  VkShaderModule vert_ = VK_NULL_HANDLE, frag_ = VK_NULL_HANDLE;
  bool triangleIds_ = false;  // the device has geometryShader: the third attachment (gbuffer_id.frag)
  vk::Image position_, normal_, triangle_, depth_;
  VkFramebuffer framebuffer_ = VK_NULL_HANDLE;
  uint32_t width_ = 0, height_ = 0;
  uint64_t targetBytes_ = 0;
  vk::Timer timer_;
};

}  // namespace cs
