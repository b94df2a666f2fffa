// The camera pass: see raster.h.
#include "raster/raster.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "raster/gbuffer.frag.h"
#include "raster/gbuffer_id.frag.h"
#include "raster/gbuffer.vert.h"
#include "raster/raster_layout.h"

namespace cs {

namespace {
constexpr VkFormat kColorFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr VkFormat kTriangleFormat = VK_FORMAT_R32_UINT;

}  // namespace

PixelRect geometryRectOf(const glm::mat4& viewProj, glm::vec3 lo, glm::vec3 hi, uint32_t width, uint32_t height) {
  const PixelRect whole{0, 0, width, height};
  if (!(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z)) return whole;  // no geometry kept (or NaN bounds)
  if (!std::isfinite(lo.x + lo.y + lo.z + hi.x + hi.y + hi.z)) return whole;
  // Corners at w <= 0 project through infinity: the image then is the only bound. A corner in front of
  // the camera but behind the near plane projects soundly (the clip only removes parts of triangles).
  // A box wholly at w <= 0 (behind the camera) holds no point the camera sees: no pixel.
  double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  const glm::dmat4 m(viewProj);
  int behind = 0;
  for (int c = 0; c < 8; ++c) {
    const glm::dvec4 p = m * glm::dvec4((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z, 1.0);
    behind += p.w <= 0.0;
  }
  if (behind == 8) return PixelRect{0, 0, 0, 0};
  for (int c = 0; c < 8; ++c) {
    const glm::dvec4 p = m * glm::dvec4((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z, 1.0);
    if (!(p.w > 1e-9 * (std::abs(p.x) + std::abs(p.y) + std::abs(p.z) + 1.0))) return whole;
    // Framebuffer coordinates (the viewport maps NDC -1..1 onto 0..size; y already points down).
    const double fx = (p.x / p.w * 0.5 + 0.5) * width, fy = (p.y / p.w * 0.5 + 0.5) * height;
    x0 = std::min(x0, fx), x1 = std::max(x1, fx), y0 = std::min(y0, fy), y1 = std::max(y1, fy);
  }
  // A pixel is covered when its centre (x + 0.5) is inside a triangle: pixels floor(x0 - 0.5) ..
  // ceil(x1 - 0.5); two more each side for the rasterizer's fixed-point snapping and our rounding.
  auto lower = [](double v, uint32_t size) {
    return uint32_t(std::clamp(std::floor(v - 0.5) - 2.0, 0.0, double(size)));
  };
  auto upper = [](double v, uint32_t size) {
    return uint32_t(std::clamp(std::ceil(v - 0.5) + 3.0, 0.0, double(size)));
  };
  PixelRect r{lower(x0, width), lower(y0, height), upper(x1, width), upper(y1, height)};
  if (r.x0 >= r.x1 || r.y0 >= r.y1) r = {0, 0, 0, 0};  // off screen: no pixel can hold geometry
  return r;
}

uint32_t maxRasterPixels(const vk::Context& ctx) {
  return uint32_t(std::min<VkDeviceSize>(ctx.maxStorageBufferRange() / sizeof(glm::vec4), UINT32_MAX));
}

glm::mat4 viewProjection(const Camera& camera, float aspect) {
  glm::vec3 forward = camera.target - camera.eye;
  glm::vec3 up = camera.up;
  if (glm::length(glm::cross(forward, up)) < 1e-6f * glm::length(forward))  // looking along up
    up = std::abs(forward.y) > 0.9f * glm::length(forward) ? glm::vec3(0, 0, 1) : glm::vec3(0, 1, 0);
  glm::mat4 view = glm::lookAtRH(camera.eye, camera.target, up);
  glm::mat4 proj = glm::perspectiveRH_ZO(camera.yfov, aspect, camera.znear, camera.zfar);
  proj[1][1] *= -1.0f;  // Vulkan's framebuffer y points down: row 0 is the top of the image
  return proj * view;
}

Raster::Raster(vk::Context& ctx, const Scene& scene) : ctx_(ctx) {
  createPipeline();
  setGeometry(scene);
  timer_ = vk::createTimer(ctx, 8);
}

Raster::~Raster() {
  destroyTargets();
  VkDevice d = ctx_.device;
  if (pipeline_) vkDestroyPipeline(d, pipeline_, nullptr);
  if (layout_) vkDestroyPipelineLayout(d, layout_, nullptr);
  if (renderPass_) vkDestroyRenderPass(d, renderPass_, nullptr);
  if (vert_) vkDestroyShaderModule(d, vert_, nullptr);
  if (frag_) vkDestroyShaderModule(d, frag_, nullptr);
}

double DeviceScene::update(vk::Context& ctx, const Scene& scene, const GeometryRevision& rev) {
  if (revision.known() && rev == revision) return 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  const GeometryCheck c = checkGeometry(scene);
  const bool withNormals = scene.normals.size() == scene.positions.size();
  CS_CHECK(scene.indices.size() <= UINT32_MAX, "scene '" << scene.name << "': more than 2^32 indices");
  constexpr VkBufferUsageFlags vb = VK_BUFFER_USAGE_VERTEX_BUFFER_BIT;
  const uint64_t vbytes = std::max<uint64_t>(scene.positions.size() * sizeof(glm::vec3), 16);
  const uint64_t ibytes = std::max<uint64_t>(scene.indices.size() * sizeof(uint32_t), 16);
  if (!positions || positions.size < vbytes) positions = vk::createBuffer(ctx, vbytes, vk::Memory::Device, vb);
  if (!withNormals) normals.reset();
  if (withNormals && (!normals || normals.size < vbytes)) normals = vk::createBuffer(ctx, vbytes, vk::Memory::Device, vb);
  if (!indices || indices.size < ibytes)
    indices = vk::createBuffer(ctx, ibytes, vk::Memory::Device, VK_BUFFER_USAGE_INDEX_BUFFER_BIT);
  vk::upload(ctx, positions, scene.positions.data(), scene.positions.size() * sizeof(glm::vec3));
  if (withNormals) vk::upload(ctx, normals, scene.normals.data(), scene.normals.size() * sizeof(glm::vec3));
  if (c.droppedTriangles == 0) {
    vk::upload(ctx, indices, scene.indices.data(), scene.indices.size() * sizeof(uint32_t));
  } else {  // the policy: a triangle with a non-finite vertex draws nothing
    std::vector<uint32_t> kept(scene.indices);
    for (size_t t = 0; t < scene.triangleCount(); ++t)
      if (!finiteTriangle(scene, t)) kept[3 * t] = kept[3 * t + 1] = kept[3 * t + 2] = 0;
    vk::upload(ctx, indices, kept.data(), kept.size() * sizeof(uint32_t));
  }
  indexCount = uint32_t(scene.indices.size());
  check = c;
  revision = rev;
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

void Raster::setGeometry(const Scene& scene) {
  CS_CHECK(scene.normals.size() == scene.positions.size(),
           "scene '" << scene.name << "': " << scene.normals.size() << " normals for " << scene.positions.size()
                     << " vertices; the camera pass needs one a vertex");
  scene_.update(ctx_, scene, geometryRevision(scene));
}

uint64_t Raster::bytesAllocated() const { return scene_.bytes() + targetBytes_; }

void Raster::createPipeline() {
  VkDevice d = ctx_.device;
  triangleIds_ = ctx_.geometryShader;
  // Colour attachments: position, normal (+ triangle ID), then the depth buffer.
  const uint32_t colors = triangleIds_ ? 3 : 2;
  VkAttachmentDescription att[4]{};
  VkAttachmentReference colorRefs[3];
  for (uint32_t i = 0; i <= colors; ++i) {
    const bool depth = i == colors;
    att[i].format = depth ? kDepthFormat : i == 2 ? kTriangleFormat : kColorFormat;
    att[i].samples = VK_SAMPLE_COUNT_1_BIT;
    att[i].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    att[i].storeOp = depth ? VK_ATTACHMENT_STORE_OP_DONT_CARE : VK_ATTACHMENT_STORE_OP_STORE;
    att[i].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    att[i].stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    att[i].initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    att[i].finalLayout = depth ? VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL : VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    if (!depth) colorRefs[i] = {i, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  }
  VkAttachmentReference depthRef{colors, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
  VkSubpassDescription sub{};
  sub.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  sub.colorAttachmentCount = colors;
  sub.pColorAttachments = colorRefs;
  sub.pDepthStencilAttachment = &depthRef;
  // Make the colour writes visible to the copy that follows the pass.
  VkSubpassDependency dep{};
  dep.srcSubpass = 0;
  dep.dstSubpass = VK_SUBPASS_EXTERNAL;
  dep.srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  dep.dstStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT;
  dep.srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  dep.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
  VkRenderPassCreateInfo rp{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  rp.attachmentCount = colors + 1;
  rp.pAttachments = att;
  rp.subpassCount = 1;
  rp.pSubpasses = &sub;
  rp.dependencyCount = 1;
  rp.pDependencies = &dep;
  VK_CHECK(vkCreateRenderPass(d, &rp, nullptr, &renderPass_));

  vert_ = vk::createShaderModule(ctx_, spv_gbuffer_vert, sizeof(spv_gbuffer_vert));
  frag_ = triangleIds_ ? vk::createShaderModule(ctx_, spv_gbuffer_id_frag, sizeof(spv_gbuffer_id_frag))
                       : vk::createShaderModule(ctx_, spv_gbuffer_frag, sizeof(spv_gbuffer_frag));

  VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(RasterPush)};
  VkPipelineLayoutCreateInfo li{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  li.pushConstantRangeCount = 1;
  li.pPushConstantRanges = &range;
  VK_CHECK(vkCreatePipelineLayout(d, &li, nullptr, &layout_));

  vk::TrianglePipelineDesc desc;
  desc.vert = vert_;
  desc.frag = frag_;
  desc.layout = layout_;
  desc.renderPass = renderPass_;
  desc.vertexStreams = 2;       // position, normal
  desc.colorAttachments = triangleIds_ ? 3 : 2;  // position, normal + light term (, triangle)
  desc.depthCompare = VK_COMPARE_OP_LESS;
  pipeline_ = vk::createTrianglePipeline(ctx_, desc);
}

void Raster::createTargets(uint32_t width, uint32_t height) {
  destroyTargets();
  VkDevice d = ctx_.device;
  const auto& lim = ctx_.properties.limits;
  if (width > lim.maxFramebufferWidth || height > lim.maxFramebufferHeight || width == 0 || height == 0)
    throw Error("resolution " + std::to_string(width) + "x" + std::to_string(height) + " is not supported",
                ctx_.deviceName(), "the device allows up to " + std::to_string(lim.maxFramebufferWidth) + "x" +
                                       std::to_string(lim.maxFramebufferHeight));
  if (uint64_t(width) * height > maxRasterPixels(ctx_))
    throw Error("resolution " + std::to_string(width) + "x" + std::to_string(height) +
                    " needs G-buffer arrays larger than one storage binding",
                ctx_.deviceName(), "at most " + std::to_string(maxRasterPixels(ctx_)) + " pixels on this device");
  targetBytes_ = 0;
  auto make = [&](VkFormat format, VkImageUsageFlags usage, VkImageAspectFlags aspect) {
    vk::Image t = vk::createImage(ctx_, width, height, format, usage, aspect);
    targetBytes_ += t.bytes;
    return t;
  };
  position_ = make(kColorFormat, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                   VK_IMAGE_ASPECT_COLOR_BIT);
  normal_ = make(kColorFormat, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                 VK_IMAGE_ASPECT_COLOR_BIT);
  if (triangleIds_)
    triangle_ = make(kTriangleFormat, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                     VK_IMAGE_ASPECT_COLOR_BIT);
  depth_ = make(kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, VK_IMAGE_ASPECT_DEPTH_BIT);
  std::vector<VkImageView> views = {position_.view, normal_.view};
  if (triangleIds_) views.push_back(triangle_.view);
  views.push_back(depth_.view);
  VkFramebufferCreateInfo fi{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
  fi.renderPass = renderPass_;
  fi.attachmentCount = uint32_t(views.size());
  fi.pAttachments = views.data();
  fi.width = width;
  fi.height = height;
  fi.layers = 1;
  VK_CHECK(vkCreateFramebuffer(d, &fi, nullptr, &framebuffer_));
  width_ = width;
  height_ = height;
}

void Raster::destroyTargets() {
  VkDevice d = ctx_.device;
  vkDeviceWaitIdle(d);
  if (framebuffer_) vkDestroyFramebuffer(d, framebuffer_, nullptr);
  framebuffer_ = VK_NULL_HANDLE;
  for (vk::Image* t : {&position_, &normal_, &triangle_, &depth_}) t->reset();
  width_ = height_ = 0;
}

bool recordCameraDraw(VkCommandBuffer cb, VkPipeline pipeline, VkPipelineLayout layout, const DeviceScene& scene,
                      const RasterPush& push, uint32_t width, uint32_t height) {
  vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
  VkViewport viewport{0, 0, float(width), float(height), 0.0f, 1.0f};
  VkRect2D scissor{{0, 0}, {width, height}};
  vkCmdSetViewport(cb, 0, 1, &viewport);
  vkCmdSetScissor(cb, 0, 1, &scissor);
  vkCmdPushConstants(cb, layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push), &push);
  if (!scene.indexCount) return false;
  VkBuffer vbs[2] = {scene.positions.buffer, scene.normals.buffer};
  VkDeviceSize offsets[2] = {0, 0};
  vkCmdBindVertexBuffers(cb, 0, 2, vbs, offsets);
  vkCmdBindIndexBuffer(cb, scene.indices.buffer, 0, VK_INDEX_TYPE_UINT32);
  vkCmdDrawIndexed(cb, scene.indexCount, 1, 0, 0, 0);
  return true;
}

RasterTiming Raster::render(const Camera& camera, glm::vec3 light, uint32_t width, uint32_t height,
                            DeviceGBuffer& out, GBuffer* host) {
  if (width != width_ || height != height_) createTargets(width, height);
  VkDeviceSize bytes = VkDeviceSize(width) * height * sizeof(glm::vec4);
  if (out.width != width || out.height != height || !out.position || bool(out.triangle) != triangleIds_) {
    out.position = vk::createBuffer(ctx_, bytes);
    out.normal = vk::createBuffer(ctx_, bytes);
    out.triangle = triangleIds_ ? vk::createBuffer(ctx_, VkDeviceSize(width) * height * 4) : vk::Buffer{};
    out.width = width;
    out.height = height;
  }

  RasterPush push{};
  push.viewProj = viewProjection(camera, float(width) / float(height));
  out.geometryRect = geometryRectOf(push.viewProj, scene_.check.lo, scene_.check.hi, width, height);
  push.eye = glm::vec4(camera.eye, 1.0f);
  push.light = glm::vec4(light, 1.0f);

  timer_.restart();
  vk::Commands cmd(ctx_, &timer_);
  VkCommandBuffer cb = cmd.handle();
  cmd.mark("start");
  VkClearValue clears[4]{};
  const uint32_t colors = triangleIds_ ? 3 : 2;
  if (triangleIds_) clears[2].color.uint32[0] = CS_NO_TRIANGLE;
  clears[colors].depthStencil = {1.0f, 0};
  VkRenderPassBeginInfo bi{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  bi.renderPass = renderPass_;
  bi.framebuffer = framebuffer_;
  bi.renderArea = {{0, 0}, {width, height}};
  bi.clearValueCount = colors + 1;
  bi.pClearValues = clears;
  vkCmdBeginRenderPass(cb, &bi, VK_SUBPASS_CONTENTS_INLINE);
  if (recordCameraDraw(cb, pipeline_, layout_, scene_, push, width, height)) ctx_.cost.dispatches++;
  vkCmdEndRenderPass(cb);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {width, height, 1};
  vkCmdCopyImageToBuffer(cb, position_.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, out.position.buffer, 1, &region);
  vkCmdCopyImageToBuffer(cb, normal_.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, out.normal.buffer, 1, &region);
  if (triangleIds_)
    vkCmdCopyImageToBuffer(cb, triangle_.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, out.triangle.buffer, 1, &region);
  cmd.barrier();  // the buffers are read by compute (and the host) afterwards
  cmd.mark("raster");
  cmd.submit();

  RasterTiming timing;
  for (auto& [name, ms] : timer_.intervals()) timing.gpuMs += ms;
  if (host) {
    auto t0 = std::chrono::steady_clock::now();
    host->width = width;
    host->height = height;
    host->position.resize(size_t(width) * height);
    host->normal.resize(size_t(width) * height);
    vk::download(ctx_, out.position, host->position.data(), bytes);
    vk::download(ctx_, out.normal, host->normal.data(), bytes);
    timing.readbackMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  return timing;
}

}  // namespace cs
