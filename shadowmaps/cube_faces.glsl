// The six face maps of a cube of shadow maps, bound at 2..7 (face f at 2 + f: float per texel, row-major,
// R x R), as cube_lookup.comp and rtw_lookup.comp read them; docs/ARCHITECTURE.md, "Conventions" (shaders).
layout(std430, binding = 2) readonly buffer Face0 { float face0[]; };
layout(std430, binding = 3) readonly buffer Face1 { float face1[]; };
layout(std430, binding = 4) readonly buffer Face2 { float face2[]; };
layout(std430, binding = 5) readonly buffer Face3 { float face3[]; };
layout(std430, binding = 6) readonly buffer Face4 { float face4[]; };
layout(std430, binding = 7) readonly buffer Face5 { float face5[]; };

// The depth at texel `index` of face `face`.
float faceDepth(uint face, uint index) {
  switch (face) {
    case 0u: return face0[index];
    case 1u: return face1[index];
    case 2u: return face2[index];
    case 3u: return face3[index];
    case 4u: return face4[index];
    default: return face5[index];
  }
}

// The 2x2 footprint whose first texel is `index`, in pcfTaps' order (rows of `side` texels).
vec4 faceDepth4(uint face, uint index, uint side) {
  return vec4(faceDepth(face, index), faceDepth(face, index + 1u), faceDepth(face, index + side),
              faceDepth(face, index + side + 1u));
}
