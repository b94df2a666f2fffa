// RMSM lookups shared by rmsm_lookup.comp and the test kernel tests/rmsm_probe.comp: the page-table walk and
// the 2x2 percentage-closer filter inside one page (pcf.glsl). Include after the bindings: it reads `tables`
// (uint per entry), `pool` (float per texel), `windows` (vec4 per face) and the push constants `pc` (RmsmPush).
// (s, t) are window coordinates (sm_shared.h windowST: the whole face unless the faces are fitted).
//
// Page tables hold each resident page at its own level only. findTexel() starts at the level asked for
// and walks toward coarser levels until a table has the footprint's page: the finest resident page at or
// below that level, which is what the paper's mip hierarchy of tables stores at every level (000
// §3.3.3: "each page table resolution should use the highest resolution page that is less than or equal
// to that page table's resolution") — without writing every finer table under every coarse page.

#include "shadowmaps/pcf.glsl"

uint pageSide() { return 1u << pc.log2Page; }
uint pageStride() { return (pageSide() + 1u) * (pageSide() + 1u); }  // texels per pool slot (apron included)

// The finest resident page at a level <= `level` that holds the bilinear footprint of (s, t) on `face`.
// Out: its level, the pool index of the footprint's lower texel, the bilinear fraction.
// `texel`: the footprint's lower texel in the found level's coordinates.
// Failing that (only at a reduced analysis resolution, where a page nobody asked for can be missing while
// a finer one, the backup level's, is there), the coarsest resident page finer than `level`.
bool findTexel(uint face, vec2 st, uint level, out uint foundLevel, out uint base, out vec2 frac, out uvec2 texelOut) {
  for (int k = 0; k <= int(pc.maxLevel); ++k) {
    int l = k <= int(level) ? int(level) - k : k;
    float res = float(pageSide() << uint(l));
    vec2 x = footprintCoord(st, res);
    vec2 b = footprintBase(x, res);
    uvec2 texel = uvec2(b);
    uvec2 page = texel >> pc.log2Page;
    uint entry = tables[tableIndex(face, uint(l), page.x, page.y, pc.maxLevel)];
    if (entry != 0u) {
      uvec2 local = texel - (page << pc.log2Page);
      foundLevel = uint(l);
      base = (entry - 1u) * pageStride() + local.y * (pageSide() + 1u) + local.x;
      frac = clamp(x - b, vec2(0.0), vec2(1.0));
      texelOut = texel;
      return true;
    }
  }
  foundLevel = 0u;
  base = 0u;
  frac = vec2(0.0);
  texelOut = uvec2(0u);
  return false;
}

// Percentage-closer filter of 4 texels at `level` (or the finest resident level below it). dF, nF: the
// sample's offset from the light and its normal in face space (receiver-plane bias). Returns -1 when no
// level has a page there.
float pcfAtLevel(uint face, vec2 st, uint level, float dist, float cosTheta, vec3 dF, vec3 nF) {
  uint found, base;
  vec2 f;
  uvec2 texel;
  if (!findTexel(face, st, level, found, base, f, texel)) return -1.0;
  float res = float(pageSide() << found);
  vec4 window = windows[face];
  float faceRes = res * window.z;  // the whole face's texels a side at this level
  Receiver r = faceReceiver(dist, cosTheta, faceRes, dF, nF);
  uint row = pageSide() + 1u;
  vec4 depth = vec4(pool[base], pool[base + 1u], pool[base + row], pool[base + row + 1u]);
  vec4 uv = vec4(windowFaceUV(vec2(texel) + 0.5, res, window), windowFaceUV(vec2(texel + 1u) + 0.5, res, window));
  return pcfBlend(pcfTaps(r, depth, uv), f);
}
