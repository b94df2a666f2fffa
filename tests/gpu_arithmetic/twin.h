// The CPU twin of the shared GLSL/C++ cone code (conetree/cone_math.h, traversal/precise_test.h,
// traversal/sphere_test.h) compiled a second time, in its own namespace, with the arithmetic Vulkan allows
// a GPU instead of IEEE-exact C++ (twin.cpp): what the property tests of gpu_arithmetic_test.cpp run.
//
// Deviations, each selectable and each pushed the same way (up, down) or at random per operation:
//   division          a / b off by up to 2.5 ulp: the correctly rounded quotient moved divUlps ulp
//   sqrt              "inherited from 1 / inversesqrt": 2 ulp + 2.5 ulp, moved sqrtUlps ulp
//   length            sqrt(dot(x, x)) with that sqrt; normalize: x * inversesqrt(dot(x, x)), inversesqrt
//                     moved rsqrtUlps ulp (2 allowed)
//   atan, sin, cos    atan off by atanRel relative (4096 ulp allowed), sin and cos by trigAbs absolute
//                     (2^-11 allowed on [-pi, pi])
//   multiply-add      fused or not: one test binary compiles everything with -ffp-contract=off, the other
//                     with -mfma -ffp-contract=fast (the compiler fuses a*b + c wherever it can)
//   denormals         flushed (FTZ and DAZ) when ftz is set
#pragma once
#include <cstdint>
#include <ostream>

#include <glm/glm.hpp>

namespace cs::gpuemu {

struct Mode {
  int divUlps = 0;
  int sqrtUlps = 0;
  int rsqrtUlps = 0;
  float atanRel = 0;
  float trigAbs = 0;
  int dir = 1;          // +1: every deviation up, -1: down
  bool random = false;  // each operation's direction drawn at random instead
  bool ftz = false;     // flush denormals (inputs and results) to zero
  const char* name = "exact";
};

// gtest prints a mode by its name.
inline void PrintTo(const Mode& mode, std::ostream* os) { *os << mode.name; }

// Sets the mode of this thread's emulated arithmetic (and its FTZ/DAZ state).
void setMode(const Mode& mode);
// Whether the binary fuses multiply-adds (the -mfma -ffp-contract=fast build).
bool fused();

struct Cone {
  glm::vec4 axisCos, sinLen;  // ConeNode's layout (conetree/cone_layout.h)
};

// scale: the far-light frame's angular scale (1: the world frame); pad: the tree's widening (CONE_PAD
// times the scale).
bool preciseConeTriangle(const Cone& cone, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2, float eps, float scale = 1.0f);
bool preciseConeCovered(const Cone& cone, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2, float eps);
bool sphereConeTriangle(const Cone& cone, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2, float eps, float scale = 1.0f);
bool leafHit(glm::vec3 p, glm::vec3 light, glm::vec4 ray, float eps, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2);
bool leafHitFromLight(glm::vec3 p, glm::vec3 light, glm::vec4 ray, float eps, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2);
bool leafHitFromSample(glm::vec3 p, glm::vec3 light, glm::vec4 ray, float eps, glm::vec3 v0, glm::vec3 v1, glm::vec3 v2);
glm::vec4 leafRay(glm::vec3 p, glm::vec3 light);
// The leaves' cull (sphere_test.h): leafRayMissesSphere(leafSphere(a0, a1, a2), w), a_i = P_i - light.
bool leafRayMissesSphere(glm::vec3 a0, glm::vec3 a1, glm::vec3 a2, glm::vec3 w);
// The plane cull (precise_test.h): leafPlaneMissesBox(leafPlane(P0, P1, P2, light), lo, hi, light, eps).
bool leafPlaneMissesBox(glm::vec3 P0, glm::vec3 P1, glm::vec3 P2, glm::vec3 light, glm::vec3 lo, glm::vec3 hi,
                        float eps);
Cone rayCone(glm::vec4 ray);
Cone coneParent(const Cone* children, uint32_t n, float pad = 1.52587890625e-05f);
Cone coneParentFar(const Cone* children, uint32_t n, float pad);  // the far frame's
Cone coneParentOfRays(const Cone* rays, uint32_t n);                // the world frame's leaf level

}  // namespace cs::gpuemu
