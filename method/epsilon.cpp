// The epsilon policy's numbers and its ray family (definitions and reasons in epsilon.h).
#include "method/epsilon.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/scene.h"

namespace cs {

EpsilonPolicy EpsilonPolicy::forBounds(glm::vec3 lo, glm::vec3 hi) {
  EpsilonPolicy p;
  p.scale = glm::length(hi - lo);
  glm::vec3 m = glm::max(glm::abs(lo), glm::abs(hi));
  p.maxAbsCoord = std::max(m.x, std::max(m.y, m.z));
  // FLT_MIN keeps eps > 0 even for an empty scene, so (eps, L - eps) stays an open, ordered interval.
  p.floor = std::max(kFloorUlps * FLT_EPSILON * p.maxAbsCoord, FLT_MIN);
  p.eps = p.floored(kRelativeEps * p.scale);
  return p;
}

EpsilonPolicy EpsilonPolicy::forScene(const Scene& scene) {
  if (scene.positions.empty()) return forBounds(glm::vec3(0), glm::vec3(0));
  glm::vec3 lo(INFINITY), hi(-INFINITY);
  for (const glm::vec3& v : scene.positions) {
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
  }
  return forBounds(lo, hi);
}

std::string lightRangeProblem(glm::vec3 light, glm::vec3 lo, glm::vec3 hi) {
  if (!std::isfinite(light.x) || !std::isfinite(light.y) || !std::isfinite(light.z))
    return "the light is not finite";
  double far2 = 0;
  for (int k = 0; k < 3; ++k) {
    double d = std::max(std::abs(double(light[k]) - double(lo[k])), std::abs(double(light[k]) - double(hi[k])));
    far2 += d * d;
  }
  if (!(std::sqrt(far2) > kMaxLightDistance)) return {};
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "the light at (%g, %g, %g) is %.3g from the farthest point of the scene, past the %.3g at which "
                "fp32 shadow-ray lengths overflow; move it closer (at 1e6 scene diagonals its rays are "
                "already parallel to 1e-6 rad)",
                light.x, light.y, light.z, std::sqrt(far2), kMaxLightDistance);
  return buf;
}

ShadowRay rayToward(glm::vec3 org, glm::vec3 target, float tnear, float endOffset) {
  ShadowRay r;
  r.org = org;
  glm::vec3 d = target - org;
  float len = glm::length(d);
  if (!(len > 0.0f) || !std::isfinite(len)) {
    // Sample at the light (or non-finite input): an empty interval (tfar < tnear), so nothing counts: lit.
    r.dir = glm::vec3(0, 0, 1);
    r.tnear = 0;
    r.tfar = -1;
    return r;
  }
  r.dir = d / len;
  r.tnear = tnear;
  r.tfar = len - endOffset;
  return r;
}

float EpsilonPolicy::lightNudge(glm::vec3 light) const {
  glm::vec3 a = glm::abs(light);
  float m = std::max(maxAbsCoord, std::max(a.x, std::max(a.y, a.z)));
  return std::max(kLightNudge * scale, kNudgeFloorUlps * FLT_EPSILON * m);
}

ShadowRay EpsilonPolicy::baseRay(glm::vec3 p, glm::vec3 light) const { return rayToward(p, light, eps, eps); }

void orthonormalBasis(glm::vec3 d, glm::vec3& u, glm::vec3& v) {
  float sign = std::copysign(1.0f, d.z);
  float a = -1.0f / (sign + d.z);
  float b = d.x * d.y * a;
  u = glm::vec3(1.0f + sign * d.x * d.x * a, sign * b, -sign * d.x);
  v = glm::vec3(b, sign + d.y * d.y * a, -d.y);
}

int EpsilonPolicy::bandFamily(glm::vec3 p, glm::vec3 n, glm::vec3 light, const BandOptions& options,
                              ShadowRay* out) const {
  const ShadowRay base = baseRay(p, light);
  int count = 0;
  auto add = [&](const ShadowRay& r) {
    if (!(r == base)) out[count++] = r;
  };
  if (options.startAlongRay)
    for (float f : kStartOffsets) add(rayToward(p, light, relative(f), eps));
  if (options.startAlongNormal)
    for (float f : kStartOffsets) add(rayToward(p + relative(f) * n, light, 0.0f, eps));
  if (options.lightNudge) {
    glm::vec3 u, v;
    orthonormalBasis(base.dir, u, v);
    float delta = lightNudge(light);
    for (glm::vec3 side : {u, -u, v, -v}) add(rayToward(p, light + delta * side, eps, eps));
  }
  if (options.endAlongRay)
    for (float f : kEndOffsets) add(rayToward(p, light, eps, relative(f)));
  if (options.startBehind) add(rayToward(p - behindOffset() * n, light, eps, eps));
  return count;
}

}  // namespace cs
