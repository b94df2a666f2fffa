// The emulated-GPU twin (twin.h): the shared headers compiled into cs::gpuemu::twin with CONE_DIV and the
// built-ins replaced by the deviating versions below.
#include "tests/gpu_arithmetic/twin.h"

#include <cmath>
#include <cstring>
#include <random>

#include <xmmintrin.h>

namespace cs::gpuemu {
namespace {
Mode g;
std::mt19937 rng(12345);

int direction() { return g.random ? ((rng() & 1u) ? 1 : -1) : g.dir; }

float flush(float x) { return g.ftz && std::fpclassify(x) == FP_SUBNORMAL ? std::copysign(0.0f, x) : x; }

// x moved `ulps` ulp up or down. An exact 0 stays 0 and no result changes sign: the allowed error is
// relative to the exact result, and the GPU forms of these operations (a * (1 / b), 1 / inversesqrt(x))
// give 0 for 0 and keep the sign.
float nudge(float x, int ulps) {
  if (!std::isfinite(x) || ulps == 0 || x == 0.0f) return flush(x);
  const float to = direction() > 0 ? INFINITY : -INFINITY;
  for (int i = 0; i < ulps; ++i) {
    const float y = std::nextafter(x, to);
    if (y == 0.0f || std::signbit(y) != std::signbit(x)) return flush(std::copysign(0.0f, x));
    x = y;
  }
  return flush(x);
}
}  // namespace

namespace math {
float div(float a, float b) { return nudge(a / b, g.divUlps); }
glm::vec2 div(glm::vec2 a, float b) { return {div(a.x, b), div(a.y, b)}; }
glm::vec3 div(glm::vec3 a, float b) { return {div(a.x, b), div(a.y, b), div(a.z, b)}; }
float sqrt(float x) { return nudge(std::sqrt(x), g.sqrtUlps); }
float inversesqrt(float x) { return nudge(float(1.0 / std::sqrt(double(x))), g.rsqrtUlps); }
float dot(glm::vec2 a, glm::vec2 b) { return a.x * b.x + a.y * b.y; }
float dot(glm::vec3 a, glm::vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
float length(glm::vec2 v) { return sqrt(dot(v, v)); }
float length(glm::vec3 v) { return sqrt(dot(v, v)); }
glm::vec3 normalize(glm::vec3 v) { return v * inversesqrt(dot(v, v)); }
float atan(float y, float x) {
  float a = std::atan2(y, x);
  return flush(a + float(direction()) * g.atanRel * std::abs(a));
}
float cos(float x) { return flush(std::cos(x) + float(direction()) * g.trigAbs); }
float sin(float x) { return flush(std::sin(x) + float(direction()) * g.trigAbs); }
}  // namespace math

}  // namespace cs::gpuemu

#define CONE_CPU_NAMESPACE cs::gpuemu::twin
#define CONE_DIV(a, b) ::cs::gpuemu::math::div(a, b)
#define CONE_CPU_MATH              \
  using glm::abs;                  \
  using glm::cross;                \
  using glm::max;                  \
  using glm::min;                  \
  using ::cs::gpuemu::math::atan;  \
  using ::cs::gpuemu::math::cos;   \
  using ::cs::gpuemu::math::dot;   \
  using ::cs::gpuemu::math::length; \
  using ::cs::gpuemu::math::normalize; \
  using ::cs::gpuemu::math::sin;   \
  using ::cs::gpuemu::math::sqrt;
#include "conetree/cone_math.h"
#include "traversal/precise_test.h"
#include "traversal/sphere_test.h"

namespace cs::gpuemu {
namespace {
twin::ConeNode node(const Cone& c) {
  twin::ConeNode n;
  n.axisCos = c.axisCos;
  n.sinLen = c.sinLen;
  return n;
}
Cone cone(const twin::ConeNode& n) { return {n.axisCos, n.sinLen}; }
}  // namespace

void setMode(const Mode& mode) {
  g = mode;
  rng.seed(12345);
  unsigned csr = _mm_getcsr() & ~0x8040u;  // FTZ (bit 15) and DAZ (bit 6)
  _mm_setcsr(mode.ftz ? csr | 0x8040u : csr);
}

bool fused() {
#if defined(__FMA__) && defined(__FP_FAST_FMAF)
  return true;
#elif defined(__FMA__)
  return true;
#else
  return false;
#endif
}

bool preciseConeTriangle(const Cone& c, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2, float eps, float scale) {
  return twin::preciseConeTriangle(node(c), twin::preciseTriangle(v0, v1, v2, scale), eps);
}
bool preciseConeCovered(const Cone& c, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2, float eps) {
  return twin::preciseConeCovered(node(c), twin::preciseTriangle(v0, v1, v2), eps);
}
bool sphereConeTriangle(const Cone& c, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2, float eps, float scale) {
  return twin::sphereConeTriangle(node(c), twin::boundingSphere(v0, v1, v2, scale), eps, scale);
}
bool leafHit(glm::vec3 p, glm::vec3 light, glm::vec4 ray, float eps, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2) {
  return twin::leafHit(p, light, ray, eps, v0, v1, v2);
}
bool leafRayMissesSphere(glm::vec3 a0, glm::vec3 a1, glm::vec3 a2, glm::vec3 w) {
  return twin::leafRayMissesSphere(twin::leafSphere(a0, a1, a2), w);
}
bool leafPlaneMissesBox(glm::vec3 P0, glm::vec3 P1, glm::vec3 P2, glm::vec3 light, glm::vec3 lo, glm::vec3 hi,
                        float eps) {
  return twin::leafPlaneMissesBox(twin::leafPlane(P0, P1, P2, light), lo, hi, light, eps);
}

bool leafHitFromLight(glm::vec3 p, glm::vec3 light, glm::vec4 ray, float eps, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2) {
  return twin::leafHitFromLight(p, light, ray, eps, v0, v1, v2);
}
bool leafHitFromSample(glm::vec3 p, glm::vec3 light, glm::vec4 ray, float eps, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2) {
  return twin::leafHitFromSample(p, light, ray, eps, v0, v1, v2);
}
glm::vec4 leafRay(glm::vec3 p, glm::vec3 light) { return twin::leafRay(p, light); }
Cone rayCone(glm::vec4 ray) { return cone(twin::rayCone(ray)); }
Cone coneParent(const Cone* c, uint32_t n, float pad) {
  twin::ConeNode k[4];
  for (uint32_t i = 0; i < 4; ++i) k[i] = i < n ? node(c[i]) : twin::emptyCone();
  return cone(twin::coneParent(k[0], k[1], k[2], k[3], n, pad));
}
Cone coneParentOfRays(const Cone* c, uint32_t n) {
  twin::ConeNode k[4];
  for (uint32_t i = 0; i < 4; ++i) k[i] = i < n ? node(c[i]) : twin::emptyCone();
  return cone(twin::coneParentOfRays(k[0], k[1], k[2], k[3], n, CONE_PAD));
}
Cone coneParentFar(const Cone* c, uint32_t n, float pad) {
  twin::ConeNode k[4];
  for (uint32_t i = 0; i < 4; ++i) k[i] = i < n ? node(c[i]) : twin::emptyCone();
  return cone(twin::coneParentFar(k[0], k[1], k[2], k[3], n, pad));
}

}  // namespace cs::gpuemu
