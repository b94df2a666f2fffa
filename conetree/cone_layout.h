// conetree/: the cone node and the build kernels' push constants, shared by GLSL and C++ (one layout,
// two languages), plus the implicit 4-way tree's index maths as plain functions both compile.
//
// The tree (002 §3.1, §3.5, §4.3). The N sorted rays are the leaves. Parents are formed bottom-up from
// four consecutive elements of the level below, so the tree is implicit and left-balanced: every node
// is full except the last one of each level. Levels are counted by depth from the root:
//   D = treeDepth(N) >= 1             depth of the leaves (interior depths are 0 .. D-1)
//   levelCount(N, D, d) = ceil(N / 4^(D-d))   nodes at depth d (depth D: the N leaves themselves)
//   levelOffset(N, D, d)              first slot of depth d in the node array (root at 0, then depth 1...)
//   children of node j at depth d     j*4 .. min(j*4+3, levelCount(d+1)-1) at depth d+1
//   leaves under node j at depth d    [j * 4^(D-d), min((j+1) * 4^(D-d), N))   computed, never stored
// Only interior nodes are stored (levelOffset(N, D, D) of them); a leaf is a sorted sample index, and
// its ray is rebuilt from the light and the sample's position (conetree/cone_math.h: leafRay).
//
// A node is a cone with its apex at the light: unit axis, half-angle alpha in [0, pi] kept as the pair
// (cos alpha, sin alpha) -- exact on both sides of pi/2, no tangent that blows up -- plus Lmin/Lmax,
// the shortest and longest ray under it. An empty node (every ray under it degenerate) has Lmax < 0.
#ifndef CONESHADOW_CONETREE_CONE_LAYOUT_H
#define CONESHADOW_CONETREE_CONE_LAYOUT_H

#define CONE_BUILD_THREADS 64
// The top of the tree in one dispatch (tree_top.comp): every height from topHeight() up, the lowest of
// at most CONE_TOP_NODES nodes, built by one workgroup that keeps each level in shared memory for the
// next, instead of a dispatch and a barrier a height over a handful of nodes.
#define CONE_TOP_NODES 256

// Division in the shared GLSL/C++ code is written CONE_DIV(a, b): a / b in both languages. Vulkan lets a
// GPU round a division to 2.5 ulp, so tests/gpu_arithmetic_test.cpp compiles the same source again with
// its own CONE_DIV (and its own sqrt, length, normalize, atan, cos, sin through CONE_CPU_MATH, into its
// own CONE_CPU_NAMESPACE) to check the margins under the worst a GPU may do.
#ifndef CONE_DIV
#define CONE_DIV(a, b) ((a) / (b))
#endif

#include "core/shared.h"

