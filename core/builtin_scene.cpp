// The built-in scene: a closed room lit by one point light, generated from a fixed seed with our own
// generator, so every run and library version builds the same scene (bit for bit within one build;
// flags that fuse multiply-adds may move the last bits). It stresses what point-light shadows find
// hard: huge wall triangles seen at grazing angles, casters on every side of the light (shadows on all
// walls, floor and ceiling), and a furball of thousands of thin strips whose shadow rays are incoherent.
#include <array>
#include <cmath>
#include <cstdint>

#include <glm/gtc/matrix_transform.hpp>

#include "core/animation.h"
#include "core/rng.h"
#include "core/scene.h"

namespace cs {
namespace {

// Room: x in [-10, 10], y in [0, 8], z in [-7, 7].
constexpr glm::dvec3 kRoomMin{-10, 0, -7}, kRoomMax{10, 8, 7};
constexpr glm::dvec3 kLight{1.3, 3.1, -0.7};        // off-centre on purpose: no symmetric shadows
constexpr glm::dvec3 kFurCentre{2.45, 2.45, 0.05};  // 1.52 from the light
constexpr double kFurReach = 0.78;                  // core radius + longest hair
constexpr glm::dvec3 kTableCentre{-4.5, 0, 2.8};    // floor point under the table's centre
constexpr glm::dvec3 kTableHalf{1.6, 0.5, 0.9};     // table top half-size in x, height / 2, z
constexpr glm::dvec3 kWallEye{1.5, 3.4, -2.8}, kWallTarget{1.2, 3.3, -7};
constexpr float kWallFov = 0.9f;

// Appends triangles with flat normals (three vertices of their own); the normal follows the winding,
// so every shape below is wound counter-clockwise seen from outside.
struct Builder {
  Scene& scene;

  void triangle(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    const glm::dvec3 n = glm::normalize(glm::cross(b - a, c - a));
    const auto first = uint32_t(scene.positions.size());
    for (const glm::dvec3& p : {a, b, c}) {
      scene.positions.emplace_back(p);
      scene.normals.emplace_back(n);
    }
    scene.indices.insert(scene.indices.end(), {first, first + 1, first + 2});
  }
  // a, b, c, d counter-clockwise seen from the front.
  void quad(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) {
    triangle(a, b, c);
    triangle(a, c, d);
  }

  // Unit shapes in [-1, 1]^3, placed by `m` (no mirroring).
  static glm::dvec3 at(const glm::dmat4& m, const glm::dvec3& p) { return glm::dvec3(m * glm::dvec4(p, 1)); }

