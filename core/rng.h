// splitmix64, the generated scenes' random numbers (core/builtin_scene.cpp, core/scene_family.cpp): tiny,
// fast, and the same numbers on every platform and standard library (std:: distributions are not).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>
#include <glm/gtc/constants.hpp>

namespace cs {

struct Rng {
  uint64_t state;
  uint64_t next() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }  // [0, 1)
  double range(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  double logRange(double lo, double hi) { return std::exp(range(std::log(lo), std::log(hi))); }  // lo, hi > 0
  uint32_t below(uint32_t n) { return uint32_t(next() % n); }
  glm::dvec3 unitVector() {  // uniform on the sphere
    const double z = range(-1, 1), phi = range(0, 2 * glm::pi<double>());
    const double r = std::sqrt(std::max(0.0, 1 - z * z));
    return {r * std::cos(phi), z, r * std::sin(phi)};
  }
};

}  // namespace cs
