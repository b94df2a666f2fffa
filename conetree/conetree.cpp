// conetree/: the cone tree build (see conetree.h).
#include "conetree/conetree.h"

#include "conetree/build_level.comp.h"
#include "conetree/cone_math.h"
#include "core/error.h"

namespace cs::cone {

TreeShape treeShape(uint32_t leaves) {
  CS_CHECK(leaves >= 1 && leaves <= kMaxLeaves, "cone tree over " << leaves << " rays (1 .. " << kMaxLeaves << ")");
  TreeShape s;
  s.leaves = leaves;
  s.depth = treeDepth(leaves);
  for (uint32_t d = 0; d <= s.depth; ++d) {
    s.counts.push_back(levelCount(leaves, s.depth, d));
    s.offsets.push_back(levelOffset(leaves, s.depth, d));
  }
  return s;
}

ConeTree::ConeTree(vk::Context& ctx)
    : ctx_(ctx), build_(vk::createKernel(ctx, "cone tree build", spv_build_level_comp, 3, sizeof(BuildPush))) {}

void ConeTree::record(vk::Commands& cmd, const vk::BufferRange& positions, const vk::BufferRange& samples,
                      uint32_t count, glm::vec3 light, float minLength) {
  shape_ = treeShape(count);
  const uint64_t bytes = uint64_t(shape_.nodes()) * sizeof(ConeNode);
  CS_CHECK(bytes <= ctx_.maxStorageBufferRange(),
           "cone tree of " << shape_.nodes() << " nodes (" << bytes << " bytes) exceeds one storage binding ("
                           << ctx_.maxStorageBufferRange() << " bytes)");
  if (nodes_.size < bytes) {
    nodes_.reset();  // the old one is not needed: free before allocating the larger one
    nodes_ = vk::createBuffer(ctx_, bytes);
  }
  for (uint32_t d = shape_.depth; d-- > 0;) {
    BuildPush p{};
    p.light = glm::vec4(light, 0.0f);
    p.count = shape_.counts[d];
    p.nodeOffset = shape_.offsets[d];
    p.childCount = shape_.counts[d + 1];
    p.childOffset = d + 1 < shape_.depth ? shape_.offsets[d + 1] : 0;
    p.fromLeaves = d + 1 == shape_.depth ? 1u : 0u;
    p.minLength = minLength;
    vk::Grid g = vk::gridFor(p.count, CONE_BUILD_THREADS, ctx_.maxWorkgroups());
    cmd.dispatch(build_, {positions, samples, nodes_}, p, g.x, g.y);
    cmd.barrier();
  }
}

std::vector<ConeNode> buildTreeOnHost(const std::vector<glm::vec4>& positions, const std::vector<uint32_t>& samples,
                                      glm::vec3 light, float minLength) {
  const TreeShape s = treeShape(uint32_t(samples.size()));
  std::vector<ConeNode> nodes(s.nodes());
  for (uint32_t d = s.depth; d-- > 0;) {
    const bool fromLeaves = d + 1 == s.depth;
    auto child = [&](uint32_t c) {
      if (fromLeaves) {
        glm::vec4 ray = leafRay(glm::vec3(positions[samples[c]]), light);
        return leafRayUsable(ray, minLength) ? rayCone(ray) : emptyCone();
      }
      return nodes[s.offsets[d + 1] + c];
    };
    for (uint32_t j = 0; j < s.counts[d]; ++j) {
      glm::uvec2 r = childRange(j, s.counts[d + 1]);
      uint32_t n = r.y - r.x;
      nodes[s.offsets[d] + j] = coneParent(child(r.x), n > 1 ? child(r.x + 1) : emptyCone(),
                                           n > 2 ? child(r.x + 2) : emptyCone(),
                                           n > 3 ? child(r.x + 3) : emptyCone(), n);
    }
  }
  return nodes;
}

}  // namespace cs::cone
