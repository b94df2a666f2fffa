// The cone path's triangle layout (triangle_layout.h): the upload, the orders, the clusters' spheres, the
// far frame's copies and the instances. docs/ARCHITECTURE.md, "The triangle layout".
#include "traversal/triangle_layout.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>

#include "core/error.h"
#include "method/settings.h"
#include "traversal/frame_triangles.comp.h"
#include "traversal/instance_triangles.comp.h"

namespace cs {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }
constexpr uint64_t kUploadTriangles = kConeUploadTriangles;
static_assert(kUploadTriangles % SUPER_SIZE == 0, "uploads of whole super clusters");

// Solid angle of triangle (a, b, c), vertices relative to the apex (Van Oosterom & Strackee); 0 for a
// degenerate one.
double solidAngle(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c) {
  const double la = glm::length(a), lb = glm::length(b), lc = glm::length(c);
  const double num = std::abs(glm::dot(a, glm::cross(b, c)));
  const double den = la * lb * lc + glm::dot(a, b) * lc + glm::dot(a, c) * lb + glm::dot(b, c) * la;
  const double omega = 2.0 * std::atan2(num, den);
  return std::isfinite(omega) ? std::abs(omega) : 0.0;
}


// A cluster's bounds, in its mesh's space, taken to the world by the row-major 3x4 `m` (centres in double,
// radii scaled by the Frobenius norm of the linear part, which bounds its stretch), padded by 2^-20 of the
// magnitudes so each sphere holds the vertices as the device's fp32 transform rounds them. The identity
// leaves it as it is.
bool identityTransform(const float* m) {
  static const float kId[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  return std::equal(m, m + 12, kId);
}
double stretchOf(const float* m) {
  double s = 0;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) s += double(m[4 * r + c]) * double(m[4 * r + c]);
  return std::sqrt(s);
}
glm::dvec3 transformPoint(const float* m, glm::dvec3 p) {
  return {m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
          m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]};
}
traversal::ClusterWorld transformCluster(const traversal::ClusterWorld& o, const float* m) {
  if (identityTransform(m)) return o;
  const double s = stretchOf(m), t = glm::length(glm::dvec3(m[3], m[7], m[11]));
  auto sphere = [&](glm::dvec3 c, double r) {
    const double pad = std::ldexp(s * (glm::length(c) + r) + t, -20);
    return glm::dvec4(transformPoint(m, c), r * s + pad);
  };
  traversal::ClusterWorld w;
  w.whole = sphere(glm::dvec3(o.whole), o.whole.w);
  for (uint32_t g = 0; g < CLUSTER_GROUPS; ++g) {
    const glm::dvec4 d = sphere(glm::dvec3(glm::vec3(o.groups[g])), double(o.groups[g].w));
    // fp32 storage: the centre rounds by half an ulp of its magnitude, the radius rounds up past that
    const glm::vec3 c(d);
    const double moved = glm::length(glm::dvec3(c) - glm::dvec3(d));
    w.groups[g] = glm::vec4(c, std::nextafter(float(d.w + moved), INFINITY));
  }
  return w;
}

}  // namespace

TriangleLayout::TriangleLayout(vk::Context& ctx, const ConeOptions& options) : ctx_(ctx), options_(options) {
  frameTris_ = vk::createKernel(ctx, "frame triangles", spv_frame_triangles_comp, 2,
                                sizeof(traversal::FrameTrianglesPush));
}

