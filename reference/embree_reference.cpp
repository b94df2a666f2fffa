// Embree ground truth: BVH build over the scene's triangle soup, 16-wide occlusion packets over the lit
// samples on all threads, and the ambiguity band traced on the same BVH.
#include "reference/embree_reference.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "core/error.h"
#include "core/scene.h"
#include "reference/parallel.h"

namespace cs {

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

const char* errorName(RTCError code) {
  switch (code) {
    case RTC_ERROR_NONE: return "no error";
    case RTC_ERROR_UNKNOWN: return "unknown error";
    case RTC_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION: return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY: return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU: return "unsupported CPU";
    case RTC_ERROR_CANCELLED: return "cancelled";
  }
  return "unrecognised error";
}

const char* qualityName(RTCBuildQuality q) {
  switch (q) {
    case RTC_BUILD_QUALITY_LOW: return "low";
    case RTC_BUILD_QUALITY_MEDIUM: return "medium";
    case RTC_BUILD_QUALITY_HIGH: return "high";
    case RTC_BUILD_QUALITY_REFIT: return "refit";
  }
  return "?";
}

static_assert(sizeof(glm::vec3) == 3 * sizeof(float), "positions are copied to Embree as packed float3");

constexpr int kPacket = 16;

// Traces up to 16 rays as one packet; occluded[i] = whether ray i hit something in its interval.
// Embree treats [tnear, tfar] as closed where the policy says open: the difference has measure zero,
// and a hit exactly at an interval end is what the band's end-moving members flag anyway.
void occluded16(RTCScene scene, const ShadowRay* rays, int n, bool* occluded) {
  alignas(64) int valid[kPacket];
  alignas(64) RTCRay16 packet;
  for (int i = 0; i < kPacket; ++i) {
    const ShadowRay& r = rays[i < n ? i : 0];
    valid[i] = i < n ? -1 : 0;
    packet.org_x[i] = r.org.x;
    packet.org_y[i] = r.org.y;
    packet.org_z[i] = r.org.z;
    packet.dir_x[i] = r.dir.x;
    packet.dir_y[i] = r.dir.y;
    packet.dir_z[i] = r.dir.z;
    packet.tnear[i] = r.tnear;
    packet.tfar[i] = r.tfar;
    packet.time[i] = 0.0f;
    packet.mask[i] = 0xFFFFFFFFu;
    packet.id[i] = unsigned(i);
    packet.flags[i] = 0;
  }
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  // Neighbouring samples' shadow rays share the light and nearly share their origins.
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  rtcOccluded16(valid, scene, &context, &packet);
  // Embree marks an occluded ray by setting tfar to -inf; rays with an empty interval are left alone.
  for (int i = 0; i < n; ++i) occluded[i] = std::isinf(packet.tfar[i]) && packet.tfar[i] < 0.0f;
}

}  // namespace

// ---- EmbreeDevice ------------------------------------------------------------------------------------

EmbreeDevice::EmbreeDevice(const std::string& config) {
  device_ = rtcNewDevice(config.empty() ? nullptr : config.c_str());
  if (!device_) {
    const RTCError e = rtcGetDeviceError(nullptr);
    throw Error(std::string("cannot create an Embree device: ") + errorName(e), "rtcNewDevice",
                e == RTC_ERROR_OUT_OF_MEMORY ? "Embree's thread pool did not get its memory: raise the process's memory "
                                               "limit (ulimit -v)"
                                             : "Embree 3 needs an SSE2-or-better x86-64 CPU and a valid config string");
  }
  rtcSetDeviceErrorFunction(device_, &EmbreeDevice::onError, this);
  rtcSetDeviceMemoryMonitorFunction(device_, &EmbreeDevice::onMemory, this);
}

EmbreeDevice::~EmbreeDevice() {
  if (device_) rtcReleaseDevice(device_);
}