#ifdef __cplusplus
#include <cstddef>
#ifndef CONE_CPU_NAMESPACE
#define CONE_CPU_NAMESPACE cs::cone
#endif
// The C++ names of the GLSL built-ins the shared cone headers call: glm's, unless a test brings its own.
#ifndef CONE_CPU_MATH
#define CONE_CPU_MATH CS_GLSL_MATH
#endif
namespace CONE_CPU_NAMESPACE {
namespace glsl {  // the code below is GLSL; these names let C++ read it as written
CS_GLSL_TYPES
CONE_CPU_MATH
#endif

struct ConeNode {
  vec4 axisCos;  // xyz: unit axis (light -> samples); w: cos(half-angle)
  vec4 sinLen;   // x: sin(half-angle) >= 0; y: Lmin; z: Lmax (< 0: empty node); w: half-angle in radians
                 //    (approximate: it steers the next merge's axis, never a cull decision)
};

// The far-light frame (traversal/traversal.h, "Far-light frame"): for a light well outside the scene's
// bounds, the cones and the pass tests work in coordinates rotated so that z points from the light at
// the scene's centre C: x_f = S R (x - C), the light at lightFrame = S R (light - C). R's rows are fp32,
// so its z row points at C only to ~2^-24 rad: the light would sit up to 2^-24 of its distance off the
// z axis, and every coordinate relative to it would round to an ulp of that offset (at 10^13 from a
// room, 0.004 across, where the room's own detail is 10^-6). S shears that offset away: x_f.x -= kx z_f,
// x_f.y -= ky z_f with (kx, ky) the light's own lateral over axial coordinates under R, so the light's
// lateral coordinates in the frame are what fp32 k leaves of them (D 2^-48 at most) instead of D 2^-24.
// Every ray and every vertex is then within Θ of z, and the tests' rounding is relative to the cones'
// own angular size. In the world frame (far == 0) the build and the tests see light-relative world
// coordinates as before (k = 0).
struct ConeFrame {
  vec4 rowX;        // xyz: the first row of R; w: 1 in the far frame, 0 in the world frame
  vec4 rowY;        // xyz: the second row of R; w: kx, the shear of x by z (0 in the world frame)
  vec4 rowZ;        // xyz: the third row of R (the direction from the light to C); w: ky, of y by z
  vec4 centre;      // xyz: C (world); w: the frame's angular scale (1 in the world frame; precise_test.h)
  vec4 lightFrame;  // xyz: S R (light - C); w: unused
};

// The tree's shape on the GPU (conetree/tree_shape.comp writes it from the ray count; the build and the
// traversal's device path read it): uint words of the shape buffer.
#define SHAPE_LEAVES 0      // n, the sorted rays (0: no tree)
#define SHAPE_DEPTH 1       // D = treeDepth(n), 0 when n = 0
#define SHAPE_NODES 2       // interior nodes stored, levelOffset(n, D, D)
#define SHAPE_COUNTS 4      // + d: levelCount(n, D, d) for d = 0 .. D (0 past D)
#define SHAPE_OFFSETS 24    // + d: levelOffset(n, D, d) for d = 0 .. D (0 past D)
#define SHAPE_BUILD_ARGS 44 // + 4 h: the indirect dispatch (x, y, 1, nodes) building height h = 1 .. topHeight - 1
                    // (0 groups from there); + 0: tree_top.comp's (one workgroup when D >= topHeight, else none)
#define SHAPE_MAX_DEPTH 15  // leaf ranges are 32-bit: 4^D must fit (kMaxLeaves)
#define SHAPE_WORDS 112

// Push constants of conetree/tree_shape.comp.
struct ShapePush {
  uint maxLeaves;     // the device count is clamped to this (the host's bound, which sized the node buffer)
  uint countIndex;    // word of the count binding holding the ray count
  uint maxPerDim;     // the device's workgroups per grid dimension (indirect grids stay within it)
  uint keepWhenZero;  // 1: a count of 0 keeps the shape already there and builds nothing (a rebuild the
                      // GPU decided against keeps the tree built before it)
};

// Push constants of conetree/tree_spread.comp.
struct SpreadPush {
  uint firstWord;     // the per-depth sums go to words firstWord + 2 d (uint64: lo, hi) of the output
  float scale;        // the sums are in units of scale^2: the far frame's angular scale (1 in the world frame)
  uint pad1, pad2;
};
#define CONE_SPREAD_THREADS 64
#define CONE_SPREAD_SAMPLES 4096  // nodes summed per depth at most (evenly strided), the rest estimated
#define CONE_SPREAD_UNIT 4294967296.0f  // 2^32: the sums' fixed point (a unit = 2^-32 of 2 pi sr; a depth of
                                        // 2^27 nodes, 16384^2 rays, sums below 2^60)

// Push constants of conetree/build_level.comp: one dispatch builds one depth of the tree.
struct BuildPush {
  uint height;        // levels above the leaves of the depth built (1: its children are the rays)
  uint fromShape;     // 1: count .. fromLeaves below come from the shape buffer (binding 3) for `height`
  uint leaves;        // the rays under the tree (fromShape: read from the shape buffer instead): the boxes' offsets
  uint pad1;
  uint count;         // nodes at this depth
  uint nodeOffset;    // levelOffset of this depth in the node array
  uint childCount;    // elements at depth + 1 (sorted rays when fromLeaves)
  uint childOffset;   // levelOffset of depth + 1 (unused when fromLeaves)
  uint fromLeaves;    // 1: the children are the sorted rays, else interior nodes (the host picks the kernel by it)
  float minLength;    // rays not longer than this are degenerate (2 * eps: an empty interval), skipped
  float sigma;        // far frame: a leaf cone's lengths widened to L -+ sigma (0 in the world frame)
  float beta;         // far frame: a leaf cone's half-angle (0 in the world frame)
  ConeFrame frame;    // world frame: identity rows, lightFrame = the light (the rays' apex either way)
};

// ---- implicit indexing (pure; unit-tested on the CPU in tests/conetree_test.cpp) -----------------

// Elements at `height` levels above the leaves: ceil(n / 4^height), written without overflow.
CS_FN uint countAtHeight(uint n, uint height) {
  if (n == 0u) return 0u;
  if (height >= 16u) return 1u;  // a shift by 32 would be undefined
  return ((n - 1u) >> (2u * height)) + 1u;
}

// Depth of the leaves: the smallest D >= 1 with 4^D >= n (a single ray still gets a root above it).
CS_FN uint treeDepth(uint n) {
  uint d = 1u;
  while (countAtHeight(n, d) > 1u) d++;
  return d;
}

// Nodes at depth d (0 = root) of a tree with `depth` levels above its n leaves.
CS_FN uint levelCount(uint n, uint depth, uint d) { return countAtHeight(n, depth - d); }

// First slot of depth d in the node array; levelOffset(n, depth, depth) = interior node count.
CS_FN uint levelOffset(uint n, uint depth, uint d) {
  uint offset = 0u;
  for (uint i = 0u; i < d; i++) offset += levelCount(n, depth, i);
  return offset;
}

// Children of node j whose own level has `childLevelCount` elements: [first, end).
CS_FN uvec2 childRange(uint j, uint childLevelCount) {
  return uvec2(4u * j, min(4u * j + 4u, childLevelCount));
}

// The first height tree_top.comp builds over n rays: the lowest of at most CONE_TOP_NODES nodes, and at
// least 2 (height 1, whose children are the rays, always has its own dispatch). Heights below it have
// their own dispatch each; a tree whose depth is below it has no top dispatch.
CS_FN uint topHeight(uint n) {
  uint h = 2u;
  while (countAtHeight(n, h) > CONE_TOP_NODES) h++;
  return h;
}

// The sample boxes (build_level.comp, tree_top.comp): for each interior node of height 2 or more (16 rays
// and up; the 4-ray nodes of height 1 have none: a box a height-1 node cost the build more than their
// culls saved), the world-coordinate bounds of its rays' samples, two vec4s (lo, hi; w unused), node j of
// height h at boxOffset(n, h) + j: the heights bottom-up, so a box's place needs only the ray count and
// the node's height, which both the test kernel (its children's leaf shift) and the leaves (theirs) know.
// The plane cull reads them (traversal/precise_test.h, leafPlaneMissesBox).
#define CONE_BOX_FIRST_HEIGHT 2u
CS_FN uint boxOffset(uint n, uint height) {
  uint offset = 0u;
  for (uint k = CONE_BOX_FIRST_HEIGHT; k < height; k++) offset += countAtHeight(n, k);
  return offset;
}

// Leaves under node j at depth d of a tree with `depth` levels over n leaves: [first, end).
CS_FN uvec2 leafRange(uint j, uint n, uint depth, uint d) {
  uint shift = 2u * (depth - d);
  return uvec2(j << shift, min((j + 1u) << shift, n));
}

#ifdef __cplusplus
}  // namespace glsl
using glsl::BuildPush;
using glsl::ShapePush;
using glsl::SpreadPush;
using glsl::ConeFrame;
using glsl::ConeNode;
using glsl::boxOffset;
using glsl::childRange;
using glsl::countAtHeight;
using glsl::leafRange;
using glsl::levelCount;
using glsl::levelOffset;
using glsl::topHeight;
using glsl::treeDepth;
static_assert(sizeof(ConeNode) == 32 && offsetof(ConeNode, sinLen) == 16, "ConeNode layout");
static_assert(sizeof(ConeFrame) == 80, "ConeFrame layout");
static_assert(CONE_TOP_NODES % CONE_BUILD_THREADS == 0, "tree_top.comp: whole nodes an invocation");
static_assert(sizeof(ShapePush) == 16 && sizeof(SpreadPush) == 16, "ShapePush, SpreadPush layout");
static_assert(SHAPE_COUNTS + SHAPE_MAX_DEPTH + 1 <= SHAPE_OFFSETS && SHAPE_OFFSETS + SHAPE_MAX_DEPTH + 1 <= SHAPE_BUILD_ARGS &&
                  SHAPE_BUILD_ARGS % 4 == 0 && SHAPE_BUILD_ARGS + 4 * (SHAPE_MAX_DEPTH + 1) <= SHAPE_WORDS,
              "shape words");
static_assert(sizeof(BuildPush) == 128 && offsetof(BuildPush, count) == 16 && offsetof(BuildPush, minLength) == 36 &&
                  offsetof(BuildPush, frame) == 48,
              "BuildPush layout");
// Leaf ranges are 32-bit: 4^D must fit, i.e. D <= 15 (n <= 2^30 rays).
constexpr uint32_t kMaxLeaves = 1u << 30;
}  // namespace CONE_CPU_NAMESPACE
#endif
#endif
