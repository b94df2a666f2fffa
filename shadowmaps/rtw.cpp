// Rectilinear texture warping as a ShadowMethod: see rtw.h.
#include "shadowmaps/rtw.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <sstream>

#include "core/error.h"
#include "method/epsilon.h"
#include "raster/raster.h"
#include "shadowmaps/depth_pass.h"
#include "shadowmaps/rtw_forward.comp.h"
#include "shadowmaps/rtw_importance.comp.h"
#include "shadowmaps/rtw_lookup.comp.h"
#include "shadowmaps/rtw_shared.h"
#include "shadowmaps/rtw_warp.comp.h"
#include "vk/context.h"

namespace cs {

uint32_t rtwFunctions(const RtwOptions& o) {
  if (o.functions) return o.functions;
  return o.analysis == RtwAnalysis::Backward ? (RTW_VIEW | RTW_DISTANCE | RTW_NORMAL)
                                             : (RTW_VIEW | RTW_DISTANCE | RTW_EDGE | RTW_NORMAL);
}

uint32_t parseRtwFunctions(const std::string& list, RtwAnalysis analysis) {
  uint32_t bits = 0;
  std::stringstream in(list);
  std::string item;
  while (std::getline(in, item, ',')) {
    std::string name;
    for (char c : item)
      if (!std::isspace(static_cast<unsigned char>(c))) name += char(std::tolower(static_cast<unsigned char>(c)));
    if (name == "view") bits |= RTW_VIEW;
    else if (name == "distance") bits |= RTW_DISTANCE;
    else if (name == "edge") bits |= RTW_EDGE;
    else if (name == "normal") bits |= RTW_NORMAL;
    else if (name == "uniform") bits |= RTW_UNIFORM;
    else
      throw UsageError("rtw: --rtw-importance: unknown function '" + item +
                       "' (want a comma-separated list of view, distance, edge, normal, or uniform alone)");
  }
  if (!bits) throw UsageError("rtw: --rtw-importance is empty (want view, distance, edge, normal or uniform)");
  if ((bits & RTW_UNIFORM) && bits != RTW_UNIFORM)
    throw UsageError("rtw: --rtw-importance uniform stands alone (it is the identity warp)");
  if ((bits & RTW_EDGE) && analysis == RtwAnalysis::Backward)
    throw UsageError("rtw: the edge function reads the light's depth image: use --rtw-analysis forward or hybrid");
  if (!(bits & RTW_UNIFORM) && !(bits & RTW_VIEW) && analysis != RtwAnalysis::Forward)
    throw UsageError("rtw: backward and hybrid analyses see only the samples in view: the view function is "
                     "implied, list it (--rtw-importance view,...)");
  return bits;
}

std::vector<float> rtwKnots(const std::vector<float>& importance, float sigma) {
  const size_t n = importance.size();
  std::vector<float> blurred(n);
  const int r = sigma > 0 ? int(std::ceil(3.0f * sigma)) : 0;
  for (size_t k = 0; k < n; ++k) {
    float v = importance[k];
    if (v > 0 && r > 0) {
      float sum = 0, weight = 0;
      for (int o = -r; o <= r; ++o) {
        const float g = std::exp(-0.5f * float(o * o) / (sigma * sigma));
        const long j = long(k) + o;
        if (j >= 0 && j < long(n)) {  // normalised over the face: edge cells keep their share
          sum += g * importance[size_t(j)];
          weight += g;
        }
      }
      v = sum / weight;
    }
    blurred[k] = v;
  }
  double total = 0;
  for (float v : blurred) total += v;
  std::vector<float> knots(n + 1);
  double acc = 0;
  for (size_t k = 0; k < n; ++k) {
    knots[k] = total > 0 && std::isfinite(total) ? float(std::min(acc / total, 1.0)) : float(k) / float(n);
    acc += blurred[k];
  }
  knots[n] = 1.0f;
  return knots;
}

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

const char* analysisName(RtwAnalysis a) {
  return a == RtwAnalysis::Forward ? "forward" : a == RtwAnalysis::Backward ? "backward" : "hybrid";
}

std::string functionNames(uint32_t bits) {
  std::string s;
  auto add = [&](uint32_t bit, const char* name) {
    if (bits & bit) s += (s.empty() ? "" : ",") + std::string(name);
  };
  add(RTW_VIEW, "view");
  add(RTW_DISTANCE, "distance");
  add(RTW_EDGE, "edge");
  add(RTW_NORMAL, "normal");
  add(RTW_UNIFORM, "uniform");
  return s;
}

class Rtw : public ShadowMethod {
 public:
  Rtw(vk::Context& ctx, const RtwOptions& options)
      : ctx_(ctx), o_(options), pass_(ctx, options.cull), timer_(vk::createTimer(ctx, 16)), readback_(ctx) {
    const uint32_t r = o_.resolution;
    if (r < 16)
      throw Error("RTW map resolution " + std::to_string(r) + " is too small", "--rtw-resolution",
                  "use at least 16 texels a side");
    const uint64_t faceBytes = uint64_t(r) * r * 4;
    if (faceBytes > ctx.maxStorageBufferRange())
      throw Error("an RTW face of " + std::to_string(r) + "² texels (" + std::to_string(faceBytes >> 20) +
                      " MiB) exceeds one storage binding of this device (" +
                      std::to_string(ctx.maxStorageBufferRange() >> 20) + " MiB)",
                  "--rtw-resolution", "lower the resolution");
    if (o_.cells == 0) o_.cells = std::clamp(r / 4, 2u, RTW_MAX_CELLS);
    if (o_.cells < 2 || o_.cells > std::min(r, RTW_MAX_CELLS))
      throw Error("RTW: " + std::to_string(o_.cells) + " super-cells per axis", "--rtw-cells",
                  "use 2 to min(resolution, " + std::to_string(RTW_MAX_CELLS) + ")");
    if (o_.forwardResolution == 0) o_.forwardResolution = o_.cells;
    if (o_.forwardResolution < o_.cells || o_.forwardResolution > r)
      throw Error("RTW: a forward depth image of " + std::to_string(o_.forwardResolution) + "² for " +
                      std::to_string(o_.cells) + " super-cells",
                  "--rtw-forward-res", "use between the cell count and the map resolution (every cell needs a texel)");
    functions_ = rtwFunctions(o_);
    CS_CHECK(o_.blurSigma >= 0 && o_.blurSigma <= 64, "RTW blur sigma " << o_.blurSigma << " is outside [0, 64]");
    CS_CHECK(o_.tessellation >= 0 && o_.tessellation <= 100, "RTW tessellation " << o_.tessellation << "% is outside [0, 100]");
    CS_CHECK(o_.warpBias >= 1 && o_.constantBias >= 0 && o_.slopeBias >= 0 && o_.maxSlope >= 0,
             "RTW biases: warpBias >= 1, the others >= 0");
    CS_CHECK(o_.alpha >= 0 && o_.beta >= 0, "RTW alpha and beta must be >= 0");
    if (!ctx.geometryShader)
      throw Error("the RTW shadow map needs the geometryShader feature, which this device lacks", ctx.deviceName(),
                  "use another shadow method (cubesm, rmsm) on this device");
    importanceKernel_ = vk::createKernel(ctx, "rtw_importance", spv_rtw_importance_comp, 5, sizeof(sm::RtwImportancePush));
    forwardKernel_ = vk::createKernel(ctx, "rtw_forward", spv_rtw_forward_comp, 4, sizeof(sm::RtwImportancePush));
    warpKernel_ = vk::createKernel(ctx, "rtw_warp", spv_rtw_warp_comp, 2, sizeof(sm::RtwWarpPush));
    lookupKernel_ = vk::createKernel(ctx, "rtw_lookup", spv_rtw_lookup_comp, 11, sizeof(sm::RtwLookupPush));
    const uint32_t n = o_.cells, m = o_.forwardResolution;
    importance_ = vk::createBuffer(ctx, uint64_t(6) * n * n * 4);
    warp_ = vk::createBuffer(ctx, uint64_t(sm::rtwWarpWords(n, r)) * 4);
    counters_ = vk::createBuffer(ctx, 16);
    view_ = vk::createBuffer(ctx, sizeof(sm::RtwView), vk::Memory::HostVisible);
    const bool needsImage = o_.analysis != RtwAnalysis::Backward;
    forward_ = vk::createBuffer(ctx, needsImage ? uint64_t(6) * m * m * 4 : 16);
    edges_ = vk::createBuffer(ctx, o_.analysis == RtwAnalysis::Hybrid ? uint64_t(6) * m * m * 4 : 16);
    for (auto& f : faces_) f = vk::createBuffer(ctx, faceBytes);
  }

