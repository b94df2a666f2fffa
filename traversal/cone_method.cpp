// The cone path as a ShadowMethod (see cone_method.h).
#include "traversal/cone_method.h"

#include <chrono>
#include <cmath>
#include <cstring>

#include "conetree/conetree.h"
#include "core/error.h"
#include "raster/raster.h"
#include "reference/epsilon.h"
#include "sort/rays.h"
#include "vk/context.h"

namespace cs {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

constexpr uint32_t kOne = 0x3F800000u;  // 1.0f: the visibility words start lit

class ConeMethod : public ShadowMethod {
 public:
  ConeMethod(vk::Context& ctx, const ConeOptions& options)
      : ctx_(ctx),
        options_(options),
        tree_(ctx),
        traversal_(options.arena.pairCapacity > 0 ? traversal::Traversal(ctx, options.arena)
                                                   : traversal::Traversal(ctx, options.traversalMemoryBytes)),
        timer_(vk::createTimer(ctx, 64)) {}

  std::string name() const override { return "cone"; }

  MethodOutput run(const FrameInput& frame) override {
    CS_CHECK(frame.scene && frame.device, "cone: the frame needs a scene and the G-buffer on the GPU");
    CS_CHECK(frame.vk == nullptr || frame.vk == &ctx_, "cone: the frame's Vulkan context is not this method's");
    const Scene& scene = *frame.scene;
    const DeviceGBuffer& g = *frame.device;
    const uint32_t pixels = g.width * g.height;
    const float eps = frame.epsilon > 0 ? frame.epsilon : EpsilonPolicy::forScene(scene).eps;
    MethodOutput out;
    auto t0 = Clock::now();

    double uploadMs = uploadTriangles(scene);
    if (!rays_ || raysWidth_ != g.width || raysHeight_ != g.height) {
      rays_.reset();
      rays_ = std::make_unique<sort::LitRays>(ctx_, g.width, g.height);
      raysWidth_ = g.width;
      raysHeight_ = g.height;
    }
    if (visibility_.size < uint64_t(pixels) * 4) {
      visibility_.reset();
      visibility_ = vk::createBuffer(ctx_, uint64_t(pixels) * 4);
    }

    // Each stage is its own submit, timed by the host's wall clock around it (waits included): lavapipe's
    // timestamps land on the wrong side of dispatches (see cone_method.h). Timestamps go to the stats too.
    std::vector<StageTime> stages;
    nlohmann::json timestamps = nlohmann::json::object();
    if (uploadMs > 0) stages.push_back({"upload", uploadMs});
    auto stage = [&](const char* name, auto&& record) {
      timer_.restart();
      vk::Commands cmd(ctx_, &timer_);
      cmd.mark("start");
      record(cmd);
      cmd.mark(name);
      auto s0 = Clock::now();
      cmd.submit();
      stages.push_back({name, msSince(s0)});
      for (auto& [n, ms] : timer_.intervals()) timestamps[n] = ms;
    };

    // Lit samples in ray order (sort/), then their count on the host: it shapes the tree.
    const sort::RayOrder order = options_.sorted ? sort::RayOrder::Hilbert : sort::RayOrder::ScreenMorton;
    stage("compact", [&](vk::Commands& cmd) {
      cmd.fill(visibility_, kOne, 0, uint64_t(pixels) * 4);
      rays_->recordCompaction(cmd, g, order);
    });
    if (options_.sorted) {
      stage("keys", [&](vk::Commands& cmd) { rays_->recordKeys(cmd, g, frame.light, rays_->count()); });
      stage("sort", [&](vk::Commands& cmd) { rays_->recordSort(cmd, rays_->count()); });
    } else {
      stages.push_back({"keys", 0.0});
      stages.push_back({"sort", 0.0});
    }
    const uint32_t lit = rays_->readCount();

    nlohmann::json stats = {{"lit_samples", lit},
                            {"triangles", triangleCount_},
                            {"triangles_dropped", droppedTriangles_},
                            {"sorted", options_.sorted},
                            {"variant", coneVariantName(options_)},
                            {"test", options_.test == ConeTest::Sphere ? "sphere" : "precise"},
                            {"front_face_culling", options_.frontFaceCulling},
                            {"early_accept", options_.earlyAccept && options_.test == ConeTest::Precise},
                            {"epsilon", eps},
                            {"traversal_memory_bytes", options_.traversalMemoryBytes},
                            {"pair_capacity", traversal_.plan().pairCapacity},
                            {"chunk_capacity", traversal_.plan().chunkCapacity}};
    traversal::TraversalStats ts;
    if (lit > 0 && triangleCount_ > 0) {
      stage("build", [&](vk::Commands& cmd) {
        tree_.record(cmd, g.position, rays_->samples(), lit, frame.light, 2.0f * eps);
      });
      traversal::TraversalInput in;
      in.triangles = &triangles_;
      in.triangleCount = triangleCount_;
      in.tree = &tree_;
      in.samples = rays_->samples();
      in.positions = g.position;
      in.visibility = &visibility_;
      in.light = frame.light;
      in.eps = eps;
      in.test = options_.test == ConeTest::Sphere ? TRAVERSE_TEST_SPHERE : TRAVERSE_TEST_PRECISE;
      in.frontFaceCulling = options_.frontFaceCulling;
      in.earlyAccept = options_.earlyAccept;
      ts = traversal_.run(in, &timer_);
      stats["tree_depth"] = tree_.shape().depth;
      stats["tree_nodes"] = tree_.shape().nodes();
    } else {
      stages.push_back({"build", 0.0});
      stats["tree_depth"] = 0;
      stats["tree_nodes"] = 0;
    }
    stages.push_back({"traversal", ts.traversalMs});
    stages.push_back({"leaves", ts.leavesMs});
    timestamps["traversal"] = ts.traversalGpuMs;
    timestamps["leaves"] = ts.leavesGpuMs;
    stats["timestamp_ms"] = timestamps;
    out.totalMs = msSince(t0);

    auto t1 = Clock::now();
    out.visibility.resize(pixels);
    if (pixels) vk::download(ctx_, visibility_, out.visibility.data(), uint64_t(pixels) * 4);
    // The words hold 1.0f or 0.0f bits; nothing else is ever written, so no NaN or inf can appear.
    stats["readback_ms"] = msSince(t1);

    double stageMs = 0;
    for (auto& st : stages) stageMs += st.ms;
    stats["stages_ms"] = stageMs;
    stats["traversal"] = ts.toJson();
    stats["pairs_tested"] = ts.pairsTested();
    stats["pairs_survived"] = ts.pairsSurvived();
    stats["leaf_tests"] = ts.leafTests;
    stats["early_accepted_nodes"] = ts.earlyAccepted;
    stats["traversal_peak_bytes"] = ts.peakBytes;
    out.stages = std::move(stages);
    out.stats = std::move(stats);
    out.bytesAllocated = bytesAllocated();
    // Working set: everything resident for the frame, with the traversal's share at its measured peak.
    out.peakBytes = out.bytesAllocated - traversal_.bytesAllocated() + ts.peakBytes;
    return out;
  }

