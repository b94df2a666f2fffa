// The cube shadow map as a ShadowMethod: see cube_sm.h.
#include "shadowmaps/cube_sm.h"

#include <array>
#include <chrono>

#include "core/error.h"
#include "raster/raster.h"
#include "reference/epsilon.h"
#include "shadowmaps/cube_lookup.comp.h"
#include "shadowmaps/depth_pass.h"
#include "shadowmaps/sm_shared.h"
#include "vk/context.h"

namespace cs {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

class CubeShadowMap : public ShadowMethod {
 public:
  CubeShadowMap(vk::Context& ctx, const CubeSmOptions& options)
      : ctx_(ctx), options_(options), pass_(ctx, options.cull), timer_(vk::createTimer(ctx, 16)) {
    const uint32_t r = options.resolution;
    if (r < 16)
      throw Error("cube shadow map resolution " + std::to_string(r) + " is too small", "--sm-resolution",
                  "use at least 16 texels a side");
    const uint64_t faceBytes = uint64_t(r) * r * 4;
    if (faceBytes > ctx.maxStorageBufferRange())
      throw Error("a cube face of " + std::to_string(r) + "² texels (" + std::to_string(faceBytes >> 20) +
                      " MiB) exceeds one storage binding of this device (" +
                      std::to_string(ctx.maxStorageBufferRange() >> 20) + " MiB)",
                  "--sm-resolution", "lower the resolution");
    CS_CHECK(options.constantBias >= 0 && options.slopeBias >= 0 && options.maxSlope >= 0,
             "cube shadow map biases must be >= 0");
    lookup_ = vk::createKernel(ctx, "cube_lookup", spv_cube_lookup_comp, 9, sizeof(sm::CubeLookupPush));
  }

  std::string name() const override { return "cubesm"; }

  MethodOutput run(const FrameInput& frame) override {
    CS_CHECK(frame.scene && frame.device, "cubesm: the frame needs a scene and the G-buffer on the GPU");
    CS_CHECK(frame.vk == nullptr || frame.vk == &ctx_, "cubesm: the frame's Vulkan context is not this method's");
    const DeviceGBuffer& g = *frame.device;
    const uint32_t pixels = g.width * g.height;
    const float eps = frame.epsilon > 0 ? frame.epsilon : EpsilonPolicy::forScene(*frame.scene).eps;
    const uint32_t r = options_.resolution;
    MethodOutput out;
    auto t0 = Clock::now();

    const double uploadMs = pass_.setGeometry(*frame.scene);
    pass_.takeTrianglesDrawn();
    pass_.ensureTargets(r, r);
    const uint64_t faceBytes = uint64_t(r) * r * 4;
    for (auto& f : faces_)
      if (f.size < faceBytes) f = vk::createBuffer(ctx_, faceBytes);
    if (visibility_.size < uint64_t(pixels) * 4) {
      visibility_.reset();
      visibility_ = vk::createBuffer(ctx_, uint64_t(pixels) * 4);
    }

    timer_.restart();
    {
      vk::Commands cmd(ctx_, &timer_);
      cmd.mark("start");
      VkBufferImageCopy region{};
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
      region.imageExtent = {r, r, 1};
      for (uint32_t f = 0; f < 6; ++f) {
        pass_.recordWindow(cmd, f, r, 0, 0, r, r, frame.light, eps);
        pass_.recordCopy(cmd, {region}, faces_[f]);
      }
      cmd.barrier();
      cmd.mark("faces");
      sm::CubeLookupPush push{};
      push.light = glm::vec4(frame.light, 1.0f);
      push.width = g.width;
      push.height = g.height;
      push.resolution = r;
      push.pcf = options_.pcf ? 1u : 0u;
      push.constantBias = options_.constantBias * eps;
      push.slopeBias = options_.slopeBias;
      push.maxSlope = options_.maxSlope;
      push.minDistance = 2.0f * eps;
      push.planeBias = options_.planeBias ? 1u : 0u;
      vk::Grid grid = vk::gridFor(pixels, SM_PIXEL_THREADS, ctx_.maxWorkgroups());
      cmd.dispatch(lookup_,
                   {g.position, g.normal, faces_[0], faces_[1], faces_[2], faces_[3], faces_[4], faces_[5],
                    visibility_},
                   push, grid.x, grid.y);
      cmd.barrier();
      cmd.mark("lookup");
      cmd.submit();
    }
    if (uploadMs > 0) out.stages.push_back({"upload", uploadMs});
    for (auto& [n, ms] : timer_.intervals()) out.stages.push_back({n, ms});
    out.totalMs = msSince(t0);

    auto t1 = Clock::now();
    out.visibility.resize(pixels);
    if (pixels) vk::download(ctx_, visibility_, out.visibility.data(), uint64_t(pixels) * 4);
    double gpuMs = 0;
    for (auto& s : out.stages) gpuMs += s.ms;
    out.bytesAllocated = pass_.bytesAllocated() + 6 * faceBytes + visibility_.size;
    out.peakBytes = out.bytesAllocated;
    out.stats = {{"resolution", r},
                 {"face_bytes", 6 * faceBytes},
                 {"target_bytes", pass_.targetBytes()},
                 {"geometry_passes", 6},
                 {"triangles", pass_.triangleCount()},
                 {"triangles_drawn", pass_.takeTrianglesDrawn()},
                 {"pcf", options_.pcf},
                 {"constant_bias", options_.constantBias * eps},
                 {"constant_bias_eps", options_.constantBias},
                 {"slope_bias_texels", options_.slopeBias},
                 {"max_slope", options_.maxSlope},
                 {"plane_bias", options_.planeBias},
                 {"epsilon", eps},
                 {"gpu_ms", gpuMs},
                 {"readback_ms", msSince(t1)}};
    return out;
  }

 private:
  vk::Context& ctx_;
  CubeSmOptions options_;
  sm::DepthPass pass_;
  vk::Timer timer_;
  vk::Kernel lookup_;
  std::array<vk::Buffer, 6> faces_;
  vk::Buffer visibility_;
};

}  // namespace

std::unique_ptr<ShadowMethod> makeCubeShadowMap(vk::Context& ctx, const CubeSmOptions& options) {
  return std::make_unique<CubeShadowMap>(ctx, options);
}

}  // namespace cs
