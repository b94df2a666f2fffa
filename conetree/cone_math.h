// conetree/: the cone maths of the tree build -- a leaf's ray rebuilt from the light and its sample, and
// the enclosing cone of up to four child cones -- as plain functions glslang and C++ both compile: the
// build kernel runs them, and the tests run the very same source on the CPU.
//
// Conservative in fp32 without trusting any transcendental function (Vulkan allows sin/cos 2^-11 of
// absolute error and atan 4096 ulp):
//   * The axis of a parent may come from anywhere: it is chosen by merging the children pairwise with
//     approximate angles (atan/cos/sin), and only steers how tight the cone is.
//   * The half-angle is then computed for that axis with +, *, sqrt only: for every child,
//     angle(axis, child axis) + child half-angle as a (cos, sin) pair by the addition formulas, the
//     largest picked with the well-conditioned sin(a1 - a2) comparison, then widened by
//     CONE_PAD = atan(2^-16) ~ 1.5e-5 rad: hundreds of times the rounding of those few operations
//     (~16 ulp = 1e-6 rad), so the stored cone contains every child's stored cone and, by induction,
//     every leaf ray as the leaf kernel computes it. A sum past pi gives the whole sphere (pi).
// A leaf ray with length <= minLength (the sample at the light, or within 2 eps of it: an empty
// interval) or a non-finite one is degenerate: no cone contains it and the leaf test skips it.
#ifndef CONESHADOW_CONETREE_CONE_MATH_H
#define CONESHADOW_CONETREE_CONE_MATH_H

#include "conetree/cone_layout.h"

#define CONE_PI 3.14159265358979f
#define CONE_PAD 1.52587890625e-05f  // 2^-16: the (1, CONE_PAD) rotation widens a half-angle by atan(2^-16)

