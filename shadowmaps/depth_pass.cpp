// The light's geometry pass: see depth_pass.h.
#include "shadowmaps/depth_pass.h"

#include <chrono>
#include <cmath>

#include "shadowmaps/depth.frag.h"
#include "shadowmaps/depth.vert.h"
#include "shadowmaps/depth_id.frag.h"
#include "shadowmaps/depth_id.vert.h"
#include "shadowmaps/depth_warp.frag.h"
#include "shadowmaps/depth_warp.geom.h"
#include "shadowmaps/depth_warp.vert.h"
#include "shadowmaps/rtw_shared.h"
#include "shadowmaps/sm_shared.h"

namespace cs::sm {

namespace {
constexpr VkFormat kColorFormat = VK_FORMAT_R32_SFLOAT;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr VkFormat kIdFormat = VK_FORMAT_R32_UINT;

}  // namespace

glm::mat4 windowClip(uint32_t face, double res, double x0, double y0, double w, double h, float nearPlane) {
  const uint32_t axis = face >> 1;
  const double sgn = (face & 1) ? -1.0 : 1.0;
  // Rows of face space: x_f = d[axis+1], y_f = d[axis+2], z_f = sgn * d[axis] (sm_shared.h).
  glm::dvec3 rx(0), ry(0), rz(0);
  rx[(axis + 1) % 3] = 1;
  ry[(axis + 2) % 3] = 1;
  rz[axis] = sgn;
  // Column x0 + i of the face (s·res = x0 + i) goes to NDC 2i/w - 1: x' = (res/w)·x_f + ((res - 2x0)/w - 1)·z_f.
  const double ax = res / w, bx = (res - 2 * x0) / w - 1;
  const double ay = res / h, by = (res - 2 * y0) / h - 1;
  glm::dvec4 row0(ax * rx + bx * rz, 0), row1(ay * ry + by * rz, 0), row2(0, 0, 0, nearPlane), row3(rz, 0);
  glm::dmat4 m = glm::transpose(glm::dmat4(row0, row1, row2, row3));
  return glm::mat4(m);
}

DepthPass::DepthPass(vk::Context& ctx, bool culling, bool triangleIds)
    : ctx_(ctx), culling_(culling), triangleIds_(triangleIds) {
  if (triangleIds_ && !ctx_.geometryShader)
    throw Error("triangle IDs in the light's depth pass (ASM's ID + depth test) need the geometryShader feature, "
                "which this device lacks",
                ctx_.deviceName(), "run without --asm-id-test on this device");
  createPipeline();
}

DepthPass::~DepthPass() {
  destroyTargets();
  VkDevice d = ctx_.device;
  if (warpedPipeline_) vkDestroyPipeline(d, warpedPipeline_, nullptr);
  if (warpedLayout_) vkDestroyPipelineLayout(d, warpedLayout_, nullptr);
  if (warpedSet_) vkDestroyDescriptorSetLayout(d, warpedSet_, nullptr);
  if (warpedVert_) vkDestroyShaderModule(d, warpedVert_, nullptr);
  if (warpedGeom_) vkDestroyShaderModule(d, warpedGeom_, nullptr);
  if (warpedFrag_) vkDestroyShaderModule(d, warpedFrag_, nullptr);
  if (pipeline_) vkDestroyPipeline(d, pipeline_, nullptr);
  if (layout_) vkDestroyPipelineLayout(d, layout_, nullptr);
  if (renderPass_) vkDestroyRenderPass(d, renderPass_, nullptr);
  if (vert_) vkDestroyShaderModule(d, vert_, nullptr);
  if (frag_) vkDestroyShaderModule(d, frag_, nullptr);
}

double DepthPass::setGeometry(const FrameInput& frame) {
  CS_CHECK(frame.scene, "depth pass: the frame has no scene");
  if (frame.deviceScene) return setGeometry(*frame.scene, frame.deviceScene);
  const auto t0 = std::chrono::steady_clock::now();
  own_.update(ctx_, *frame.scene, revisionOf(frame));
  if (setGeometry(*frame.scene, &own_) == 0.0) return 0.0;
  return std::max(1e-6, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
}

double DepthPass::setGeometry(const Scene& scene, const DeviceScene* shared) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!shared) {
    own_.update(ctx_, scene, geometryRevision(scene));
    shared = &own_;
  } else if (shared != &own_ && own_.revision.known()) {
    own_ = DeviceScene{};  // the camera pass's copy serves: no second one on the device
  }
  CS_CHECK(shared->revision.known(), "depth pass: the shared geometry was never uploaded");
  draw_ = shared;
  if (revision_ == shared->revision) return 0.0;
  indexCount_ = shared->indexCount;
  boundsLo_ = shared->check.lo, boundsHi_ = shared->check.hi;
  clusters_.clear();
  for (uint32_t first = 0; first < indexCount_; first += 3 * kClusterTriangles) {
    Cluster c;
    c.firstIndex = first;
    c.indexCount = std::min(indexCount_ - first, 3 * kClusterTriangles);
    glm::vec3 lo(INFINITY), hi(-INFINITY);
    for (uint32_t i = first; i < first + c.indexCount; ++i) {
      if (!finiteTriangle(scene, i / 3)) continue;  // drawn as (0, 0, 0): nothing (checkGeometry's policy)
      lo = glm::min(lo, scene.positions[scene.indices[i]]);
      hi = glm::max(hi, scene.positions[scene.indices[i]]);
    }
    if (!(lo.x <= hi.x)) continue;  // no finite triangle: nothing to draw
    c.center = 0.5f * (lo + hi);
    for (uint32_t i = first; i < first + c.indexCount; ++i)
      if (finiteTriangle(scene, i / 3))
        c.radius = std::max(c.radius, glm::length(scene.positions[scene.indices[i]] - c.center));
    c.radius = c.radius * 1.0001f + 1e-6f * glm::length(c.center);  // rounding of the sums above
    clusters_.push_back(c);
  }
  revision_ = shared->revision;
  // A change never reads as "unchanged" (0), however fast the clusters were.
  return std::max(1e-6, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
}

void DepthPass::createPipeline() {
  VkDevice d = ctx_.device;
  // Attachments: the distance (, the triangle ID), then the depth buffer.
  const uint32_t colors = triangleIds_ ? 2 : 1;
  VkAttachmentDescription att[3]{};
  att[0].format = kColorFormat;
  att[0].samples = VK_SAMPLE_COUNT_1_BIT;
  att[0].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  att[0].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  att[0].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  att[0].stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  att[0].initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  att[0].finalLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  if (triangleIds_) {
    att[1] = att[0];
    att[1].format = kIdFormat;
  }
  att[colors] = att[0];
  att[colors].format = kDepthFormat;
  att[colors].storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  att[colors].finalLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
  VkAttachmentReference colorRefs[2] = {{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL},
                                        {1, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL}};
  VkAttachmentReference depthRef{colors, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
  VkSubpassDescription sub{};
  sub.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  sub.colorAttachmentCount = colors;
  sub.pColorAttachments = colorRefs;
  sub.pDepthStencilAttachment = &depthRef;
  // Passes follow each other on one target: the previous pass's copy (transfer read) and depth writes
  // must finish before this pass clears; this pass's colour must be written before the copy reads it.
  VkSubpassDependency deps[2]{};
  deps[0].srcSubpass = VK_SUBPASS_EXTERNAL;
  deps[0].dstSubpass = 0;
  deps[0].srcStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
  deps[0].dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT |
                         VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
  deps[0].srcAccessMask = VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  deps[0].dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
                          VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  deps[1].srcSubpass = 0;
  deps[1].dstSubpass = VK_SUBPASS_EXTERNAL;
  deps[1].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  deps[1].dstStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT;
  deps[1].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  deps[1].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
  VkRenderPassCreateInfo rp{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  rp.attachmentCount = colors + 1;
  rp.pAttachments = att;
  rp.subpassCount = 1;
  rp.pSubpasses = &sub;
  rp.dependencyCount = 2;
  rp.pDependencies = deps;
  VK_CHECK(vkCreateRenderPass(d, &rp, nullptr, &renderPass_));

  vert_ = triangleIds_ ? vk::createShaderModule(ctx_, spv_depth_id_vert, sizeof(spv_depth_id_vert))
                       : vk::createShaderModule(ctx_, spv_depth_vert, sizeof(spv_depth_vert));
  frag_ = triangleIds_ ? vk::createShaderModule(ctx_, spv_depth_id_frag, sizeof(spv_depth_id_frag))
                       : vk::createShaderModule(ctx_, spv_depth_frag, sizeof(spv_depth_frag));

  VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(DepthPush)};
  VkPipelineLayoutCreateInfo li{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  li.pushConstantRangeCount = 1;
  li.pPushConstantRanges = &range;
  VK_CHECK(vkCreatePipelineLayout(d, &li, nullptr, &layout_));

  vk::TrianglePipelineDesc desc;  // no culling: every triangle casts, whichever side faces the light
  desc.vert = vert_;
  desc.frag = frag_;
  desc.layout = layout_;
  desc.renderPass = renderPass_;
  desc.vertexStreams = 1;
  desc.colorAttachments = colors;
  desc.colorWriteMask = VK_COLOR_COMPONENT_R_BIT;
  desc.depthCompare = VK_COMPARE_OP_GREATER;  // reversed Z: depth = near / z_f, larger is nearer
  pipeline_ = vk::createTrianglePipeline(ctx_, desc);
}

void DepthPass::ensureTargets(uint32_t largest, uint32_t smallest) {
  std::vector<uint32_t> sizes;
  for (uint32_t size = largest; sizes.empty() || (size >= smallest && size < sizes.back()); size = (size - 1) / 2 + 1)
    sizes.insert(sizes.begin(), size);
  bool same = sizes.size() == targets_.size();
  for (size_t i = 0; same && i < sizes.size(); ++i) same = targets_[i].size == sizes[i];
  if (same) return;
  const auto& lim = ctx_.properties.limits;
  if (largest > lim.maxFramebufferWidth || largest > lim.maxFramebufferHeight || largest > lim.maxImageDimension2D)
    throw Error("shadow-map target of " + std::to_string(largest) + "² texels is not supported", ctx_.deviceName(),
                "the device allows up to " + std::to_string(std::min(lim.maxFramebufferWidth, lim.maxImageDimension2D)) +
                    " a side: lower --sm-resolution or the superpage size");
  destroyTargets();
  VkDevice d = ctx_.device;
  auto make = [&](vk::Image& t, uint32_t size, VkFormat format, VkImageUsageFlags usage, VkImageAspectFlags aspect) {
    t = vk::createImage(ctx_, size, size, format, usage, aspect, "lower --sm-resolution or the superpage size");
    targetBytes_ += t.bytes;
  };
  for (uint32_t size : sizes) {
    targets_.emplace_back();
    Target& t = targets_.back();
    t.size = size;
    make(t.color, size, kColorFormat, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
         VK_IMAGE_ASPECT_COLOR_BIT);
    if (triangleIds_)
      make(t.ids, size, kIdFormat, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
           VK_IMAGE_ASPECT_COLOR_BIT);
    make(t.depth, size, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, VK_IMAGE_ASPECT_DEPTH_BIT);
    VkImageView views[3] = {t.color.view, t.ids.view, t.depth.view};
    if (!triangleIds_) views[1] = t.depth.view;
    VkFramebufferCreateInfo fi{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
    fi.renderPass = renderPass_;
    fi.attachmentCount = triangleIds_ ? 3 : 2;
    fi.pAttachments = views;
    fi.width = size;
    fi.height = size;
    fi.layers = 1;
    VK_CHECK(vkCreateFramebuffer(d, &fi, nullptr, &t.framebuffer));
  }
}

void DepthPass::destroyTargets() {
  if (targets_.empty()) return;
  VkDevice d = ctx_.device;
  vkDeviceWaitIdle(d);
  for (Target& t : targets_) {
    if (t.framebuffer) vkDestroyFramebuffer(d, t.framebuffer, nullptr);
    t.color.reset();
    t.ids.reset();
    t.depth.reset();
  }
  targets_.clear();
  current_ = 0;
  targetBytes_ = 0;
}

VkCommandBuffer DepthPass::beginPass(vk::Commands& cmd, uint32_t w, uint32_t h) {
  CS_CHECK(w > 0 && h > 0 && w <= largestTarget() && h <= largestTarget(),
           "depth pass window " << w << "x" << h << " does not fit the largest target of " << largestTarget());
  current_ = 0;
  while (targets_[current_].size < std::max(w, h)) ++current_;
  VkCommandBuffer cb = cmd.handle();
  VkClearValue clears[3]{};
  const uint32_t colors = triangleIds_ ? 2 : 1;
  clears[0].color.float32[0] = SM_EMPTY_DEPTH;
  if (triangleIds_) clears[1].color.uint32[0] = CS_NO_TRIANGLE;
  clears[colors].depthStencil = {0.0f, 0};  // reversed Z: 0 is infinitely far
  VkRenderPassBeginInfo bi{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  bi.renderPass = renderPass_;
  bi.framebuffer = targets_[current_].framebuffer;
  bi.renderArea = {{0, 0}, {w, h}};
  bi.clearValueCount = colors + 1;
  bi.pClearValues = clears;
  vkCmdBeginRenderPass(cb, &bi, VK_SUBPASS_CONTENTS_INLINE);
  VkViewport viewport{0, 0, float(w), float(h), 0.0f, 1.0f};
  VkRect2D scissor{{0, 0}, {w, h}};
  vkCmdSetViewport(cb, 0, 1, &viewport);
  vkCmdSetScissor(cb, 0, 1, &scissor);
  return cb;
}

void DepthPass::drawClusters(VkCommandBuffer cb, uint32_t face, double u0, double u1, double v0, double v1,
                             glm::vec3 light, float nearPlane) {
  VkDeviceSize offset = 0;
  vkCmdBindVertexBuffers(cb, 0, 1, &draw_->positions.buffer, &offset);
  vkCmdBindIndexBuffer(cb, draw_->indices.buffer, 0, VK_INDEX_TYPE_UINT32);
  if (!culling_) {
    vkCmdDrawIndexed(cb, indexCount_, 1, 0, 0, 0);  // firstInstance: the first triangle (depth_id.vert)
    ctx_.cost.dispatches++;
    drawn_ += indexCount_ / 3;
    return;
  }
  // The frustum in face space: u in [u0, u1], v in [v0, v1] (u = x_f / z_f), z_f >= near.
  const double nu0 = std::sqrt(1 + u0 * u0), nu1 = std::sqrt(1 + u1 * u1);
  const double nv0 = std::sqrt(1 + v0 * v0), nv1 = std::sqrt(1 + v1 * v1);
  uint32_t runFirst = 0, runCount = 0;
  auto flush = [&] {
    if (runCount) vkCmdDrawIndexed(cb, runCount, 1, runFirst, 0, runFirst / 3), ctx_.cost.dispatches++;
    drawn_ += runCount / 3;
    runCount = 0;
  };
  for (const Cluster& c : clusters_) {
    const glm::dvec3 f(faceSpace(face, c.center - light));
    const double r = c.radius;
    const bool outside = f.z + r < nearPlane || (f.x - u0 * f.z) / nu0 < -r || (u1 * f.z - f.x) / nu1 < -r ||
                         (f.y - v0 * f.z) / nv0 < -r || (v1 * f.z - f.y) / nv1 < -r;
    if (outside) {
      flush();
      continue;
    }
    if (runCount == 0) runFirst = c.firstIndex;
    runCount += c.indexCount;
  }
  flush();
}

void DepthPass::recordWindow(vk::Commands& cmd, uint32_t face, double res, uint32_t x0, uint32_t y0, uint32_t w,
                             uint32_t h, glm::vec3 light, float nearPlane) {
  VkCommandBuffer cb = beginPass(cmd, w, h);
  if (indexCount_) {
    DepthPush push{};
    push.clip = windowClip(face, res, x0, y0, w, h, nearPlane);
    push.light = glm::vec4(light, 1.0f);
    vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_);
    vkCmdPushConstants(cb, layout_, VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(push), &push);
    const double u0 = 2.0 * x0 / res - 1, u1 = 2.0 * (double(x0) + w) / res - 1;
    const double v0 = 2.0 * y0 / res - 1, v1 = 2.0 * (double(y0) + h) / res - 1;
    drawClusters(cb, face, u0, u1, v0, v1, light, nearPlane);
  }
  vkCmdEndRenderPass(cb);
}

// The warped pass's clip margin past the face's edges (face coordinates): the lookup's last texels read
// geometry just beyond the edge, and the margin keeps every vertex within the warp's end cells.
constexpr float kWarpMargin = 0.01f;
constexpr VkShaderStageFlags kWarpedStages =
    VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_GEOMETRY_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;

void DepthPass::createWarpedPipeline() {
  if (!ctx_.geometryShader)
    throw Error("the RTW shadow map needs the geometryShader feature, which this device lacks", ctx_.deviceName(),
                "use another shadow method (cubesm, rmsm) on this device");
  const auto& lim = ctx_.properties.limits;
  if (lim.maxGeometryOutputVertices < RTW_GS_MAX_VERTICES ||
      lim.maxGeometryTotalOutputComponents < RTW_GS_MAX_VERTICES * RTW_GS_COMPONENTS)
    throw Error("the RTW geometry stage emits up to " + std::to_string(RTW_GS_MAX_VERTICES) +
                    " vertices of " + std::to_string(RTW_GS_COMPONENTS) + " components; this device allows " + std::to_string(lim.maxGeometryOutputVertices) +
                    " vertices and " + std::to_string(lim.maxGeometryTotalOutputComponents) + " components",
                ctx_.deviceName(), "use another shadow method (cubesm, rmsm) on this device");
  VkDevice d = ctx_.device;
  warpedVert_ = vk::createShaderModule(ctx_, spv_depth_warp_vert, sizeof(spv_depth_warp_vert));
  warpedGeom_ = vk::createShaderModule(ctx_, spv_depth_warp_geom, sizeof(spv_depth_warp_geom));
  warpedFrag_ = vk::createShaderModule(ctx_, spv_depth_warp_frag, sizeof(spv_depth_warp_frag));
  VkDescriptorSetLayoutBinding binding{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1,
                                      VK_SHADER_STAGE_GEOMETRY_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
  VkDescriptorSetLayoutCreateInfo si{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  si.flags = VK_DESCRIPTOR_SET_LAYOUT_CREATE_PUSH_DESCRIPTOR_BIT_KHR;
  si.bindingCount = 1;
  si.pBindings = &binding;
  VK_CHECK(vkCreateDescriptorSetLayout(d, &si, nullptr, &warpedSet_));
  VkPushConstantRange range{kWarpedStages, 0, sizeof(RtwDepthPush)};
  VkPipelineLayoutCreateInfo li{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  li.setLayoutCount = 1;
  li.pSetLayouts = &warpedSet_;
  li.pushConstantRangeCount = 1;
  li.pPushConstantRanges = &range;
  VK_CHECK(vkCreatePipelineLayout(d, &li, nullptr, &warpedLayout_));
  vk::TrianglePipelineDesc desc;
  desc.vert = warpedVert_;
  desc.geom = warpedGeom_;
  desc.frag = warpedFrag_;
  desc.layout = warpedLayout_;
  desc.renderPass = renderPass_;
  desc.vertexStreams = 1;
  desc.colorAttachments = 1;
  desc.colorWriteMask = VK_COLOR_COMPONENT_R_BIT;
  desc.depthCompare = VK_COMPARE_OP_GREATER;
  warpedPipeline_ = vk::createTrianglePipeline(ctx_, desc);
}

void DepthPass::recordWarped(vk::Commands& cmd, uint32_t face, uint32_t resolution, const vk::Buffer& warp,
                             uint32_t cells, glm::vec3 light, float nearPlane, float tessTexels) {
  CS_CHECK(!triangleIds_, "the warped depth pass writes no triangle IDs: make its DepthPass without them");
  if (!warpedPipeline_) createWarpedPipeline();
  VkCommandBuffer cb = beginPass(cmd, resolution, resolution);
  if (indexCount_) {
    RtwDepthPush push{};
    push.light = glm::vec4(light, 1.0f);
    push.face = face;
    push.cells = cells;
    push.resolution = resolution;
    push.tessellate = tessTexels > 0 ? 1u : 0u;
    push.tessTexels = tessTexels;
    push.nearPlane = nearPlane;
    push.margin = kWarpMargin;
    vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_GRAPHICS, warpedPipeline_);
    vkCmdPushConstants(cb, warpedLayout_, kWarpedStages, 0, sizeof(push), &push);
    VkDescriptorBufferInfo info{warp.buffer, 0, VK_WHOLE_SIZE};
    VkWriteDescriptorSet write{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    write.dstBinding = 0;
    write.descriptorCount = 1;
    write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    write.pBufferInfo = &info;
    ctx_.cmdPushDescriptorSet(cb, VK_PIPELINE_BIND_POINT_GRAPHICS, warpedLayout_, 0, 1, &write);
    const double m = 1.0 + kWarpMargin;
    drawClusters(cb, face, -m, m, -m, m, light, nearPlane);
  }
  vkCmdEndRenderPass(cb);
}

void DepthPass::recordCopy(vk::Commands& cmd, const std::vector<VkBufferImageCopy>& regions, const vk::Buffer& dst) {
  if (regions.empty()) return;
  vkCmdCopyImageToBuffer(cmd.handle(), targets_[current_].color.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, dst.buffer,
                         uint32_t(regions.size()), regions.data());
}

void DepthPass::recordCopyIds(vk::Commands& cmd, const std::vector<VkBufferImageCopy>& regions, const vk::Buffer& dst) {
  CS_CHECK(triangleIds_, "recordCopyIds: this depth pass writes no triangle IDs");
  if (regions.empty()) return;
  vkCmdCopyImageToBuffer(cmd.handle(), targets_[current_].ids.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, dst.buffer,
                         uint32_t(regions.size()), regions.data());
}

// Fitted faces (RMSM, ASM): per face (s0, t0, zoom, 0), the window of the face the quadtree covers --
// the square of side 1 / zoom holding what the scene's bounding box [lo, hi] projects to; zoom a power of
// two, s0 and t0 multiples of 1 / (page * zoom) so that every level's window starts on a whole texel. The
// whole face (0, 0, 1, 0) when the box reaches the face's apex plane (a light inside or beside it). zoom *
// maxRes stays <= 2^22: (s, t) are fp32 (2^-24 of 1), a quarter texel at the finest level.
std::array<glm::vec4, 6> fitWindows(glm::vec3 light, glm::vec3 lo, glm::vec3 hi, uint32_t page, uint32_t maxRes) {
  std::array<glm::vec4, 6> w;
  w.fill(glm::vec4(0, 0, 1, 0));
  if (!(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z)) return w;
  const double maxZoom = std::max(1.0, std::ldexp(1.0, 22) / double(maxRes));
  for (uint32_t face = 0; face < 6; ++face) {
    double s0 = INFINITY, s1 = -INFINITY, t0 = INFINITY, t1 = -INFINITY;
    bool whole = false;
    for (int k = 0; k < 8 && !whole; ++k) {
      const glm::dvec3 d = glm::dvec3((k & 1) ? hi.x : lo.x, (k & 2) ? hi.y : lo.y, (k & 4) ? hi.z : lo.z) -
                           glm::dvec3(light);
      const uint32_t axis = face >> 1;
      glm::dvec3 f = axis == 0 ? glm::dvec3(d.y, d.z, d.x) : (axis == 1 ? glm::dvec3(d.z, d.x, d.y) : d);
      if (face & 1) f.z = -f.z;
      if (!(f.z > 1e-6 * (std::abs(f.x) + std::abs(f.y)))) whole = true;
      const double s = 0.5 + 0.5 * f.x / f.z, t = 0.5 + 0.5 * f.y / f.z;
      s0 = std::min(s0, s), s1 = std::max(s1, s), t0 = std::min(t0, t), t1 = std::max(t1, t);
    }
    if (whole) continue;
    s0 = std::max(s0, 0.0), t0 = std::max(t0, 0.0), s1 = std::min(s1, 1.0), t1 = std::min(t1, 1.0);
    if (!(s0 < s1 && t0 < t1)) continue;
    const double span = std::max(s1 - s0, t1 - t0);
    double zoom = 1;
    while (zoom * 2 <= maxZoom && span * zoom * 2 * (1.0 + 2.0 / page) <= 1.0) zoom *= 2;
    if (zoom == 1) continue;
    const double grid = double(page) * zoom;
    w[face] = glm::vec4(float(std::floor(s0 * grid) / grid), float(std::floor(t0 * grid) / grid), float(zoom), 0.0f);
  }
  return w;
}

}  // namespace cs::sm
