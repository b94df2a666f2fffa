// The cone path's triangles on the device: the upload (finite triangles in Hilbert order of their centroids,
// or blockers first for two-pass), the buffers a storage binding each, the clusters' bounds and their
// spheres a (frame in flight, light), the far frame's copies, and the engine's meshes and instances (a run
// of slots an instance, transformed on the device). docs/ARCHITECTURE.md, "The triangle layout".
#pragma once
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "conetree/conetree.h"
#include "core/scene.h"
#include "method/method.h"
#include "traversal/cone_method.h"
#include "traversal/traversal.h"
#include "vk/context.h"

namespace cs {

// A mesh in its own space and an instance of it (row-major 3x4: world = M (x, y, z, 1)).
struct EngineMesh {
  const glm::vec3* positions = nullptr;
  size_t vertexCount = 0;
  const uint32_t* indices = nullptr;  // three a triangle, each < vertexCount (checked by the caller)
  size_t indexCount = 0;
};
struct EngineInstance {
  uint32_t mesh = 0;
  float transform[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
};

class TriangleLayout {
 public:
  TriangleLayout(vk::Context& ctx, const ConeOptions& options);

  // The scene's triangles (vec4 x 3, world space), uploaded when their revision changed (with two-pass,
  // also when the light moved: the blockers, first in the buffers, depend on it). Returns the wall ms, 0
  // when nothing was uploaded.
  double upload(const FrameInput& frame);
  // The engine's geometry: every used mesh uploaded once in its own space, each instance a run of slots
  // padded to whole super clusters; `framesInFlight` transform slots.
  void setInstances(std::span<const EngineMesh> meshes, std::span<const EngineInstance> instances,
                    uint32_t framesInFlight);
  // New transforms for the same instances: the clusters' bounds transformed on the host, the triangles at
  // the next recordTransforms.
  void setTransforms(std::span<const EngineInstance> instances);
  bool transformsDirty() const { return transformsDirty_; }
  // The transforms into `slot` of the ring, and the world triangles from them.
  void recordTransforms(vk::Commands& cmd, uint32_t slot);
  // Buffers a replaced geometry left, for the caller to keep until no frame in flight reads them.
  std::vector<vk::Buffer> takeRetired();

  // The far frame's copies of the triangles: stale when they predate the triangles or `frame`'s rotation.
  bool frameTrianglesStale(const cone::FrameChoice& frame) const;
  void recordFrameTriangles(vk::Commands& cmd, const cone::FrameChoice& frame);

  // The clusters' spheres relative to `light` in `frame`'s coordinates, into sphere set `slot`
  // (host written; kept while the triangles, the light and the frame stay).
  void updateClusterSpheres(glm::vec3 light, uint32_t slot, const cone::FrameChoice& frame);
  void resizeSphereSets(size_t count) { sphereSets_.resize(count); }
  size_t sphereSetCount() const { return sphereSets_.size(); }
  const vk::Buffer* clusterSpheres(uint32_t slot, size_t buffer) const { return &sphereSets_[slot].buffers[buffer]; }
  uint64_t clusterSphereBytes() const;
  // The bytes updateClusterSpheres() allocates a set for the current triangles.
  uint64_t expectedClusterSphereBytes() const;

  // Calls fn with `in` narrowed to each triangle buffer that triangles [first, first + count) fall in
  // (one, unless the scene exceeds a storage binding).
  template <class Fn>
  void forEachTriangleBuffer(traversal::TraversalInput in, uint32_t first, uint32_t count,
                             const cone::FrameChoice& frame, Fn&& fn) {
    const uint64_t end = uint64_t(first) + count;
    for (uint64_t c = first / chunkTriangles_; c < triangles_.size() && c * chunkTriangles_ < end; ++c) {
      const uint64_t lo = std::max<uint64_t>(first, c * chunkTriangles_);
      const uint64_t hi = std::min<uint64_t>(end, (c + 1) * uint64_t(chunkTriangles_));
      if (lo >= hi) continue;
      in.triangles = &triangles_[c];
      in.frameTriangles = frame.far ? &frameTriangles_[c] : nullptr;
      in.coneScale = frame.scale;
      in.firstTriangle = uint32_t(lo - c * chunkTriangles_);
      in.triangleCount = uint32_t(hi - lo);
      fn(in);
    }
  }

