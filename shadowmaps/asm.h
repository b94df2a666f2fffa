// shadowmaps/: adaptive shadow maps (ASM, paper 001) for an omnidirectional light. CLI name "asm".
// Per cube face a tree of shadow-map nodes, refined frame by frame where samples straddle shadow edges at
// texels coarser than their pixels, within a memory limit (--asm-memory); progressive: the tree persists
// across run() calls, so a static view converges over frames. The analysis, refinement, nodes and lookup
// and the ID + depth test: shadowmaps/README.md, "ASM (paper 001) per cube face".
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "method/method.h"

namespace cs {
namespace vk { struct Context; }

struct AsmOptions {
  uint32_t nodeResolution = 256;   // N: texels a side of every node (--asm-node-res)
  uint32_t cells = 4;              // C: cells a side of a node (--asm-cells); N must be a multiple
  uint64_t memoryBytes = 32ull << 20;  // the node pool (--asm-memory): (N + 1)² · 4 bytes a node
  double budgetMs = 30;            // node creation per frame (--asm-budget-ms); 0: no time limit
  uint32_t analysisStep = 1;       // analyse every K-th pixel in x and y (--asm-analysis)
  uint32_t maxDepth = 0;           // deepest level; 0: as deep as fp32 face coordinates allow
  float lodBias = 0;               // refine until texels are 2^lodBias times finer than pixels (--asm-lod-bias)
  bool keepTree = false;           // tests: stats "node_keys" holds every resident node's key
  float constantBias = 2.0f;       // as cube_sm.h
  float slopeBias = 1.5f;
  float maxSlope = 10.0f;
  bool pcf = true;
  bool planeBias = false;
  bool cull = true;                // per-node frustum culling (depth_pass.h); the same result
  bool fitFaces = true;            // each face's tree over the window of it the scene's bounds cover (fitWindows)
  // §4.2's ID + depth test (--asm-id-test): every node also stores, per texel, the triangle nearest the
  // light, and a tap whose triangle is the sample's own is lit; other taps take the depth comparison.
  // Doubles a node's bytes ((N + 1)² · 8); needs triangle IDs in the G-buffer and the depth pass (the
  // device's geometryShader feature).
  bool idTest = false;
};

// The host's tree: which node sits in which pool slot, when it was last used, what it was created for.
// Pure bookkeeping (no device), so the tests can drive it directly.
class AsmTree {
 public:
  // `slots` pool slots, the first six the faces' roots; C cells a side; nodes down to maxDepth.
  AsmTree(uint32_t slots, uint32_t cells, uint32_t maxDepth);

  struct Node {
    uint32_t key = 0;        // sm::pageKey(face, depth, x, y); SM_INVALID_KEY when the slot is free
    uint32_t parent = 0;     // the parent's slot (roots: their own)
    uint32_t children = 0;   // resident children
    uint64_t lastUsed = 0;   // frame index of the last walk through it
    uint64_t benefit = 0;    // the benefit it was created for (roots: ~0)
  };
  // A cell that asks for a child: the node's slot, the cell (row-major in C x C), its benefit.
  struct Candidate {
    uint32_t slot = 0, cell = 0;
    uint64_t benefit = 0;
  };
  struct Refinement {
    std::vector<std::pair<uint32_t, uint32_t>> created;  // (key, slot) to render this frame
    uint32_t evicted = 0;   // LRU evictions of nodes unused in the last frame
    uint32_t replaced = 0;  // nodes in use replaced by a more beneficial cell
    uint32_t refused = 0;   // candidates left for want of memory (the budget aside)
  };

  // Drops every child; the roots stay (keys of face f in slot f).
  void reset();
  // Marks the slots whose `used` flag is set as used in `frame`.
  void markUsed(const std::vector<uint32_t>& used, uint64_t frame);
  // Creates children for up to `maxNew` candidates, the most beneficial first, in frame `frame`.
  Refinement refine(std::vector<Candidate> candidates, uint64_t frame, uint32_t maxNew);
  // The open-addressing table asm_frame.comp probes: `capacity` (a power of two, > resident nodes)
  // pairs (key, slot), SM_INVALID_KEY where empty.
  std::vector<uint32_t> hashTable(uint32_t capacity) const;

  const std::vector<Node>& nodes() const { return nodes_; }
  uint32_t resident() const;
  uint32_t deepest() const;  // the deepest resident node's depth
  uint32_t cells() const { return cells_; }

 private:
  uint32_t childKey(uint32_t slot, uint32_t cell) const;
  bool residentKey(uint32_t key) const;
  void drop(uint32_t slot);

  std::vector<Node> nodes_;
  uint32_t cells_, maxDepth_;
};

// MethodOutput: visibility per pixel in [0, 1] (PCF) or {0, 1}; stages "analysis", "nodes" (the new
// nodes' geometry passes and copies; the first frame: the roots), "lookup"; stats: nodes_resident,
// nodes_created, nodes_evicted, nodes_replaced, candidates, refused, frame (frames since the last flush),
// deepest, effective_resolution (N·C^deepest), pool_slots, pool_bytes (both pools), id_test, node_cost_a_ms_per_texel,
// node_cost_b_ms, analysed_samples, straddling, coarser_than_pixel, triangles_drawn, bias terms. Throws
// cs::Error on limits (N, C, memory for the six roots and one child, one storage binding).
std::unique_ptr<ShadowMethod> makeAdaptiveShadowMap(vk::Context& ctx, const AsmOptions& options = {});

// Bytes of one pool slot: (N + 1)² distances, and as many triangle IDs with the ID + depth test.
uint64_t asmSlotBytes(uint32_t nodeResolution, bool idTest);

// The deepest level the face coordinates of fp32 resolve: N·C^L texels a side <= 2^21.
uint32_t asmMaxDepth(uint32_t nodeResolution, uint32_t cells);

}  // namespace cs
