// rays/: workgroup shape, screen order and push constants of the ray-generation kernels, shared by GLSL
// and C++ (one layout, two languages).
#ifndef CONESHADOW_RAYS_LAYOUT_H
#define CONESHADOW_RAYS_LAYOUT_H

#include "sort/sort_layout.h"  // FLAG_COUNT_FROM_BUFFER: the ray keys read the lit count from the GPU

// Per-pixel kernels (ray keys, test kernels).
#define PIXEL_THREADS 256
// ray_bounds.comp: up to RAY_BOUNDS_GROUPS workgroups of RAY_BOUNDS_THREADS (fewer where the keys' device
// count is smaller, none where it is 0), each invocation the subset's members (RAY_BOUNDS_SAMPLES,
// rays/hilbert.h) in every (workgroups * RAY_BOUNDS_THREADS)-th row of the pixels that may hold geometry.
#define RAY_BOUNDS_THREADS 64
#define RAY_BOUNDS_GROUPS 16

// Unsorted ("screen") order: square tiles of 2^MORTON_TILE_BITS pixels a side, row-major, Morton
// (Z) order inside a tile. Four consecutive samples are a 2x2 block, 16 a 4x4 block, ... up to the
// 64x64 tile; tiles follow each other along rows.
#define MORTON_TILE_BITS 6
#if ((1 << (2 * MORTON_TILE_BITS)) % SCAN_ITEMS) != 0
#error "lit_count.comp and lit_samples.comp take one Morton tile per invocation's run of SCAN_ITEMS positions"
#endif

#ifdef __cplusplus
namespace cs::rays {
CS_GLSL_TYPES
#endif

// lit_count.comp, lit_samples.comp
struct LitPush {
  uint width, height;
  uint order;       // 0: row-major (domain index = pixel index), 1: tiled Morton (see MORTON_TILE_BITS); the
                    // kernel takes it as SPEC_MORTON (its pipeline), this copy is for the record
  uint tilesX;      // Morton tiles per row
  uint domain;      // elements enumerated: width * height, or tilesX * tilesY * tile area
  uint rectX, rectY;  // x0 | x1 << 16, y0 | y1 << 16: DeviceGBuffer::geometryRect, clamped (lit_count.comp
                      // reads no position outside it)
  uint firstTile;   // Morton: tileX0 | tileY0 << 16, the enumeration's first tile (ScreenDomain: the
                    // window of tiles that meet the rect)
  vec4 light;       // xyz: the point light whose lit samples these are (lit_count.comp, litSampleFor)
};

// ray_bounds.comp, ray_grids.comp, ray_keys.comp, lit_runs.comp, run_items.comp
struct KeysPush {
  vec4 light;       // xyz: the point light
  uint count;       // rays, or their upper bound when FLAG_COUNT_FROM_BUFFER is set
  uint countIndex;
  uint flags;
  uint framed;      // 1: keys in a rotated frame (frameRayKey), the rows, origin, light and rect below;
                    // LitRays picks the pipeline by it (the kernel's SPEC_FRAMED)
  vec4 rowX, rowY, rowZ;  // the frame's rotation, rows (world -> frame); rowY.w, rowZ.w its shear (ConeFrame)
  vec4 origin;            // xyz: the frame's origin (world)
  vec4 lightFrame;        // xyz: the light in the frame
  vec4 rect;              // (u0, v0, 1 / (u1 - u0), 1 / (v1 - v0)): the scene's projection on z = 1, which
                          // the frame's key grid starts from (frameKeyGrid, ray_grids.comp)
};

// run_items.comp, run_expand.comp (LitRays::recordCompactionWithKeys: the sort takes one item a run of
// equal keys, its leader's pixel and its length less one in the value's high bits, up to SCAN_ITEMS).
#define RUN_PIXEL_BITS 27
#define RUN_PIXEL_MASK ((1u << RUN_PIXEL_BITS) - 1u)
#if (SCAN_ITEMS - 1) >= (1 << (32 - RUN_PIXEL_BITS))
#error "a run (at most SCAN_ITEMS pixels) has its length less one in the bits above RUN_PIXEL_BITS"
#endif
// run_items.comp: an invocation takes the runs of RUN_ITEMS_SPAN lit_runs invocations, RUN_ITEMS_SPAN
// apart, in rounds (a lit_runs block holds whole groups of RUN_ITEMS_SPAN^2 of them; at most 32 rounds).
#define RUN_ITEMS_SPAN 8
#if (SCAN_THREADS % (RUN_ITEMS_SPAN * RUN_ITEMS_SPAN)) != 0 || RUN_ITEMS_SPAN > 32
#error "run_items.comp's groups of RUN_ITEMS_SPAN^2 lit_runs invocations tile a block"
#endif
struct RunsPush {
  uint positions;   // run_items: the pixels enumerated (row-major)
  uint items;       // the runs' upper bound (the lit samples' capacity); the count is countWords[itemsIndex]
  uint itemsIndex;  // the word of the count binding holding the runs' count
  uint litIndex;    // the word of the count binding holding the lit count
};

// tests/hilbert_grid.comp (test kernel): every cell's Hilbert index and the keys of a list of directions.
struct HilbertGridPush {
  uint order;       // grid of 2^order x 2^order cells
  uint directions;  // directions in the dirs binding
};

#ifdef __cplusplus
static_assert(sizeof(LitPush) == 48 && offsetof(LitPush, domain) == 16 && offsetof(LitPush, light) == 32, "LitPush layout");
static_assert(sizeof(KeysPush) == 128 && offsetof(KeysPush, count) == 16 && offsetof(KeysPush, rowX) == 32,
              "KeysPush layout");
static_assert(sizeof(HilbertGridPush) == 8, "HilbertGridPush layout");
static_assert(sizeof(RunsPush) == 16, "RunsPush layout");
}  // namespace cs::rays
#endif
#endif
