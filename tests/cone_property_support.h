// Random and adversarial (cone, triangle) pairs and a brute-force search for an intersection, shared by
// the property tests of the traversal's tests (tests/traversal_test.cpp) and of the same source under the
// arithmetic a GPU is allowed (tests/gpu_arithmetic_test.cpp).
#pragma once
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "method/epsilon.h"
#include "traversal/precise_test.h"

namespace cs::test {

using cone::ConeNode;
using glm::dvec3;
using glm::vec3;
using glm::vec4;

// ---- random (cone, triangle) pairs ------------------------------------------------------------------

struct Pair {
  ConeNode cone;
  vec3 v[3];  // relative to the apex
  int kind;
  float eps;  // hits count at distances in (eps, Lmax - eps) from the apex
};
inline constexpr int kKinds = 14;
inline const char* kindName(int k) {
  static const char* names[kKinds] = {"random",          "near the boundary", "touching the boundary",
                                      "vertex at apex",  "apex in plane",     "apex on an edge line",
                                      "repeated vertex", "collinear",         "a point",
                                      "sliver",          "in the complement", "around Lmax",
                                      "huge",            "edge just outside"};
  return names[k];
}

struct PairGenerator {
  std::mt19937_64 rng;
  explicit PairGenerator(uint64_t seed) : rng(seed) {}
  double uni(double a = 0, double b = 1) { return std::uniform_real_distribution<double>(a, b)(rng); }
  double logUni(double lo, double hi) { return std::exp(uni(std::log(lo), std::log(hi))); }
  dvec3 unit() {
    for (;;) {
      dvec3 p(uni(-1, 1), uni(-1, 1), uni(-1, 1));
      double l = glm::length(p);
      if (l > 1e-3 && l <= 1) return p / l;
    }
  }
  // Half-angles that matter: zero, tiny, around pi/2 (both sides of the pi/2 - eps switch), past it, pi.
  double angle() {
    static const double table[] = {0,        1e-7,   1e-6,          1e-5,           1e-4,           1e-3,
                                   0.01,     0.1,    0.3,           0.7,            1.2,            1.5,
                                   M_PI / 2 - 2e-3, M_PI / 2 - 9e-4, M_PI / 2 - 1e-5, M_PI / 2, M_PI / 2 + 1e-5,
                                   M_PI / 2 + 1e-3, 2.0,  2.5,  3.0,  M_PI - 1e-3,  M_PI - 1e-6,  M_PI};
    size_t k = rng() % 30;
    return k < std::size(table) ? table[k] : uni(0, M_PI);
  }
  dvec3 at(dvec3 a, double theta) {  // a direction at angle theta from unit a
    dvec3 t = std::abs(a.x) < 0.5 ? dvec3(1, 0, 0) : dvec3(0, 1, 0);
    dvec3 u = glm::normalize(glm::cross(a, t)), v = glm::cross(a, u);
    double phi = uni(0, 2 * M_PI);
    return std::cos(theta) * a + std::sin(theta) * (std::cos(phi) * u + std::sin(phi) * v);
  }
  static ConeNode cone(dvec3 a, double alpha, double lmax) {
    ConeNode c;
    c.axisCos = vec4(vec3(a), float(std::cos(alpha)));
    c.sinLen = vec4(float(std::sin(alpha)), float(lmax * 0.5), float(lmax), float(alpha));
    if (alpha >= M_PI) c.axisCos.w = -1, c.sinLen.x = 0;
    return c;
  }
  Pair make() {
    Pair p;
    dvec3 a = unit();
    double alpha = angle();
    double lmax = logUni(1e-2, 1e3);
    p.cone = cone(a, alpha, lmax);
    p.kind = int(rng() % kKinds);
    p.eps = rng() % 2 ? 0.0f : float(lmax * logUni(1e-5, 0.3));
    double sc = logUni(1e-3, 1e3);
    auto rnd = [&] { return unit() * sc * uni(0, 1.5); };
    dvec3 v[3];
    switch (p.kind) {
      case 0: for (auto& x : v) x = rnd(); break;
      case 1: {
        double d = (rng() % 2 ? 1 : -1) * logUni(1e-9, 1e-1);
        dvec3 x = at(a, std::min(std::max(alpha + d, 0.0), M_PI)) * lmax * uni(0.2, 1.5);
        double r = logUni(1e-6, 1) * lmax;
        v[0] = x, v[1] = x + unit() * r, v[2] = x + unit() * r;
        break;
      }
      case 2: {
        dvec3 x = at(a, alpha) * lmax * uni(0.1, 1.2), e1 = unit() * sc, e2 = unit() * sc;
        v[0] = x - uni(0, 0.5) * e1 - uni(0, 0.5) * e2, v[1] = v[0] + e1, v[2] = v[0] + e2;
        break;
      }
      case 3: v[0] = dvec3(0), v[1] = rnd(), v[2] = rnd(); break;
      case 4: v[0] = rnd(), v[1] = rnd(), v[2] = uni(-2, 2) * v[0] + uni(-2, 2) * v[1]; break;
      case 5: v[0] = rnd(), v[1] = -v[0] * uni(0.1, 3), v[2] = rnd(); break;
      case 6: v[0] = rnd(), v[1] = v[0], v[2] = rnd(); break;
      case 7: {
        v[0] = rnd();
        dvec3 d = unit();
        v[1] = v[0] + d * uni(0, sc), v[2] = v[0] + d * uni(-sc, sc);
        break;
      }
      case 8: v[0] = v[1] = v[2] = rnd(); break;
      case 9: v[0] = rnd(), v[1] = rnd(), v[2] = v[1] + (v[1] - v[0]) * 1e-6 + unit() * sc * 1e-7; break;
      case 10: for (auto& x : v) x = at(-a, uni(0, std::max(0.0, M_PI - alpha))) * sc; break;
      case 11: {
        dvec3 x = a * lmax * uni(0.9, 1.1);
        for (auto& y : v) y = x + unit() * lmax * uni(0, 3);
        break;
      }
      case 12: {
        dvec3 c = a * uni(-1, 1) * sc;
        for (auto& y : v) y = c + unit() * sc * 100.0;
        break;
      }
      default: {
        dvec3 x = at(a, alpha + logUni(1e-7, 1e-2)) * lmax * uni(0.1, 1);
        dvec3 t = glm::normalize(glm::cross(x, unit()));
        v[0] = x, v[1] = x + t * sc, v[2] = x + t * sc * uni(-1, 1) + x * uni(0, 1e-3);
        break;
      }
    }
    for (int i = 0; i < 3; ++i) p.v[i] = vec3(v[i]);
    return p;
  }
};

// Brute force: does some ray of the (fp32-stored) cone, up to Lmax, meet the (fp32) triangle? Searched
// three ways: points of the triangle inside the cone (exact, double), rays of the cone against the
// triangle (double Moller-Trumbore), and fp32 leaf rays of the cone through the very leaf test the
// traversal runs. Returns the ray found (xyz, length) in `ray` for the GPU check.
struct BruteForce {
  std::mt19937_64 rng{7};
  double uni(double a = 0, double b = 1) { return std::uniform_real_distribution<double>(a, b)(rng); }
  // x on a ray of the cone at a distance where hits count: eps < |x| < Lmax - eps.
  static bool inCone(dvec3 x, dvec3 a, double alpha, double lmax, double eps) {
    double l = glm::length(x);
    if (!(l > 0) || !(l > eps) || !(l < lmax - eps)) return false;
    return std::atan2(glm::length(glm::cross(x, a)), glm::dot(x, a)) <= alpha;
  }
  // The leaf test is run with eps at least the epsilon policy's floor (32 ulp of the largest coordinate,
  // here the triangle's and the cone's length): below it, which no frame passes, a hit at the end of the
  // ray far from the frame the test picks is rounding (the pair's eps may be 0: the whole cone).
  static float leafEps(const Pair& p) {
    float m = p.cone.sinLen.z;
    for (const vec3& v : p.v) m = std::max(m, std::max(std::abs(v.x), std::max(std::abs(v.y), std::abs(v.z))));
    return std::max(p.eps, EpsilonPolicy::kFloorUlps * FLT_EPSILON * m);
  }
  // The fp32 leaf test the search runs on the cone's rays: sample w (the apex at the origin), its leaf
  // ray, eps, the triangle. By default the traversal's own, any of its three (cone::leafHit,
  // cone::leafHitFromLight, cone::leafHitFromSample: traversal.h LeafTest), so the pass tests must keep
  // what any hits; the GPU-arithmetic tests pass their emulated twins.
  std::function<bool(vec3, vec4, float, const vec3*)> leaf = [](vec3 w, vec4 ray, float eps, const vec3* v) {
    return cone::leafHit(w, vec3(0), ray, eps, v[0], v[1], v[2]) ||
           cone::leafHitFromLight(w, vec3(0), ray, eps, v[0], v[1], v[2]) ||
           cone::leafHitFromSample(w, vec3(0), ray, eps, v[0], v[1], v[2]);
  };
  bool hit(const Pair& p, vec4* leafHit = nullptr) {
    dvec3 a = glm::normalize(dvec3(vec3(p.cone.axisCos)));
    double alpha = std::atan2(double(p.cone.sinLen.x), double(p.cone.axisCos.w));
    double lmax = p.cone.sinLen.z, eps = p.eps;
    dvec3 v0(p.v[0]), v1(p.v[1]), v2(p.v[2]);
    const int G = 20;
    for (int i = 0; i <= G; ++i)
      for (int j = 0; i + j <= G; ++j)
        if (inCone(v0 + (double(i) / G) * (v1 - v0) + (double(j) / G) * (v2 - v0), a, alpha, lmax, eps)) return true;
    for (int k = 0; k < 300; ++k) {
      double b1 = uni(), b2 = uni();
      if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
      if (k < 100) b2 = 0;
      else if (k < 150) b1 = 1 - b2;
      else if (k < 200) b1 = 0;
      if (inCone(v0 + b1 * (v1 - v0) + b2 * (v2 - v0), a, alpha, lmax, eps)) return true;
    }
    dvec3 t = std::abs(a.x) < 0.5 ? dvec3(1, 0, 0) : dvec3(0, 1, 0);
    dvec3 u = glm::normalize(glm::cross(a, t)), w = glm::cross(a, u);
    for (int k = 0; k < 400; ++k) {
      double th = k == 1 ? 0.0 : (k % 3 == 0 ? alpha : uni(0, alpha)), phi = uni(0, 2 * M_PI);
      dvec3 r = std::cos(th) * a + std::sin(th) * (std::cos(phi) * u + std::sin(phi) * w);
      dvec3 e1 = v1 - v0, e2 = v2 - v0, pv = glm::cross(r, e2);
      double det = glm::dot(e1, pv);
      if (det != 0) {
        dvec3 tv = -v0, qv = glm::cross(tv, e1);
        double bu = glm::dot(tv, pv) / det, bv = glm::dot(r, qv) / det, tt = glm::dot(e2, qv) / det;
        if (bu >= 0 && bv >= 0 && bu + bv <= 1 && tt > eps && tt < lmax - eps) return true;
      }
      vec3 wf = vec3(r * (lmax * (k % 5 == 0 ? 1.0 : uni(0.01, 1))));
      vec4 ray = cone::leafRay(wf, vec3(0));
      if (ray.w <= lmax && std::atan2(glm::length(glm::cross(dvec3(wf), a)), glm::dot(dvec3(wf), a)) <= alpha &&
          leaf(wf, ray, leafEps(p), p.v)) {
        if (leafHit) *leafHit = ray;
        return true;
      }
    }
    return false;
  }
};

// Pairs as the far-light frame sees them (traversal/traversal.h): every vertex and every ray within an
// angle theta (1e-6 .. 0.12 rad) of +z, at distances around D (1 .. 1e6) from the apex; the cone's axis
// inside that range, its half-angle from 0 to a fraction of theta; vertices scattered over the range,
// gathered near the cone, or placed just outside its boundary or its edge planes. `scale` is the frame's
// angular scale for theta, min(1, 4 tan theta), as chooseFrame computes it.
struct FarPair {
  Pair pair;
  float scale;
};
struct FarPairGenerator {
  PairGenerator g;
  explicit FarPairGenerator(uint64_t seed) : g(seed) {}
  // A unit direction within `theta` of +z (uniform in the projected disc).
  dvec3 within(double theta) {
    for (;;) {
      double x = g.uni(-1, 1), y = g.uni(-1, 1);
      if (x * x + y * y > 1) continue;
      return glm::normalize(dvec3(x * std::tan(theta), y * std::tan(theta), 1.0));
    }
  }
  FarPair make() {
    const double theta = g.logUni(1e-6, 0.12), D = g.logUni(1.0, 1e6);
    FarPair f;
    f.scale = float(std::min(1.0, 4.0 * std::tan(theta)));
    Pair& p = f.pair;
    const dvec3 a = within(0.5 * theta);
    const int kind = int(g.rng() % 5);
    const double alpha = kind == 4 ? 0.0 : theta * g.logUni(1e-4, 0.4);
    const double lmax = D * g.uni(0.8, 1.2);
    p.cone = PairGenerator::cone(a, alpha, lmax);
    p.eps = float(g.rng() % 2 ? 0.0 : D * g.logUni(1e-9, 1e-4));
    p.kind = kind;
    auto keep = [&](dvec3 d) {  // stays within theta of +z
      return std::atan2(std::hypot(d.x, d.y), d.z) <= theta ? d : a;
    };
    dvec3 v[3];
    switch (kind) {
      case 0:  // anywhere in the range
        for (auto& x : v) x = within(theta) * D * g.uni(0.5, 1.3);
        break;
      case 1: {  // around the cone: its footprint times a few
        for (auto& x : v) x = keep(g.at(a, alpha * g.uni(0, 4) + theta * 1e-3 * g.uni(0, 1))) * D * g.uni(0.6, 1.2);
        break;
      }
      case 2: {  // a vertex just outside the boundary, the others beyond it
        const double off = alpha + std::max(alpha, theta * 1e-4) * g.logUni(1e-7, 1e-2);
        v[0] = keep(g.at(a, off)) * D * g.uni(0.7, 1.1);
        const dvec3 out = glm::normalize(v[0] - glm::dot(v[0], a) * a);
        for (int k = 1; k < 3; ++k) v[k] = keep(glm::normalize(v[0] / glm::length(v[0]) + out * alpha * g.uni(0.1, 2) +
                                                               g.unit() * alpha * 0.2)) * D * g.uni(0.7, 1.1);
        break;
      }
      case 3: {  // an edge just outside: two vertices on a line tangent to the cone's boundary
        const dvec3 side = glm::normalize(glm::cross(a, g.unit()));
        const dvec3 along = glm::cross(a, side);
        const double off = alpha * (1 + g.logUni(1e-7, 1e-2)) + theta * 1e-7;
        const double t = D * g.uni(0.7, 1.1);
        v[0] = t * (a + side * off + along * alpha * g.uni(1, 3));
        v[1] = t * (a + side * off - along * alpha * g.uni(1, 3));
        v[2] = t * (a + side * (off + alpha * g.uni(0.5, 3)));
        break;
      }
      default:  // a ray cone (alpha 0) and a small triangle around or beside it
        for (auto& x : v) x = keep(g.at(a, theta * g.logUni(1e-6, 1e-2))) * D * g.uni(0.9, 1.0);
        break;
    }
    for (int i = 0; i < 3; ++i) p.v[i] = vec3(v[i]);
    return f;
  }
};

// One of the rays an early-accept check probes in the cone (axis a, half-angle alpha, lengths [lmin, lmax]):
// the k-th -- along the axis first, then on the boundary and inside in turn, at Lmin, Lmax or between.
// The sample w (the apex at the origin) and its leaf ray as `leafRayFn` (the twin's leafRay) computes
// it, lengthened by a hair when its fp32 length rounds below Lmin.
struct ProbeRay {
  dvec3 r;  // unit direction
  double L, theta;
  vec3 w;
  vec4 ray;
};
template <class Uni, class LeafRay>
ProbeRay probeRay(int k, dvec3 a, double alpha, double lmin, double lmax, Uni&& uni, LeafRay&& leafRayFn) {
  const dvec3 tu = glm::normalize(glm::cross(a, std::abs(a.x) < 0.5 ? dvec3(1, 0, 0) : dvec3(0, 1, 0)));
  const dvec3 tw = glm::cross(a, tu);
  const double th = k == 0 ? 0.0 : (k % 2 ? alpha : uni(0.0, alpha)), ph = uni(0.0, 2 * M_PI);
  ProbeRay p;
  p.r = std::cos(th) * a + std::sin(th) * (std::cos(ph) * tu + std::sin(ph) * tw);
  p.L = k % 3 == 0 ? lmin : (k % 3 == 1 ? lmax : uni(lmin, lmax));
  p.theta = th;
  p.w = vec3(p.r * p.L);
  p.ray = leafRayFn(p.w, vec3(0));
  if (p.ray.w < float(lmin)) p.ray = leafRayFn(p.w = vec3(p.r * p.L * (1 + 1e-6)), vec3(0));
  return p;
}

// ---- sample boxes against a triangle's plane (the plane cull, precise_test.h leafPlaneMissesBox) ------

// Case i of the plane cull's property tests: a triangle over six decades of scale, a light 0.1 to 90
// degrees over its plane (either side) 0.5 to 1e5 sizes away, and sixteen samples of kind i % 5 --
// 0: anywhere around the triangle; 1: receivers, on an axis-aligned plane (a ground, a wall) a few ulp
// off it either way, as a rasterised surface gives them; 2: on the light's side of such a plane; 3:
// along rays through the triangle, past it (hits); 4: beyond an axis-aligned triangle along rays through
// it, the crossing 0.2 to 3 eps from the sample (the interval's end). `points` holds the samples, their
// box's corners and sixteen random points in the box: the cull's claim covers all of them.
struct PlaneBox {
  bool valid = false;  // false: a degenerate triangle, skip
  int kind = 0;
  vec3 P[3];
  vec3 light;
  float eps = 0;
  vec3 lo, hi;                // the box of the sixteen samples
  std::vector<vec3> points;
  bool clear = false;         // clear of the cull's margins, so it should drop the box: kind 1 under a light
                              // 5+ degrees over the plane within 100 sizes, every kind 2
  std::string describe;
};

inline PlaneBox makePlaneBox(std::mt19937& rng, int i) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PlaneBox c;
  c.kind = i % 5;
  const double scale = std::pow(10.0, 6.0 * u(rng) - 3.0);
  const dvec3 centre = scale * (dvec3(u(rng), u(rng), u(rng)) - 0.5);
  const double size = scale * std::pow(10.0, -2.0 * u(rng));
  // Receivers, the light's side and the interval's end on an axis-aligned plane: every vertex's
  // coordinate `axis` the same.
  const int axis = c.kind == 1 || c.kind == 2 || c.kind == 4 ? i / 5 % 3 : -1;
  for (vec3& x : c.P) {
    x = vec3(centre + size * (dvec3(u(rng), u(rng), u(rng)) - 0.5));
    if (axis >= 0) x[axis] = float(centre[axis]);
  }
  const dvec3 e1 = dvec3(c.P[1]) - dvec3(c.P[0]), e2 = dvec3(c.P[2]) - dvec3(c.P[0]);
  const dvec3 n = glm::cross(e1, e2);
  if (!(glm::length(n) > 1e-6 * size * size)) return c;
  const dvec3 nh = glm::normalize(n);
  const dvec3 ua = glm::normalize(glm::cross(nh, std::abs(nh.x) < 0.5 ? dvec3(1, 0, 0) : dvec3(0, 1, 0)));
  const dvec3 va = glm::cross(nh, ua);
  const double elevation = std::pow(10.0, std::log10(0.1) + u(rng) * std::log10(900.0)) * M_PI / 180.0;
  const double az = 2.0 * M_PI * u(rng), away = size * std::pow(10.0, -0.3 + 5.3 * u(rng));
  const double side = u(rng) < 0.5 ? 1.0 : -1.0;
  const dvec3 toLight = std::cos(elevation) * (std::cos(az) * ua + std::sin(az) * va) + side * std::sin(elevation) * nh;
  c.light = vec3(dvec3(c.P[0]) + away * toLight);
  c.eps = float(1e-4 * scale);
  const dvec3 lightSide = glm::dot(dvec3(c.light) - dvec3(c.P[0]), nh) > 0 ? nh : -nh;
  for (int k = 0; k < 16; ++k) {
    const dvec3 onPlane = dvec3(c.P[0]) + (3.0 * u(rng) - 1.0) * e1 + (3.0 * u(rng) - 1.0) * e2;
    dvec3 x;
    if (c.kind == 0) {
      x = centre + 2.0 * size * (dvec3(u(rng), u(rng), u(rng)) - 0.5);
    } else if (c.kind == 1) {
      x = onPlane;
    } else if (c.kind == 2) {
      x = onPlane + size * (1e-3 + u(rng)) * lightSide;
    } else if (c.kind == 3) {
      x = dvec3(c.light) + (1.0 + u(rng)) * (dvec3(c.P[0]) + u(rng) * 0.5 * (e1 + e2) - dvec3(c.light));
    } else {
      const dvec3 X = dvec3(c.P[0]) + 0.5 * u(rng) * e1 + 0.5 * u(rng) * e2;
      x = X + (0.2 + 2.8 * u(rng)) * double(c.eps) * glm::normalize(X - dvec3(c.light));
    }
    vec3 xf(x);
    if (c.kind == 1) {  // on the plane, up to 4 ulp off it either way
      xf[axis] = c.P[0][axis];
      for (int m = int(u(rng) * 9.0) - 4; m != 0; m += m > 0 ? -1 : 1)
        xf[axis] = std::nextafter(xf[axis], m > 0 ? INFINITY : -INFINITY);
    }
    c.points.push_back(xf);
  }
  c.lo = vec3(INFINITY), c.hi = vec3(-INFINITY);
  for (const vec3& x : c.points) c.lo = glm::min(c.lo, x), c.hi = glm::max(c.hi, x);
  for (int k = 0; k < 8; ++k)
    c.points.push_back(vec3(k & 1 ? c.hi.x : c.lo.x, k & 2 ? c.hi.y : c.lo.y, k & 4 ? c.hi.z : c.lo.z));
  for (int k = 0; k < 16; ++k) c.points.push_back(glm::mix(c.lo, c.hi, vec3(u(rng), u(rng), u(rng))));
  c.clear = (c.kind == 1 && elevation > 5.0 * M_PI / 180.0 && away < 100.0 * size) || c.kind == 2;
  c.describe = "scale " + std::to_string(scale) + ", elevation " + std::to_string(elevation * 180.0 / M_PI) +
               " deg, light " + std::to_string(away / size) + " sizes away";
  c.valid = true;
  return c;
}

