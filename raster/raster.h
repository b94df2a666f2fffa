// raster/: the camera pass on Vulkan graphics. Per pixel: world position (fp32), normal and the point
// light's direct term (the light buffer). One pass, shared by every shadow method, so all methods are
// judged on the very same samples.
#pragma once
#include <cstdint>

#include "core/scene.h"
#include "raster/gbuffer.h"
#include "raster/raster_layout.h"
#include "vk/context.h"

namespace cs {

// The G-buffer resident on the GPU: two arrays of vec4 in the layout of GBuffer (row 0 at the top), and
// the index of the scene triangle each pixel sees (uint per pixel, CS_NO_TRIANGLE where none) on
// devices with the geometryShader feature (a fragment stage's gl_PrimitiveID needs it); an empty buffer
// elsewhere. Only the GPU copy carries the IDs (ASM's ID + depth test reads them there).
// `geometryRect` bounds the pixels that may hold geometry: the cone path's compaction reads no pixel
// outside it (a far view's scene covers a tenth of the image; the read of every pixel was its floor).
// Whoever fills the buffers says it: the camera pass gives its geometry's projected box (geometryRectOf);
// the whole image (the default, clamped to the size) where nothing is known.
struct PixelRect {
  uint32_t x0 = 0, y0 = 0, x1 = UINT32_MAX, y1 = UINT32_MAX;  // [x0, x1) x [y0, y1), clamped to the image
};
struct DeviceGBuffer {
  uint32_t width = 0, height = 0;
  vk::Buffer position;  // vec4 per pixel
  vk::Buffer normal;    // vec4 per pixel
  vk::Buffer triangle;  // uint per pixel; empty without triangle IDs
  PixelRect geometryRect;
};

// The pixels of a width x height camera pass through viewProj (viewProjection) that geometry inside the
// box [lo, hi] can cover: its eight corners projected, widened by two pixels for rounding; the whole
// image where a corner is not in front of the camera (the box reaches behind it) or the bounds are not
// finite; no pixel where the box is wholly behind the camera or projects off the image. Never smaller
// than the pixels a rasterizer covers with such geometry.
PixelRect geometryRectOf(const glm::mat4& viewProj, glm::vec3 lo, glm::vec3 hi, uint32_t width, uint32_t height);

// The scene's geometry on the device, uploaded once per revision (core/scene.h: GeometryRevision) and
// shared through FrameInput::deviceScene by every pass that draws the triangles: the camera pass and the
// shadow maps' depth passes. The one geometry policy (checkGeometry) holds here: a bad index list is an
// error and leaves the held geometry as it was; a triangle with a non-finite vertex is written as the
// degenerate triangle (0, 0, 0), which draws nothing.
struct DeviceScene {
  GeometryRevision revision;               // of the geometry held (not known before the first update)
  vk::Buffer positions, normals, indices;  // vec3 a vertex (vertex buffers; normals only when the scene has one
                                           // a vertex); uint32 3 a triangle (index buffer)
  uint32_t indexCount = 0;
  GeometryCheck check;                     // dropped triangles and the bounds of the kept ones
  uint64_t bytes() const { return positions.size + normals.size + indices.size; }
  // Uploads `scene` when `revision` (geometryRevision(scene)) differs from the one held; the milliseconds
  // spent, 0 when nothing changed.
  double update(vk::Context& ctx, const Scene& scene, const GeometryRevision& revision);
};

struct RasterTiming {
  double gpuMs = 0;       // draw + copy to buffers, from timestamps
  double readbackMs = 0;  // GPU -> host copy of the G-buffer (wall clock)
};

// Largest square resolution the device can hold (each G-buffer array must fit one storage binding).
uint32_t maxRasterPixels(const vk::Context& ctx);

// World -> clip for a camera at an aspect ratio, Vulkan conventions (y down, depth in [0,1]).
glm::mat4 viewProjection(const Camera& camera, float aspect);

// Records the camera pass's draw inside a render pass the caller began: the pipeline, a width x height
// viewport, the push constants, the scene's buffers and one indexed draw (none for an empty scene).
// Returns whether it drew. Raster::render records it; so does the viewer, into its own frame.
bool recordCameraDraw(VkCommandBuffer cb, VkPipeline pipeline, VkPipelineLayout layout, const DeviceScene& scene,
                      const RasterPush& push, uint32_t width, uint32_t height);

class Raster {
 public:
  // Uploads the scene's triangles; call setGeometry again when they move (dynamic scenes).
  Raster(vk::Context& ctx, const Scene& scene);
  ~Raster();
  Raster(const Raster&) = delete;
  Raster& operator=(const Raster&) = delete;

  // Uploads the scene's geometry when its revision changed (checkGeometry's errors on a bad scene).
  void setGeometry(const Scene& scene);
  // The geometry the pass draws, for the other passes to draw too (FrameInput::deviceScene).
  const DeviceScene& deviceScene() const { return scene_; }
  // Renders the view into `out` (resized as needed) and, when `host` is non-null, reads it back.
  RasterTiming render(const Camera& camera, glm::vec3 light, uint32_t width, uint32_t height,
                      DeviceGBuffer& out, GBuffer* host);
  uint64_t bytesAllocated() const;

 private:
  void createPipeline();
  void createTargets(uint32_t width, uint32_t height);
  void destroyTargets();

  vk::Context& ctx_;
  DeviceScene scene_;
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
