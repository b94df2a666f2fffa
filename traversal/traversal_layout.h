// traversal/: push constants, workgroup shapes and counter slots of the traversal kernels, shared by
// GLSL and C++ (one layout, two languages).
#ifndef CONESHADOW_TRAVERSAL_LAYOUT_H
#define CONESHADOW_TRAVERSAL_LAYOUT_H

#define TRAVERSE_THREADS 64

// Counters the kernels add to (uint each, per submit; the host reads and clears them).
#define STAT_MISSING 0     // tests short of 4 per input (1 per triangle): children or rays past a level's end
#define STAT_TOTAL 1       // the scan's total: survivors of the chunk (written by sort/'s Scan)
#define STAT_ACCEPTED 2    // early accept (002 §3.3): nodes the test kernel found covered and shadowed at once
#define STAT_DROPPED 3     // early accept: input pairs dropped because their node was accepted (their tests in STAT_MISSING)
#define STAT_WORDS 4

// TraversePush::test: the cone/triangle test of the passes (cone_method.h, ConeOptions::test).
#define TRAVERSE_TEST_PRECISE 0u  // precise_test.h (002 §3.2)
#define TRAVERSE_TEST_SPHERE 1u   // sphere_test.h: the triangle's bounding sphere (the ray-space-hierarchy baseline)

#ifdef __cplusplus
#include <cstddef>
#include <cstdint>

#include <glm/glm.hpp>
namespace cs::traversal {
using uint = uint32_t;
using vec4 = glm::vec4;
#endif

// traverse_test.comp, traverse_scatter.comp, traverse_leaves.comp. A pair is uvec2(triangle, node index
// within its depth); the arena holds the pairs of every depth on a stack (traversal.h).
struct TraversePush {
  vec4 light;         // xyz: the point light (the cones' apex)
  uint first;         // first input pair in the arena, or first triangle when fromTriangles
  uint count;         // input elements of this dispatch
  uint fromTriangles; // 1: input i is triangle first + i, tested against the root (pass 0)
  uint childOffset;   // node-array offset of the child depth (test); unused by the leaves
  uint childCount;    // elements at the child depth (nodes, or the rays at the leaves)
  uint outFirst;      // scatter: arena slot of the first output pair
  float eps;          // leaves: hits count at distances in (eps, L - eps) from the light
  float minLength;    // leaves: rays not longer than this are degenerate (2 eps), never tested
  uint outLimit;      // scatter: no pair is written at or past this slot (the chunk overflowed)
  uint test;          // test: TRAVERSE_TEST_PRECISE or TRAVERSE_TEST_SPHERE
  uint frontFaceCulling; // test, pass 0: 1 drops the triangles that face the light (002 §3.6, cone_method.h)
  uint earlyAccept;   // test: 1 shadows the leaves of a covered child at once (002 §3.3) and marks it
  uint leafCount;     // test, early accept: the tree's leaves (sorted rays)
  uint leafShift;     // test, early accept: 2 (D - d) for the child depth d: leaves under a child = 4^(D-d)
  uint inputOffset;   // test, early accept: node-array offset of the input pairs' depth (their flags)
  uint frameVertices; // test: 1 = binding 0 holds the vertices relative to the light in the far-light frame
                      // (frame_triangles.comp), used as they are; 0 = world positions, the light subtracted
  float coneScale;    // test: the frame's angular scale (1 in the world frame; precise_test.h)
  uint pad0, pad1, pad2;
};

// frame_triangles.comp: the triangles' vertices relative to the light in the far-light frame.
struct FrameTrianglesPush {
  vec4 rowX, rowY, rowZ;  // the rotation's rows (conetree/cone_layout.h, ConeFrame)
  vec4 centre;            // xyz: its origin C
  vec4 lightFrame;        // xyz: the light in the frame
  uint count;             // triangles
  uint pad0, pad1, pad2;
};

#ifdef __cplusplus
static_assert(sizeof(FrameTrianglesPush) == 96, "FrameTrianglesPush layout");
static_assert(sizeof(TraversePush) == 96 && offsetof(TraversePush, frameVertices) == 76 && offsetof(TraversePush, first) == 16 &&
                  offsetof(TraversePush, minLength) == 44 && offsetof(TraversePush, outLimit) == 48 &&
                  offsetof(TraversePush, test) == 52 && offsetof(TraversePush, frontFaceCulling) == 56,
              "TraversePush layout");
}  // namespace cs::traversal
#endif
#endif