 private:
  uint64_t bytesAllocated() const {
    return triangles_.size + (rays_ ? rays_->bytesAllocated() : 0) + visibility_.size + tree_.bytesAllocated() +
           traversal_.bytesAllocated() + traversal_.flagBytes();
  }

  // Gathers the scene's triangles (vec4 x 3, world space) and uploads them when they changed. Triangles
  // with a non-finite coordinate are dropped, as Embree drops them. Returns the wall ms, 0 if cached.
  double uploadTriangles(const Scene& scene) {
    if (cachedPositions_ == scene.positions && cachedIndices_ == scene.indices && triangles_) return 0.0;
    auto t0 = Clock::now();
    CS_CHECK(scene.indices.size() % 3 == 0, "scene '" << scene.name << "': index count is not a multiple of 3");
    std::vector<glm::vec4> tris;
    tris.reserve(scene.indices.size());
    droppedTriangles_ = 0;
    for (size_t t = 0; t + 2 < scene.indices.size(); t += 3) {
      glm::vec3 v[3];
      bool finite = true;
      for (int k = 0; k < 3; ++k) {
        uint32_t i = scene.indices[t + k];
        CS_CHECK(i < scene.positions.size(), "scene '" << scene.name << "': index " << t + k << " = " << i
                                                       << " is past the " << scene.positions.size() << " vertices");
        v[k] = scene.positions[i];
        finite = finite && std::isfinite(v[k].x) && std::isfinite(v[k].y) && std::isfinite(v[k].z);
      }
      if (!finite) {
        droppedTriangles_++;
        continue;
      }
      for (auto& p : v) tris.emplace_back(p, 1.0f);
    }
    triangleCount_ = uint32_t(tris.size() / 3);
    const uint64_t bytes = std::max<uint64_t>(tris.size() * sizeof(glm::vec4), 16);
    CS_CHECK(bytes <= ctx_.maxStorageBufferRange(),
             "scene '" << scene.name << "': " << triangleCount_ << " triangles (" << bytes
                       << " bytes) exceed one storage binding of this device (" << ctx_.maxStorageBufferRange() << ")");
    if (triangles_.size < bytes) {
      triangles_.reset();
      triangles_ = vk::createBuffer(ctx_, bytes);
    }
    if (!tris.empty()) vk::upload(ctx_, triangles_, tris.data(), tris.size() * sizeof(glm::vec4));
    cachedPositions_ = scene.positions;
    cachedIndices_ = scene.indices;
    return msSince(t0);
  }

  vk::Context& ctx_;
  ConeOptions options_;
  cone::ConeTree tree_;
  traversal::Traversal traversal_;
  vk::Timer timer_;
  std::unique_ptr<sort::LitRays> rays_;
  uint32_t raysWidth_ = 0, raysHeight_ = 0;
  vk::Buffer triangles_, visibility_;
  uint32_t triangleCount_ = 0;
  uint64_t droppedTriangles_ = 0;
  std::vector<glm::vec3> cachedPositions_;
  std::vector<uint32_t> cachedIndices_;
};

}  // namespace

bool applyConeVariant(const std::string& name, ConeOptions& o) {
  if (name == "Precise" || name == "PreciseSorted" || name == "PreciseSEA") o.test = ConeTest::Precise;
  else if (name == "Spheres" || name == "SpheresSorted") o.test = ConeTest::Sphere;
  else return false;
  o.sorted = name == "PreciseSorted" || name == "SpheresSorted" || name == "PreciseSEA";
  o.earlyAccept = name == "PreciseSEA";
  return true;
}

bool isUnimplementedConeVariant(const std::string& name) { return name == "PreciseEATP" || name == "PreciseSEATP"; }

std::string coneVariantName(const ConeOptions& o) {
  if (o.test == ConeTest::Precise && o.earlyAccept) return o.sorted ? "PreciseSEA" : "PreciseEA";
  return std::string(o.test == ConeTest::Sphere ? "Spheres" : "Precise") + (o.sorted ? "Sorted" : "");
}

std::unique_ptr<ShadowMethod> makeConeMethod(vk::Context& ctx, const ConeOptions& options) {
  return std::make_unique<ConeMethod>(ctx, options);
}

}  // namespace cs
