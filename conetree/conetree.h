// conetree/: the cone hierarchy over the shadow rays of one frame (002 §3.1, §3.5, §4.3). The leaves are
// the sorted rays -- a pixel index each, nothing more: a leaf's ray is rebuilt from the light and the
// sample's position (leafRay in cone_math.h). Interior nodes are cones with their apex at the light
// (ConeNode in cone_layout.h), built bottom-up four consecutive elements at a time, one dispatch per depth
// (on the device path, the top depths of at most CONE_TOP_NODES nodes in one), into an implicit left-balanced 4-way tree whose index maths (levels, children, leaf ranges) is in
// cone_layout.h. Knows nothing about who walks the tree.
#pragma once
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "conetree/cone_layout.h"
#include "vk/context.h"

namespace cs::cone {

// The shape of the implicit tree over `leaves` rays (pure; leaves >= 1).
struct TreeShape {
  uint32_t leaves = 0;
  uint32_t depth = 0;                 // depth of the leaves (treeDepth); interior depths 0 .. depth-1
  std::vector<uint32_t> counts;       // counts[d] = elements at depth d, d = 0 .. depth (counts[depth] = leaves)
  std::vector<uint32_t> offsets;      // offsets[d] = first slot of depth d in the node array, d = 0 .. depth
  uint32_t nodes() const { return offsets.empty() ? 0 : offsets.back(); }  // interior nodes stored
};
TreeShape treeShape(uint32_t leaves);
// Interior nodes stored for `leaves` rays: treeShape(leaves).nodes() without the shape's arrays, so sizing
// a recording allocates nothing on the host.
uint32_t treeNodes(uint32_t leaves);

// The frame the cones are built and tested in (cone_layout.h, ConeFrame; traversal/traversal.h,
// "Far-light frame"), with the slack that covers the difference between the frame's geometry and the
// world geometry the leaf test sees.
struct FrameChoice {
  ConeFrame frame;          // the world frame: identity rows, C = 0, scale 1, lightFrame = the light
  bool far = false;
  float scale = 1.0f;       // the frame's angular scale, min(1, 4 tan Θ) (frame.centre.w)
  float sigma = 0.0f;       // lateral slack: 2^-16 of the scene's bounding diagonal (far frame)
  float beta = 0.0f;        // sigma over the nearest distance from the light to the bounds, as an angle
  glm::vec4 keyRect{0};     // far frame: the bounds' projection (u0, v0, 1/(u1-u0), 1/(v1-v0)) for ray keys
  double distance = 0;      // from the light to the centre of the bounds
};
// The far-light frame when the light is at least kFarFrameRatio half-diagonals from the centre of the
// bounds [lo, hi] (Θ <= 7.2 degrees), else the world frame.
constexpr double kFarFrameRatio = 8.0;
FrameChoice chooseFrame(glm::vec3 light, glm::vec3 lo, glm::vec3 hi);
// The frame's map in double, with its fp32 rows, centre and shear as stored: S R (x - C), what
// toConeFrame (cone_math.h) computes in fp32. The host's exact side of the frame (the light, the keys'
// rectangle, the clusters' spheres).
glm::dvec3 toConeFrameExact(glm::dvec3 x, const ConeFrame& f);
FrameChoice worldFrame(glm::vec3 light);

class ConeTree {
 public:
  explicit ConeTree(vk::Context& ctx);

  // Records the build over the first `count` entries of `samples` (pixel indices in ray order) whose
  // positions are in `positions` (vec4 per pixel): one dispatch per depth, bottom-up, a barrier after each.
  // Rays not longer than minLength (2 eps: an empty hit interval) or not finite are in no cone.
  // Grows the node buffer when needed; count must be >= 1 and <= kMaxLeaves. `samples` starts on a
  // 16-byte boundary (the leaves' level reads four pixel indices at a time).
  void record(vk::Commands& cmd, const vk::Buffer& positions, const vk::BufferRange& samples, uint32_t count,
              glm::vec3 light, float minLength, const FrameChoice* frame = nullptr);