  std::string name() const override { return "rtw"; }

  MethodOutput run(const FrameInput& frame) override {
    CS_CHECK(frame.scene && frame.device, "rtw: the frame needs a scene and the G-buffer on the GPU");
    CS_CHECK(frame.vk == nullptr || frame.vk == &ctx_, "rtw: the frame's Vulkan context is not this method's");
    const bool needsView = (functions_ & (RTW_DISTANCE | RTW_NORMAL)) ||
                           ((functions_ & RTW_VIEW) && o_.analysis == RtwAnalysis::Forward);
    if (needsView && !frame.camera)
      throw Error("rtw: the frame carries no camera, and the importance functions '" + functionNames(functions_) +
                      "' weigh samples by the view",
                  "--rtw-importance", "run it through the harness (render, compare), or use uniform");
    const DeviceGBuffer& g = *frame.device;
    const uint32_t pixels = g.width * g.height;
    const float eps = frame.epsilon > 0 ? frame.epsilon : EpsilonPolicy::forScene(*frame.scene).eps;
    const uint32_t r = o_.resolution, n = o_.cells, m = o_.forwardResolution;
    MethodOutput out;
    const auto t0 = Clock::now();

    const double uploadMs = pass_.setGeometry(frame);
    pass_.takeTrianglesDrawn();
    pass_.ensureTargets(r, o_.analysis == RtwAnalysis::Backward ? r : m);
    if (visibility_.size < uint64_t(pixels) * 4) {
      visibility_.reset();
      visibility_ = vk::createBuffer(ctx_, std::max<uint64_t>(uint64_t(pixels) * 4, 16));
    }

    sm::RtwView view{};
    if (frame.camera) {
      const float aspect = g.height ? float(g.width) / float(g.height) : 1.0f;
      view.viewProj = viewProjection(*frame.camera, aspect);
      view.eye = glm::vec4(frame.camera->eye, frame.camera->znear);
      const glm::vec3 fwd = frame.camera->target - frame.camera->eye;
      view.forward = glm::vec4(glm::length(fwd) > 0 ? glm::normalize(fwd) : glm::vec3(0, 0, -1), 0.0f);
    } else {
      view.viewProj = glm::mat4(1.0f);
      view.eye = glm::vec4(0, 0, 0, 1e-6f);
      view.forward = glm::vec4(0, 0, -1, 0);
    }
    std::memcpy(view_.mapped, &view, sizeof(view));
    sm::RtwImportancePush ip{};
    ip.light = glm::vec4(frame.light, 1.0f);
    ip.width = g.width;
    ip.height = g.height;
    ip.cells = n;
    ip.forwardRes = m;
    ip.functions = functions_;
    ip.alpha = o_.alpha;
    ip.beta = o_.beta;
    ip.constantBias = o_.constantBias * eps;
    ip.minDistance = 2.0f * eps;

    timer_.restart();
    double submitMs = 0;
    readback_.clear();
    const uint32_t visSlot = readback_.add(visibility_, uint64_t(pixels) * 4);
    // The knots, active flags and live ranges come back (stats); the inverse tables stay on the device.
    const uint32_t warpWords = sm::rtwInverseBase(0, 0, n, r);
    const uint32_t warpSlot = readback_.add(warp_, uint64_t(warpWords) * 4);
    const uint32_t countSlot = readback_.add(counters_, 16);
    {
      vk::Commands cmd(ctx_, &timer_);
      cmd.mark("start");
      // Uniform importance: every cell 1 (float bits), the identity warp; no analysis runs.
      const bool uniform = functions_ == RTW_UNIFORM;
      cmd.fill(importance_, uniform ? 0x3f800000u : 0u);
      cmd.fill(counters_, 0);
      if (!uniform && o_.analysis != RtwAnalysis::Backward) {
        // The light's low-resolution depth image, m x m per face (the plain pass: nothing is warped yet).
        for (uint32_t f = 0; f < 6; ++f) {
          pass_.recordWindow(cmd, f, double(m), 0, 0, m, m, frame.light, eps);
          VkBufferImageCopy region{};
          region.bufferOffset = uint64_t(f) * m * m * 4;
          region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
          region.imageExtent = {m, m, 1};
          pass_.recordCopy(cmd, {region}, forward_);
        }
        cmd.barrier();
        ip.mode = o_.analysis == RtwAnalysis::Forward ? RTW_FORWARD_IMPORTANCE : RTW_FORWARD_EDGES;
        const vk::Grid fg = vk::gridFor(uint64_t(6) * m * m, RTW_THREADS, ctx_.maxWorkgroups());
        cmd.dispatch(forwardKernel_, {forward_, importance_, edges_, view_}, ip, fg.x, fg.y);
        cmd.barrier();
      }
      if (!uniform && pixels) {
        // Backward and hybrid: the samples' importance. Forward: a floor under it at every sample's cell
        // (RTW_SAMPLE_COVERAGE), so that no lit sample is looked up in a culled cell.
        ip.mode = o_.analysis == RtwAnalysis::Forward ? RTW_SAMPLE_COVERAGE : 0u;
        const vk::Grid pg = vk::gridFor(pixels, RTW_THREADS, ctx_.maxWorkgroups());
        cmd.dispatch(importanceKernel_, {g.position, g.normal, importance_, edges_, view_}, ip, pg.x, pg.y);
        cmd.barrier();
      }
      cmd.mark("analysis");
      sm::RtwWarpPush wp{};
      wp.cells = n;
      wp.sigma = o_.blurSigma;
      wp.radius = o_.blurSigma > 0 ? uint32_t(std::ceil(3.0f * o_.blurSigma)) : 0u;
      wp.resolution = r;
      cmd.dispatch(warpKernel_, {importance_, warp_}, wp, 12, 1);
      // The warp maps feed the geometry stage of the warped passes, then the lookup.
      VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
      mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
      mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT;
      vkCmdPipelineBarrier(cmd.handle(), VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                           VK_PIPELINE_STAGE_GEOMETRY_SHADER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1, &mb, 0,
                           nullptr, 0, nullptr);
      cmd.mark("warp");
      const float tessTexels = o_.tessellation > 0 ? o_.tessellation / 100.0f * float(r) : 0.0f;
      VkBufferImageCopy region{};
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
      region.imageExtent = {r, r, 1};
      for (uint32_t f = 0; f < 6; ++f) {
        pass_.recordWarped(cmd, f, r, warp_, n, frame.light, eps, tessTexels);
        pass_.recordCopy(cmd, {region}, faces_[f]);
      }
      cmd.barrier();
      cmd.mark("faces");
      sm::RtwLookupPush lp{};
      lp.light = glm::vec4(frame.light, 1.0f);
      lp.width = g.width;
      lp.height = g.height;
      lp.resolution = r;
      lp.cells = n;
      lp.constantBias = o_.constantBias * eps;
      lp.slopeBias = o_.slopeBias;
      lp.maxSlope = o_.maxSlope;
      lp.minDistance = 2.0f * eps;
      lp.pcf = o_.pcf ? 1u : 0u;
      lp.planeBias = o_.planeBias ? 1u : 0u;
      lp.warpBias = o_.warpBias;
      if (pixels) {
        const vk::Grid pg = vk::gridFor(pixels, RTW_THREADS, ctx_.maxWorkgroups());
        cmd.dispatch(lookupKernel_,
                     {g.position, g.normal, faces_[0], faces_[1], faces_[2], faces_[3], faces_[4], faces_[5],
                      visibility_, warp_, counters_},
                     lp, pg.x, pg.y);
      }
      cmd.barrier();
      cmd.mark("lookup");
      readback_.record(cmd);
      const auto ts = Clock::now();
      cmd.submit();
      submitMs = msSince(ts);
    }
    // Where timestamps cannot split the submission, it is one stage (vk::Timer::intervalsOr).
    if (uploadMs > 0) out.stages.push_back({"upload", uploadMs, StageKind::Rebuild});
    for (auto& [name, ms] : timer_.intervalsOr("analysis_warp_faces_and_lookup", submitMs))
      out.stages.push_back({name, ms, name == "lookup" ? StageKind::Lookup : StageKind::Rebuild});
    out.totalMs = msSince(t0);

    const auto t1 = Clock::now();
    out.visibility.resize(pixels);
    if (pixels) readback_.read(visSlot, out.visibility);
    std::vector<float> warp(warpWords);
    readback_.read(warpSlot, warp);
    uint32_t counters[4] = {};
    readback_.read(countSlot, counters);

    nlohmann::json mer = nlohmann::json::array(), culled = nlohmann::json::array(), knots = nlohmann::json::array();
    double merMax = 0;
    uint32_t active = 0;
    for (uint32_t f = 0; f < 6; ++f) {
      const bool on = warp[sm::rtwActiveIndex(f, n)] != 0.0f;
      active += on;
      double widest[2] = {0, 0};
      uint32_t zero = 0;
      for (uint32_t a = 0; a < 2; ++a) {
        const float* k = warp.data() + sm::rtwKnotBase(f, a, n);
        for (uint32_t c = 0; c < n; ++c) {
          widest[a] = std::max(widest[a], double(k[c + 1] - k[c]));
          zero += on && !(k[c + 1] > k[c]);
        }
        if (o_.keepWarp) knots.push_back(std::vector<float>(k, k + n + 1));
      }
      const double ms = on ? double(r) * n * widest[0] : 0, mt = on ? double(r) * n * widest[1] : 0;
      mer.push_back({std::lround(ms), std::lround(mt)});
      merMax = std::max({merMax, ms, mt});
      culled.push_back(double(zero) / (2.0 * n));
    }
    double gpuMs = 0;
    for (auto& s : out.stages) gpuMs += s.ms;
    const uint64_t faceBytes = uint64_t(r) * r * 4;
    out.bytesAllocated = pass_.bytesAllocated() + 6 * faceBytes + importance_.size + warp_.size + forward_.size +
                         edges_.size + counters_.size + view_.size + visibility_.size + readback_.bytesAllocated();
    out.peakBytes = out.bytesAllocated;
    out.work = std::to_string(active) + " faces of " + std::to_string(r) + "², MER " + std::to_string(std::lround(merMax));
    out.stats = {{"resolution", r},
                 {"cells", n},
                 {"analysis", analysisName(o_.analysis)},
                 {"functions", functionNames(functions_)},
                 {"alpha", o_.alpha},
                 {"beta", o_.beta},
                 {"blur_sigma", o_.blurSigma},
                 {"forward_resolution", o_.analysis == RtwAnalysis::Backward ? 0u : m},
                 {"mer", mer},
                 {"mer_max", std::lround(merMax)},
                 {"culled_cells", culled},
                 {"active_faces", active},
                 {"culled_samples", counters[0]},
                 {"tessellation_percent", o_.tessellation},
                 {"face_bytes", 6 * faceBytes},
                 {"geometry_passes", 6 + (o_.analysis == RtwAnalysis::Backward ? 0 : 6)},
                 {"triangles", pass_.triangleCount()},
                 {"triangles_drawn", pass_.takeTrianglesDrawn()},
                 {"pcf", o_.pcf},
                 {"plane_bias", o_.planeBias},
                 {"warp_bias", o_.warpBias},
                 {"constant_bias", o_.constantBias * eps},
                 {"slope_bias_texels", o_.slopeBias},
                 {"max_slope", o_.maxSlope},
                 {"epsilon", eps},
                 {"gpu_ms", gpuMs},
                 {"readback_ms", msSince(t1)}};
    if (o_.keepWarp) out.stats["warp_knots"] = knots;
    return out;
  }

 private:
  vk::Context& ctx_;
  RtwOptions o_;
  uint32_t functions_ = 0;
  sm::DepthPass pass_;
  vk::Timer timer_;
  vk::Readback readback_;
  vk::Kernel importanceKernel_, forwardKernel_, warpKernel_, lookupKernel_;
  vk::Buffer importance_;  // uint (float bits) per cell, 6 faces of n x n
  vk::Buffer warp_;        // rtw_shared.h layout
  vk::Buffer counters_;    // 0: lit samples in culled cells
  vk::Buffer view_;        // sm::RtwView, host-visible, written each frame
  vk::Buffer forward_;     // the light's depth image, 6 faces of m x m (forward, hybrid)
  vk::Buffer edges_;       // I_E per depth-image texel (hybrid)
  std::array<vk::Buffer, 6> faces_;
  vk::Buffer visibility_;
};

}  // namespace

std::unique_ptr<ShadowMethod> makeRtw(vk::Context& ctx, const RtwOptions& options) {
  return std::make_unique<Rtw>(ctx, options);
}

}  // namespace cs
