// The cube shadow map as a ShadowMethod: see cube_sm.h.
#include "shadowmaps/cube_sm.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <chrono>

#include "core/error.h"
#include "raster/raster.h"
#include "method/epsilon.h"
#include "shadowmaps/cube_lookup.comp.h"
#include "shadowmaps/depth_pass.h"
#include "shadowmaps/sm_shared.h"
#include "vk/context.h"

namespace cs {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// The window of face `face` that the scene's bounding box [lo, hi] can cover, seen from `light`: a square
// of r x r texels at an effective resolution res >= r for the whole face, starting at texel (x0, y0)
// (depth_pass.h recordWindow's terms). Every sample lies in the box, so every sample that picks this
// face projects into the window, and so does every caster between it and the light. The full face when
// the box reaches the face's apex plane (a light inside or beside the box: the standard cube map).
// The zoom res / r is capped at kMaxFaceZoom: face coordinates are fp32 (relative error 2^-24 of
// |u| <= 1), so texel coordinates st·res keep <= 0.12 texel of rounding at r = 2048 (2^-24·2^21); a far
// light whose scene spans less than 2/kMaxFaceZoom of a face is resolution-limited from there on.
constexpr double kMaxFaceZoom = 1024.0;

struct FaceWindow {
  double res = 0;
  uint32_t x0 = 0, y0 = 0;
};

FaceWindow fitFace(uint32_t face, glm::vec3 light, glm::vec3 lo, glm::vec3 hi, uint32_t r) {
  FaceWindow full{double(r), 0, 0};
  double u0 = INFINITY, u1 = -INFINITY, v0 = INFINITY, v1 = -INFINITY;
  for (int k = 0; k < 8; ++k) {
    const glm::dvec3 corner((k & 1) ? hi.x : lo.x, (k & 2) ? hi.y : lo.y, (k & 4) ? hi.z : lo.z);
    const glm::dvec3 d = corner - glm::dvec3(light);
    const uint32_t axis = face >> 1;
    glm::dvec3 f = axis == 0 ? glm::dvec3(d.y, d.z, d.x) : (axis == 1 ? glm::dvec3(d.z, d.x, d.y) : d);
    if (face & 1) f.z = -f.z;
    // The box reaches the apex plane (within a relative hair): its projection is unbounded.
    if (!(f.z > 1e-6 * (std::abs(f.x) + std::abs(f.y)))) return full;
    u0 = std::min(u0, f.x / f.z), u1 = std::max(u1, f.x / f.z);
    v0 = std::min(v0, f.y / f.z), v1 = std::max(v1, f.y / f.z);
  }
  u0 = std::max(u0, -1.0), v0 = std::max(v0, -1.0), u1 = std::min(u1, 1.0), v1 = std::min(v1, 1.0);
  if (!(u0 < u1 && v0 < v1)) return full;  // the box is not seen through this face: nothing to fit
  const double span = std::max({u1 - u0, v1 - v0, 2.0 / kMaxFaceZoom});
  // r texels hold the span with a texel to spare on each side (x0 is rounded down).
  const double res = std::floor(2.0 * (double(r) - 2.0) / span);
  if (!(res > double(r))) return full;
  FaceWindow w;
  w.res = res;
  w.x0 = uint32_t(std::floor(0.5 * (u0 + 1.0) * res));
  w.y0 = uint32_t(std::floor(0.5 * (v0 + 1.0) * res));
  return w;
}

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
    lookup_ = vk::createKernel(ctx, "cube_lookup", spv_cube_lookup_comp, 10, sizeof(sm::CubeLookupPush));
    windows_ = vk::createBuffer(ctx, 6 * sizeof(glm::vec4), vk::Memory::HostVisible);
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

    const double uploadMs = pass_.setGeometry(frame);
    pass_.takeTrianglesDrawn();
    pass_.ensureTargets(r, r);
    const uint64_t faceBytes = uint64_t(r) * r * 4;
    for (auto& f : faces_)
      if (f.size < faceBytes) f = vk::createBuffer(ctx_, faceBytes);
    if (visibility_.size < uint64_t(pixels) * 4) {
      visibility_.reset();
      visibility_ = vk::createBuffer(ctx_, uint64_t(pixels) * 4);
    }

    // Each face fitted to what it can see of the scene (fitFace): its effective resolution and window.
    std::array<FaceWindow, 6> windows;
    std::array<glm::vec4, 6> windowData;
    const glm::vec3 lo = pass_.boundsLo(), hi = pass_.boundsHi();
    for (uint32_t f = 0; f < 6; ++f) {
      windows[f] = options_.fitFaces && lo.x <= hi.x ? fitFace(f, frame.light, lo, hi, r) : FaceWindow{double(r), 0, 0};
      windowData[f] = glm::vec4(float(windows[f].res), float(windows[f].x0), float(windows[f].y0), 0.0f);
    }
    vk::upload(ctx_, windows_, windowData.data(), sizeof(windowData));

    timer_.restart();
    double submitMs = 0;
    {
      vk::Commands cmd(ctx_, &timer_);
      cmd.mark("start");
      VkBufferImageCopy region{};
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
      region.imageExtent = {r, r, 1};
      for (uint32_t f = 0; f < 6; ++f) {
        pass_.recordWindow(cmd, f, windows[f].res, windows[f].x0, windows[f].y0, r, r, frame.light, eps);
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
                    visibility_, windows_},
                   push, grid.x, grid.y);
      cmd.barrier();
      cmd.mark("lookup");
      const auto ts = Clock::now();
      cmd.submit();
      submitMs = msSince(ts);
    }
    // The faces are the cube map's shadow structure, drawn again every frame; the lookup answers the samples.
    // Where timestamps cannot split a submission, the faces and the lookup are one stage (vk::Timer::intervalsOr).
    if (uploadMs > 0) out.stages.push_back({"upload", uploadMs, StageKind::Rebuild});
    for (auto& [n, ms] : timer_.intervalsOr("faces_and_lookup", submitMs))
      out.stages.push_back({n, ms, n == "lookup" ? StageKind::Lookup : StageKind::Rebuild});
    out.work = "6 faces of " + std::to_string(r) + "²";
    out.totalMs = msSince(t0);

    auto t1 = Clock::now();
    out.visibility.resize(pixels);
    if (pixels) vk::download(ctx_, visibility_, out.visibility.data(), uint64_t(pixels) * 4);
    double gpuMs = 0;
    for (auto& s : out.stages) gpuMs += s.ms;
    out.bytesAllocated = pass_.bytesAllocated() + 6 * faceBytes + visibility_.size;
    out.peakBytes = out.bytesAllocated;
    nlohmann::json zoom = nlohmann::json::array();
    for (const FaceWindow& w : windows) zoom.push_back(w.res / double(r));
    out.stats = {{"resolution", r},
                 {"fit_faces", options_.fitFaces},
                 {"face_zoom", zoom},
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
  vk::Buffer windows_;  // vec4 per face: effective resolution, x0, y0 (fitFace)
};

}  // namespace

std::unique_ptr<ShadowMethod> makeCubeShadowMap(vk::Context& ctx, const CubeSmOptions& options) {
  return std::make_unique<CubeShadowMap>(ctx, options);
}

}  // namespace cs