  void box(const glm::dmat4& m) {
    auto v = [&](int i) { return at(m, {i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1}); };
    quad(v(0), v(4), v(6), v(2));  // -x
    quad(v(1), v(3), v(7), v(5));  // +x
    quad(v(0), v(1), v(5), v(4));  // -y
    quad(v(2), v(6), v(7), v(3));  // +y
    quad(v(0), v(2), v(3), v(1));  // -z
    quad(v(4), v(5), v(7), v(6));  // +z
  }
  void pyramid(const glm::dmat4& m) {  // square base at y = -1, apex at y = +1
    const glm::dvec3 apex = at(m, {0, 1, 0});
    const std::array<glm::dvec3, 4> base = {at(m, {-1, -1, -1}), at(m, {-1, -1, 1}), at(m, {1, -1, 1}),
                                            at(m, {1, -1, -1})};
    for (int i = 0; i < 4; ++i) triangle(base[size_t(i)], base[size_t((i + 1) % 4)], apex);
    quad(base[0], base[3], base[2], base[1]);
  }
  void sphere(const glm::dmat4& m, int slices, int stacks) {
    auto v = [&](int i, int j) {  // i: around, j: from the south pole (0) to the north pole (stacks)
      const double theta = glm::pi<double>() * j / stacks, phi = 2 * glm::pi<double>() * i / slices;
      return at(m, {std::sin(theta) * std::cos(phi), -std::cos(theta), -std::sin(theta) * std::sin(phi)});
    };
    for (int j = 0; j < stacks; ++j)
      for (int i = 0; i < slices; ++i) {
        if (j > 0) triangle(v(i, j), v(i + 1, j), v(i + 1, j + 1));
        if (j < stacks - 1) triangle(v(i, j), v(i + 1, j + 1), v(i, j + 1));
      }
  }
  void cylinder(const glm::dmat4& m, int segments) {  // axis y, radius 1, y in [-1, 1]
    auto rim = [&](int i, double y) {
      const double phi = 2 * glm::pi<double>() * i / segments;
      return at(m, {std::cos(phi), y, -std::sin(phi)});
    };
    const glm::dvec3 top = at(m, {0, 1, 0}), bottom = at(m, {0, -1, 0});
    for (int i = 0; i < segments; ++i) {
      quad(rim(i, -1), rim(i + 1, -1), rim(i + 1, 1), rim(i, 1));
      triangle(top, rim(i, 1), rim(i + 1, 1));
      triangle(bottom, rim(i + 1, -1), rim(i, -1));
    }
  }
};

glm::dmat4 placed(const glm::dvec3& centre, const glm::dmat4& rotation, const glm::dvec3& halfSize) {
  return glm::translate(glm::dmat4(1), centre) * rotation * glm::scale(glm::dmat4(1), halfSize);
}

// True when a sphere may show in the "wall" view (conservative: any aspect ratio up to 2:1). Random
// clutter stays out of it, so that view is the large wall and the shadows on it.
bool inWallView(const glm::dvec3& centre, double radius) {
  const glm::dvec3 axis = glm::normalize(kWallTarget - kWallEye), d = centre - kWallEye;
  const double along = glm::dot(d, axis);
  if (along < -radius) return false;
  const double halfAngle = std::atan(std::tan(0.5 * kWallFov) * std::sqrt(5.0));
  return glm::length(d - along * axis) < std::max(along, 0.0) * std::tan(halfAngle) + radius / std::cos(halfAngle);
}

glm::dmat4 randomRotation(Rng& rng) {
  return glm::rotate(glm::dmat4(1), rng.range(0, 2 * glm::pi<double>()), rng.unitVector());
}

// The named views, in order; each sees the light's shadows from inside the room.
std::vector<Camera> views() {
  auto view = [](const char* name, glm::vec3 eye, glm::vec3 target, float yfov) {
    Camera c;
    c.name = name;
    c.eye = eye;
    c.target = target;
    c.up = glm::vec3(0, 1, 0);
    c.yfov = yfov;
    c.znear = 0.01f;
    c.zfar = 40.0f;  // longer than the room's diagonal (25.4)
    return c;
  };
  return {
      // The back wall (z = -7) square on, from between it and the light: nothing stands in the view
      // (see `inWallView`), the wall fills it, and the casters behind the camera throw large shadows.
      view("wall", glm::vec3(kWallEye), glm::vec3(kWallTarget), kWallFov),
      // Close into the furball, half from the light's side: neighbouring pixels hit unrelated hairs.
      view("fur", {1.72f, 3.22f, 0.34f}, glm::vec3(kFurCentre), 0.7f),
      // Wide overview from the front-right ceiling corner.
      view("room", {9.3f, 7.3f, 6.3f}, {-3.0f, 1.5f, -3.0f}, 1.1f),
      // Looking up at the shadows thrown on the ceiling by the casters above the light.
      view("ceiling", {-2.5f, 1.6f, 3.5f}, {1.0f, 8.0f, -1.0f}, 1.0f),
      // Zoomed from the wall view's eye (so the casters' placement, which keeps clear of every eye, is
      // unchanged) onto a long shadow edge on the back wall: a 3.5° field of view, where a 2048² cube
      // map's texels span many pixels and aliasing shows (paper 004's Fig. 1 situation).
      view("edge", glm::vec3(kWallEye), {0.43f, 4.05f, -7.0f}, 0.06f),
  };
}

// The movable objects, for the built-in motion: which triangles each one owns.
enum class PieceKind { WallCaster, Floating, Floor, Table, Fur };
struct Piece {
  PieceKind kind;
  glm::dvec3 centre;
  uint32_t firstVertex = 0, firstIndex = 0, vertexCount = 0, indexCount = 0;
};

Scene buildScene(std::vector<Piece>* pieces);

}  // namespace

std::vector<std::string> builtinViewNames() {
  std::vector<std::string> names;
  for (const Camera& c : views()) names.push_back(c.name);
  return names;
}

Scene builtinScene() { return buildScene(nullptr); }

namespace {

// `pieces`, when given, receives the vertex and index range of every movable object.
Scene buildScene(std::vector<Piece>* pieces) {
  Scene scene;
  scene.name = "builtin";
  Builder b{scene};
  Rng rng{0xC0FFEE5EEDull};
  auto beginPiece = [&](PieceKind kind, const glm::dvec3& centre) {
    if (pieces) pieces->push_back({kind, centre, uint32_t(scene.positions.size()), uint32_t(scene.indices.size())});
  };
  auto endPiece = [&] {
    if (!pieces) return;
    Piece& p = pieces->back();
    p.vertexCount = uint32_t(scene.positions.size()) - p.firstVertex;
    p.indexCount = uint32_t(scene.indices.size()) - p.firstIndex;
  };

  // Room: two triangles per face, normals inward. Its corners: x0/x1, y0/y1, z0/z1.
  const double x0 = kRoomMin.x, y0 = kRoomMin.y, z0 = kRoomMin.z, x1 = kRoomMax.x, y1 = kRoomMax.y, z1 = kRoomMax.z;
  b.quad({x0, y0, z0}, {x0, y0, z1}, {x1, y0, z1}, {x1, y0, z0});  // floor, +y
  b.quad({x0, y1, z0}, {x1, y1, z0}, {x1, y1, z1}, {x0, y1, z1});  // ceiling, -y
  b.quad({x0, y0, z0}, {x1, y0, z0}, {x1, y1, z0}, {x0, y1, z0});  // back wall, +z
  b.quad({x0, y0, z1}, {x0, y1, z1}, {x1, y1, z1}, {x1, y0, z1});  // front wall, -z
  b.quad({x0, y0, z0}, {x0, y1, z0}, {x0, y1, z1}, {x0, y0, z1});  // left wall, +x
  b.quad({x1, y0, z0}, {x1, y0, z1}, {x1, y1, z1}, {x1, y1, z0});  // right wall, -x

  // Table: four legs and a top.
  const glm::dvec3 topCentre = kTableCentre + glm::dvec3(0, 2 * kTableHalf.y, 0);
  b.box(placed(topCentre, glm::dmat4(1), {kTableHalf.x, 0.05, kTableHalf.z}));
  for (int sx : {-1, 1})
    for (int sz : {-1, 1})
      b.box(placed(kTableCentre + glm::dvec3(sx * (kTableHalf.x - 0.12), kTableHalf.y, sz * (kTableHalf.z - 0.12)),
                   glm::dmat4(1), {0.05, kTableHalf.y, 0.05}));

  // Clutter: ~40 small shapes, kept apart from each other, the light, the furball, the table and
  // the cameras. Floating ones sit on a shell around the light so shadows fall in every direction.
  struct Blocker {
    glm::dvec3 centre;
    double radius;
  };
  std::vector<Blocker> taken = {{kLight, 0.45}, {kFurCentre, kFurReach + 0.05}};
  for (const Camera& c : views()) taken.push_back({glm::dvec3(c.eye), 0.6});
  // `onFloor`: the shape rests on the floor, so only its sides and top are checked against the room.
  auto isFree = [&](const glm::dvec3& c, double r, bool onFloor) {
    const glm::dvec3 lo = c - r + glm::dvec3(0, onFloor ? r : 0, 0);
    if (glm::any(glm::lessThan(lo, kRoomMin + 0.1 * double(!onFloor))) ||
        glm::any(glm::greaterThan(c + r, kRoomMax - 0.1)))
      return false;
    const glm::dvec3 table = topCentre - glm::dvec3(0, kTableHalf.y, 0);
    if (std::abs(c.x - table.x) < kTableHalf.x + r && std::abs(c.z - table.z) < kTableHalf.z + r &&
        c.y - r < topCentre.y + 0.06)
      return false;
    for (const Blocker& t : taken)
      if (glm::length(c - t.centre) < t.radius + r + 0.05) return false;
    return !inWallView(c, r);
  };
  auto shape = [&](int kind, const glm::dmat4& m) {
    switch (kind) {
      case 0: b.box(m); break;
      case 1: b.pyramid(m); break;
      case 2: b.sphere(m, 8, 5); break;
      default: b.cylinder(m, 10); break;
    }
  };
  auto randomHalfSize = [&](int kind) {
    const double s = rng.range(0.18, 0.45);
    if (kind >= 2) return glm::dvec3(s, kind == 2 ? s : rng.range(0.5, 1.6) * s, s);  // round shapes stay round
    return glm::dvec3(s * rng.range(0.5, 1.5), s * rng.range(0.5, 1.5), s * rng.range(0.5, 1.5));
  };
  // Three casters just behind the "wall" camera, on the light's side: their shadows, magnified about
  // five times, land in that view.
  const std::array<std::pair<glm::dvec3, double>, 3> wallCasters = {
      {{{0.95, 3.3, -1.9}, 0.13}, {{1.6, 2.95, -1.95}, 0.1}, {{1.45, 3.55, -2.05}, 0.09}}};
  for (size_t i = 0; i < wallCasters.size(); ++i) {
    const auto& [c, r] = wallCasters[i];
    beginPiece(PieceKind::WallCaster, c);
    shape(int(i), placed(c, randomRotation(rng), glm::dvec3(r)));
    endPiece();
    taken.push_back({c, r * std::sqrt(3.0)});
  }
  int placedCount = 3;
  // Floating around the light (23 more), resting on the floor (10), standing on the table (4).
  for (int attempt = 0; placedCount < 26 && attempt < 10000; ++attempt) {
    const int kind = int(rng.next() % 4);
    const glm::dvec3 half = randomHalfSize(kind);
    const glm::dvec3 c = kLight + rng.unitVector() * rng.range(1.2, 3.6);
    const double r = glm::length(half);
    const glm::dmat4 rotation = randomRotation(rng);
    if (!isFree(c, r, false)) continue;
    taken.push_back({c, r});
    beginPiece(PieceKind::Floating, c);
    shape(kind, placed(c, rotation, half));
    endPiece();
    ++placedCount;
  }
  for (int attempt = 0; placedCount < 36 && attempt < 10000; ++attempt) {
    const int kind = int(rng.next() % 4);
    const glm::dvec3 half = randomHalfSize(kind);
    // Pyramids and boxes lie flat on the floor; spheres touch it; cylinders stand upright.
    const glm::dvec3 c(rng.range(x0 + 1, x1 - 1), half.y, rng.range(z0 + 1, z1 - 1));
    const double r = glm::length(half);
    const glm::dmat4 rotation = glm::rotate(glm::dmat4(1), rng.range(0, 2 * glm::pi<double>()), glm::dvec3(0, 1, 0));
    if (!isFree(c, r, true)) continue;
    taken.push_back({c, r});
    beginPiece(PieceKind::Floor, c);
    shape(kind, placed(c, rotation, half));
    endPiece();
    ++placedCount;
  }
  for (int i = 0; i < 4; ++i) {  // on the table top, one per quarter
    const int kind = i;
    const glm::dvec3 half = randomHalfSize(kind) * 0.6;
    const glm::dvec3 c = topCentre + glm::dvec3((i % 2 ? 0.5 : -0.5) * kTableHalf.x, 0.05 + half.y,
                                                (i / 2 ? 0.45 : -0.45) * kTableHalf.z);
    beginPiece(PieceKind::Table, c);
    shape(kind, placed(c, glm::rotate(glm::dmat4(1), rng.range(0, 6.28), glm::dvec3(0, 1, 0)), half));
    endPiece();
  }

  // Furball: a small core on a thin stand, 3000 hairs. Each hair is a twisted strip of two
  // triangles, root wider than tip, bent sideways by a random curl.
  constexpr double kCore = 0.16;
  beginPiece(PieceKind::Fur, kFurCentre);
  b.sphere(placed(kFurCentre, glm::dmat4(1), glm::dvec3(kCore)), 10, 6);
  b.cylinder(placed({kFurCentre.x, 0.5 * (kFurCentre.y - kCore), kFurCentre.z}, glm::dmat4(1),
                    {0.03, 0.5 * (kFurCentre.y - kCore), 0.03}),
             8);
  for (int i = 0; i < 3000; ++i) {
    const glm::dvec3 dir = rng.unitVector();
    // Two unit vectors across the hair, for its width at the root and at the tip (the twist).
    const glm::dvec3 helper = std::abs(dir.y) < 0.9 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0);
    const glm::dvec3 u = glm::normalize(glm::cross(dir, helper)), v = glm::cross(dir, u);
    const double a0 = rng.range(0, 2 * glm::pi<double>()), twist = rng.range(-1.2, 1.2);
    const glm::dvec3 across0 = std::cos(a0) * u + std::sin(a0) * v;
    const glm::dvec3 across1 = std::cos(a0 + twist) * u + std::sin(a0 + twist) * v;
    const double length = rng.range(0.35, kFurReach - kCore);
    const glm::dvec3 curl = rng.range(-0.35, 0.35) * u + rng.range(-0.35, 0.35) * v;
    const glm::dvec3 root = kFurCentre + dir * kCore * 0.95;
    const glm::dvec3 tip = root + glm::normalize(dir + curl) * length;
    const double w0 = rng.range(0.004, 0.008), w1 = 0.3 * w0;
    b.quad(root - across0 * w0, root + across0 * w0, tip + across1 * w1, tip - across1 * w1);
  }
  endPiece();