// A leaf test's case under a far light (the far frame's leaves: LeafTest::FromSample), with the exact
// answer where rounding does not decide it: samples and triangles in a unit box, lights 10 to 10^6 box
// sizes away in every direction, triangles anywhere or around a point of the ray within a box size of
// its sample, and every fourth case a receiver (the sample on the triangle). `decided`: the exact ray (in
// double) passes the triangle's edges and both ends of (eps, L - eps) by more than `margin`; `receiver`:
// a receiver whose plane the ray crosses within half eps of the sample (never a shadow).
struct FarLeafCase {
  bool usable = false, decided = false, receiver = false, exactHit = false;
  vec3 light, p, P[3];
  vec4 ray;
  float eps = 1e-4f;
  double away = 0, tau = 0, length = 0, outside = 0;
};

inline FarLeafCase makeFarLeafCase(std::mt19937& rng, int i, double margin = 1e-5) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  auto point = [&]() { return vec3(u(rng), u(rng), u(rng)); };
  FarLeafCase c;
  const vec3 dir = glm::normalize(point() - 0.5f);
  const float away = std::exp(std::log(10.0f) + u(rng) * std::log(1e5f));
  c.away = away;
  c.light = vec3(0.5f) + away * dir;
  c.p = point();
  const float size = std::exp(std::log(1e-3f) + u(rng) * std::log(1e3f));
  const vec3 towards = glm::normalize(c.light - c.p);
  const vec3 centre = i % 2 ? c.p + (0.001f + u(rng)) * towards : point();
  for (vec3& x : c.P) x = centre + size * (point() - 0.5f);
  const bool receiverCase = i % 4 == 0;
  if (receiverCase) c.p = c.P[0] + u(rng) * (c.P[1] - c.P[0]) + u(rng) * 0.5f * (c.P[2] - c.P[0]);
  c.ray = cone::leafRay(c.p, c.light);
  if (!cone::leafRayUsable(c.ray, 2.0f * c.eps)) return c;
  const dvec3 L0(c.light), d = dvec3(c.p) - dvec3(c.light), e1 = dvec3(c.P[1]) - dvec3(c.P[0]),
              e2 = dvec3(c.P[2]) - dvec3(c.P[0]);
  const dvec3 n = glm::cross(e1, e2);
  const double len = glm::length(d), det = -glm::dot(d, n);
  if (!(std::abs(det) > 1e-9 * len * glm::length(n))) return c;  // (nearly) in the plane: undecided
  c.usable = true;
  const dvec3 s = L0 - dvec3(c.P[0]);
  const double t = glm::dot(s, n) / det, b1 = -glm::dot(d, glm::cross(s, e2)) / det,
               b2 = -glm::dot(d, glm::cross(e1, s)) / det;
  const dvec3 x = L0 + t * d;
  auto edgeDistance = [&](dvec3 a, dvec3 b) {  // negative inside
    const dvec3 m = glm::normalize(glm::cross(n, b - a));
    return -glm::dot(x - a, m);
  };
  const dvec3 A(c.P[0]), B(c.P[1]), C(c.P[2]);
  c.outside = std::max({edgeDistance(A, B), edgeDistance(B, C), edgeDistance(C, A)});
  c.tau = t * len;
  c.length = len;
  c.exactHit = b1 >= 0 && b2 >= 0 && b1 + b2 <= 1 && c.tau > c.eps && c.tau < len - c.eps;
  c.receiver = receiverCase && t > 0 && len - c.tau < 0.5 * c.eps;
  const double sinAngle = std::abs(det) / (len * glm::length(n));
  const double slack = std::min({std::abs(c.outside), std::abs(c.tau - c.eps) * sinAngle,
                                 std::abs(len - c.eps - c.tau) * sinAngle});
  c.decided = !c.receiver && slack > margin && std::isfinite(slack);
  return c;
}

}  // namespace cs::test
