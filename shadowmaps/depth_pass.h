// shadowmaps/: the geometry pass the four shadow maps share (cube_sm, rmsm, asm, rtw). Renders the scene
// as seen from the light into a texel window of one cube face — a whole face for the cube shadow map, a
// superpage for RMSM, a node's window for ASM (and, with --asm-id-test, the triangle nearest the light
// per texel), for RTW the light's low-resolution depth image its forward and hybrid analyses read and a
// whole face through the warp maps (recordWarped) — storing the linear distance to the light (R32F; a
// D32 reversed-Z buffer with an infinite far plane picks the nearest fragment), then copies rectangles
// of it into storage buffers. The long form: docs/ARCHITECTURE.md, "Stage notes", shadowmaps/.
//
// Why linear distance: for an omnidirectional light the six faces must agree where they meet, and a
// distance is the same number whichever face (or level) stored it, so one bias rule serves every face
// and every level; fp32 distance keeps 24 bits of relative precision at any range, where a
// perspective depth would spend them near the light.
#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "core/scene.h"
#include "method/method.h"
#include "raster/raster.h"
#include "vk/context.h"

namespace cs::sm {

// The clip transform of a window of face `face` at `res` texels a side: texel column x0 + i (row y0 + j)
// of the face lands on column i (row j) of a w x h viewport. Points are light-relative. z_clip = near,
// w_clip = z_f: depth = near / z_f (reversed, infinite far), and points nearer than `near` are clipped.
glm::mat4 windowClip(uint32_t face, double res, double x0, double y0, double w, double h, float nearPlane);

// Frustum culling: the triangles are grouped into clusters of kClusterTriangles consecutive ones (index
// order; meshes are mostly spatially coherent in it), each bounded by a sphere computed when the geometry
// is uploaded. A pass draws only the runs of clusters whose sphere meets the window's frustum (four planes
// through the light and the near plane) — the culling paper 000 §4.4 leaves as future work. Host work is
// per cluster and per pass, never per sample or per triangle.
inline constexpr uint32_t kClusterTriangles = 64;

// A shadow-map quadtree's fitted faces (RMSM, ASM): per face (s0, t0, zoom, 0), the window of the face
// that what the box [lo, hi] projects to fits in -- zoom a power of two, s0 and t0 multiples of
// 1 / (page * zoom), so every level's window starts on a whole texel; (0, 0, 1, 0), the whole face, when
// the box reaches the face's apex plane (a light inside or beside it). zoom * maxRes <= 2^22: (s, t) are
// fp32, a quarter texel at the finest level. Lookups map face (s, t) to window (s, t) with windowST.
std::array<glm::vec4, 6> fitWindows(glm::vec3 light, glm::vec3 lo, glm::vec3 hi, uint32_t page, uint32_t maxRes);

class DepthPass {
 public:
  // triangleIds: every target also holds, per texel, the index of the scene triangle nearest the light
  // (R32UI, CS_NO_TRIANGLE where none; depth_id.frag), for ASM's ID + depth test. Needs the device's
  // geometryShader feature (an Error naming it otherwise); the warped pass (RTW) does not write them.
  explicit DepthPass(vk::Context& ctx, bool culling = true, bool triangleIds = false);
  ~DepthPass();
  DepthPass(const DepthPass&) = delete;
  DepthPass& operator=(const DepthPass&) = delete;

  // The scene's triangles, when their revision (core/scene.h) differs from the last call's: drawn from
  // `shared` (the camera pass's DeviceScene, FrameInput::deviceScene) when given, which must hold the
  // scene's revision, else from the pass's own upload; the draw clusters and bounds recomputed. Returns
  // wall ms, 0 exactly when the geometry is unchanged (a change returns > 0).
  double setGeometry(const Scene& scene, const DeviceScene* shared = nullptr);
  // From a frame: its scene, its revision when the harness computed one, and its shared geometry.
  double setGeometry(const FrameInput& frame);
  // Square colour + depth targets: `largest` texels a side, then halving ((largest - 1) / 2 + 1: 1025,
  // 513, ..., so windows of 2^k + 1 texels fit) down to no less than `smallest`. Each pass renders into
  // the smallest target its window fits: a render pass costs in proportion to its framebuffer on some
  // drivers (lavapipe bins the whole framebuffer), so small windows must not pay for a large target.
  // Recreated only when the sizes change.
  void ensureTargets(uint32_t largest, uint32_t smallest);
  uint32_t largestTarget() const { return targets_.empty() ? 0 : targets_.back().size; }