  PointLight light;
  light.name = "room_light";
  light.position = glm::vec3(kLight);
  scene.lights.push_back(light);
  scene.cameras = views();
  scene.computeBounds();
  return scene;
}

// A rotation channel of `turns` whole turns about `axis` over t in [0, 1], keyed every eighth of a turn
// (slerp between keys 45 degrees apart is exactly uniform).
AnimationChannel spin(int node, const glm::dvec3& axis, int turns) {
  AnimationChannel c;
  c.node = node;
  c.path = AnimationPath::Rotation;
  const int keys = 8 * std::abs(turns);
  for (int k = 0; k <= keys; ++k) {
    const double t = double(k) / keys;
    const glm::dquat q = glm::angleAxis(2 * glm::pi<double>() * turns * t, glm::normalize(axis));
    c.times.push_back(t);
    c.values.emplace_back(q.x, q.y, q.z, q.w);
  }
  return c;
}

// A rotation about +y swinging as amplitude · sin(2πt), keyed at 32 points of the cycle.
AnimationChannel swing(int node, double amplitude) {
  AnimationChannel c;
  c.node = node;
  c.path = AnimationPath::Rotation;
  for (int k = 0; k <= 32; ++k) {
    const double t = k / 32.0;
    const glm::dquat q = glm::angleAxis(amplitude * std::sin(2 * glm::pi<double>() * t), glm::dvec3(0, 1, 0));
    c.times.push_back(t);
    c.values.emplace_back(q.x, q.y, q.z, q.w);
  }
  return c;
}

}  // namespace