#ifdef __cplusplus
namespace CONE_CPU_NAMESPACE {
namespace glsl {  // the built-ins' C++ names: CONE_CPU_MATH (cone_layout.h)
#endif

// The leaf ray of a sample: xyz = w = sample - light (light -> sample, exactly as every kernel computes
// it), w = its length L. Every kernel that needs a leaf ray calls this, so all agree bit for bit.
CS_FN vec4 leafRay(vec3 samplePosition, vec3 light) {
  CS_PRECISE vec3 w = samplePosition - light;
  CS_PRECISE float L = length(w);
  return vec4(w, L);
}

// A world point in the cone frame (cone_layout.h, ConeFrame): S R (x - C), the shear S by rowY.w, rowZ.w.
CS_FN vec3 toConeFrame(vec3 x, ConeFrame f) {
  vec3 d = x - vec3(f.centre);
  float z = dot(vec3(f.rowZ), d);
  return vec3(dot(vec3(f.rowX), d) - f.rowY.w * z, dot(vec3(f.rowY), d) - f.rowZ.w * z, z);
}

// A ray is degenerate (never tested, in no cone) unless its length is finite and above minLength.
CS_FN bool leafRayUsable(vec4 ray, float minLength) { return ray.w > minLength && ray.w <= CS_FLT_MAX; }

CS_FN ConeNode emptyCone() {
  ConeNode c;
  c.axisCos = vec4(0.0f, 0.0f, 1.0f, 1.0f);
  c.sinLen = vec4(0.0f, CS_FLT_MAX, -1.0f, 0.0f);
  return c;
}

CS_FN bool coneIsEmpty(ConeNode c) { return !(c.sinLen.z >= 0.0f); }

// The cone of one usable leaf ray: half-angle 0 (the parent's padding absorbs the normalisation).
CS_FN ConeNode rayCone(vec4 ray) {
  ConeNode c;
  c.axisCos = vec4(CONE_DIV(vec3(ray), ray.w), 1.0f);
  c.sinLen = vec4(0.0f, ray.w, ray.w, 0.0f);
  return c;
}

// Some unit vector perpendicular to unit a.
CS_FN vec3 anyPerpendicular(vec3 a) {
  vec3 t = abs(a.x) < 0.57f ? vec3(1.0f, 0.0f, 0.0f) : vec3(0.0f, 1.0f, 0.0f);
  return normalize(cross(a, t));
}

// Approximate minimal cone around two cones (axis and the approximate angle in sinLen.w only; the
// exact pair is computed by coneEnclose). Either may be empty.
CS_FN ConeNode coneMergeApprox(ConeNode A, ConeNode B) {
  if (coneIsEmpty(A)) return B;
  if (coneIsEmpty(B)) return A;
  vec3 a1 = vec3(A.axisCos);
  vec3 a2 = vec3(B.axisCos);
  float al1 = A.sinLen.w;
  float al2 = B.sinLen.w;
  float cosT = dot(a1, a2);
  vec3 perp = a2 - cosT * a1;
  float sinT = length(cross(a1, a2));
  float theta = atan(sinT, cosT);
  ConeNode r = A;
  r.sinLen.y = min(A.sinLen.y, B.sinLen.y);
  r.sinLen.z = max(A.sinLen.z, B.sinLen.z);
  if (theta + al2 <= al1) return r;  // B inside A
  if (theta + al1 <= al2) {          // A inside B
    r.axisCos = B.axisCos;
    r.sinLen.x = B.sinLen.x;
    r.sinLen.w = al2;
    return r;
  }
  float alpha = 0.5f * (theta + al1 + al2);
  if (alpha >= CONE_PI) {
    r.sinLen.w = CONE_PI;
    return r;
  }
  float beta = alpha - al1;  // rotate a1 towards a2 by beta
  float pl = length(perp);
  vec3 dir = pl > 1e-12f ? CONE_DIV(perp, pl) : anyPerpendicular(a1);
  vec3 axis = cos(beta) * a1 + sin(beta) * dir;
  float al = length(axis);
  r.axisCos = vec4(al > 0.5f ? CONE_DIV(axis, al) : a1, 1.0f);
  r.sinLen.w = alpha;
  return r;
}

// (cos, sin) of angle(axis, child axis) + child half-angle, both factors from dot/cross (scale-free).
// y < 0 when the sum reaches pi: the addition formulas wrap at 2 pi, so sums past pi are caught first by
// theta + alpha >= pi <=> cos(alpha) <= -cos(theta) (either rounding way is safe: y < 0 near pi anyway).
CS_FN vec2 coneReach(vec3 axis, ConeNode child) {
  vec3 a = vec3(child.axisCos);
  float ct = dot(axis, a);
  float st = length(cross(axis, a));
  float c = child.axisCos.w;
  float s = child.sinLen.x;
  if (c + ct <= 0.0f) return vec2(-1.0f, -1.0f);
  return vec2(ct * c - st * s, st * c + ct * s);
}

// True when the angle of pair p exceeds that of pair q (both in [0, pi]): sin(p - q) > 0, well
// conditioned everywhere; it is 0 only for equal angles or for exactly 0 against pi, where cos decides.
CS_FN bool angleGreater(vec2 p, vec2 q) {
  float s = p.y * q.x - p.x * q.y;
  return s != 0.0f ? s > 0.0f : p.x < q.x;
}

// Sets the exact (cos, sin) of `node` (whose axis is chosen) so that it contains each child cone,
// widened by `pad` (CONE_PAD, or CONE_PAD times the far-light frame's angular scale: there every axis is
// within Θ of the frame's z, the cross products and (cos, sin) sums above round to ~ulp·scale instead of
// ~ulp, and the padding keeps its 256-fold cover of that); the whole sphere when a reach passes pi or
// anything is not finite.
CS_FN ConeNode coneEnclose(ConeNode node, ConeNode c0, ConeNode c1, ConeNode c2, ConeNode c3, uint n, float pad) {
  vec3 axis = vec3(node.axisCos);
  vec2 best = vec2(1.0f, 0.0f);
  bool whole = false;
  for (uint i = 0u; i < 4u; i++) {
    if (i >= n) break;
    ConeNode c = i == 0u ? c0 : (i == 1u ? c1 : (i == 2u ? c2 : c3));
    if (coneIsEmpty(c)) continue;
    vec2 p = coneReach(axis, c);
    if (!(p.y >= 0.0f) || !(abs(p.x) <= CS_FLT_MAX)) whole = true;  // past pi, or NaN/inf
    if (angleGreater(p, best)) best = p;
  }
  // Widen: rotate by (1, pad), i.e. by atan(pad).
  vec2 w = vec2(best.x - pad * best.y, best.y + pad * best.x);
  float len = length(w);
  if (whole || !(w.y >= 0.0f) || !(len > 0.0f) || !(len <= CS_FLT_MAX)) {
    node.axisCos.w = -1.0f;
    node.sinLen.x = 0.0f;
    node.sinLen.w = CONE_PI;
    return node;
  }
  w = CONE_DIV(w, len);
  node.axisCos.w = w.x;
  node.sinLen.x = w.y;
  node.sinLen.w = atan(w.y, w.x);
  return node;
}

// (Lmin, Lmax) over the first n children, empty ones skipped (exact: min and max do not round); Lmax < 0
// when every child is empty.
CS_FN vec2 childLengths(ConeNode c0, ConeNode c1, ConeNode c2, ConeNode c3, uint n) {
  float lmin = CS_FLT_MAX, lmax = -1.0f;
  for (uint i = 0u; i < 4u; i++) {
    if (i >= n) break;
    ConeNode c = i == 0u ? c0 : (i == 1u ? c1 : (i == 2u ? c2 : c3));
    if (coneIsEmpty(c)) continue;
    lmin = min(lmin, c.sinLen.y);
    lmax = max(lmax, c.sinLen.z);
  }
  return vec2(lmin, lmax);
}

// The parent of up to four children (n = 1..4; entries past n are ignored; empty children skipped),
// widened by `pad` (coneEnclose).
CS_FN ConeNode coneParent(ConeNode c0, ConeNode c1, ConeNode c2, ConeNode c3, uint n, float pad) {
  ConeNode left = c0;
  if (n > 1u) left = coneMergeApprox(c0, c1);
  ConeNode right = emptyCone();
  if (n > 2u) right = c2;
  if (n > 3u) right = coneMergeApprox(c2, c3);
  ConeNode merged = coneMergeApprox(left, right);
  if (coneIsEmpty(merged)) return emptyCone();
  vec2 lengths = childLengths(c0, c1, c2, c3, n);
  merged.sinLen.y = lengths.x;
  merged.sinLen.z = lengths.y;
  return coneEnclose(merged, c0, c1, c2, c3, n, pad);
}

CS_FN ConeNode coneParent(ConeNode c0, ConeNode c1, ConeNode c2, ConeNode c3, uint n) {
  return coneParent(c0, c1, c2, c3, n, CONE_PAD);
}

// A cone through its axis and the (cos, sin) of its half-angle: the approximate merges of
// coneParentOfRays, with + * / sqrt only.
struct ConeCS {
  vec3 axis;
  vec2 cs;  // (cos, sin) of the half-angle; (1, 0) for a ray
};

// The smallest cone around rays a and b (unit; `hasA`/`hasB` false for no ray): the bisector.
CS_FN ConeCS rayPairCone(vec3 a, bool hasA, vec3 b, bool hasB) {
  ConeCS r;
  r.axis = hasA ? a : b;
  r.cs = vec2(1.0f, 0.0f);
  if (!hasA || !hasB) return r;
  vec3 m = a + b;
  float l = length(m);
  if (!(l > 1e-6f)) return r;  // opposite rays: any axis, coneEnclose makes it hold both
  r.axis = CONE_DIV(m, l);
  r.cs = vec2(dot(r.axis, a), length(cross(r.axis, a)));
  return r;
}

// The axis of the smallest cone around cones p and q, as coneMergeApprox chooses it, from (cos, sin)
// pairs: rotate p's axis towards q's by (theta + alpha_q - alpha_p) / 2 (the half-angle formulas), or keep
// the axis of a cone that holds the other.
CS_FN vec3 conePairAxis(ConeCS p, ConeCS q) {
  float ct = dot(p.axis, q.axis);
  vec3 perp = q.axis - ct * p.axis;
  float st = length(perp);
  if (!(st > 1e-12f)) return p.axis;
  // x = theta + alpha_q - alpha_p, in (-pi/2, 3pi/2): both half-angles are at most pi/2 (bisectors).
  vec2 tq = vec2(ct * q.cs.x - st * q.cs.y, st * q.cs.x + ct * q.cs.y);                          // theta + alpha_q
  vec2 x = vec2(tq.x * p.cs.x + tq.y * p.cs.y, tq.y * p.cs.x - tq.x * p.cs.y);                     // - alpha_p
  vec2 y = vec2(ct * p.cs.x - st * p.cs.y, st * p.cs.x + ct * p.cs.y);                             // theta + alpha_p
  y = vec2(y.x * q.cs.x + y.y * q.cs.y, y.y * q.cs.x - y.x * q.cs.y);                              // - alpha_q
  if (x.y <= 0.0f && x.x > 0.0f) return p.axis;  // x <= 0: q inside p
  if (y.y <= 0.0f && y.x > 0.0f) return q.axis;  // p inside q
  // beta = x / 2: (1 + cos x, sin x) points at x / 2 for x in (-pi, pi), the other way past pi; unlike
  // sqrt((1 - cos x) / 2) it keeps its precision for the tiny angles of coherent rays.
  vec2 h = vec2(x.x + length(x), x.y);  // |x| (1 + cos x, sin x): x is not normalised
  if (x.y < 0.0f) h = -h;               // x in [pi, 3pi/2)
  float hl = length(h);
  h = hl > 0.0f ? CONE_DIV(h, hl) : vec2(0.0f, 1.0f);  // x = pi: a right angle
  return h.x * p.axis + h.y * CONE_DIV(perp, st);
}

// The parent of up to four leaf rays (world frame; rayCone children, half-angle 0): the same pairwise
// merges as coneParent -- two bisectors, then the smallest cone around those two -- through (cos, sin)
// pairs instead of atan/cos/sin, which lavapipe evaluates as long polynomials in every lane: three
// quarters of a tree's nodes are this level. The axis only steers how tight the cone is: coneEnclose
// makes it hold every ray exactly, as for any parent.
CS_FN ConeNode coneParentOfRays(ConeNode c0, ConeNode c1, ConeNode c2, ConeNode c3, uint n, float pad) {
  bool h0 = !coneIsEmpty(c0), h1 = n > 1u && !coneIsEmpty(c1), h2 = n > 2u && !coneIsEmpty(c2),
       h3 = n > 3u && !coneIsEmpty(c3);
  if (!h0 && !h1 && !h2 && !h3) return emptyCone();
  ConeCS left = rayPairCone(vec3(c0.axisCos), h0, vec3(c1.axisCos), h1);
  ConeCS right = rayPairCone(vec3(c2.axisCos), h2, vec3(c3.axisCos), h3);
  bool hasLeft = h0 || h1, hasRight = h2 || h3;
  vec3 axis = !hasRight ? left.axis : (!hasLeft ? right.axis : conePairAxis(left, right));
  float al = length(axis);
  vec2 lengths = childLengths(c0, c1, c2, c3, n);
  ConeNode merged;
  merged.axisCos = vec4(al > 0.5f ? CONE_DIV(axis, al) : (hasLeft ? left.axis : right.axis), 1.0f);
  merged.sinLen = vec4(0.0f, lengths.x, lengths.y, 0.0f);
  return coneEnclose(merged, c0, c1, c2, c3, n, pad);
}

// A cone of the far-light frame as a disc on the plane z = 1 (its axis's point there, the tangent of its
// half-angle): the approximate merges of coneParentFar work on these. w = 0: empty; w = -1: not a
// disc (axis not in front, or not finite).
CS_FN vec4 coneDisc(ConeNode c) {
  if (coneIsEmpty(c)) return vec4(0.0f);
  vec3 a = vec3(c.axisCos);
  if (!(a.z > 0.0f) || !(c.axisCos.w > 0.0f)) return vec4(0.0f, 0.0f, 0.0f, -1.0f);
  return vec4(CONE_DIV(a.x, a.z), CONE_DIV(a.y, a.z), CONE_DIV(c.sinLen.x, c.axisCos.w), 1.0f);
}

// The smallest disc holding discs p and q (xy centre, z radius; w as coneDisc).
CS_FN vec4 discMerge(vec4 p, vec4 q) {
  if (p.w == 0.0f) return q;
  if (q.w == 0.0f || p.w < 0.0f) return p;
  if (q.w < 0.0f) return q;
  vec2 d = vec2(q) - vec2(p);
  float l = length(d);
  if (l + q.z <= p.z) return p;
  if (l + p.z <= q.z) return q;
  float r = 0.5f * (l + p.z + q.z);
  return vec4(vec2(p) + d * CONE_DIV(r - p.z, l), r, 1.0f);
}

// The parent in the far-light frame. Its axis steers only how tight the cone is (coneEnclose then makes it
// hold every child exactly), but it must stay near the cones below: the padding CONE_PAD * scale and the
// tests' scaled margins assume every axis within Θ of the frame's z, and the world frame's approximate
// merge, through atan/cos/sin that Vulkan lets err by 2^-11, can steer an axis 5e-4 rad off cones a
// millionth of a radian wide. Here the children are discs on z = 1 (coneDisc), merged pairwise as the
// world merge does, with + * / sqrt only; the axis through the merged disc's centre. When a child is no
// disc (never in the far frame), the normalised sum of the axes instead, inside their hull; a sum that
// is not finite after normalising gives the whole sphere through coneEnclose.
CS_FN ConeNode coneParentFar(ConeNode c0, ConeNode c1, ConeNode c2, ConeNode c3, uint n, float pad) {
  vec3 sum = vec3(0.0f);
  float lmin = CS_FLT_MAX, lmax = -1.0f;
  for (uint i = 0u; i < 4u; i++) {
    if (i >= n) break;
    ConeNode c = i == 0u ? c0 : (i == 1u ? c1 : (i == 2u ? c2 : c3));
    if (coneIsEmpty(c)) continue;
    sum += vec3(c.axisCos);
    lmin = min(lmin, c.sinLen.y);
    lmax = max(lmax, c.sinLen.z);
  }
  if (!(lmax >= 0.0f)) return emptyCone();
  vec4 d0 = coneDisc(c0);
  vec4 d1 = n > 1u ? coneDisc(c1) : vec4(0.0f);
  vec4 d2 = n > 2u ? coneDisc(c2) : vec4(0.0f);
  vec4 d3 = n > 3u ? coneDisc(c3) : vec4(0.0f);
  vec4 disc = discMerge(discMerge(d0, d1), discMerge(d2, d3));
  vec3 axis = disc.w > 0.0f && d0.w >= 0.0f && d1.w >= 0.0f && d2.w >= 0.0f && d3.w >= 0.0f
                  ? vec3(disc.x, disc.y, 1.0f)
                  : sum;
  ConeNode merged;
  merged.axisCos = vec4(normalize(axis), 1.0f);
  merged.sinLen = vec4(0.0f, lmin, lmax, 0.0f);
  return coneEnclose(merged, c0, c1, c2, c3, n, pad);
}

// The cone of a leaf ray in the far-light frame: half-angle beta and lengths L -+ sigma, so that it also
// holds the ray to the same sample as the world-space leaf test sees it (traversal.h, "Far-light frame").
CS_FN ConeNode rayConeWidened(vec4 ray, float beta, float sigma) {
  ConeNode c = rayCone(ray);
  c.axisCos.w = 1.0f;
  c.sinLen.x = beta;
  c.sinLen.y = ray.w - sigma;
  c.sinLen.z = ray.w + sigma;
  c.sinLen.w = beta;
  return c;
}

#ifdef __cplusplus
}  // namespace glsl
using glsl::angleGreater;
using glsl::coneEnclose;
using glsl::coneIsEmpty;
using glsl::coneMergeApprox;
using glsl::coneParent;
using glsl::coneParentFar;
using glsl::coneParentOfRays;
using glsl::coneReach;
using glsl::emptyCone;
using glsl::leafRay;
using glsl::leafRayUsable;
using glsl::rayCone;
using glsl::rayConeWidened;
using glsl::toConeFrame;
}  // namespace CONE_CPU_NAMESPACE
#endif
#endif