  // One geometry pass: the texel window [x0, x0 + w) x [y0, y0 + h) of face `face` at `res` texels a side
  // into the target's top-left w x h texels; texels no triangle covers hold SM_EMPTY_DEPTH.
  void recordWindow(vk::Commands& cmd, uint32_t face, double res, uint32_t x0, uint32_t y0, uint32_t w,
                    uint32_t h, glm::vec3 light, float nearPlane);
  // RTW (rtw.h): one geometry pass of face `face` whose vertices move through the face's warp maps
  // (`warp`, rtw_shared.h layout, `cells` super-cells an axis; depth_warp.geom clips each triangle to the
  // face first) into the target's top-left `resolution`² texels. tessTexels > 0: triangles whose warped
  // edges are longer are subdivided. Needs the device's geometryShader feature (Error naming it if not).
  // Clusters are culled against the whole face.
  void recordWarped(vk::Commands& cmd, uint32_t face, uint32_t resolution, const vk::Buffer& warp, uint32_t cells,
                    glm::vec3 light, float nearPlane, float tessTexels);
  // Copies rectangles of the target the last recordWindow or recordWarped rendered into `dst` (4-byte
  // texels). No barrier: the caller adds one before reading `dst`.
  void recordCopy(vk::Commands& cmd, const std::vector<VkBufferImageCopy>& regions, const vk::Buffer& dst);
  // The same rectangles of the triangle-ID target (4-byte texels); only with triangleIds.
  void recordCopyIds(vk::Commands& cmd, const std::vector<VkBufferImageCopy>& regions, const vk::Buffer& dst);
  bool triangleIds() const { return triangleIds_; }

  uint32_t triangleCount() const { return indexCount_ / 3; }
  // Bounds of the uploaded geometry's finite positions (computed with each upload; lo > hi when none):
  // what the shadow maps fit their faces to.
  glm::vec3 boundsLo() const { return boundsLo_; }
  glm::vec3 boundsHi() const { return boundsHi_; }
  // Triangles drawn by the passes recorded since the last call (culling's effect); resets the count.
  uint64_t takeTrianglesDrawn() { uint64_t n = drawn_; drawn_ = 0; return n; }
  uint64_t geometryBytes() const { return own_.bytes(); }  // the shared geometry is the camera pass's
  uint64_t targetBytes() const { return targetBytes_; }
  uint64_t bytesAllocated() const { return geometryBytes() + targetBytes_; }

 private:
  void createPipeline();
  void createWarpedPipeline();
  void destroyTargets();
  // Begins the render pass on the smallest target holding w x h, viewport and scissor set.
  VkCommandBuffer beginPass(vk::Commands& cmd, uint32_t w, uint32_t h);
  // Draws the clusters whose sphere meets the frustum u in [u0, u1], v in [v0, v1], z_f >= near of face
  // `face` (all triangles without culling); the pipeline and its constants are bound.
  void drawClusters(VkCommandBuffer cb, uint32_t face, double u0, double u1, double v0, double v1, glm::vec3 light,
                    float nearPlane);

  struct Cluster {
    glm::vec3 center{0};
    float radius = 0;
    uint32_t firstIndex = 0, indexCount = 0;
  };

  vk::Context& ctx_;
  bool culling_;
  bool triangleIds_;
  std::vector<Cluster> clusters_;
  uint64_t drawn_ = 0;
  DeviceScene own_;                      // the pass's own upload, when no shared geometry is given
  const DeviceScene* draw_ = nullptr;    // what the passes draw: the shared geometry or own_
  GeometryRevision revision_;            // of the clusters and bounds below
  uint32_t indexCount_ = 0;
  glm::vec3 boundsLo_{INFINITY}, boundsHi_{-INFINITY};
  VkRenderPass renderPass_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
  VkShaderModule vert_ = VK_NULL_HANDLE, frag_ = VK_NULL_HANDLE;
  // The warped pass (RTW), made on first use.
  VkDescriptorSetLayout warpedSet_ = VK_NULL_HANDLE;
  VkPipelineLayout warpedLayout_ = VK_NULL_HANDLE;
  VkPipeline warpedPipeline_ = VK_NULL_HANDLE;
  VkShaderModule warpedVert_ = VK_NULL_HANDLE, warpedGeom_ = VK_NULL_HANDLE, warpedFrag_ = VK_NULL_HANDLE;
  struct Target {
    vk::Image color, ids, depth;  // ids: only with triangleIds
    VkFramebuffer framebuffer = VK_NULL_HANDLE;
    uint32_t size = 0;
  };
  std::vector<Target> targets_;  // ascending sizes
  size_t current_ = 0;           // the target of the last recordWindow
  uint64_t targetBytes_ = 0;
};

}  // namespace cs::sm