bool EmbreeDevice::onMemory(void* self, ssize_t bytes, bool /*post*/) {
  // Embree reports an allocation (bytes > 0) before making it and a release (bytes < 0) after; a failed
  // allocation is reported back as a release, so the running sum is the live total either way.
  auto* d = static_cast<EmbreeDevice*>(self);
  int64_t live = d->live_.fetch_add(int64_t(bytes)) + int64_t(bytes);
  if (bytes > 0) d->allocated_.fetch_add(uint64_t(bytes));
  int64_t peak = d->peak_.load();
  while (live > peak && !d->peak_.compare_exchange_weak(peak, live)) {
  }
  return true;  // never veto: bounds on the reference are the caller's business
}

void EmbreeDevice::onError(void* self, RTCError code, const char* message) {
  auto* d = static_cast<EmbreeDevice*>(self);
  std::lock_guard<std::mutex> lock(d->errorMutex_);
  if (d->error_.empty()) d->error_ = std::string(errorName(code)) + (message ? std::string(": ") + message : "");
}

void EmbreeDevice::check(const std::string& where) {
  RTCError code = rtcGetDeviceError(device_);  // this thread's code; the callback covers the others
  std::string message;
  {
    std::lock_guard<std::mutex> lock(errorMutex_);
    message.swap(error_);
  }
  if (message.empty() && code != RTC_ERROR_NONE) message = errorName(code);
  if (!message.empty())
    throw Error("Embree: " + message, where,
                code == RTC_ERROR_OUT_OF_MEMORY || code == RTC_ERROR_UNKNOWN || code == RTC_ERROR_NONE
                    ? "Embree fails this way when its build or its threads cannot get memory: raise the process's "
                      "memory limit (ulimit -v) or use a smaller scene"
                    : "");
}

// ---- EmbreeReference -----------------------------------------------------------------------------------

EmbreeReference::EmbreeReference(std::shared_ptr<EmbreeDevice> device, EmbreeOptions options)
    : device_(device ? std::move(device) : std::make_shared<EmbreeDevice>()),
      options_(options),
      pool_(std::make_unique<ThreadPool>(options.threads)) {}

EmbreeReference::~EmbreeReference() { releaseScene(); }

unsigned EmbreeReference::threadCount() const { return pool_->threadCount(); }

void EmbreeReference::releaseScene() {
  if (scene_) rtcReleaseScene(scene_);
  scene_ = nullptr;
  vertices_ = nullptr;
  indices_ = nullptr;
  vertexCount_ = triangleCount_ = 0;
}

double EmbreeReference::build(const Scene& scene) {
  CS_CHECK(scene.indices.size() % 3 == 0,
           "scene '" << scene.name << "': index count " << scene.indices.size() << " is not a multiple of 3");
  const size_t nv = scene.positions.size(), nt = scene.triangleCount();
  // Embree does not check indices; an index past the end would read outside the vertex buffer.
  for (size_t i = 0; i < scene.indices.size(); ++i)
    CS_CHECK(scene.indices[i] < nv, "scene '" << scene.name << "': index " << i << " = " << scene.indices[i]
                                              << " is past the " << nv << " vertices");
  releaseScene();

  auto t0 = Clock::now();
  RTCDevice dev = device_->handle();
  scene_ = rtcNewScene(dev);
  // ROBUST: watertight intersection without the accuracy-reducing shortcuts, so a ray through the shared
  // edge of two triangles cannot slip between them. A ground truth needs it; it costs a few percent.
  rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(scene_, options_.quality);
  if (nt > 0) {
    RTCGeometry geom = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(geom, options_.quality);
    // Embree-allocated buffers (not shared ones): Embree pads vertex buffers for its 16-byte loads, and
    // the copy is what a dynamic scene pays per frame anyway. Counted by the memory monitor.
    auto* v = static_cast<float*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
    auto* idx = static_cast<uint32_t*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), nt));
    device_->check("rtcSetNewGeometryBuffer (" + std::to_string(nv) + " vertices, " + std::to_string(nt) +
                   " triangles)");
    std::memcpy(v, scene.positions.data(), nv * sizeof(glm::vec3));
    std::memcpy(idx, scene.indices.data(), nt * 3 * sizeof(uint32_t));
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene_, geom);
    rtcReleaseGeometry(geom);  // the scene holds it now
    vertices_ = v;
    indices_ = idx;
  }
  rtcCommitScene(scene_);
  device_->check("rtcCommitScene (scene '" + scene.name + "')");
  vertexCount_ = nv;
  triangleCount_ = nt;
  return msSince(t0);
}

