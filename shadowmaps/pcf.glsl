// The shadow test every shadow-map lookup shares (cube_lookup.comp, rtw_lookup.comp, asm_frame.comp,
// rmsm.glsl): a tap's depth against the sample's reach -- its distance minus the slope-scaled bias, or per
// tap the distance along the tap's own texel-centre ray to the sample's tangent plane (sm_shared.h
// slopeScaledBias, planeReach) -- and the bilinear 2x2 percentage-closer filter of four taps.
// Include after the push constants: it reads pc.constantBias, pc.slopeBias, pc.maxSlope and pc.planeBias,
// which every lookup's push struct names alike. docs/ARCHITECTURE.md, "Conventions" (shaders).

// A lit sample as the taps see it.
struct Receiver {
  float reach;  // the depth a tap must reach to light the sample (its distance minus the slope-scaled bias)
  float slack;  // a quarter texel at the sample's distance: planeReach's allowance for curved receivers
  vec3 dF, nF;  // the sample's offset from the light and its normal, in face space
};

// texelAngle: the face coordinate a texel spans at the sample; slack as above.
Receiver receiver(float dist, float cosTheta, float texelAngle, float slack, vec3 dF, vec3 nF) {
  Receiver r;
  r.reach = dist - slopeScaledBias(dist, cosTheta, texelAngle, pc.constantBias, pc.slopeBias, pc.maxSlope);
  r.slack = slack;
  r.dF = dF;
  r.nF = nF;
  return r;
}

// A map of `faceRes` unwarped texels across the whole face (the cube map, RMSM's and ASM's levels).
Receiver faceReceiver(float dist, float cosTheta, float faceRes, vec3 dF, vec3 nF) {
  return receiver(dist, cosTheta, 2.0f / faceRes, 0.25 * dist * 2.0f / faceRes, dF, nF);
}

// 1 when the map's depth at a tap lights the sample, else 0. uv: the tap's texel centre in face coordinates
// (u, v in [-1, 1]), which only the receiver-plane bias reads.
float tapLit(Receiver r, float depth, vec2 uv) {
  float reach = pc.planeBias != 0u ? planeReach(r.dF, r.nF, uv, r.reach, pc.constantBias, r.slack) : r.reach;
  return depth >= reach ? 1.0 : 0.0;
}

// The four taps of a 2x2 footprint, x first: (0, 0), (1, 0), (0, 1), (1, 1). depth: the map's depth at each;
// uv.xy: the first tap's texel centre, uv.zw the last's (the taps share them per axis).
vec4 pcfTaps(Receiver r, vec4 depth, vec4 uv) {
  return vec4(tapLit(r, depth.x, uv.xy), tapLit(r, depth.y, uv.zy), tapLit(r, depth.z, uv.xw),
              tapLit(r, depth.w, uv.zw));
}

// The bilinear blend of the four taps' results by the footprint's fraction f.
float pcfBlend(vec4 lit, vec2 f) { return mix(mix(lit.x, lit.y, f.x), mix(lit.z, lit.w, f.x), f.y); }
