// traversal/: the sphere cone/triangle test, the ray-space-hierarchy baseline 002 §3.2 compares the precise
// test against: the triangle's bounding sphere against the cone. Compiled by glslang and C++, like
// precise_test.h (same conventions: vertices relative to the light, the cone's apex).
// Sphere: centre = the centroid, radius = the largest distance to a vertex, both padded for fp32 so the
// sphere provably holds the three fp32 vertices (and so the triangle: both are convex).
// Reject (false) only when provably disjoint, every threshold padded by CONE_TEST_MARGIN of the magnitudes:
//   - the sphere is wholly beyond Lmax - eps from the apex (no counted hit lies there: the leaf test counts
//     tau in (eps, L - eps), L <= Lmax), or wholly within eps of it;
//   - the sphere is outside the cone widened by its angular radius: the distance from the centre to the
//     set of the cone's rays exceeds the radius. With theta the angle of the centre c off the axis, that
//     distance is 0 for theta <= alpha, |c| sin(theta - alpha) when 0 <= theta - alpha <= pi/2 and |c|
//     past pi/2; evaluated from |c| sin(theta - alpha) = |c x a| cos(alpha) - (c.a) sin(alpha)
//     (coneOutside's quantity) and |c| cos(theta - alpha) = (c.a) cos(alpha) + |c x a| sin(alpha).
//     A sphere holding the apex is never rejected by it (the distance is at most |c| < r).
// NaN or inf anywhere makes every rejection condition false: the pair is kept.
#ifndef CONESHADOW_TRAVERSAL_SPHERE_TEST_H
#define CONESHADOW_TRAVERSAL_SPHERE_TEST_H

#include "traversal/precise_test.h"