bool EmbreeReference::builtFrom(const Scene& scene) const {
  if (!scene_ || scene.positions.size() != vertexCount_ || scene.triangleCount() != triangleCount_) return false;
  if (triangleCount_ == 0) return true;
  return std::memcmp(vertices_, scene.positions.data(), vertexCount_ * sizeof(glm::vec3)) == 0 &&
         std::memcmp(indices_, scene.indices.data(), triangleCount_ * 3 * sizeof(uint32_t)) == 0;
}

MethodOutput EmbreeReference::run(const FrameInput& frame) {
  CS_CHECK(frame.scene && frame.gbuffer, "embree: the frame needs a scene and a host G-buffer");
  const Scene& scene = *frame.scene;
  const GBuffer& g = *frame.gbuffer;
  CS_CHECK_EQ(g.position.size(), g.size());
  CS_CHECK_EQ(g.normal.size(), g.size());
  const float eps = frame.epsilon > 0 ? frame.epsilon : EpsilonPolicy::forScene(scene).eps;
  const glm::vec3 light = frame.light;

  MethodOutput out;
  out.visibility.assign(g.size(), 1.0f);  // not-lit samples stay 1 (method.h)

  releaseScene();  // the previous frame's BVH is not this frame's memory
  device_->resetPeak();
  const int64_t liveBefore = device_->liveBytes();
  const uint64_t allocatedBefore = device_->allocatedBytes();

  const double buildMs = build(scene);

  auto t0 = Clock::now();
  std::atomic<uint64_t> rays{0};
  RTCScene rtcScene = scene_;
  float* vis = out.visibility.data();
  pool_->parallelFor(g.size(), options_.grain, [&](size_t begin, size_t end) {
    ShadowRay packet[kPacket];
    size_t sample[kPacket];
    bool occluded[kPacket];
    int n = 0;
    uint64_t traced = 0;
    auto flush = [&] {
      occluded16(rtcScene, packet, n, occluded);
      for (int k = 0; k < n; ++k) vis[sample[k]] = occluded[k] ? 0.0f : 1.0f;
      traced += uint64_t(n);
      n = 0;
    };
    for (size_t i = begin; i < end; ++i) {
      if (!g.isLit(i)) continue;
      packet[n] = rayToward(glm::vec3(g.position[i]), light, eps, eps);  // EpsilonPolicy::baseRay
      sample[n++] = i;
      if (n == kPacket) flush();
    }
    if (n > 0) flush();
    rays.fetch_add(traced, std::memory_order_relaxed);
  });
  device_->check("rtcOccluded16");
  const double raysMs = msSince(t0);

  out.stages = {{"bvh_build", buildMs, StageKind::Rebuild}, {"rays", raysMs, StageKind::Lookup}};
  out.totalMs = buildMs + raysMs;
  out.work = std::to_string(rays.load()) + " rays";
  const uint64_t visBytes = out.visibility.size() * sizeof(float);
  // Embree's allocations this frame include its copies of the vertex and index buffers.
  out.bytesAllocated = (device_->allocatedBytes() - allocatedBefore) + visBytes;
  out.peakBytes = uint64_t(std::max<int64_t>(0, device_->peakBytes() - liveBefore)) + visBytes;
  out.stats = {{"triangles", triangleCount_},
               {"lit_samples", rays.load()},
               {"rays", rays.load()},
               {"threads", pool_->threadCount()},
               {"build_quality", qualityName(options_.quality)},
               {"epsilon", eps},
               {"embree_bytes", device_->liveBytes() - liveBefore}};
  return out;
}

