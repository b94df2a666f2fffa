// The key cell of the ray to pixel p's position (rays/hilbert.h faceCellCode, frameCellCode), for
// lit_runs.comp and run_items.comp: equal cells, equal keys. Expects `position`, `pc` (KeysPush),
// SPEC_FRAMED and the faces' grids in g0 .. g5 (in a rotated frame, the frame's grid in g0).
uint runCellAt(vec3 x) {  // of the position x
  if (SPEC_FRAMED != 0u)
    return frameCellCode(frameRay(x, pc.rowX, pc.rowY, pc.rowZ, pc.origin, pc.lightFrame), g0);
  vec3 d = x - pc.light.xyz;
  uint face = rayFace(d);
  vec4 grid = face == 0u ? g0 : face == 1u ? g1 : face == 2u ? g2 : face == 3u ? g3 : face == 4u ? g4 : g5;
  return face == 7u ? 7u << 24u : faceCellCode(d, face, grid);
}
uint runCell(uint p) { return runCellAt(texelFetch(position, int(p)).xyz); }
// The key of a cell runCell gave.
uint runCellKey(uint code) {
  if (SPEC_FRAMED != 0u) return frameCodeKey(code, g0);
  uint face = code >> 24u;
  vec4 grid = face == 0u ? g0 : face == 1u ? g1 : face == 2u ? g2 : face == 3u ? g3 : face == 4u ? g4 : g5;
  return face == 7u ? RAY_KEY_DEGENERATE : faceCodeKey(code, grid);
}
