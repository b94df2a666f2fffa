// The generated scene family (scene.h, "family:"): scenes no benchmark was tuned on, drawn from a seed
// over what users bring -- camera distance, light direction and distance, triangle size against a pixel's
// footprint, a ground plane or none, closed and open meshes. docs/ARCHITECTURE.md, "The scene family".
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>

#include <glm/gtc/constants.hpp>

#include "core/error.h"
#include "core/rng.h"
#include "core/scene.h"

namespace cs {
namespace {

// One mesh appended to the scene: vertices with their normals, then triangles counter-clockwise seen
// from outside (or from the side the normals point to, for an open sheet).
struct Builder {
  Scene& s;
  uint32_t vertex(glm::dvec3 p, glm::dvec3 n) {
    s.positions.emplace_back(glm::vec3(p));
    s.normals.push_back(glm::normalize(glm::vec3(n)));
    return uint32_t(s.positions.size() - 1);
  }
  void triangle(uint32_t a, uint32_t b, uint32_t c) { s.indices.insert(s.indices.end(), {a, b, c}); }
  // A (u, v) grid of (nu + 1) x (nv + 1) vertices, two triangles a cell; `wrapU` joins the last column to
  // the first (a closed ring).
  template <class F>
  void grid(uint32_t nu, uint32_t nv, bool wrapU, F point) {
    const uint32_t cols = wrapU ? nu : nu + 1, base = uint32_t(s.positions.size());
    for (uint32_t j = 0; j <= nv; ++j)
      for (uint32_t i = 0; i < cols; ++i) {
        glm::dvec3 p, n;
        point(double(i) / nu, double(j) / nv, p, n);
        vertex(p, n);
      }
    for (uint32_t j = 0; j < nv; ++j)
      for (uint32_t i = 0; i < nu; ++i) {
        const uint32_t i1 = wrapU ? (i + 1) % nu : i + 1;
        const uint32_t a = base + j * cols + i, b = base + j * cols + i1, c = a + cols, d = b + cols;
        triangle(a, b, d);
        triangle(a, d, c);
      }
  }
};

// The closed and the open shapes, each about `tris` triangles (at least a few), centred at c, radius r.
void sphere(Builder& b, glm::dvec3 c, double r, uint64_t tris) {
  const uint32_t n = uint32_t(std::lround(std::clamp(std::sqrt(double(tris) / 4.0), 3.0, 4096.0)));
  b.grid(2 * n, n, true, [&](double u, double v, glm::dvec3& p, glm::dvec3& nn) {
    const double phi = 2 * glm::pi<double>() * u, theta = glm::pi<double>() * (1 - v);
    nn = {std::sin(theta) * std::cos(phi), std::cos(theta), -std::sin(theta) * std::sin(phi)};
    p = c + r * nn;
  });
}
void torus(Builder& b, glm::dvec3 c, double r, uint64_t tris) {
  const uint32_t n = uint32_t(std::lround(std::clamp(std::sqrt(double(tris) / 6.0), 3.0, 4096.0)));
  const double minor = 0.3 * r, major = 0.7 * r;
  b.grid(3 * n, n, true, [&](double u, double v, glm::dvec3& p, glm::dvec3& nn) {
    const double phi = 2 * glm::pi<double>() * u, theta = 2 * glm::pi<double>() * v;
    const glm::dvec3 ring{std::cos(phi), 0, -std::sin(phi)};
    nn = std::cos(theta) * ring + glm::dvec3(0, std::sin(theta), 0);
    p = c + major * ring + minor * nn;
  });
  // The grid's v seam repeats its first row: the same positions, so the surface stays closed.
}
void box(Builder& b, glm::dvec3 c, double r, uint64_t tris) {
  const uint32_t n = uint32_t(std::lround(std::clamp(std::sqrt(double(tris) / 12.0), 1.0, 4096.0)));
  const double h = r / std::sqrt(3.0);
  for (int axis = 0; axis < 3; ++axis)
    for (int sign : {-1, 1}) {
      glm::dvec3 nn(0), e1(0), e2(0);
      nn[axis] = sign;
      e1[(axis + 1) % 3] = 1;
      e2[(axis + 2) % 3] = sign;  // e1 x e2 = nn: counter-clockwise from outside
      b.grid(n, n, false, [&](double u, double v, glm::dvec3& p, glm::dvec3& out) {
        out = nn;
        p = c + h * (nn + (2 * u - 1) * e1 + (2 * v - 1) * e2);
      });
    }
}
void sheet(Builder& b, glm::dvec3 c, double r, uint64_t tris, double tilt) {  // a wavy open square
  const uint32_t n = uint32_t(std::lround(std::clamp(std::sqrt(double(tris) / 2.0), 1.0, 8192.0)));
  const glm::dvec3 e1{std::cos(tilt), std::sin(tilt), 0}, e2{0, 0, -1}, up = glm::cross(e1, e2);
  b.grid(n, n, false, [&](double u, double v, glm::dvec3& p, glm::dvec3& nn) {
    const double x = 2 * u - 1, z = 2 * v - 1, k = 5.0;
    const double y = 0.12 * std::sin(k * x) * std::cos(k * z);
    const double dx = 0.12 * k * std::cos(k * x) * std::cos(k * z), dz = -0.12 * k * std::sin(k * x) * std::sin(k * z);
    p = c + r * (x * e1 + z * e2 + y * up);
    nn = glm::normalize(up - dx * e1 - dz * e2);
  });
}
void tube(Builder& b, glm::dvec3 c, double r, uint64_t tris) {  // an open cylinder, no caps
  const uint32_t n = uint32_t(std::lround(std::clamp(std::sqrt(double(tris) / 4.0), 3.0, 4096.0)));
  b.grid(2 * n, n, true, [&](double u, double v, glm::dvec3& p, glm::dvec3& nn) {
    const double phi = 2 * glm::pi<double>() * u;
    nn = {std::cos(phi), 0, -std::sin(phi)};
    p = c + 0.6 * r * nn + glm::dvec3(0, r * (1.4 * v - 0.7), 0);
  });
}
void shell(Builder& b, glm::dvec3 c, double r, uint64_t tris) {  // an open hemisphere, dome up
  const uint32_t n = uint32_t(std::lround(std::clamp(std::sqrt(double(tris) / 4.0), 3.0, 4096.0)));
  b.grid(2 * n, n, true, [&](double u, double v, glm::dvec3& p, glm::dvec3& nn) {
    const double phi = 2 * glm::pi<double>() * u, theta = 0.5 * glm::pi<double>() * (1 - v);
    nn = {std::sin(theta) * std::cos(phi), std::cos(theta), -std::sin(theta) * std::sin(phi)};
    p = c + r * nn;
  });
}

uint64_t parseCount(const std::string& arg, const std::string& v) {
  size_t digits = 0;
  while (digits < v.size() && std::isdigit(static_cast<unsigned char>(v[digits]))) ++digits;
  const std::string suffix = v.substr(digits);
  const uint64_t scale = suffix.empty() ? 1 : suffix == "k" || suffix == "K" ? 1000 : suffix == "M" ? 1000000 : 0;
  if (digits == 0 || digits > 9 || scale == 0)
    throw UsageError("'" + arg + "': '" + v + "' is not a count (digits with an optional k or M, e.g. 50k)");
  return std::stoull(v.substr(0, digits)) * scale;
}

double parseNumber(const std::string& arg, const std::string& key, const std::string& v, double lo, double hi) {
  size_t used = 0;
  double x = 0;
  try {
    x = std::stod(v, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != v.size() || !(x >= lo && x <= hi)) {
    std::ostringstream m;
    m << "'" << arg << "': " << key << " is a number in [" << lo << ", " << hi << "], not '" << v << "'";
    throw UsageError(m.str());
  }
  return x;
}

}  // namespace

FamilyParams familyMember(uint64_t seed) {
  Rng d{seed * 0x2545F4914F6CDD1Dull + 1};
  FamilyParams p;
  p.seed = seed;
  p.triangles = uint64_t(d.logRange(300, 100000));
  p.view = d.range(0, 1);
  p.lightElevation = d.range(4, 90);
  p.lightDistance = d.logRange(0.7, 1000);
  p.ground = d.below(4) != 0;  // three in four on a ground plane
  p.openShare = double(d.below(3)) / 2;
  p.objects = 2 + d.below(10);
  return p;
}

FamilyParams parseFamilyArg(const std::string& arg) {
  const std::string prefix = "family:";
  FamilyParams p;
  if (arg.compare(0, prefix.size(), prefix) != 0) return p;
  const std::string usage = "a family member is family:SEED or family:seed=S:tris=N:view=V:elevation=E:distance=D:"
                            "ground=0|1:open=F:objects=K (any of them after the seed; e.g. family:7, family:7:tris=1M)";
  std::vector<std::pair<std::string, std::string>> fields;
  std::stringstream ss(arg.substr(prefix.size()));
  for (std::string item; std::getline(ss, item, ':');) {
    const size_t eq = item.find('=');
    if (eq == std::string::npos && fields.empty()) fields.emplace_back("seed", item);
    else if (eq == std::string::npos || eq == 0) throw UsageError("'" + arg + "': '" + item + "' is not key=value; " + usage);
    else fields.emplace_back(item.substr(0, eq), item.substr(eq + 1));
  }
  if (fields.empty() || fields.front().first != "seed") throw UsageError("'" + arg + "': no seed; " + usage);
  p = familyMember(parseCount(arg, fields.front().second));
  for (size_t i = 1; i < fields.size(); ++i) {
    const auto& [k, v] = fields[i];
    if (k == "tris") p.triangles = parseCount(arg, v);
    else if (k == "view") p.view = parseNumber(arg, k, v, 0, 1);
    else if (k == "elevation") p.lightElevation = parseNumber(arg, k, v, 1, 90);
    else if (k == "distance") p.lightDistance = parseNumber(arg, k, v, 0.6, 1e6);
    else if (k == "ground") p.ground = parseNumber(arg, k, v, 0, 1) != 0;
    else if (k == "open") p.openShare = parseNumber(arg, k, v, 0, 1);
    else if (k == "objects") p.objects = uint32_t(parseNumber(arg, k, v, 1, 64));
    else throw UsageError("'" + arg + "': unknown key '" + k + "'; " + usage);
  }
  if (p.triangles < 100 || p.triangles > kMaxHeightFieldTriangles)
    throw UsageError("'" + arg + "': a family member has 100 to " + std::to_string(kMaxHeightFieldTriangles / 1000000) +
                     "M triangles");
  p.valid = true;
  return p;
}

std::string familyDescription(const FamilyParams& p) {
  std::ostringstream o;
  o.precision(3);
  o << "family:" << p.seed << ":tris=" << p.triangles << ":view=" << p.view << ":elevation=" << p.lightElevation
    << ":distance=" << p.lightDistance << ":ground=" << (p.ground ? 1 : 0) << ":open=" << p.openShare
    << ":objects=" << p.objects;
  return o.str();
}

Scene familyScene(const FamilyParams& p) {
  if (p.triangles < 100 || p.triangles > kMaxHeightFieldTriangles || p.objects < 1)
    throw Error("a family member of " + std::to_string(p.triangles) + " triangles and " + std::to_string(p.objects) + " objects",
                "family", "give 100 to " + std::to_string(kMaxHeightFieldTriangles) + " triangles and 1 or more objects");
  // The layout has its own stream, so overriding a parameter moves nothing else.
  Rng d{p.seed * 0xD1B54A32D192ED03ull + 7};
  Scene s;
  s.name = "family-" + std::to_string(p.seed);
  Builder b{s};
  // The ground takes a tenth of the triangles (as two at the least: triangles far larger than a pixel).
  const uint64_t groundTris = p.ground ? std::max<uint64_t>(2, p.triangles / 10) : 0;
  const uint64_t perObject = (p.triangles - groundTris) / p.objects;
  const uint32_t openObjects = uint32_t(std::lround(p.openShare * p.objects));
  glm::dvec3 focus(0);
  double focusRadius = 0.3;
  for (uint32_t k = 0; k < p.objects; ++k) {
    const double r = d.range(0.12, 0.45);
    const double lift = d.below(3) == 0 ? d.range(0.1, 0.6) : 0.0;  // a third float, their shadows apart
    const glm::dvec3 c{d.range(-1, 1), r + lift + 1e-3, d.range(-1, 1)};
    const uint32_t shape = d.below(3);
    if (k < openObjects) {
      if (shape == 0) sheet(b, c, r, perObject, d.range(-0.6, 0.6));
      else if (shape == 1) tube(b, c, r, perObject);
      else shell(b, c - glm::dvec3(0, r, 0), r, perObject);
    } else {
      if (shape == 0) sphere(b, c, r, perObject);
      else if (shape == 1) torus(b, c, r, perObject);
      else box(b, c, r, perObject);
    }
    if (k == p.objects - 1) {
      focus = c;
      focusRadius = r;
    }
  }
  if (p.ground) {
    const uint32_t n = uint32_t(std::lround(std::clamp(std::sqrt(double(groundTris) / 2.0), 1.0, 8192.0)));
    b.grid(n, n, false, [&](double u, double v, glm::dvec3& q, glm::dvec3& nn) {
      q = {3.2 * u - 1.6, 0.0, 1.6 - 3.2 * v};
      nn = {0, 1, 0};
    });
  }
  s.computeBounds();
  const glm::dvec3 centre = 0.5 * (glm::dvec3(s.boundsMin) + glm::dvec3(s.boundsMax));
  const double radius = 0.5 * double(s.diagonal());

  // The light: from `lightElevation` degrees over the horizon, `lightDistance` scene diagonals from the
  // centre, at an azimuth of the seed's.
  const double az = d.range(0, 2 * glm::pi<double>()), el = glm::radians(p.lightElevation);
  const glm::dvec3 toLight{std::cos(el) * std::cos(az), std::sin(el), std::cos(el) * std::sin(az)};
  s.lights.push_back({"family", glm::vec3(centre + toLight * (p.lightDistance * 2 * radius)), glm::vec3(1.0f), 1.0f});

  // The camera: view 0 sees the whole scene in about 300 pixels of 1024 (its bounding sphere across 0.3 of
  // the field of view), view 1 is a close-up of the last object from 1.3 times its radius; between them
  // the distance goes geometrically and the target along the line between the centres.
  Camera cam;
  cam.name = "family";
  cam.yfov = 0.8f;
  const double far = radius / (std::tan(0.5 * cam.yfov) * 0.3), close = 1.3 * focusRadius;
  const double dist = std::exp(std::log(far) + p.view * (std::log(close) - std::log(far)));
  const glm::dvec3 target = centre + p.view * (focus - centre);
  const double camAz = d.range(0, 2 * glm::pi<double>()), camEl = glm::radians(d.range(12, 65));
  cam.target = glm::vec3(target);
  cam.eye = glm::vec3(target + dist * glm::dvec3(std::cos(camEl) * std::cos(camAz), std::sin(camEl), std::cos(camEl) * std::sin(camAz)));
  cam.znear = float(std::max(1e-4 * radius, 0.02 * std::max(0.0, dist - 2 * radius) + 1e-3 * dist));
  cam.zfar = float(dist + 4 * radius);
  s.cameras.push_back(cam);
  return s;
}

}  // namespace cs
