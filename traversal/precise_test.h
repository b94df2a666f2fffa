// traversal/: the two geometric tests of the traversal, as plain functions that glslang and C++ both
// compile -- the kernels run them, and the conservativeness property test runs the very same source.
//
// preciseConeTriangle (002 §3.2). The paper projects the triangle with the cone's perspective
// projection and works in clip space; we run the same tests directly on directions from the apex,
// which is the same geometry without a projection that degenerates near pi/2 and without vertices
// behind the apex needing clipping (a vertex behind the light is just a direction). All triangle
// vertices are relative to the light (P - light), the cone's apex.
//   1. Complementary cone: the cone rounded up to at least pi/2 has a convex complement; if all three
//      vertices lie strictly inside that complement, so does the triangle (for narrow cones this is
//      "all vertices behind the apex plane"). For cones at or past pi/2 - eps (cos < CONE_WIDE_COS)
//      this is the only angular test, as in the paper.
//   2. Near point vs Lmax: the nearest point of the triangle's plane inside the cone is farther than
//      Lmax - eps (the paper's Z_near > 1 test; hits count only up to L - eps). Done on the slab
//      [min, max] of N.v_i that provably holds the triangle, so slivers with an inaccurate normal stay
//      conservative. (And, trivially, a triangle wholly within eps of the light is rejected.)
//   3. Homogeneous edge equations: the plane through the apex and edge (v_j, v_k), oriented towards v_i,
//      has the whole triangle on its positive side; reject when the cone is strictly on the negative
//      side, i.e. when the angle between the plane normal and the axis exceeds pi/2 + alpha. In the
//      paper's clip space this is "the normalised distance from the origin to the edge line exceeds
//      1"; here it is evaluated as cos(phi - alpha) < 0, well conditioned for every alpha.
//   4. Triangle-shadow separating planes: for each vertex, the plane through the apex tangent to the
//      cone on that vertex's side; reject when all three vertices are strictly beyond it.
// What depends on the triangle alone (lengths, plane slab, oriented edge planes) is computed once per
// (triangle, node) pair by preciseTriangle() and reused for the node's four children.
// Conservative in fp32 (reject only when the exact geometry of the fp32 inputs is provably disjoint):
// every rejection threshold is padded by CONE_TEST_MARGIN = 2^-16 relative (256 ulp) of the magnitudes
// that bound the rounding of the quantity compared, plus explicit error bounds where a direction is
// ill-conditioned (edge normals of edges seen end-on, vertices near the axis). Orientation of an edge
// plane is used only when |det| clears its error bound (light in or near the triangle's plane: edge
// tests skipped). NaN or inf anywhere makes every rejection condition false: the pair is kept.
// The margins also cover the leaf test's own rounding: whenever the fp32 leaf test below reports a hit
// for some ray of the cone, the pair is kept (tests/traversal_test.cpp checks both claims).
//
// leafRayHitsTriangle: the exact ray/triangle test at the leaves, watertight (Woop, Benthin, Wald 2013:
// shear to the ray's major axis, 2-D edge functions; an edge value of exactly 0 counts as inside, so a
// ray through a shared edge or vertex hits at least one of the triangles and never slips between).
// A ray lying (within rounding) in the triangle's plane is a miss: there the edge signs are noise, and
// a plain det != 0 test reports hits behind the light or far outside the triangle. "Within rounding"
// is a bound on det's error; the exact hits it drops are on triangles whose projection along the ray is
// a sliver only a few ulp of their coordinates wide, which a sideways nudge of the light (the ambiguity
// band) moves the ray off.
// The ray runs from the light to the sample, hits count at distances tau from the light in
// (eps, L - eps): by symmetry the reference's interval (eps, L - eps) measured from the sample.
#ifndef CONESHADOW_TRAVERSAL_PRECISE_TEST_H
#define CONESHADOW_TRAVERSAL_PRECISE_TEST_H

#include "conetree/cone_math.h"

#define CONE_TEST_MARGIN 1.52587890625e-05f  // 2^-16, relative
#define CONE_WIDE_COS 9.765625e-04f          // cones with cos(alpha) below this (alpha > pi/2 - ~2^-10) are "wide"
#define CONE_ULP16 9.5367431640625e-07f      // 16 ulp = 2^-20: error growth of a nearly parallel projection
#define CONE_ULP8 4.76837158203125e-07f      // 8 ulp = 2^-21
#define CONE_ULP2 1.1920928955078125e-07f   // 2 ulp = 2^-23
// The shortest edge-plane or triangle-plane normal (a product of two coordinates relative to the apex)
// the early accept trusts: 2^-40. A GPU may flush denormals to zero, so a length() of a vector whose
// components are below 2^-63 loses their squares; from 2^-40 up the loss (under 2^-62 in the length)
// is far inside the test's margin (2^-14 of the length), below it the cone is simply not accepted.
#define CONE_COVER_MIN_LENGTH 9.094947017729282e-13f  // 2^-40

