// conetree/: the cone tree build (see conetree.h).
#include "conetree/conetree.h"

#include <algorithm>
#include <cmath>

#include "conetree/build_level.comp.h"
#include "conetree/tree_shape.comp.h"
#include "conetree/tree_spread.comp.h"
#include "conetree/tree_top.comp.h"
#include "conetree/cone_math.h"
#include "core/error.h"

namespace cs::cone {

namespace {
void checkLeaves(uint32_t leaves) {
  CS_CHECK(leaves >= 1 && leaves <= kMaxLeaves, "cone tree over " << leaves << " rays (1 .. " << kMaxLeaves << ")");
}
}  // namespace

uint32_t treeNodes(uint32_t leaves) {
  checkLeaves(leaves);
  const uint32_t depth = treeDepth(leaves);
  return levelOffset(leaves, depth, depth);
}

TreeShape treeShape(uint32_t leaves) {
  checkLeaves(leaves);
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
    : ctx_(ctx),
      shapeKernel_(vk::createKernel(ctx, "cone tree shape", spv_tree_shape_comp, 2, sizeof(ShapePush))),
      spread_(vk::createKernel(ctx, "cone tree spread", spv_tree_spread_comp, 3, sizeof(SpreadPush))),
      shapeWords_(vk::createBuffer(ctx, SHAPE_WORDS * 4, vk::Memory::Device, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT)) {
  for (uint32_t far = 0; far < 2; ++far)
    for (uint32_t kind = 0; kind < 4; ++kind)  // SPEC_LEAVES 0 (boxes from the children's), 1, 2; 0 at height 2
      build_[far][kind] = vk::createKernel(ctx, "cone tree build", spv_build_level_comp, 9, sizeof(BuildPush),
                                           {{0, far}, {1, kind == 3 ? 0u : kind}, {2, kind == 0 ? 2u : kind == 3 ? 1u : 0u}});
  for (uint32_t far = 0; far < 2; ++far)
    top_[far] = vk::createKernel(ctx, "cone tree top", spv_tree_top_comp, 5, sizeof(BuildPush), {{0, far}});
}

const vk::Kernel& ConeTree::buildKernel(const BuildPush& p, uint32_t leaves) const {
  return build_[p.frame.rowX.w != 0.0f ? 1 : 0][leaves == 0 && p.height == CONE_BOX_FIRST_HEIGHT ? 3 : leaves];
}

FrameChoice worldFrame(glm::vec3 light) {
  FrameChoice f;
  f.frame.rowX = glm::vec4(1, 0, 0, 0);
  f.frame.rowY = glm::vec4(0, 1, 0, 0);
  f.frame.rowZ = glm::vec4(0, 0, 1, 0);
  f.frame.centre = glm::vec4(0, 0, 0, 1);
  f.frame.lightFrame = glm::vec4(light, 0);
  return f;
}

FrameChoice chooseFrame(glm::vec3 light, glm::vec3 lo, glm::vec3 hi) {
  FrameChoice world = worldFrame(light);
  if (!(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z)) return world;
  const glm::dvec3 C = 0.5 * (glm::dvec3(lo) + glm::dvec3(hi)), L(light);
  const double r = 0.5 * glm::length(glm::dvec3(hi) - glm::dvec3(lo));
  const double D = glm::length(C - L);
  if (!(r > 0) || !(D >= kFarFrameRatio * r) || !std::isfinite(D)) return world;
  FrameChoice f;
  f.far = true;
  f.distance = D;
  // z from the light to C; x, y completing a right-handed orthonormal basis (Duff et al. 2017).
  const glm::dvec3 z = (C - L) / D;
  const double sign = std::copysign(1.0, z.z), a = -1.0 / (sign + z.z), b = z.x * z.y * a;
  glm::dvec3 x(1.0 + sign * z.x * z.x * a, sign * b, -sign * z.x);
  glm::dvec3 y = glm::cross(z, x);
  f.frame.rowX = glm::vec4(glm::vec3(x), 1.0f);
  f.frame.rowY = glm::vec4(glm::vec3(y), 0.0f);
  f.frame.rowZ = glm::vec4(glm::vec3(z), 0.0f);
  const glm::vec3 Cf(C);
  f.frame.centre = glm::vec4(Cf, 0.0f);
  // The rows as stored (fp32) define the map; the light goes through it in double. Its lateral coordinates
  // under R alone are up to 2^-24 of D (the rows' rounding): the shear (kx, ky), stored as fp32 too, takes
  // them to what fp32 k leaves (cone_layout.h, ConeFrame).
  const glm::dvec3 rotatedLight = toConeFrameExact(L, f.frame);  // the shear still 0
  f.frame.rowY.w = float(rotatedLight.x / rotatedLight.z);
  f.frame.rowZ.w = float(rotatedLight.y / rotatedLight.z);
  auto toFrame = [&](glm::dvec3 p) { return toConeFrameExact(p, f.frame); };
  const glm::dvec3 lf = toFrame(L);
  f.frame.lightFrame = glm::vec4(glm::vec3(lf), 0.0f);
  const double tanTheta = r / std::sqrt(D * D - r * r);
  f.scale = float(std::min(1.0, 4.0 * tanTheta));
  f.frame.centre.w = f.scale;
  // Slack between frame and world geometry: the transform's rounding (a few ulp of |x - C| <= r, and of
  // the light's lateral coordinates the shear leaves, which x - light subtracts) and the world leaf
  // test's (a few ulp of the triangle's distance to the sample, <= 2r), 2^-16 (256 ulp) of the diagonal
  // and that lateral offset over both; as an angle from the light, over the nearest distance to the bounds.
  f.sigma = float(std::ldexp(2.0 * r + std::abs(lf.x) + std::abs(lf.y), -16));
  f.beta = float(double(f.sigma) / (D - r - double(f.sigma)) * (1.0 + std::ldexp(1.0, -10)));
  // The bounds' projection onto z = 1 in the frame: the ray keys' grid starts from a square holding it.
  double u0 = INFINITY, u1 = -INFINITY, v0 = INFINITY, v1 = -INFINITY;
  for (int k = 0; k < 8; ++k) {
    const glm::dvec3 corner((k & 1) ? hi.x : lo.x, (k & 2) ? hi.y : lo.y, (k & 4) ? hi.z : lo.z);
    const glm::dvec3 d = toFrame(corner) - lf;
    u0 = std::min(u0, d.x / d.z), u1 = std::max(u1, d.x / d.z);
    v0 = std::min(v0, d.y / d.z), v1 = std::max(v1, d.y / d.z);
  }
  const double pu = 1e-3 * (u1 - u0) + 1e-30, pv = 1e-3 * (v1 - v0) + 1e-30;
  u0 -= pu, u1 += pu, v0 -= pv, v1 += pv;
  f.keyRect = glm::vec4(float(u0), float(v0), float(1.0 / (u1 - u0)), float(1.0 / (v1 - v0)));
  return f;
}

glm::dvec3 toConeFrameExact(glm::dvec3 x, const ConeFrame& f) {
  const glm::dvec3 d = x - glm::dvec3(glm::vec3(f.centre));
  const double z = glm::dot(glm::dvec3(glm::vec3(f.rowZ)), d);
  return glm::dvec3(glm::dot(glm::dvec3(glm::vec3(f.rowX)), d) - double(f.rowY.w) * z,
                    glm::dot(glm::dvec3(glm::vec3(f.rowY)), d) - double(f.rowZ.w) * z, z);
}

void ConeTree::ensureNodes(uint32_t count) {
  const uint32_t nodes = treeNodes(count);
  const uint64_t bytes = uint64_t(nodes) * sizeof(ConeNode);
  CS_CHECK(bytes <= ctx_.maxStorageBufferRange(),
           "cone tree of " << nodes << " nodes (" << bytes << " bytes) exceeds one storage binding ("
                           << ctx_.maxStorageBufferRange() << " bytes)");
  if (nodes_.size < bytes) {
    nodes_.reset();  // the old one is not needed: free before allocating the larger one
    nodes_ = vk::createBuffer(ctx_, bytes);
  }
  const uint64_t rayBytes = uint64_t(count) * 16;
  CS_CHECK(rayBytes <= ctx_.maxStorageBufferRange(),
           "cone tree over " << count << " rays (" << rayBytes << " bytes of rays) exceeds one storage binding ("
                             << ctx_.maxStorageBufferRange() << " bytes)");
  if (rays_.size < rayBytes) {
    rays_.reset();
    rays_ = vk::createBuffer(ctx_, rayBytes);
  }
  // A box a node of height 2 and up (boxOffset), one storage binding as the nodes; at least one.
  const uint64_t boxBytes = std::max<uint64_t>(uint64_t(boxOffset(count, treeDepth(count) + 1)) * 32, 32);
  if (boxes_.size < boxBytes) {
    boxes_.reset();
    boxes_ = vk::createBuffer(ctx_, boxBytes);
  }
}

BuildPush ConeTree::basePush(glm::vec3 light, float minLength, const FrameChoice& fc) const {
  BuildPush p{};
  p.minLength = minLength;
  p.sigma = fc.sigma;
  p.beta = fc.beta;
  p.frame = fc.frame;
  if (!fc.far) p.frame.lightFrame = glm::vec4(light, 0.0f);  // the world frame's apex is the light itself
  return p;
}

void ConeTree::record(vk::Commands& cmd, const vk::Buffer& positions, const vk::BufferRange& samples,
                      uint32_t count, glm::vec3 light, float minLength, const FrameChoice* frame) {
  CS_CHECK(samples.offset % 16 == 0, "cone tree: the samples start at byte " << samples.offset << ", not a multiple of 16");
  const FrameChoice fc = frame ? *frame : worldFrame(light);
  shape_ = treeShape(count);
  maxDepth_ = shape_.depth;
  ensureNodes(count);
  for (uint32_t d = shape_.depth; d-- > 0;) {
    BuildPush p = basePush(light, minLength, fc);
    p.height = shape_.depth - d;
    p.leaves = count;
    p.count = shape_.counts[d];
    p.nodeOffset = shape_.offsets[d];
    p.childCount = shape_.counts[d + 1];
    p.childOffset = d + 1 < shape_.depth ? shape_.offsets[d + 1] : 0;
    p.fromLeaves = d + 1 == shape_.depth ? 1u : 0u;
    vk::Grid g = vk::gridFor(p.count, CONE_BUILD_THREADS, ctx_.maxWorkgroups());
    cmd.dispatch(buildKernel(p, p.fromLeaves != 0 ? 1u : 0u),
                 {vk::texels(positions, VK_FORMAT_R32G32B32A32_SFLOAT), samples, nodes_,
                  vk::texels(shapeWords_, VK_FORMAT_R32G32B32A32_UINT), rays_, vk::texels(nodes_, VK_FORMAT_R32G32B32A32_SFLOAT),
                  vk::texels(rays_, VK_FORMAT_R32G32B32A32_UINT), boxes_, vk::texels(boxes_, VK_FORMAT_R32G32B32A32_SFLOAT)},
                 p, g.x, g.y);
    cmd.barrier();
  }
}

void ConeTree::recordDevice(vk::Commands& cmd, const vk::Buffer& positions, const vk::BufferRange& samples,
                            const vk::Buffer& countWords, uint32_t countIndex, uint32_t maxCount, glm::vec3 light,
                            float minLength, const FrameChoice* frame, bool keepWhenZero, bool recordsGiven,
                            VkBuffer gate, VkDeviceSize gateOffset) {
  CS_CHECK(maxCount >= 1 && maxCount <= kMaxLeaves, "cone tree bound of " << maxCount << " rays (1 .. " << kMaxLeaves << ")");
  CS_CHECK(samples.offset % 16 == 0, "cone tree: the samples start at byte " << samples.offset << ", not a multiple of 16");
  const FrameChoice fc = frame ? *frame : worldFrame(light);
  ensureNodes(maxCount);
  maxDepth_ = treeDepth(maxCount);
  CS_CHECK(maxDepth_ <= SHAPE_MAX_DEPTH, "cone tree deeper than " << SHAPE_MAX_DEPTH);
  ShapePush sp{maxCount, countIndex, ctx_.maxWorkgroups(), keepWhenZero ? 1u : 0u};
  if (gate != VK_NULL_HANDLE && keepWhenZero) {
    // A gate (indirect arguments of 1 or 0 workgroups): closed, the shape kernel does not run and the tree
    // there is stays, as a count of 0 would keep it -- its build's arguments cleared here, so no height
    // of this build launches.
    cmd.fill(shapeWords_, 0, SHAPE_BUILD_ARGS * 4, (SHAPE_MAX_DEPTH + 1) * 16);
    cmd.barrier();
    cmd.dispatchIndirect(shapeKernel_, {vk::BufferRange(countWords, 0, (VkDeviceSize(countIndex) + 1) * 4), shapeWords_},
                         &sp, sizeof(sp), gate, gateOffset);
  } else {
    cmd.dispatch(shapeKernel_, {vk::BufferRange(countWords, 0, (VkDeviceSize(countIndex) + 1) * 4), shapeWords_}, sp, 1);
  }
  cmd.barrier();
  // A dispatch a height below the top (the heights any count up to maxCount may need: topHeight only
  // grows with the count), then the top's one workgroup.
  const uint32_t separate = std::min(topHeight(maxCount) - 1, maxDepth_);
  for (uint32_t h = 1; h <= separate; ++h) {
    BuildPush p = basePush(light, minLength, fc);
    p.height = h;
    p.fromShape = 1;
    cmd.dispatchIndirect(buildKernel(p, h == 1 ? (recordsGiven ? 2u : 1u) : 0u),
                         {vk::texels(positions, VK_FORMAT_R32G32B32A32_SFLOAT), samples, nodes_,
                          vk::texels(shapeWords_, VK_FORMAT_R32G32B32A32_UINT), rays_, vk::texels(nodes_, VK_FORMAT_R32G32B32A32_SFLOAT),
                          vk::texels(rays_, VK_FORMAT_R32G32B32A32_UINT), boxes_, vk::texels(boxes_, VK_FORMAT_R32G32B32A32_SFLOAT)},
                         &p, sizeof(p), shapeWords_, (SHAPE_BUILD_ARGS + 4 * h) * 4);
    cmd.barrier();
  }
  if (maxDepth_ > separate) {
    const BuildPush p = basePush(light, minLength, fc);
    cmd.dispatchIndirect(top_[p.frame.rowX.w != 0.0f ? 1 : 0],
                         {nodes_, vk::texels(shapeWords_, VK_FORMAT_R32G32B32A32_UINT),
                          vk::texels(nodes_, VK_FORMAT_R32G32B32A32_SFLOAT), boxes_,
                          vk::texels(rays_, VK_FORMAT_R32G32B32A32_UINT)},
                         &p, sizeof(p), shapeWords_, SHAPE_BUILD_ARGS * 4);
    cmd.barrier();
  }
}

void ConeTree::recordSpread(vk::Commands& cmd, const vk::Buffer& words, uint32_t firstWord, float scale) {
  CS_CHECK(firstWord % 2 == 0 && (uint64_t(firstWord) + 2 * (SHAPE_MAX_DEPTH + 1)) * 4 <= words.size,
           "cone tree spread: words " << firstWord << " .. of a " << words.size << "-byte buffer");
  CS_CHECK(scale > 0.0f && scale <= 1.0f, "cone tree spread: scale " << scale << " (0 .. 1]");
  SpreadPush sp{firstWord, scale, 0, 0};
  cmd.dispatch(spread_, {nodes_, shapeWords_, words}, sp, std::max(maxDepth_, 1u));  // a workgroup per height
  cmd.barrier();
}

void ConeTree::setShape(uint32_t leaves) { shape_ = leaves ? treeShape(leaves) : TreeShape{}; }

std::vector<ConeNode> buildTreeOnHost(const std::vector<glm::vec4>& positions, const std::vector<uint32_t>& samples,
                                      glm::vec3 light, float minLength, const FrameChoice* frame) {
  const FrameChoice fc = frame ? *frame : worldFrame(light);
  const TreeShape s = treeShape(uint32_t(samples.size()));
  std::vector<ConeNode> nodes(s.nodes());
  for (uint32_t d = s.depth; d-- > 0;) {
    const bool fromLeaves = d + 1 == s.depth;
    auto child = [&](uint32_t c) {
      if (fromLeaves) {
        const glm::vec3 position(positions[samples[c]]);
        if (fc.far) {
          glm::vec4 ray = leafRay(toConeFrame(position, fc.frame), glm::vec3(fc.frame.lightFrame));
          return leafRayUsable(ray, minLength) ? rayConeWidened(ray, fc.beta, fc.sigma) : emptyCone();
        }
        glm::vec4 ray = leafRay(position, light);
        return leafRayUsable(ray, minLength) ? rayCone(ray) : emptyCone();
      }
      return nodes[s.offsets[d + 1] + c];
    };
    for (uint32_t j = 0; j < s.counts[d]; ++j) {
      glm::uvec2 r = childRange(j, s.counts[d + 1]);
      uint32_t n = r.y - r.x;
      const ConeNode c0 = child(r.x), c1 = n > 1 ? child(r.x + 1) : emptyCone(),
                     c2 = n > 2 ? child(r.x + 2) : emptyCone(), c3 = n > 3 ? child(r.x + 3) : emptyCone();
      nodes[s.offsets[d] + j] = fc.far       ? coneParentFar(c0, c1, c2, c3, n, CONE_PAD * fc.frame.centre.w)
                                : fromLeaves ? coneParentOfRays(c0, c1, c2, c3, n, CONE_PAD)
                                             : coneParent(c0, c1, c2, c3, n, CONE_PAD);
    }
  }
  return nodes;
}

}  // namespace cs::cone