AnimatedScene builtinAnimatedScene() {
  AnimatedScene a;
  std::vector<Piece> pieces;
  a.rest = buildScene(&pieces);
  a.localPositions = a.rest.positions;
  a.localNormals = a.rest.normals;
  a.start = 0;
  a.end = 1;
  a.cyclic = true;
  // Node 0: the pivot of the shapes floating around the light, on the light's vertical axis.
  AnimationNode group;
  group.translation = kLight;
  a.nodes.push_back(group);
  a.channels.push_back(swing(0, 0.5));
  for (size_t i = 0; i < pieces.size(); ++i) {
    const Piece& p = pieces[i];
    const bool floating = p.kind == PieceKind::Floating;
    AnimationNode n;
    n.parent = floating ? 0 : -1;
    n.translation = floating ? p.centre - kLight : p.centre;
    const int node = int(a.nodes.size());
    a.nodes.push_back(n);
    // Upright things (floor, table, fur) turn about +y; casters in the air tumble about a tilted axis.
    const double k = double(i);
    const bool upright = p.kind == PieceKind::Floor || p.kind == PieceKind::Table || p.kind == PieceKind::Fur;
    const glm::dvec3 axis = upright ? glm::dvec3(0, 1, 0) : glm::dvec3(std::sin(1.7 * k), 1.0, std::cos(2.3 * k));
    a.channels.push_back(spin(node, axis, i % 2 ? 1 : -1));
    a.ranges.push_back({node, p.firstVertex, p.vertexCount, p.firstIndex, p.indexCount, true});
    for (uint32_t v = p.firstVertex; v < p.firstVertex + p.vertexCount; ++v)
      a.localPositions[v] = glm::vec3(glm::dvec3(a.rest.positions[v]) - p.centre);
  }
  return a;
}

}  // namespace cs