#ifdef __cplusplus
namespace CONE_CPU_NAMESPACE {
namespace glsl {
#endif

// xyz: centre relative to the apex; w: radius, padded so the sphere holds the three vertices. `scale`:
// the frame's angular scale (precise_test.h, edgePlane): the radius is measured from the rounded centre,
// so what it must cover is the rounding of v_i - c, a few ulp of the components across z (~|v| scale in
// the far frame; the components along z are within a factor 2 of each other and subtract exactly).
// The centre as v0 plus a third of the edges, not a third of the sum: in the far frame the vertices' z
// components are all about the light's distance D, and 3 D rounds to an ulp of 3 D, so (v0 + v1 + v2) / 3
// could land an ulp of D off them (64 at 10^9, 8192 at 10^11) and the radius grow to that: a sphere as
// wide as the room from 10^9 away, and the test rejecting nothing (a frame 10x slower at those distances).
CS_FN vec4 boundingSphere(vec3 v0, vec3 v1, vec3 v2, float scale) {
  vec3 c = v0 + ((v1 - v0) + (v2 - v0)) * (1.0f / 3.0f);
  // The largest of three lengths as one square root of the largest squared length: the same value
  // (sqrt is monotonic and correctly rounded), a third of the square roots.
  vec3 d0 = v0 - c, d1 = v1 - c, d2 = v2 - c;
  float r = sqrt(max(dot(d0, d0), max(dot(d1, d1), dot(d2, d2))));
  float big = sqrt(max(dot(v0, v0), max(dot(v1, v1), dot(v2, v2))));
  return vec4(c, r * (1.0f + CONE_TEST_MARGIN) + CONE_TEST_MARGIN * big * scale);
}

CS_FN vec4 boundingSphere(vec3 v0, vec3 v1, vec3 v2) { return boundingSphere(v0, v1, v2, 1.0f); }

// False only when no ray of the cone can meet the sphere (and so the triangle) at a distance tau from the
// apex with eps < tau < Lmax - eps. `scale`: the frame's angular scale. The distances along the ray keep
// their margin relative to |c|; the distance across it (|c x a| cos - (c.a) sin) rounds to ~ulp |c| scale
// in the far frame (the axis and the centre both within Θ of z), its margin scaled with it.
CS_FN bool sphereConeTriangle(ConeNode cone, vec4 sphere, float eps, float scale) {
  if (coneIsEmpty(cone)) return false;
  vec3 a = vec3(cone.axisCos);
  float c = cone.axisCos.w;
  float s = cone.sinLen.x;
  vec3 ctr = vec3(sphere);
  float r = sphere.w;
  float lc = length(ctr);
  float pad = CONE_TEST_MARGIN * (lc + r);
  float lfar = cone.sinLen.z * (1.0f + CONE_TEST_MARGIN) - eps;
  if (lc - r - pad > lfar) return false;                           // wholly beyond Lmax - eps
  if (lc + r + pad < eps * (1.0f - CONE_TEST_MARGIN)) return false;  // wholly within eps of the apex
  float across = length(cross(ctr, a));
  float along = dot(ctr, a);
  float sinOff = across * c - along * s;  // |c| sin(theta - alpha): <= 0 with the centre inside the cone
  float cosOff = along * c + across * s;  // |c| cos(theta - alpha): <= 0 past pi/2, the apex is nearest
  float dist = sinOff <= 0.0f ? 0.0f : (cosOff <= 0.0f ? lc : sinOff);
  return !(dist > r + CONE_TEST_MARGIN * (lc * scale + r));
}

CS_FN bool sphereConeTriangle(ConeNode cone, vec4 sphere, float eps) { return sphereConeTriangle(cone, sphere, eps, 1.0f); }

CS_FN bool sphereConeTriangle(ConeNode cone, vec3 v0, vec3 v1, vec3 v2, float eps) {
  return sphereConeTriangle(cone, boundingSphere(v0, v1, v2), eps);
}

// 002 §3.6, front-face culling: true when the triangle (CCW = front, glTF) provably faces the light,
// i.e. the light is strictly on the side its normal N = (v1 - v0) x (v2 - v0) points to: N.v0 < 0 with v0
// relative to the light, beyond a rounding margin. Triangles within rounding of edge-on are kept (the
// margin bounds N.v0's error by |e1| |e2| |v0|, so slivers with a noisy normal are kept too).
CS_FN bool facesLight(vec3 v0, vec3 v1, vec3 v2) {
  vec3 e1 = v1 - v0;
  vec3 e2 = v2 - v0;
  vec3 N = cross(e1, e2);
  float big = max(length(v0), max(length(v1), length(v2)));
  return dot(N, v0) < -4.0f * CONE_TEST_MARGIN * length(e1) * length(e2) * big;
}

// The leaves' cull of a pair's rays before their exact test (traverse_leaves.comp, SPEC_CULL): the
// triangle's bounding sphere relative to the light (of P_i - light, world coordinates, as the leaves
// have them), its radius widened by the sphere test's margin, CONE_TEST_MARGIN (|c| + r): leafSphere, once a
// pair (xyz: the centre, w: the widened radius squared). leafRayMissesSphere(s, w), w = sample - light as
// leafRay computes it: true only when the line through the light along w passes farther than that radius
// from the centre, |c x w|^2 > R^2 |w|^2 (no square root a ray). Conservative for every leaf test
// (precise_test.h): a hit they report lies on their ray's line within a few ulp of the triangle's
// coordinates relative to the end they work from. The test from the light (and leafHit from the light's
// end) runs on this very line; leafHit takes the sample's end only when the triangle is nearer the sample
// in the max norm (leafHitFromSample, an edge's, only when its first end is), so at least 0.37 L from
// the light, where that line's offset from this one (the rounding of w, an ulp of L) is far inside the
// sphere's padding (2^-16 of the vertices' distance from the light). The products here round to ~ulp |c| |w|, inside the margin's 2^-16 |c| |w|. NaN, overflow
// and a radius or ray too short for its square to stay a normal float keep the ray.
CS_FN vec4 leafSphere(vec3 a0, vec3 a1, vec3 a2) {
  vec4 s = boundingSphere(a0, a1, a2, 1.0f);
  float R = s.w + CONE_TEST_MARGIN * (length(vec3(s)) + s.w);
  return vec4(vec3(s), R > CONE_COVER_MIN_LENGTH ? R * R : CS_FLT_MAX);
}

CS_FN bool leafRayMissesSphere(vec4 s, vec3 w) {
  vec3 x = cross(vec3(s), w);
  float d2 = dot(x, x), l2 = dot(w, w);
  return d2 > s.w * l2 && d2 <= CS_FLT_MAX && l2 >= 7.888609052210118e-31f;  // 2^-100
}

#ifdef __cplusplus
}  // namespace glsl
using glsl::boundingSphere;
using glsl::facesLight;
using glsl::leafRayMissesSphere;
using glsl::leafSphere;
using glsl::sphereConeTriangle;
}  // namespace CONE_CPU_NAMESPACE
#endif
#endif