void TriangleLayout::setInstances(std::span<const EngineMesh> meshes, std::span<const EngineInstance> instances,
                                  uint32_t framesInFlight) {
  if (!instanceTriangles_.module)
    instanceTriangles_ = vk::createKernel(ctx_, "instance triangles", spv_instance_triangles_comp, 4,
                                          sizeof(traversal::TraversePush));
  framesInFlight_ = framesInFlight;
  // Each used mesh's kept triangles (finite) in Hilbert order of their centroids over its own bounds.
  std::vector<std::vector<uint32_t>> order(meshes.size());
  std::vector<glm::vec3> meshLo(meshes.size(), glm::vec3(INFINITY)), meshHi(meshes.size(), glm::vec3(-INFINITY));
  std::vector<uint8_t> used(meshes.size(), 0);
  for (const EngineInstance& inst : instances) {
    CS_CHECK(inst.mesh < meshes.size(), "instance of mesh " << inst.mesh << " of " << meshes.size());
    used[inst.mesh] = 1;
  }
  uint64_t dropped = 0;
  for (size_t m = 0; m < meshes.size(); ++m) {
    if (!used[m]) continue;
    const EngineMesh& mesh = meshes[m];
    auto vertex = [&](uint32_t t, int k) { return mesh.positions[mesh.indices[3 * size_t(t) + k]]; };
    std::vector<uint32_t>& kept = order[m];
    for (size_t t = 0; t < mesh.indexCount / 3; ++t) {
      const glm::vec3 a = vertex(uint32_t(t), 0), b = vertex(uint32_t(t), 1), c = vertex(uint32_t(t), 2);
      auto finite = [](glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
      if (!(finite(a) && finite(b) && finite(c))) {
        ++dropped;
        continue;
      }
      kept.push_back(uint32_t(t));
      meshLo[m] = glm::min(meshLo[m], glm::min(a, glm::min(b, c)));
      meshHi[m] = glm::max(meshHi[m], glm::max(a, glm::max(b, c)));
    }
    if (kept.empty()) continue;
    boundsLo_ = meshLo[m], boundsHi_ = meshHi[m];  // orderForClusters reads the bounds
    std::vector<uint32_t> none;
    orderForClusters(kept, none, vertex);
  }
  // Slots: each instance's run, padded to whole super clusters (with its last triangle again) but the last.
  std::vector<InstanceRun> runs;
  uint64_t total = 0;
  for (size_t i = 0; i < instances.size(); ++i) {
    const uint64_t count = order[instances[i].mesh].size();
    const bool last = i + 1 == instances.size();
    const uint64_t padded = last || count == 0 ? count : (count + SUPER_SIZE - 1) / SUPER_SIZE * SUPER_SIZE;
    runs.push_back({instances[i].mesh, total, count, padded, meshLo[instances[i].mesh], meshHi[instances[i].mesh]});
    total += padded;
  }
  if (total > UINT32_MAX)
    throw Error(std::to_string(total) + " triangle slots in the instances", "cone engine", "at most 2^32 - 1 a scene");
  retireGeometry();
  triangleCount_ = uint32_t(total);
  droppedTriangles_ = dropped;
  planChunks();
  const size_t chunks = std::max<size_t>(1, (total + chunkTriangles_ - 1) / chunkTriangles_);
  objectClusters_.assign((total + CLUSTER_SIZE - 1) / CLUSTER_SIZE, traversal::ClusterWorld{});
  clusterInstance_.assign(objectClusters_.size(), 0);
  triangles_.resize(chunks);
  objectTriangles_.resize(chunks);
  slotInstance_.resize(chunks);
  // The slot's mesh triangle, in order: instance by instance, padding repeating the run's last one.
  size_t run = 0;
  auto slotSource = [&](uint64_t slot, uint32_t& inst) -> const EngineMesh* {
    while (run < runs.size() && slot >= runs[run].first + runs[run].padded) ++run;
    inst = uint32_t(run);
    return &meshes[runs[run].mesh];
  };
  for (size_t c = 0; c < chunks; ++c) {
    const uint64_t first = uint64_t(c) * chunkTriangles_;
    const uint64_t count = std::min<uint64_t>(chunkTriangles_, total - std::min<uint64_t>(first, total));
    const uint64_t bytes = std::max<uint64_t>(count * 48, 16);
    triangles_[c] = vk::createBuffer(ctx_, bytes);
    objectTriangles_[c] = vk::createBuffer(ctx_, bytes);
    slotInstance_[c] = vk::createBuffer(ctx_, std::max<uint64_t>(count * 4, 16));
    if (count == 0) continue;
    std::vector<uint32_t> ids(count);
    vk::uploadInPlace(ctx_, objectTriangles_[c], count * 48, 0, [&](void* out) {
      glm::vec4 cluster[3 * CLUSTER_SIZE];
      for (uint64_t t = 0; t < count; t += CLUSTER_SIZE) {
        const uint64_t k = std::min<uint64_t>(CLUSTER_SIZE, count - t);
        uint32_t inst = 0;
        for (uint64_t j = 0; j < k; ++j) {
          const EngineMesh* mesh = slotSource(first + t + j, inst);
          const InstanceRun& r = runs[inst];
          const uint64_t within = std::min(first + t + j - r.first, r.count - 1);
          const uint32_t tri = order[r.mesh][within];
          for (int v = 0; v < 3; ++v) cluster[3 * j + v] = glm::vec4(mesh->positions[mesh->indices[3 * size_t(tri) + v]], 1.0f);
          ids[t + j] = inst;
        }
        const uint64_t index = (first + t) / CLUSTER_SIZE;
        objectClusters_[index] = traversal::clusterWorld(cluster, k);
        clusterInstance_[index] = inst;  // a cluster never mixes instances (runs are padded)
        std::memcpy(static_cast<glm::vec4*>(out) + 3 * t, cluster, 3 * k * sizeof(glm::vec4));
      }
    });
    vk::upload(ctx_, slotInstance_[c], ids.data(), count * 4);
  }
  runs_ = std::move(runs);
  transformRing_ = vk::createBuffer(ctx_, std::max<uint64_t>(uint64_t(framesInFlight_) * runs_.size() * 64, 16),
                                    vk::Memory::HostVisible);
  revision_ = {};
  hostPeakBytes_ = objectClusters_.size() * (sizeof(traversal::ClusterWorld) * 2 + 4);
  setTransforms(instances);
}

void TriangleLayout::setTransforms(std::span<const EngineInstance> instances) {
  CS_CHECK(instances.size() == runs_.size(), "cone engine: " << instances.size() << " transforms for "
                                                             << runs_.size() << " instances");
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (size_t i = 0; i < runs_.size(); ++i) {
    std::memcpy(runs_[i].transform, instances[i].transform, sizeof(runs_[i].transform));
    const InstanceRun& r = runs_[i];
    if (r.count == 0) continue;
    for (int corner = 0; corner < 8; ++corner) {
      const glm::dvec3 p((corner & 1) ? r.lo.x : r.hi.x, (corner & 2) ? r.lo.y : r.hi.y, (corner & 4) ? r.lo.z : r.hi.z);
      const glm::dvec3 w = identityTransform(r.transform) ? p : transformPoint(r.transform, p);
      const double pad = identityTransform(r.transform) ? 0 : std::ldexp(glm::length(w) + stretchOf(r.transform), -20);
      lo = glm::min(lo, w - pad), hi = glm::max(hi, w + pad);
    }
  }
  const bool any = lo.x <= hi.x;
  const auto down = [](double v) { const float f = float(v); return double(f) > v ? std::nextafter(f, -INFINITY) : f; };
  const auto up = [](double v) { const float f = float(v); return double(f) < v ? std::nextafter(f, INFINITY) : f; };
  boundsLo_ = any ? glm::vec3(down(lo.x), down(lo.y), down(lo.z)) : glm::vec3(0);
  boundsHi_ = any ? glm::vec3(up(hi.x), up(hi.y), up(hi.z)) : glm::vec3(0);
  clusterWorld_.resize(objectClusters_.size());
  for (size_t c = 0; c < objectClusters_.size(); ++c)
    clusterWorld_[c] = transformCluster(objectClusters_[c], runs_[clusterInstance_[c]].transform);
  transformsDirty_ = true;
  uploads_++;  // the spheres and far-frame triangles made for the old triangles are stale
}

// The cluster spheres' bytes updateClusterSpheres() allocates for the current triangles.
uint64_t TriangleLayout::expectedClusterSphereBytes() const {
  if (!options_.clusters || options_.twoPass || chunkTriangles_ < CLUSTER_SIZE) return 0;
  uint64_t bytes = 0;
  const uint64_t perBuffer = chunkTriangles_ / CLUSTER_SIZE, clusters = (triangleCount_ + CLUSTER_SIZE - 1) / CLUSTER_SIZE;
  for (uint64_t b = 0; b < triangles_.size(); ++b)
    bytes += std::max<uint64_t>(1, (std::min(perBuffer, clusters - std::min(clusters, b * perBuffer)) + SUPER_CLUSTERS - 1) / SUPER_CLUSTERS) *
             SUPER_SPHERES * sizeof(glm::vec4);
  return bytes;
}

uint64_t TriangleLayout::clusterSphereBytes() const {
  uint64_t n = 0;
  for (const SphereSet& set : sphereSets_)
    for (const vk::Buffer& b : set.buffers) n += b.size;
  return n;
}

// Whether the far frame's triangle copies predate the triangles or this frame's far frame (a static
// scene under a static light keeps them).
bool TriangleLayout::frameTrianglesStale(const cone::FrameChoice& choice) const {
  const cone::ConeFrame& a = choice.frame;
  const cone::ConeFrame& b = frameTrianglesOf_;
  return frameTrianglesUpload_ != uploads_ || a.rowX != b.rowX || a.rowY != b.rowY || a.rowZ != b.rowZ ||
         a.centre != b.centre || a.lightFrame != b.lightFrame;
}

// The far-light frame's copy of every triangle buffer (frame_triangles.comp), for the pass tests.
void TriangleLayout::recordFrameTriangles(vk::Commands& cmd, const cone::FrameChoice& choice) {
  frameTrianglesUpload_ = uploads_;
  frameTrianglesOf_ = choice.frame;
  frameTriangles_.resize(triangles_.size());
  for (size_t c = 0; c < triangles_.size(); ++c) {
    if (frameTriangles_[c].size < triangles_[c].size) {
      frameTriangles_[c].reset();
      frameTriangles_[c] = vk::createBuffer(ctx_, triangles_[c].size);
    }
    const uint64_t first = uint64_t(c) * chunkTriangles_;
    const uint32_t count = uint32_t(std::min<uint64_t>(chunkTriangles_, triangleCount_ - std::min<uint64_t>(first, triangleCount_)));
    if (count == 0) continue;
    traversal::FrameTrianglesPush p{};
    p.rowX = choice.frame.rowX, p.rowY = choice.frame.rowY, p.rowZ = choice.frame.rowZ;
    p.centre = choice.frame.centre;
    p.lightFrame = choice.frame.lightFrame;
    p.count = count;
    vk::Grid grid = vk::gridFor(count, TRAVERSE_THREADS, ctx_.maxWorkgroups());
    cmd.dispatch(frameTris_, {triangles_[c], frameTriangles_[c]}, p, grid.x, grid.y);
  }
  cmd.barrier();
}

// One buffer per `perBinding` triangles: a scene larger than one storage binding of the device
// (128 MiB on lavapipe: 2.8 M triangles) is traversed binding by binding (traverse()), and within one
// texel buffer's maxTexelBufferElements (the traversal reads them as texels, three a triangle).
void TriangleLayout::planChunks() {
  const uint64_t perBinding =
      options_.trianglesPerBinding
          ? options_.trianglesPerBinding
          : std::min<uint64_t>(ctx_.maxStorageBufferRange() / 48, ctx_.properties.limits.maxTexelBufferElements / 3);
  CS_CHECK(perBinding >= 1, "cone: a storage binding of this device cannot hold one triangle");
  chunkTriangles_ = uint32_t(std::min<uint64_t>(perBinding, UINT32_MAX));
  if (chunkTriangles_ >= SUPER_SIZE) chunkTriangles_ -= chunkTriangles_ % SUPER_SIZE;  // whole super clusters a buffer
  else if (chunkTriangles_ >= CLUSTER_SIZE) chunkTriangles_ -= chunkTriangles_ % CLUSTER_SIZE;  // whole clusters
}

// Uploads the scene's triangles (vec4 x 3, world space) when they changed (with two-pass, also when the
// light moved: the blockers, first in the buffer, depend on it). Triangles with a non-finite coordinate
// are dropped, as Embree drops them. Returns the wall ms, 0 if cached.
// The host working set stays small beside the scene: the buffers' order of the kept triangles (4 bytes
// each; 8 more while clusters sort them, 9 while two-pass ranks them), the cluster bounds, and one
// chunk of at most kUploadTriangles written into the buffers at a time. A change is seen from a 128-bit
// hash of the positions and the indices -- the frame's geometry revision (core/scene.h), computed once
// per frame by the harness -- not from a copy of them (hostPeakBytes_ counts all of it).
double TriangleLayout::upload(const FrameInput& frame) {
  const Scene& scene = *frame.scene;
  const GeometryRevision revision = revisionOf(frame);
  if (revision == revision_ && !triangles_.empty() && (!options_.twoPass || cachedLight_ == frame.light)) return 0.0;
  auto t0 = Clock::now();
  // The one geometry policy (checkGeometry), unless the camera pass's upload of this revision checked it.
  if (!frame.deviceScene) checkGeometry(scene);
  const size_t sceneTriangles = scene.indices.size() / 3;
  // The kept triangles and their bounds.
  const bool sameIndices = revision.indices == revision_.indices && droppedTriangles_ == 0;
  std::vector<uint32_t> previous;  // the last order: clusters keep it while the index list stays
  previous.swap(order_);
  if (!sameIndices) std::vector<uint32_t>().swap(previous);
  std::vector<uint32_t> kept;
  kept.reserve(sceneTriangles);
  glm::vec3 lo(INFINITY), hi(-INFINITY);
  for (size_t t = 0; t < sceneTriangles; ++t) {
    if (!finiteTriangle(scene, t)) continue;  // the policy: no geometry
    kept.push_back(uint32_t(t));
    for (int k = 0; k < 3; ++k) {
      lo = glm::min(lo, scene.positions[scene.indices[3 * t + k]]);
      hi = glm::max(hi, scene.positions[scene.indices[3 * t + k]]);
    }
  }
  droppedTriangles_ = sceneTriangles - kept.size();
  boundsLo_ = kept.empty() ? glm::vec3(0) : lo;
  boundsHi_ = kept.empty() ? glm::vec3(0) : hi;
  triangleCount_ = uint32_t(kept.size());
  auto vertex = [&](uint32_t t, int k) { return scene.positions[scene.indices[3 * size_t(t) + k]]; };

  constexpr uint64_t kTriangleBytes = 3 * sizeof(glm::vec4);
  planChunks();
  const size_t chunks = std::max<size_t>(1, (triangleCount_ + uint64_t(chunkTriangles_) - 1) / chunkTriangles_);
  const bool clusters = options_.clusters && !options_.twoPass;

  // The host working set of this upload, checked against the budget before any buffer is made.
  const uint64_t n = kept.size();
  const uint64_t chunkBytes = std::min<uint64_t>(kUploadTriangles, std::max<uint64_t>(n, 1)) * kTriangleBytes;
  const uint64_t orderBytes = n * sizeof(uint32_t);
  // two-pass: the solid angles, the blocker flags, the ranked candidates and the new order; clusters:
  // the Hilbert keys and the new order
  const uint64_t rankBytes = options_.twoPass ? n * (sizeof(double) + 1 + 2 * sizeof(uint32_t))
                             : clusters       ? n * (sizeof(uint64_t) + sizeof(uint32_t))
                                              : 0;
  const uint64_t boundsBytes = clusters ? (n + CLUSTER_SIZE - 1) / CLUSTER_SIZE * sizeof(traversal::ClusterWorld) : 0;
  // The vertices are written straight into the device buffer's mapping, or where device memory is not
  // host visible into the staging buffer (one chunk): the host holds no copy of them.
  const uint64_t staging = ctx_.hostVisibleDeviceLocal ? 0 : chunkBytes;
  hostPeakBytes_ = orderBytes + std::max({rankBytes, orderBytes, boundsBytes + staging});
  if (options_.memoryBudgetBytes) {
    uint64_t device = 0;
    for (size_t c = 0; c < chunks; ++c)
      device += std::max<uint64_t>(16, std::min<uint64_t>(chunkTriangles_, n - std::min<uint64_t>(n, c * chunkTriangles_)) * kTriangleBytes);
    if (device + hostPeakBytes_ > options_.memoryBudgetBytes)
      throw Error("--memory-budget " + byteSizeLabel(options_.memoryBudgetBytes) + " cannot hold this scene: its " +
                      std::to_string(n) + " triangles take " + byteSizeLabel(device) + " on the device (48 bytes each) and " +
                      byteSizeLabel(hostPeakBytes_) + " of host working set while they are uploaded",
                  "cone path", "give --memory-budget well above " + byteSizeLabel(device + hostPeakBytes_) +
                                   ": the frame's rays, tree and traversal come on top");
  }

  // The buffers' order of the kept triangles: blockers first (two-pass), Hilbert order of the centroids
  // (clusters; kept while the index list stays, so moving vertices keep their clusters), else scene order.
  if (options_.twoPass) orderBlockersFirst(kept, vertex, frame.light);
  else if (clusters) orderForClusters(kept, previous, vertex);
  order_.swap(kept);
  std::vector<uint32_t>().swap(kept);

  triangles_.resize(chunks);
  if (clusters) clusterWorld_.assign((n + CLUSTER_SIZE - 1) / CLUSTER_SIZE, traversal::ClusterWorld{});
  else std::vector<traversal::ClusterWorld>().swap(clusterWorld_);
  const uint64_t perChunk = chunkBytes / kTriangleBytes;  // a multiple of CLUSTER_SIZE or all triangles
  for (size_t c = 0; c < chunks; ++c) {
    const uint64_t first = uint64_t(c) * chunkTriangles_;
    const uint64_t count = std::min<uint64_t>(chunkTriangles_, n - std::min<uint64_t>(first, n));
    const uint64_t bytes = std::max<uint64_t>(count * kTriangleBytes, 16);
    if (triangles_[c].size < bytes || triangles_[c].size > 2 * bytes) {
      triangles_[c].reset();
      triangles_[c] = vk::createBuffer(ctx_, bytes);
    }
    for (uint64_t done = 0; done < count; done += perChunk) {
      const uint64_t m = std::min(perChunk, count - done);
      // A cluster's vertices at a time (chunks start on a cluster: perChunk and chunkTriangles_ are
      // multiples of it): its bounds from them, then written out, never read back from the mapping.
      vk::uploadInPlace(ctx_, triangles_[c], m * kTriangleBytes, done * kTriangleBytes, [&](void* out) {
        glm::vec4 cluster[3 * CLUSTER_SIZE];
        for (uint64_t t = 0; t < m; t += CLUSTER_SIZE) {
          const uint64_t k = std::min<uint64_t>(CLUSTER_SIZE, m - t);
          for (uint64_t i = 0; i < k; ++i)
            for (int v = 0; v < 3; ++v) cluster[3 * i + v] = glm::vec4(vertex(order_[first + done + t + i], v), 1.0f);
          if (clusters) clusterWorld_[(first + done + t) / CLUSTER_SIZE] = traversal::clusterWorld(cluster, k);
          std::memcpy(static_cast<glm::vec4*>(out) + 3 * t, cluster, 3 * k * sizeof(glm::vec4));
        }
      });
    }
  }
  revision_ = revision;
  uploads_++;
  cachedLight_ = frame.light;
  return msSince(t0);
}

// Clusters (traversal.h, "Clusters"): the triangles in Hilbert order of their centroids on a grid of
// 2^10 cubes a side over the bounds, so every CLUSTER_SIZE consecutive ones are one piece of space and
// their sphere is small (cubes, not the bounds' box: docs/ARCHITECTURE.md, "The triangle layout"). The
// previous order is kept when there is one (the same index list, no triangle dropped: moving vertices
// keep their clusters, whose spheres follow them).
template <class Vertex>
void TriangleLayout::orderForClusters(std::vector<uint32_t>& kept, std::vector<uint32_t>& previous, const Vertex& vertex) {
  if (previous.size() == kept.size() && kept.size() > 0) {
    kept.swap(previous);
    return;
  }
  std::vector<uint32_t>().swap(previous);
  const glm::vec3 lo = boundsLo_, size = boundsHi_ - boundsLo_;
  const glm::vec3 ext(std::max({size.x, size.y, size.z, 1e-30f}));  // cubes
  std::vector<uint64_t> keys(kept.size());  // Hilbert position, then the position in scene order: stable
  for (size_t t = 0; t < kept.size(); ++t) {
    const glm::vec3 c = (vertex(kept[t], 0) + vertex(kept[t], 1) + vertex(kept[t], 2)) / 3.0f;
    const glm::vec3 u = glm::clamp((c - lo) / ext, 0.0f, 1.0f) * 1023.0f;
    const uint32_t code = traversal::hilbertIndex3(uint32_t(u.x), uint32_t(u.y), uint32_t(u.z), 10);
    keys[t] = (uint64_t(code) << 32) | t;
  }
  std::sort(keys.begin(), keys.end());
  std::vector<uint32_t> ordered(kept.size());
  for (size_t t = 0; t < kept.size(); ++t) ordered[t] = kept[uint32_t(keys[t])];
  kept.swap(ordered);
}

// The clusters' spheres relative to the light in the pass tests' coordinates (the world, or the far
// frame through its fp32 rows), written to host-visible buffers when the triangles or the frame
// changed. Padded by 2^-16 of the magnitudes: the GPU's vertices are fp32 differences of up to those
// magnitudes (v - light, or S R (v - C) - S R (light - C)), a few ulp off the exact ones.
void TriangleLayout::updateClusterSpheres(glm::vec3 light, uint32_t slot, const cone::FrameChoice& choice) {
  const cone::ConeFrame& f = choice.frame;
  if (sphereSets_.size() <= slot) sphereSets_.resize(slot + 1);
  SphereSet& set = sphereSets_[slot];
  if (set.upload == uploads_ && set.light == light && set.far == choice.far && set.of.rowX == f.rowX &&
      set.of.rowY == f.rowY && set.of.rowZ == f.rowZ && set.of.centre == f.centre && set.of.lightFrame == f.lightFrame)
    return;
  set.upload = uploads_, set.light = light, set.far = choice.far;
  set.of = f;
  const size_t perBuffer = chunkTriangles_ / CLUSTER_SIZE;
  std::vector<vk::Buffer>& clusterSpheres_ = set.buffers;
  clusterSpheres_.resize(triangles_.size());
  const glm::dvec3 C(glm::vec3(f.centre)), LF(glm::vec3(f.lightFrame)), L(light);
  auto sphere = [&](glm::dvec3 c, double r) {
    if (choice.far)
      return traversal::clusterSphereFar(cone::toConeFrameExact(c, f) - LF, r,
                                         glm::length(c - C) + r + glm::length(glm::dvec2(LF)));
    return traversal::clusterSphere(c - L, r, glm::length(c) + r + glm::length(L));
  };
  for (size_t b = 0; b < triangles_.size(); ++b) {
    const size_t first = b * perBuffer, end = std::min(clusterWorld_.size(), first + perBuffer);
    const size_t supers = std::max<size_t>(1, (end - std::min(first, end) + SUPER_CLUSTERS - 1) / SUPER_CLUSTERS);
    const uint64_t bytes = supers * SUPER_SPHERES * sizeof(glm::vec4);
    if (clusterSpheres_[b].size < bytes) {
      clusterSpheres_[b].reset();
      clusterSpheres_[b] = vk::createBuffer(ctx_, bytes, vk::Memory::HostVisible);
    }
    // Written straight into the mapping, never read back (no host copy of the spheres): per super
    // cluster its sphere (holding its clusters' world spheres), then each cluster's and its groups'.
    glm::vec4* out = static_cast<glm::vec4*>(clusterSpheres_[b].mapped);
    // Every slot is written below but a last super cluster's missing clusters', never read: zeroed once.
    std::fill_n(out + (supers - 1) * SUPER_SPHERES, SUPER_SPHERES, glm::vec4(0));
    auto write = [&, first, end, out](size_t from, size_t to) {  // super clusters [from, to) of the buffer
      for (size_t i = from; i < to; ++i) {
        const size_t k = first + i * SUPER_CLUSTERS, last = std::min(end, k + SUPER_CLUSTERS);
        if (k >= last) break;
        glm::vec4* at = out + i * SUPER_SPHERES;
        const glm::dvec4 s = traversal::superBounds(&clusterWorld_[k], last - k);
        at[0] = sphere(glm::dvec3(s), s.w);
        for (size_t q = k; q < last; ++q) {
          const traversal::ClusterWorld& w = clusterWorld_[q];
          glm::vec4* c = at + 1 + CLUSTER_SPHERES * (q - k);
          c[0] = sphere(glm::dvec3(w.whole), w.whole.w);
          for (uint32_t g = 0; g < CLUSTER_GROUPS; ++g) c[1 + g] = sphere(glm::dvec3(glm::vec3(w.groups[g])), w.groups[g].w);
        }
      }
    };
    // On the host's cores, a run of at least 8192 super clusters each (docs/ARCHITECTURE.md, "The triangle
    // layout"); where a thread cannot start, this one does its share.
    const size_t hw = std::max(1u, std::thread::hardware_concurrency());
    const size_t parts = std::clamp<size_t>(supers / 8192, 1, std::min<size_t>(hw, 16));
    std::vector<std::thread> threads;
    for (size_t t = 1; t < parts; ++t) {
      const size_t from = supers * t / parts, to = supers * (t + 1) / parts;
      try {
        threads.emplace_back(write, from, to);
      } catch (...) {  // (std::system_error; or no memory for the thread list)
        write(from, to);
      }
    }
    write(0, supers / parts);
    for (std::thread& th : threads) th.join();
  }
}

// Two-pass blockers (docs/ARCHITECTURE.md, "The cone path's settings"): triangles subtending at least blockerSolidAngle at the light, the
// largest blockerMaxFraction of all at most, moved to the front in their scene order; sets blockerCount_.
template <class Vertex>
void TriangleLayout::orderBlockersFirst(std::vector<uint32_t>& kept, const Vertex& vertex, glm::vec3 light) {
  const size_t n = kept.size();
  std::vector<double> omega(n);
  const glm::dvec3 l(light);
  for (size_t t = 0; t < n; ++t)
    omega[t] = solidAngle(glm::dvec3(vertex(kept[t], 0)) - l, glm::dvec3(vertex(kept[t], 1)) - l,
                          glm::dvec3(vertex(kept[t], 2)) - l);
  size_t candidates = 0;
  for (size_t t = 0; t < n; ++t) candidates += omega[t] >= double(options_.blockerSolidAngle);
  const size_t cap = size_t(std::floor(double(options_.blockerMaxFraction) * double(n)));
  std::vector<uint8_t> isBlocker(n, 0);
  if (candidates <= cap) {
    for (size_t t = 0; t < n; ++t) isBlocker[t] = omega[t] >= double(options_.blockerSolidAngle);
  } else if (cap > 0) {  // the largest `cap`, ties broken by scene order: deterministic
    std::vector<uint32_t> rank;
    rank.reserve(candidates);
    for (size_t t = 0; t < n; ++t)
      if (omega[t] >= double(options_.blockerSolidAngle)) rank.push_back(uint32_t(t));
    auto larger = [&](uint32_t a, uint32_t b) { return omega[a] != omega[b] ? omega[a] > omega[b] : a < b; };
    std::nth_element(rank.begin(), rank.begin() + cap, rank.end(), larger);
    for (size_t k = 0; k < cap; ++k) isBlocker[rank[k]] = 1;
    candidates = cap;
  } else {
    candidates = 0;
  }
  std::vector<uint32_t> ordered;
  ordered.reserve(n);
  for (int pass = 1; pass >= 0; --pass)
    for (size_t t = 0; t < n; ++t)
      if (isBlocker[t] == pass) ordered.push_back(kept[t]);
  kept.swap(ordered);
  blockerCount_ = uint32_t(candidates);
}

// The buffers of the geometry being replaced, kept until no frame in flight can read them.
void TriangleLayout::retireGeometry() {
  for (std::vector<vk::Buffer>* list : {&triangles_, &objectTriangles_, &slotInstance_, &frameTriangles_})
    for (vk::Buffer& b : *list)
      if (b) retiring_.push_back(std::move(b));
  triangles_.clear(), objectTriangles_.clear(), slotInstance_.clear(), frameTriangles_.clear();
  if (transformRing_) retiring_.push_back(std::move(transformRing_));
  for (SphereSet& set : sphereSets_) {
    for (vk::Buffer& b : set.buffers)
      if (b) retiring_.push_back(std::move(b));
    set = SphereSet{};
  }
}

// The instances' transforms into this frame's ring slot, and every slot's world vertices from them.
void TriangleLayout::recordTransforms(vk::Commands& cmd, uint32_t slot) {
  glm::vec4* rows = static_cast<glm::vec4*>(transformRing_.mapped) + uint64_t(slot) * runs_.size() * 4;
  for (size_t i = 0; i < runs_.size(); ++i) {
    const float* m = runs_[i].transform;
    rows[4 * i] = {m[0], m[1], m[2], m[3]};
    rows[4 * i + 1] = {m[4], m[5], m[6], m[7]};
    rows[4 * i + 2] = {m[8], m[9], m[10], m[11]};
    rows[4 * i + 3] = {identityTransform(m) ? 1.0f : 0.0f, 0, 0, 0};
  }
  const uint64_t ringBytes = std::max<uint64_t>(runs_.size() * 64, 16);
  for (size_t c = 0; c < triangles_.size(); ++c) {
    const uint64_t first = uint64_t(c) * chunkTriangles_;
    const uint32_t count = uint32_t(std::min<uint64_t>(chunkTriangles_, triangleCount_ - std::min<uint64_t>(first, triangleCount_)));
    if (count == 0) continue;
    traversal::TraversePush p{};
    p.count = count;
    const vk::Grid grid = vk::gridFor(count, TRAVERSE_THREADS, ctx_.maxWorkgroups());
    cmd.dispatch(instanceTriangles_,
                 {objectTriangles_[c], slotInstance_[c],
                  vk::BufferRange(transformRing_, uint64_t(slot) * runs_.size() * 64, ringBytes), triangles_[c]},
                 p, grid.x, grid.y);
  }
  cmd.barrier();
  transformsDirty_ = false;
}

std::vector<vk::Buffer> TriangleLayout::takeRetired() {
  std::vector<vk::Buffer> out = std::move(retiring_);
  retiring_.clear();
  return out;
}

uint64_t TriangleLayout::bytes() const {
  uint64_t triangleBytes = 0;
  for (const vk::Buffer& b : triangles_) triangleBytes += b.size;
  for (const vk::Buffer& b : frameTriangles_) triangleBytes += b.size;
  for (const vk::Buffer& b : objectTriangles_) triangleBytes += b.size;
  for (const vk::Buffer& b : slotInstance_) triangleBytes += b.size;
  return triangleBytes + transformRing_.size;
}

}  // namespace cs
