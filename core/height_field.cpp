// The generated height field (scene.h, heightFieldScene): the stress scene of the scale benchmark and
// the memory budget, a scene of any size that needs no file.
#include <cmath>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "core/scene.h"

namespace cs {

Scene heightFieldScene(uint64_t triangles) {
  if (triangles < 2 || triangles > kMaxHeightFieldTriangles)
    throw Error("a height field of " + std::to_string(triangles) + " triangles", "heightfield",
                "give 2 to " + std::to_string(kMaxHeightFieldTriangles) + " triangles (e.g. heightfield:1M)");
  // n x n cells of two triangles: the n whose 2 n^2 is nearest the count asked for.
  const uint32_t n = uint32_t(std::max<double>(1.0, std::round(std::sqrt(double(triangles) / 2.0))));
  Scene s;
  s.name = "heightfield-" + std::to_string(2ull * n * n);
  s.positions.reserve(size_t(n + 1) * (n + 1));
  for (uint32_t j = 0; j <= n; ++j) {
    const double z = -1.0 + 2.0 * j / n;
    for (uint32_t i = 0; i <= n; ++i) {
      const double x = -1.0 + 2.0 * i / n;
      // Two octaves of waves, 0.08 and 0.03 high over a 2 x 2 square: crests shadow their neighbours
      // from the light above, at every scale from the whole field to a few cells.
      const double y = 0.08 * std::sin(9.0 * x) * std::cos(7.0 * z) + 0.03 * std::sin(31.0 * x + 17.0 * z);
      s.positions.emplace_back(float(x), float(y), float(z));
    }
  }
  s.indices.reserve(size_t(6) * n * n);
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      for (uint32_t v : {a, c, b, b, c, d}) s.indices.push_back(v);  // counter-clockwise from +y
    }
  // Smooth normals from the height function's gradient.
  s.normals.reserve(s.positions.size());
  for (const glm::vec3& p : s.positions) {
    const double x = p.x, z = p.z;
    const double dx = 0.08 * 9.0 * std::cos(9.0 * x) * std::cos(7.0 * z) + 0.03 * 31.0 * std::cos(31.0 * x + 17.0 * z);
    const double dz = -0.08 * 7.0 * std::sin(9.0 * x) * std::sin(7.0 * z) + 0.03 * 17.0 * std::cos(31.0 * x + 17.0 * z);
    s.normals.push_back(glm::normalize(glm::vec3(float(-dx), 1.0f, float(-dz))));
  }
  s.lights.push_back({"light", glm::vec3(0.0f, 1.5f, 0.0f), glm::vec3(1.0f), 1.0f});
  s.computeBounds();
  return s;
}

uint64_t parseHeightFieldArg(const std::string& arg) {
  const std::string prefix = "heightfield:";
  if (arg.compare(0, prefix.size(), prefix) != 0) return 0;
  const std::string v = arg.substr(prefix.size());
  size_t digits = 0;
  while (digits < v.size() && std::isdigit(static_cast<unsigned char>(v[digits]))) ++digits;
  const std::string suffix = v.substr(digits);
  const uint64_t scale = suffix.empty() ? 1 : suffix == "k" || suffix == "K" ? 1000 : suffix == "M" ? 1000000 : 0;
  if (digits == 0 || digits > 9 || scale == 0)
    throw UsageError("'" + arg + "': a height field is heightfield:N, N triangles as digits with an optional k or M "
                     "(e.g. heightfield:100k, heightfield:10M)");
  const uint64_t triangles = std::stoull(v.substr(0, digits)) * scale;
  if (triangles < 2 || triangles > kMaxHeightFieldTriangles)
    throw UsageError("'" + arg + "': a height field has 2 to " + std::to_string(kMaxHeightFieldTriangles / 1000000) +
                     "M triangles");
  return triangles;
}

}  // namespace cs