std::vector<uint8_t> EmbreeReference::traceOccluded(const std::vector<ShadowRay>& rays) {
  CS_CHECK(scene_ != nullptr, "embree: traceOccluded() before any build()");
  std::vector<uint8_t> result(rays.size(), 0);
  RTCScene rtcScene = scene_;
  pool_->parallelFor((rays.size() + kPacket - 1) / kPacket, 64, [&](size_t begin, size_t end) {
    bool occluded[kPacket];
    for (size_t p = begin; p < end; ++p) {
      size_t first = p * kPacket;
      int n = int(std::min<size_t>(kPacket, rays.size() - first));
      occluded16(rtcScene, rays.data() + first, n, occluded);
      for (int k = 0; k < n; ++k) result[first + size_t(k)] = occluded[k];
    }
  });
  device_->check("rtcOccluded16");
  return result;
}

std::vector<uint8_t> EmbreeReference::ambiguityBand(const Scene& scene, const GBuffer& g, glm::vec3 light,
                                                    const EpsilonPolicy& policy, const BandOptions& options,
                                                    StageTime* timing) {
  CS_CHECK_EQ(g.position.size(), g.size());
  CS_CHECK_EQ(g.normal.size(), g.size());
  auto t0 = Clock::now();
  if (!builtFrom(scene)) build(scene);

  std::vector<uint8_t> band(g.size(), 0);
  RTCScene rtcScene = scene_;
  constexpr int kMembers = EpsilonPolicy::kMaxBandMembers;
  pool_->parallelFor(g.size(), options_.grain, [&](size_t begin, size_t end) {
    // 16 samples at a time: their base rays as one packet, then member k of each as one packet, so a
    // packet's rays stay as coherent as the samples themselves.
    ShadowRay base[kPacket], family[kPacket][kMembers], packet[kPacket];
    int familySize[kPacket];
    size_t sample[kPacket];
    bool baseOccluded[kPacket], occluded[kPacket], disagree[kPacket];
    int n = 0;
    auto flush = [&] {
      occluded16(rtcScene, base, n, baseOccluded);
      int most = 0;
      for (int s = 0; s < n; ++s) {
        disagree[s] = false;
        most = std::max(most, familySize[s]);
      }
      for (int m = 0; m < most; ++m) {
        int lanes = 0, lane[kPacket];
        for (int s = 0; s < n; ++s)
          if (m < familySize[s] && !disagree[s]) {
            lane[lanes] = s;
            packet[lanes++] = family[s][m];
          }
        if (lanes == 0) break;
        occluded16(rtcScene, packet, lanes, occluded);
        for (int k = 0; k < lanes; ++k)
          if (occluded[k] != baseOccluded[lane[k]]) disagree[lane[k]] = true;
      }
      for (int s = 0; s < n; ++s) band[sample[s]] = disagree[s] ? 1 : 0;
      n = 0;
    };
    for (size_t i = begin; i < end; ++i) {
      if (!g.isLit(i)) continue;
      glm::vec3 p(g.position[i]), nrm(g.normal[i]);
      base[n] = policy.baseRay(p, light);
      familySize[n] = policy.bandFamily(p, nrm, light, options, family[n]);
      sample[n++] = i;
      if (n == kPacket) flush();
    }
    if (n > 0) flush();
  });
  device_->check("rtcOccluded16 (band)");
  if (timing) *timing = {"band", msSince(t0)};
  return band;
}

std::vector<uint8_t> ambiguityBand(const Scene& scene, const GBuffer& gbuffer, glm::vec3 light,
                                   const EpsilonPolicy& policy, const BandOptions& options) {
  EmbreeReference reference;
  return reference.ambiguityBand(scene, gbuffer, light, policy, options);
}

}  // namespace cs