  // The same build with the ray count on the GPU (word `countIndex` of `countWords`, clamped to
  // `maxCount`): tree_shape.comp writes the shape (shapeBuffer(), SHAPE_* words of cone_layout.h); every
  // height below topHeight(maxCount) is an indirect dispatch, and the heights from topHeight(count) up
  // are one (tree_top.comp, a single workgroup, levels in shared memory); nothing is read
  // back, and the node buffer is sized for maxCount rays (so a frame allocates nothing once warm).
  // shape() is not known on the host afterwards: setShape() sets it when the count has been read back.
  // With keepWhenZero, a device count of 0 builds nothing and leaves the shape and nodes of the build
  // recorded before (a rebuild the GPU decided against).
  // With recordsGiven, rays() already holds the sorted rays' records (rayRecords(), written by
  // rays::LitRays::recordSort from the same order as `samples`): the level above the rays reads them
  // instead of gathering the positions by `samples` and storing the records.
  void recordDevice(vk::Commands& cmd, const vk::Buffer& positions, const vk::BufferRange& samples,
                    const vk::Buffer& countWords, uint32_t countIndex, uint32_t maxCount, glm::vec3 light,
                    float minLength, const FrameChoice* frame = nullptr, bool keepWhenZero = false,
                    bool recordsGiven = false, VkBuffer gate = VK_NULL_HANDLE, VkDeviceSize gateOffset = 0);
  // After a device build: writes words firstWord + 2 d (uint64, even firstWord) of `words`, for each
  // depth d of the tree, the sum over its nodes of (1 - cos(half-angle)) / scale^2 in CONE_SPREAD_UNIT
  // fixed point, estimated from CONE_SPREAD_SAMPLES strided nodes on a larger depth (tree_spread.comp).
  // scale: the frame's angular scale (FrameChoice::scale; in (0, 1]), so a far light's narrow cones
  // still register. Words of depths the tree does not have are left as they are.
  void recordSpread(vk::Commands& cmd, const vk::Buffer& words, uint32_t firstWord, float scale = 1.0f);
  // The host's copy of the shape after a device build (`leaves` from shapeBuffer()); 0: no tree.
  void setShape(uint32_t leaves);
  const vk::Buffer& shapeBuffer() const { return shapeWords_; }
  // Depth of the deepest tree the last recording allowed for (recordDevice: treeDepth(maxCount)).
  uint32_t maxDepth() const { return maxDepth_; }

  const TreeShape& shape() const { return shape_; }
  const vk::Buffer& nodes() const { return nodes_; }
  // Per sorted ray of the last build: uvec4(float bits of the sample's position, its pixel index), written
  // as the depth above the rays reads them, so the leaves fetch one RGBA32UI texel a ray.
  const vk::Buffer& rays() const { return rays_; }
  // rays(), sized for up to maxCount rays, for a producer of the records before a recordDevice of as many
  // (its recordsGiven).
  const vk::Buffer& rayRecords(uint32_t maxCount) {
    ensureNodes(maxCount);
    return rays_;
  }
  // The sample boxes of the interior nodes of height 2 and up (cone_layout.h, boxOffset), written by the
  // same build.
  const vk::Buffer& boxes() const { return boxes_; }
  uint64_t bytesAllocated() const { return nodes_.size + rays_.size + boxes_.size + shapeWords_.size; }

 private:
  void ensureNodes(uint32_t count);  // and the rays' buffer
  BuildPush basePush(glm::vec3 light, float minLength, const FrameChoice& fc) const;

  vk::Context& ctx_;
  // build_level.comp specialised: [far frame][children: nodes (their boxes), rays, rays whose records are
  // given, nodes of height 2 (boxes from the rays)] (its SPEC_FAR, SPEC_LEAVES, SPEC_BOXES).
  vk::Kernel build_[2][4];
  vk::Kernel top_[2];  // tree_top.comp: [far frame]
  vk::Kernel shapeKernel_, spread_;
  const vk::Kernel& buildKernel(const BuildPush& p, uint32_t leaves) const;  // leaves: SPEC_LEAVES
  vk::Buffer nodes_, rays_, boxes_, shapeWords_;
  TreeShape shape_;
  uint32_t maxDepth_ = 0;
};

// CPU reference of the same build (tests): the whole node array for rays from `light` to
// positions[samples[i]], computed by the same source as the kernel (cone_math.h).
std::vector<ConeNode> buildTreeOnHost(const std::vector<glm::vec4>& positions, const std::vector<uint32_t>& samples,
                                      glm::vec3 light, float minLength, const FrameChoice* frame = nullptr);

}  // namespace cs::cone