#ifdef __cplusplus
namespace CONE_CPU_NAMESPACE {
namespace glsl {
#endif

// Vertex v (length lv) strictly outside the cone (axis a, pair cs) by the margin:
// |v| sin(theta_v - alpha) >= margin |v|. A vertex at the apex itself (v = 0) passes: a triangle may
// touch the apex, which no ray counts (hits need tau > eps > 0), and be rejected all the same.
CS_FN bool coneOutside(vec3 v, float lv, vec3 a, vec2 cs) {
  return length(cross(v, a)) * cs.x - dot(v, a) * cs.y >= CONE_TEST_MARGIN * lv;
}

// What the precise test needs of a triangle, whatever the cone: computed once per (triangle, node) pair
// and used for all four children.
struct PreciseTriangle {
  vec3 v0, v1, v2;  // relative to the apex (the light)
  vec3 len;         // |v0|, |v1|, |v2|
  vec4 plane;       // xyz: N = (v1 - v0) x (v2 - v0); w: |N|
  vec2 slab;        // [lo, hi] holding N.x for every point x of the triangle, rounding included
  vec4 edge0;       // edge planes through the apex: xyz = normal oriented towards the opposite vertex
  vec4 edge1;       //   (zero when that orientation is not reliable: light in or near the plane),
  vec4 edge2;       //   w = the margin a separation must clear (normal's own error + rounding)
  float scale;      // the frame's angular scale (edgePlane): 1 in the world frame
};

// Edge plane through the apex and (vj, vk), oriented towards vi; zero when |det| does not clear its error.
// `scale` (in (0, 1]) is the frame's angular scale: 1 for directions anywhere (the light among the
// geometry); in the far-light frame (traversal.h, "Far-light frame") every vertex and every ray lies
// within an angle Θ of the frame's z axis and scale = min(1, 4 tan Θ) bounds the lateral components
// of unit directions. There the rounding of n = vj x vk is ~ulp·lj·lk·scale in its components across z
// (products of an axial ~|v| and a lateral ~|v|·scale component) and ~ulp·lj·lk·scale² along z, so the
// error of n.r for any ray r of a cone is ~ulp·lj·lk·scale² and that of det = n.vi ~ulp·li·lj·lk·scale²:
// the margins below are those bounds times 2^-16 / ulp = 256, as everywhere in this file.
CS_FN vec4 edgePlane(vec3 vi, vec3 vj, vec3 vk, float li, float lj, float lk, float scale) {
  vec3 n = cross(vj, vk);
  float o = dot(n, vi);                             // = det, the same for all three edges when exact
  if (!(abs(o) > CONE_TEST_MARGIN * li * lj * lk * scale * scale)) return vec4(0.0f);
  if (o < 0.0f) n = -n;
  // The edge normal's own error is ~ulp * lj * lk (times scale^2 across the cone in the far frame),
  // an angle of that over |n|; plus the rounding of n.r itself (~ulp |n| scale).
  return vec4(n, CONE_TEST_MARGIN * scale * (lj * lk * scale + length(n)));
}

CS_FN PreciseTriangle preciseTriangle(vec3 v0, vec3 v1, vec3 v2, float scale) {
  PreciseTriangle t;
  t.v0 = v0;
  t.v1 = v1;
  t.v2 = v2;
  t.len = vec3(length(v0), length(v1), length(v2));
  vec3 N = cross(v1 - v0, v2 - v0);
  float nl = length(N);
  t.plane = vec4(N, nl);
  float h0 = dot(N, v0);
  float h1 = dot(N, v1);
  float h2 = dot(N, v2);
  float herr = CONE_TEST_MARGIN * nl * max(t.len.x, max(t.len.y, t.len.z));
  t.slab = vec2(min(h0, min(h1, h2)) - herr, max(h0, max(h1, h2)) + herr);
  t.scale = scale;
  t.edge0 = edgePlane(v0, v1, v2, t.len.x, t.len.y, t.len.z, scale);
  t.edge1 = edgePlane(v1, v2, v0, t.len.y, t.len.z, t.len.x, scale);
  t.edge2 = edgePlane(v2, v0, v1, t.len.z, t.len.x, t.len.y, scale);
  return t;
}

// Directions anywhere (scale 1).
CS_FN PreciseTriangle preciseTriangle(vec3 v0, vec3 v1, vec3 v2) { return preciseTriangle(v0, v1, v2, 1.0f); }

// The cone lies strictly on the far side of the (oriented) edge plane e, beyond its margin: the angle
// phi between its normal and the axis exceeds pi/2 + alpha, evaluated as |n| cos(phi - alpha) < -margin.
CS_FN bool edgeSeparates(vec4 e, vec3 a, float c, float s) {
  vec3 n = vec3(e);
  return dot(n, a) * c + length(cross(n, a)) * s < -e.w;
}

// Separating plane tangent to the cone on vertex vi's side: true when all three vertices are
// strictly beyond it.
// In the far-light frame (t.scale < 1) p, the part of vi across the axis, comes from a x (vi x a): vi - (vi.a) a
// cancels along z (both ~|v|) to an error of ~ulp |v|, a tilt of ulp |v| / |p| that can exceed the cones;
// the cross products round to ~ulp |v| scale, so the tilt, the on-axis guard and the margin of n.v scale
// with the frame (the world frame keeps the subtraction and its bounds as they were).
CS_FN bool tangentSeparates(vec3 vi, float li, PreciseTriangle t, vec3 a, float c, float s) {
  bool far = t.scale < 1.0f;
  float z = dot(vi, a);
  vec3 p = far ? cross(a, cross(vi, a)) : vi - z * a;
  float pl = length(p);
  float fine = far ? t.scale : 1.0f;
  if (!(pl * 4096.0f > li * fine)) return false;    // vertex (nearly) on the axis
  // Widen the cone by gamma >= the tilt of b = p / |p| off the plane normal to a (~10 ulp |v| / |p|, times
  // the scale in the far frame).
  float gamma = CONE_TEST_MARGIN * fine + CONE_DIV(CONE_ULP16 * li * fine, pl);
  float c2 = c - gamma * s;
  float s2 = s + gamma * c;
  if (!(c2 > 0.0f)) return false;                   // widened past pi/2: no tangent plane
  vec3 n = CONE_DIV(c2, pl) * p - s2 * a;                  // angle(n, a) >= pi/2 + alpha: cone on n.r <= 0
  float m = CONE_TEST_MARGIN * length(n) * fine;  // >=: a vertex at the apex (l = 0) may touch the plane, as in coneOutside
  return dot(n, t.v0) >= m * t.len.x && dot(n, t.v1) >= m * t.len.y && dot(n, t.v2) >= m * t.len.z;
}

// False only when no ray of the cone -- directions within its half-angle of its axis -- can meet the
// triangle (given relative to the cone's apex, the light) at a distance tau with eps < tau < Lmax - eps:
// the leaf test counts hits in (eps, L - eps) and L <= Lmax. eps = 0 asks about the whole cone.
CS_FN bool preciseConeTriangle(ConeNode cone, PreciseTriangle t, float eps) {
  if (coneIsEmpty(cone)) return false;
  vec3 a = vec3(cone.axisCos);
  float c = cone.axisCos.w;
  float s = cone.sinLen.x;
  // The farthest a counted hit can be, rounded up by the margin of the longest ray.
  float lfar = cone.sinLen.z * (1.0f + CONE_TEST_MARGIN) - eps;

  // 0. The whole triangle within eps of the apex: no hit counts there.
  if (max(t.len.x, max(t.len.y, t.len.z)) < eps * (1.0f - CONE_TEST_MARGIN)) return false;

  // 1. Complementary cone of the cone rounded up to pi/2 (the apex plane for narrow cones).
  vec2 wide = c > 0.0f ? vec2(0.0f, 1.0f) : vec2(c, s);
  if (coneOutside(t.v0, t.len.x, a, wide) && coneOutside(t.v1, t.len.y, a, wide) &&
      coneOutside(t.v2, t.len.z, a, wide))
    return false;

  // 2. Nearest point of the triangle's plane (slab) inside the cone, against Lmax - eps.
  float nl = t.plane.w;
  if (nl > 0.0f && (t.slab.x > 0.0f || t.slab.y < 0.0f)) {
    vec3 m = t.slab.x > 0.0f ? vec3(t.plane) : -vec3(t.plane);
    float dist = t.slab.x > 0.0f ? t.slab.x : -t.slab.y;  // the slab's near side, in units of |N|
    float mu = dot(m, a);
    float nu = length(cross(m, a));
    // |N| * max over the cone's unit directions r of m.r, rounded up: 1 when m is inside the cone,
    // else cos(theta_m - alpha).
    float reach = nu * c - mu * s <= CONE_TEST_MARGIN * nl ? nl : mu * c + nu * s + CONE_TEST_MARGIN * nl;
    if (reach * lfar < dist) return false;  // lfar <= 0: no hit can count at all, any slab rejects
  }

  if (!(c > CONE_WIDE_COS)) return true;            // wide cone: only the tests above apply

  // 3. Homogeneous edge equations.
  if (edgeSeparates(t.edge0, a, c, s) || edgeSeparates(t.edge1, a, c, s) || edgeSeparates(t.edge2, a, c, s))
    return false;

  // 4. Triangle-shadow separating planes.
  if (tangentSeparates(t.v0, t.len.x, t, a, c, s) || tangentSeparates(t.v1, t.len.y, t, a, c, s) ||
      tangentSeparates(t.v2, t.len.z, t, a, c, s))
    return false;
  return true;
}

// Early accept (002 §3.3), the other direction from preciseConeTriangle: true only when EVERY ray of the
// cone -- a unit direction r within its half-angle of its axis, of length L >= Lmin -- meets the
// triangle's interior at a distance tau from the apex (the light) with eps < tau < L - eps, i.e. the leaf
// test would shadow every sample under the node. It may say false for a covered cone, never true for a
// cone with a ray that misses. Checked with the same margins as the reject test, the other way round:
//  - every direction lies strictly inside the three edge planes through the apex (oriented towards the
//    triangle), by the edge normal's own error and a relative margin: min over the cone of n.r > 0;
//  - the plane crossing tau = d / (m.r) (m the plane normal on the triangle's side, d in the slab) of
//    every direction lies in (eps, Lmin - eps), the slab's far side over the smallest m.r against
//    Lmin - eps, its near side over the largest against eps, each with the relative margin.
// Narrow cones only (cos alpha > CONE_WIDE_COS); an empty cone or an unreliable edge plane is never covered,
// nor a triangle whose plane or edge-plane normals are shorter than CONE_COVER_MIN_LENGTH (micro geometry
// next to the light, where flushed denormals would void the margins).
CS_FN bool edgeContains(vec4 e, vec3 a, float c, float s) {
  vec3 n = vec3(e);
  float nl = length(n);
  // |n| cos(phi + alpha) = min over the cone of n.r (alpha < pi/2 here), against the normal's error.
  return e.w > 0.0f && nl >= CONE_COVER_MIN_LENGTH &&
         dot(n, a) * c - length(cross(n, a)) * s > e.w + 4.0f * CONE_TEST_MARGIN * nl;
}

CS_FN bool preciseConeCovered(ConeNode cone, PreciseTriangle t, float eps) {
  if (coneIsEmpty(cone)) return false;
  vec3 a = vec3(cone.axisCos);
  float c = cone.axisCos.w;
  float s = cone.sinLen.x;
  float lmin = cone.sinLen.y;
  if (!(c > CONE_WIDE_COS) || !(lmin > 0.0f)) return false;
  float nl = t.plane.w;
  if (!(nl >= CONE_COVER_MIN_LENGTH) || !(t.slab.x > 0.0f || t.slab.y < 0.0f)) return false;  // light (near) in the plane
  if (!edgeContains(t.edge0, a, c, s) || !edgeContains(t.edge1, a, c, s) || !edgeContains(t.edge2, a, c, s))
    return false;
  vec3 m = t.slab.x > 0.0f ? vec3(t.plane) : -vec3(t.plane);
  float dnear = t.slab.x > 0.0f ? t.slab.x : -t.slab.y;
  float dfar = t.slab.x > 0.0f ? t.slab.y : -t.slab.x;
  float mu = dot(m, a);
  float nu = length(cross(m, a));
  float lo = mu * c - nu * s - 4.0f * CONE_TEST_MARGIN * nl;  // <= min over the cone of m.r
  if (!(lo > 0.0f)) return false;                             // some direction (nearly) parallel to the plane
  float hi = nu * c - mu * s <= CONE_TEST_MARGIN * nl ? nl : mu * c + nu * s + 4.0f * CONE_TEST_MARGIN * nl;
  const float k = 1.0f + 4.0f * CONE_TEST_MARGIN;
  // farthest crossing dfar / lo < Lmin - eps; nearest crossing dnear / hi > eps (margins both ways)
  return dfar * k < lo * (CONE_DIV(lmin, k) - eps * k) && dnear > hi * eps * k * k;
}

CS_FN bool preciseConeTriangle(ConeNode cone, vec3 v0, vec3 v1, vec3 v2, float eps) {
  return preciseConeTriangle(cone, preciseTriangle(v0, v1, v2), eps);
}

CS_FN bool preciseConeTriangle(ConeNode cone, vec3 v0, vec3 v1, vec3 v2) {
  return preciseConeTriangle(cone, preciseTriangle(v0, v1, v2), 0.0f);
}

// v with the ray's major axis kz moved last, cyclically (kx = kz + 1, ky = kz + 2), and x, y swapped when
// the major component is negative (keeps the winding). Selects, not dynamic indexing: GPUs (and
// lavapipe) index vector components by a variable through memory.
CS_FN vec3 shearOrder(vec3 v, int kz, bool flip) {
  vec3 r = kz == 0 ? vec3(v.y, v.z, v.x) : (kz == 1 ? vec3(v.z, v.x, v.y) : v);
  return flip ? vec3(r.y, r.x, r.z) : r;
}

// The leaf test: ray = leafRay(sample, light) (xyz = w = sample - light, w = L), triangle relative to the
// light. True when it meets the triangle at a distance tau from the light with eps < tau < L - eps.
CS_FN bool leafRayHitsTriangle(vec4 ray, float eps, vec3 v0, vec3 v1, vec3 v2) {
  vec3 w = vec3(ray);
  float L = ray.w;
  vec3 aw = abs(w);
  int kz = aw.x >= aw.y ? (aw.x >= aw.z ? 0 : 2) : (aw.y >= aw.z ? 1 : 2);
  float wz = kz == 0 ? w.x : (kz == 1 ? w.y : w.z);
  bool flip = wz < 0.0f;
  vec3 d = shearOrder(w, kz, flip);
  vec3 A = shearOrder(v0, kz, flip);
  vec3 B = shearOrder(v1, kz, flip);
  vec3 C = shearOrder(v2, kz, flip);
  CS_PRECISE float Sx = CONE_DIV(d.x, d.z);
  CS_PRECISE float Sy = CONE_DIV(d.y, d.z);
  CS_PRECISE float Sz = CONE_DIV(1.0f, d.z);
  CS_PRECISE float Ax = A.x - Sx * A.z;
  CS_PRECISE float Ay = A.y - Sy * A.z;
  CS_PRECISE float Bx = B.x - Sx * B.z;
  CS_PRECISE float By = B.y - Sy * B.z;
  CS_PRECISE float Cx = C.x - Sx * C.z;
  CS_PRECISE float Cy = C.y - Sy * C.z;
  CS_PRECISE float U = Cx * By - Cy * Bx;
  CS_PRECISE float V = Ax * Cy - Ay * Cx;
  CS_PRECISE float W = Bx * Ay - By * Ax;
  if ((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f)) return false;
  CS_PRECISE float det = U + V + W;
  // The ray (nearly) in the triangle's plane, or a projection degenerate within rounding: the signs of
  // U, V, W are noise there (all three can agree by chance, and T / det is then anything). Require det
  // to clear twice a bound on its rounding: sheared coordinates are off by <= 8 ulp of the vertex's
  // largest component (e), products and sums by an ulp each.
  vec3 aA = abs(A);
  vec3 aB = abs(B);
  vec3 aC = abs(C);
  float eA = CONE_ULP8 * max(aA.x, max(aA.y, aA.z));
  float eB = CONE_ULP8 * max(aB.x, max(aB.y, aB.z));
  float eC = CONE_ULP8 * max(aC.x, max(aC.y, aC.z));
  float bA = abs(Ax) + abs(Ay);
  float bB = abs(Bx) + abs(By);
  float bC = abs(Cx) + abs(Cy);
  float errDet = eC * bB + eB * bC + 2.0f * eB * eC + CONE_ULP2 * (bB * bC + abs(U)) +
                 eA * bC + eC * bA + 2.0f * eA * eC + CONE_ULP2 * (bA * bC + abs(V)) +
                 eB * bA + eA * bB + 2.0f * eA * eB + CONE_ULP2 * (bA * bB + abs(W));
  if (!(abs(det) > 2.0f * errDet)) return false;
  CS_PRECISE float T = U * (Sz * A.z) + V * (Sz * B.z) + W * (Sz * C.z);
  float tau = CONE_DIV(T, det) * L;  // T / det: the hit as a fraction of w
  return tau > eps && tau < L - eps;
}

// Largest |coordinate| over three vectors (the max norm of a triangle's vertices in some frame).
CS_FN float maxAbs3(vec3 a, vec3 b, vec3 c) {
  vec3 m = max(abs(a), max(abs(b), abs(c)));
  return max(m.x, max(m.y, m.z));
}

// The leaf test of one sample against one triangle, from world coordinates: sample p, light, the leaf
// The leaf test from the light (traversal.h, LeafTest::FromLight): the same question as leafHit, asked
// so that all it needs of the triangle is computed once for the 4, 16 or 64 rays of a leaf pair,
// which share their origin, the light. Used where the light is among the geometry (the world frame: a
// light within 8 half-diagonals of the scene, coordinates in [2^-12, 2^40] -- traversal.h leafTestFor);
// a far light takes leafHit, whose nearer end keeps the hit distance's rounding an ulp of the
// triangle's distance to that end.
//  - Inside: the edge functions of the rays from the light are triple products, U = w.n0 for the plane
//    through the light and the edge P1 -> P2 (w = sample - light; V, W for the edges P2 -> P0, P0 -> P1):
//    the signs of the sheared 2-D edge functions of leafRayHitsTriangle, up to the shear's positive
//    factor. The normal (P1 - light) x (P2 - light) is made as (A - light) x (B - A), A the edge's
//    lexicographically smaller end, negated when the edge runs from B to A: its components round to an ulp
//    of |A - light| |B - A| (not of |A - light| |B - light|, which a small triangle far from the light
//    would make noise), and a neighbour across the edge makes exactly the negated normal from the same
//    operands. Summed in one order and never fused (CS_PRECISE), a ray through a shared edge or vertex
//    then hits at least one of the triangles (0 counts as inside), as in the watertight test.
//  - Where: the ray's line meets the triangle's plane (normal N = (P1 - P0) x (P2 - P0), in world
//    coordinates) once; it crosses it between the light and the sample when dl = N.(light - P0) and
//    ds = N.(sample - P0) have opposite signs, at tau = L dl / (dl - ds) from the light. tau in
//    (eps, L - eps) is |dl| L > eps (|dl| + |ds|) and |ds| L > eps (|dl| + |ds|): no division. ds rounds to
//    an ulp of the sample's distance from P0, not of its distance from the light, so a receiver (the
//    sample on the triangle, ds ~ 0) does not shadow itself.
//  - Within rounding, a miss: dl or ds within its bound on its rounding (the light or the sample on the
//    plane, a degenerate triangle). Nothing more: unlike leafRayHitsTriangle, which divides by det and so
//    needs det clear of its rounding, this test takes the crossing from the signs of dl and ds, each
//    checked against its own bound, so a ray at a grazing angle to the plane still crosses it at one
//    certain point between its ends, and the edge functions say whether that point is inside. (A bound
//    of |N.w| against the edge functions' rounding, ~ulp |P - light| |edge|, dropped every ray within
//    ~1 degree of a small triangle's plane a thousandth of its distance from the light, hits well inside
//    it included: docs/ARCHITECTURE.md, "Grazing hits on small triangles".)
// Hits are where leafHit's are, up to each test's rounding at the edges and the ends of the interval,
// far below the ambiguity band's nudges (tests/traversal_test.cpp, LeafHitFromLight).
struct LeafTriangle {
  vec3 n0, n1, n2;  // the edge planes' normals through the light (P1 -> P2, P2 -> P0, P0 -> P1)
  vec3 N;           // (P1 - P0) x (P2 - P0), the plane's normal in world coordinates
  vec3 P0;          // the plane's anchor
  float dl;         // N.(light - P0): the light's side of the plane
  float errL;       // the bound on dl's rounding
  float errN;       // the bound on each of N's components' rounding
  float errS;       // over |sample - P0|_1: the bound on ds's rounding
};

// A strict total order on points (x, then y, then z): both triangles of an edge pick the same end.
CS_FN bool lexLess(vec3 a, vec3 b) { return a.x < b.x || (a.x == b.x && (a.y < b.y || (a.y == b.y && a.z < b.z))); }

// The normal (Pa - light) x (Pb - light) of the plane through the light and the edge Pa -> Pb, made from
// the edge's smaller end (see above); va, vb = Pa - light, Pb - light.
CS_FN vec3 edgeNormalFromLight(vec3 Pa, vec3 Pb, vec3 va, vec3 vb) {
  bool forward = lexLess(Pa, Pb);
  CS_PRECISE vec3 e = Pb - Pa;
  vec3 base = forward ? va : vb;
  vec3 dir = forward ? e : -e;  // fl(Pa - Pb) = -fl(Pb - Pa) exactly
  CS_PRECISE vec3 n = cross(base, dir);
  return forward ? n : -n;
}

// The plane's share of leafTriangle (N, P0, dl and the bounds; the edge normals zero): what the
// crossing test and the box cull below need, and all the two-ends test needs of it.
CS_FN LeafTriangle leafPlane(vec3 P0, vec3 P1, vec3 P2, vec3 light) {
  LeafTriangle t;
  t.n0 = vec3(0.0f);
  t.n1 = vec3(0.0f);
  t.n2 = vec3(0.0f);
  CS_PRECISE vec3 e1 = P1 - P0;
  CS_PRECISE vec3 e2 = P2 - P0;
  CS_PRECISE vec3 N = cross(e1, e2);
  t.N = N;
  t.P0 = P0;
  // An edge's components are rounded to an ulp of themselves (a difference of two fp32 values), the
  // cross product's two products and their difference to an ulp each: <= 8 ulp of the largest product.
  float me = maxAbs3(e1, e2, e2);
  t.errN = CONE_ULP8 * me * me;
  CS_PRECISE vec3 dL = light - P0;
  CS_PRECISE float dl = dot(N, dL);
  t.dl = dl;
  vec3 a = abs(dL);
  t.errL = CONE_ULP8 * dot(abs(N), a) + t.errN * (a.x + a.y + a.z);
  // ds = N.d rounds by <= 8 ulp of sum |N_k d_k| plus N's own error over |d|_1: <= errS |d|_1.
  t.errS = CONE_ULP8 * maxAbs3(N, N, N) + t.errN;
  return t;
}

CS_FN LeafTriangle leafTriangle(vec3 P0, vec3 P1, vec3 P2, vec3 light) {
  LeafTriangle t = leafPlane(P0, P1, P2, light);
  CS_PRECISE vec3 v0 = P0 - light;
  CS_PRECISE vec3 v1 = P1 - light;
  CS_PRECISE vec3 v2 = P2 - light;
  t.n0 = edgeNormalFromLight(P1, P2, v1, v2);
  t.n1 = edgeNormalFromLight(P2, P0, v2, v0);
  t.n2 = edgeNormalFromLight(P0, P1, v0, v1);
  return t;
}

// The ray from the light to sample p (length L) crosses the triangle's plane between its ends, at a
// distance tau from the light with eps < tau < L - eps: dl = N.(light - P0) and ds = N.(p - P0) of
// opposite signs, each clear of its bound on its rounding, tau = L |dl| / (|dl| + |ds|). Both leaf tests
// ask it (leafHitFromLight as its "where", leafHit beside its sheared test), so a hit always has the
// sample beyond the plane from the light: what the box cull (leafPlaneMissesBox) relies on.
CS_FN bool leafCrosses(LeafTriangle t, vec3 p, float L, float eps) {
  CS_PRECISE vec3 d = p - t.P0;
  CS_PRECISE float ds = dot(t.N, d);
  vec3 a = abs(d);
  float errS = t.errS * (a.x + a.y + a.z);
  float adl = abs(t.dl);
  float ads = abs(ds);
  float sum = adl + ads;  // |dl - ds| = |N.w| where the signs differ: tau = L adl / sum
  return (t.dl > 0.0f) != (ds > 0.0f) && adl > t.errL && ads > errS && adl * L > eps * sum && ads * L > eps * sum;
}

// The box cull of a leaf pair: true only when no sample in the box [lo, hi] (world coordinates) can have
// leafCrosses true, i.e. the pair's leaf tests would all miss. A crossing needs the sample beyond the
// plane from the light by ds_far > errS(p) (computed), and tau from the sample, L ds_far / (|dl| + ds_far),
// above eps, so ds_far L > eps |dl|. Over the box, ds_far is at most the far corner's, D (computed; the
// true value within errS |q - P0|_1 of it, and a tiny normal component of the wrong sign costs errN times
// the box's extent), so with A = max over the box of |p - P0|_1 (>= every such |d|_1), every sample's
// computed ds_far is below D + 6 errS A: a box with (D + 6 errS A) Lb <= eps (|dl| - 2 errL), Lb an upper
// bound on the rays' computed lengths, has no crossing (and none at all when D + 6 errS A <= 0: the
// whole box on the light's side). It drops the receivers -- samples on the triangle's own plane, whose
// rays' crossings are within eps of them -- and what lies between the light and the plane; it asks
// nothing of the triangle's edges, so it is no pass test's duplicate. Empty boxes (lo > hi) are culled.
CS_FN bool leafPlaneMissesBox(LeafTriangle t, vec3 lo, vec3 hi, vec3 light, float eps) {
  if (lo.x > hi.x) return true;
  vec3 m = t.dl > 0.0f ? -t.N : t.N;  // towards the far side
  vec3 q = vec3(m.x > 0.0f ? hi.x : lo.x, m.y > 0.0f ? hi.y : lo.y, m.z > 0.0f ? hi.z : lo.z);
  CS_PRECISE vec3 d = q - t.P0;
  CS_PRECISE float D = dot(m, d);
  vec3 a = max(abs(lo - t.P0), abs(hi - t.P0));
  float f = D + 6.0f * t.errS * (a.x + a.y + a.z);
  if (!(f > 0.0f)) return !(f != f);  // NaN keeps the pair
  vec3 r = max(abs(lo - light), abs(hi - light));
  float Lb = length(r) * (1.0f + 4.0f * CONE_TEST_MARGIN);
  return f * Lb <= eps * (abs(t.dl) - 2.0f * t.errL) * (1.0f - 4.0f * CONE_TEST_MARGIN);
}

// ray = leafRay(p, light) for a sample p (as leafHit takes it); t = leafTriangle(P0, P1, P2, light).
CS_FN bool leafHitFromLight(LeafTriangle t, vec3 p, vec4 ray, float eps) {
  vec3 w = vec3(ray);
  // Summed in one order, unfused: -n gives exactly -U.
  CS_PRECISE float U = w.x * t.n0.x + w.y * t.n0.y + w.z * t.n0.z;
  CS_PRECISE float V = w.x * t.n1.x + w.y * t.n1.y + w.z * t.n1.z;
  CS_PRECISE float W = w.x * t.n2.x + w.y * t.n2.y + w.z * t.n2.z;
  bool inside = !((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f));
  return inside && leafCrosses(t, p, ray.w, eps);
}

// The leaf test from the sample (traversal.h, LeafTest::FromSample): leafHitFromLight's question and
// structure -- inside from the signs of three triple products, where from leafCrosses -- with each edge's
// plane taken through whichever of the ray's ends is nearer the edge's first end: U = w.((A - p) x (B - A))
// for the edge A -> B (A its lexicographically smaller end, negated when the edge runs the other way)
// where |A - p| <= |A - light| (max norm), else w.((A - light) x (B - A)), leafHitFromLight's. The two
// are one quantity in exact arithmetic (w = p - light lies along p - light); in fp32 each rounds to an
// ulp of its base |A - p| or |A - light| times |B - A| |w|, so across the ray the error is an ulp of the
// edge's distance from the nearer end: what leafHit's sheared test gets from its nearer end (and the
// reference's own test from its origin), and never more than the test from the light, whose error the
// pass tests' margins cover. A far light's rays take the sample's end for every edge (every triangle is
// nearer its samples than the light); the choice only guards samples the caller put farther away. The
// edges' ends, directions and bases through the light are the pair's (leafEdges); a ray adds three
// differences, cross and dot products, no shear, division or choice of a whole triangle's end. Both
// neighbours across an edge choose by the same end A and make the negated value from the same operands,
// so a ray through a shared edge or vertex hits at least one of the triangles (0 counts as inside).
struct LeafEdges {
  vec3 a0, a1, a2;  // each edge's lexicographically smaller end (P1 -> P2, P2 -> P0, P0 -> P1)
  vec3 d0, d1, d2;  // from it to the other end
  vec3 l0, l1, l2;  // it relative to the light
  vec3 reach;       // |a_k - light| in the max norm, per edge
  vec3 sign;        // +1 where the edge runs from that end, -1 where it runs to it
};

CS_FN LeafEdges leafEdges(vec3 P0, vec3 P1, vec3 P2, vec3 light) {
  LeafEdges e;
  bool f0 = lexLess(P1, P2), f1 = lexLess(P2, P0), f2 = lexLess(P0, P1);
  e.a0 = f0 ? P1 : P2;
  e.a1 = f1 ? P2 : P0;
  e.a2 = f2 ? P0 : P1;
  CS_PRECISE vec3 d0 = (f0 ? P2 : P1) - e.a0;
  CS_PRECISE vec3 d1 = (f1 ? P0 : P2) - e.a1;
  CS_PRECISE vec3 d2 = (f2 ? P1 : P0) - e.a2;
  e.d0 = d0;
  e.d1 = d1;
  e.d2 = d2;
  CS_PRECISE vec3 l0 = e.a0 - light;
  CS_PRECISE vec3 l1 = e.a1 - light;
  CS_PRECISE vec3 l2 = e.a2 - light;
  e.l0 = l0;
  e.l1 = l1;
  e.l2 = l2;
  e.reach = vec3(maxAbs3(l0, l0, l0), maxAbs3(l1, l1, l1), maxAbs3(l2, l2, l2));
  e.sign = vec3(f0 ? 1.0f : -1.0f, f1 ? 1.0f : -1.0f, f2 ? 1.0f : -1.0f);
  return e;
}

// w.(base x d), summed in one order, unfused (a neighbour gets the same value exactly).
CS_FN float edgeFunction(vec3 w, vec3 base, vec3 d) {
  CS_PRECISE vec3 n = cross(base, d);
  CS_PRECISE float v = w.x * n.x + w.y * n.y + w.z * n.z;
  return v;
}

// base = a - p where that is no farther than the light's end (reach), else l = a - light.
CS_FN float edgeFromNearerEnd(vec3 w, vec3 p, vec3 a, vec3 d, vec3 l, float reach) {
  CS_PRECISE vec3 b = a - p;
  return edgeFunction(w, maxAbs3(b, b, b) <= reach ? b : l, d);
}

// Whether every sample p in the box [lo, hi] takes the sample's end for every edge of e: the computed
// |a - p| (max norm) is at most the edge's reach. fl(a - p) is monotonic in p, so its magnitude over the
// box is at most its larger one at the box's two ends, per component. Where true, leafHitFromSampleEnd
// answers as leafHitFromSample for each of those samples, bit for bit, without the per-edge choice (an
// empty or NaN box: false).
CS_FN bool leafSamplesNearer(LeafEdges e, vec3 lo, vec3 hi) {
  CS_PRECISE vec3 a0 = e.a0 - lo;
  CS_PRECISE vec3 b0 = e.a0 - hi;
  CS_PRECISE vec3 a1 = e.a1 - lo;
  CS_PRECISE vec3 b1 = e.a1 - hi;
  CS_PRECISE vec3 a2 = e.a2 - lo;
  CS_PRECISE vec3 b2 = e.a2 - hi;
  return lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z && maxAbs3(a0, b0, b0) <= e.reach.x &&
         maxAbs3(a1, b1, b1) <= e.reach.y && maxAbs3(a2, b2, b2) <= e.reach.z;
}

// ray = leafRay(p, light); t = leafPlane(P0, P1, P2, light) (or leafTriangle), e = leafEdges(P0, P1, P2, light).
CS_FN bool leafHitFromSample(LeafTriangle t, LeafEdges e, vec3 p, vec4 ray, float eps) {
  vec3 w = vec3(ray);
  float U = e.sign.x * edgeFromNearerEnd(w, p, e.a0, e.d0, e.l0, e.reach.x);
  float V = e.sign.y * edgeFromNearerEnd(w, p, e.a1, e.d1, e.l1, e.reach.y);
  float W = e.sign.z * edgeFromNearerEnd(w, p, e.a2, e.d2, e.l2, e.reach.z);
  bool inside = !((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f));
  return inside && leafCrosses(t, p, ray.w, eps);
}

// leafHitFromSample with every edge from the sample's end: for samples in a box leafSamplesNearer holds
// for (the leaves take it where every pair of a subgroup's does: the choice's cost saved).
CS_FN bool leafHitFromSampleEnd(LeafTriangle t, LeafEdges e, vec3 p, vec4 ray, float eps) {
  vec3 w = vec3(ray);
  CS_PRECISE vec3 b0 = e.a0 - p;
  CS_PRECISE vec3 b1 = e.a1 - p;
  CS_PRECISE vec3 b2 = e.a2 - p;
  float U = e.sign.x * edgeFunction(w, b0, e.d0);
  float V = e.sign.y * edgeFunction(w, b1, e.d1);
  float W = e.sign.z * edgeFunction(w, b2, e.d2);
  bool inside = !((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f));
  return inside && leafCrosses(t, p, ray.w, eps);
}

// The same from world coordinates, one call a ray (the host's brute force and property tests).
CS_FN bool leafHitFromSample(vec3 p, vec3 light, vec4 ray, float eps, vec3 P0, vec3 P1, vec3 P2) {
  return leafHitFromSample(leafPlane(P0, P1, P2, light), leafEdges(P0, P1, P2, light), p, ray, eps);
}

// The same from world coordinates, one call a ray (the host's brute force and property tests).
CS_FN bool leafHitFromLight(vec3 p, vec3 light, vec4 ray, float eps, vec3 P0, vec3 P1, vec3 P2) {
  return leafHitFromLight(leafTriangle(P0, P1, P2, light), p, ray, eps);
}

// ray = leafRay(p, light), triangle P0, P1, P2. The same geometry from whichever end of the ray the
// triangle is nearer (in the max norm): relative to the light, the ray light -> p as above; relative to
// the sample, the ray p -> light along -w = light - p (fl(light - p) = -fl(p - light) exactly: the same
// line), hits at tau in (eps, L - eps) from the sample as the reference counts them.
// Why both ends: the vertices' rounding is about an ulp of their distance from the origin of the frame,
// and so is that of the hit distance. Relative to the light alone, a triangle next to a far light's
// sample sits at tau ~ L, where ulp(L) can exceed eps (a light 10^5 scene diagonals away): the receiver
// would shadow itself, or a blocker a hair above it be lost. Relative to the sample alone, a triangle a
// hair from the light inherits ulp(L) the same way. From the nearer end, the error is an ulp of the
// triangle's distance to that end, never more than relative to the light, so the traversal's margins
// (relative to |P - light|) still cover every hit this test reports.
// The plane t (leafPlane(P0, P1, P2, light)) is computed once a pair; its crossing is asked beside the
// sheared test (leafCrosses), so both tests agree on which side of the plane a hit's sample lies.
CS_FN bool leafHit(LeafTriangle t, vec3 p, vec3 light, vec4 ray, float eps, vec3 P0, vec3 P1, vec3 P2) {
  CS_PRECISE vec3 a0 = P0 - light;
  CS_PRECISE vec3 a1 = P1 - light;
  CS_PRECISE vec3 a2 = P2 - light;
  CS_PRECISE vec3 b0 = P0 - p;
  CS_PRECISE vec3 b1 = P1 - p;
  CS_PRECISE vec3 b2 = P2 - p;
  // One call on the chosen end's values (selected, not branched: a GPU or lavapipe running both sides of
  // a divergent branch would run the test twice).
  bool fromSample = maxAbs3(b0, b1, b2) < maxAbs3(a0, a1, a2);
  vec4 r = fromSample ? vec4(-vec3(ray), ray.w) : ray;
  return leafRayHitsTriangle(r, eps, fromSample ? b0 : a0, fromSample ? b1 : a1, fromSample ? b2 : a2) &&
         leafCrosses(t, p, ray.w, eps);
}

CS_FN bool leafHit(vec3 p, vec3 light, vec4 ray, float eps, vec3 P0, vec3 P1, vec3 P2) {
  return leafHit(leafPlane(P0, P1, P2, light), p, light, ray, eps, P0, P1, P2);
}

#ifdef __cplusplus
}  // namespace glsl
using glsl::leafHit;
using glsl::leafHitFromLight;
using glsl::leafHitFromSample;
using glsl::leafHitFromSampleEnd;
using glsl::leafSamplesNearer;
using glsl::leafEdges;
using glsl::LeafEdges;
using glsl::lexLess;
using glsl::leafTriangle;
using glsl::leafPlane;
using glsl::leafCrosses;
using glsl::leafPlaneMissesBox;
using glsl::LeafTriangle;
using glsl::leafRayHitsTriangle;
using glsl::preciseConeCovered;
using glsl::preciseConeTriangle;
using glsl::preciseTriangle;
using glsl::PreciseTriangle;
}  // namespace CONE_CPU_NAMESPACE
#endif
#endif