  const std::vector<vk::Buffer>& triangles() const { return triangles_; }
  uint32_t triangleCount() const { return triangleCount_; }
  uint64_t droppedTriangles() const { return droppedTriangles_; }
  uint32_t chunkTriangles() const { return chunkTriangles_; }
  uint32_t blockerCount() const { return blockerCount_; }  // two-pass: triangles [0, blockerCount) are blockers
  glm::vec3 boundsLo() const { return boundsLo_; }
  glm::vec3 boundsHi() const { return boundsHi_; }
  uint64_t hostPeakBytes() const { return hostPeakBytes_; }  // the last upload's host working set
  // Device bytes of the triangles, their far-frame copies and the instances' buffers (not the spheres).
  uint64_t bytes() const;

 private:
  void planChunks();
  template <class Vertex>
  void orderForClusters(std::vector<uint32_t>& kept, std::vector<uint32_t>& previous, const Vertex& vertex);
  template <class Vertex>
  void orderBlockersFirst(std::vector<uint32_t>& kept, const Vertex& vertex, glm::vec3 light);
  void retireGeometry();

  vk::Context& ctx_;
  ConeOptions options_;
  std::vector<vk::Buffer> triangles_;  // chunkTriangles_ triangles each (the last: the rest)
  uint32_t chunkTriangles_ = 1;
  uint32_t triangleCount_ = 0;
  uint64_t droppedTriangles_ = 0;
  GeometryRevision revision_;       // of the uploaded scene
  std::vector<uint32_t> order_;     // scene triangle (the kept ones) of each triangle buffer slot, in order
  uint64_t hostPeakBytes_ = 0;      // host working set of the last upload
  glm::vec3 cachedLight_{0};
  glm::vec3 boundsLo_{0}, boundsHi_{0};  // of the uploaded (finite) triangles
  uint64_t uploads_ = 0;                 // triangle uploads so far
  uint32_t blockerCount_ = 0;
  std::vector<traversal::ClusterWorld> clusterWorld_;  // per cluster: its world bound and its groups'
  std::vector<vk::Buffer> frameTriangles_;             // far frame: the triangles relative to the light in the frame
  uint64_t frameTrianglesUpload_ = ~uint64_t(0);       // the upload and the frame frameTriangles_ were made for
  cone::ConeFrame frameTrianglesOf_{};
  vk::Kernel frameTris_;
  // The clusters' spheres of one light of one frame (per triangle buffer), host written when the frame is
  // recorded: one set a (frame in flight, light) so that no set is rewritten while a frame reads it.
  struct SphereSet {
    std::vector<vk::Buffer> buffers;
    uint64_t upload = ~uint64_t(0);  // the triangles, the light and the frame they were made for
    glm::vec3 light{0};
    bool far = false;
    cone::ConeFrame of{};
  };
  std::vector<SphereSet> sphereSets_ = std::vector<SphereSet>(1);
  // An instance's run of triangle slots: its mesh's kept triangles (count), padded to whole super clusters,
  // the mesh's bounds of them and the instance's transform.
  struct InstanceRun {
    uint32_t mesh = 0;
    uint64_t first = 0, count = 0, padded = 0;
    glm::vec3 lo{0}, hi{0};
    float transform[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  };
  std::vector<InstanceRun> runs_;
  std::vector<vk::Buffer> objectTriangles_, slotInstance_;  // per triangle buffer: the mesh-space vertices, the instances
  std::vector<traversal::ClusterWorld> objectClusters_;    // per cluster, in its mesh's space
  std::vector<uint32_t> clusterInstance_;                   // per cluster, its instance
  vk::Buffer transformRing_;                                // per frame in flight: 4 vec4 an instance
  uint32_t framesInFlight_ = 0;
  bool transformsDirty_ = false;
  std::vector<vk::Buffer> retiring_;  // replaced buffers, until the next frame's slot holds them
  vk::Kernel instanceTriangles_;
};

}  // namespace cs
