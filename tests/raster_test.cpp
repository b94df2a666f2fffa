// The camera pass against an analytic case: a plane and a finely tessellated sphere, seen from a known
// camera. At every pixel the G-buffer must hold the first hit of the pixel-centre ray, its normal and
// the light term max(0, N·L̂).
#include <cmath>

#include <gtest/gtest.h>

#include "raster/raster.h"
#include "raster/raster_layout.h"
#include "tests/shadowmap_test_support.h"
#include "tests/test_context.h"

namespace cs {
namespace {

constexpr float kPi = 3.14159265358979f;

void addSphere(Scene& s, glm::vec3 c, float r, int slices, int stacks) {
  uint32_t base = uint32_t(s.positions.size());
  for (int i = 0; i <= stacks; ++i) {
    float th = kPi * float(i) / float(stacks);
    for (int j = 0; j <= slices; ++j) {
      float ph = 2 * kPi * float(j) / float(slices);
      glm::vec3 n(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
      s.positions.push_back(c + r * n);
      s.normals.push_back(n);
    }
  }
  for (int i = 0; i < stacks; ++i)
    for (int j = 0; j < slices; ++j) {
      uint32_t a = base + uint32_t(i * (slices + 1) + j), b = a + uint32_t(slices + 1);
      s.indices.insert(s.indices.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
}

Scene planeAndSphere() {
  Scene s;
  s.name = "plane+sphere";
  float e = 10;
  s.positions = {{-e, 0, -e}, {e, 0, -e}, {e, 0, e}, {-e, 0, e}};
  s.normals.assign(4, glm::vec3(0, 1, 0));
  s.indices = {0, 2, 1, 0, 3, 2};
  addSphere(s, {0.5f, 1.0f, -0.3f}, 1.0f, 256, 128);
  s.computeBounds();
  return s;
}

// Nearest hit of a ray with the plane y=0 (|x|,|z| <= 10) and the sphere; t = inf when none.
float analyticHit(glm::vec3 o, glm::vec3 d, glm::vec3* n) {
  float best = INFINITY;
  if (std::abs(d.y) > 1e-9f) {
    float t = -o.y / d.y;
    glm::vec3 p = o + t * d;
    if (t > 0 && std::abs(p.x) <= 10 && std::abs(p.z) <= 10) best = t, *n = {0, 1, 0};
  }
  glm::vec3 c(0.5f, 1.0f, -0.3f);
  glm::vec3 oc = o - c;
  float b = glm::dot(oc, d), cc = glm::dot(oc, oc) - 1.0f, disc = b * b - cc;
  if (disc >= 0) {
    float t = -b - std::sqrt(disc);
    if (t > 0 && t < best) best = t, *n = glm::normalize(o + t * d - c);
  }
  return best;
}

TEST(Raster, PositionsNormalsAndLightTermMatchTheAnalyticScene) {
  auto& ctx = test::context();
  Scene scene = planeAndSphere();
  Camera cam;
  cam.eye = {3.0f, 4.0f, 5.0f};
  cam.target = {0.3f, 0.5f, -0.2f};
  cam.yfov = 0.9f;
  cam.znear = 0.05f;
  cam.zfar = 100.0f;
  glm::vec3 light(-1.0f, 4.0f, 2.0f);
  const uint32_t w = 160, h = 120;  // not square, not a power of two

  Raster raster(ctx, scene);
  DeviceGBuffer dev;
  GBuffer gb;
  raster.render(cam, light, w, h, dev, &gb);
  ASSERT_EQ(gb.size(), size_t(w) * h);

  glm::mat4 inv = glm::inverse(viewProjection(cam, float(w) / float(h)));
  int checked = 0, background = 0;
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      size_t i = size_t(y) * w + x;
      glm::vec4 ndc((x + 0.5f) / w * 2 - 1, (y + 0.5f) / h * 2 - 1, 0.5f, 1.0f);
      glm::vec4 p = inv * ndc;
      glm::vec3 dir = glm::normalize(glm::vec3(p) / p.w - cam.eye);
      glm::vec3 n;
      float t = analyticHit(cam.eye, dir, &n);
      if (!std::isfinite(t)) {
        EXPECT_FALSE(gb.hasGeometry(i)) << x << "," << y;
        ++background;
        continue;
      }
      ASSERT_TRUE(gb.hasGeometry(i)) << x << "," << y;
      glm::vec3 got(gb.position[i]);
      glm::vec3 want = cam.eye + t * dir;
      // Tessellation of the sphere (1 - cos(pi/128)) ~ 3e-4, and silhouette pixels may see either surface.
      bool silhouette = false;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          glm::vec4 q = inv * glm::vec4((x + 0.5f + dx) / w * 2 - 1, (y + 0.5f + dy) / h * 2 - 1, 0.5f, 1.0f);
          glm::vec3 nn;
          float tt = analyticHit(cam.eye, glm::normalize(glm::vec3(q) / q.w - cam.eye), &nn);
          silhouette |= std::abs(tt - t) > 0.1f * t || !std::isfinite(tt);
        }
      if (silhouette) continue;
      EXPECT_LT(glm::length(got - want), 2e-3f * t) << x << "," << y;
      glm::vec3 gn(gb.normal[i]);
      if (glm::dot(n, cam.eye - want) < 0) n = -n;
      EXPECT_GT(glm::dot(gn, n), 0.9995f) << x << "," << y;
      float direct = std::max(0.0f, glm::dot(n, glm::normalize(light - want)));
      EXPECT_NEAR(gb.normal[i].w, direct, 5e-3f) << x << "," << y;
      EXPECT_EQ(gb.isLit(i), gb.normal[i].w > 0);
      ++checked;
    }
  EXPECT_GT(checked, int(w * h) / 2);
  EXPECT_GT(background, 0);
}

// The third attachment (devices with geometryShader): each pixel names the scene triangle its sample lies
// on, and pixels without geometry name none — what ASM's ID + depth test compares with the light's.
TEST(Raster, TriangleIdsNameTheTriangleUnderEachPixel) {
  auto& ctx = test::context();
  if (!ctx.geometryShader) GTEST_SKIP() << "no geometryShader: the G-buffer carries no triangle IDs";
  Scene scene = planeAndSphere();
  Camera cam;
  cam.eye = {3.0f, 4.0f, 5.0f};
  cam.target = {0.3f, 0.5f, -0.2f};
  cam.yfov = 0.9f;
  const uint32_t w = 160, h = 120;
  Raster raster(ctx, scene);
  DeviceGBuffer dev;
  GBuffer gb;
  raster.render(cam, {-1.0f, 4.0f, 2.0f}, w, h, dev, &gb);
  ASSERT_TRUE(dev.triangle);
  std::vector<uint32_t> ids(size_t(w) * h);
  vk::download(ctx, dev.triangle, ids.data(), ids.size() * 4);
  size_t sphere = 0, plane = 0, wrong = 0;
  for (size_t i = 0; i < ids.size(); ++i) {
    if (!gb.hasGeometry(i)) {
      EXPECT_EQ(ids[i], CS_NO_TRIANGLE) << i;
      continue;
    }
    const glm::vec3 p(gb.position[i]);
    // A twentieth of the pixel's footprint: rasterizers snap vertices to 1/256 of a pixel or finer.
    const float pixel = 2 * std::tan(0.5f * cam.yfov) / float(h) * glm::length(p - cam.eye);
    wrong += !smtest::onTriangle(scene, ids[i], p, 0.05 * pixel);
    (ids[i] < 2 ? plane : sphere)++;
  }
  EXPECT_GT(plane, 1000u);
  EXPECT_GT(sphere, 1000u);
  EXPECT_EQ(wrong, 0u) << "pixels whose sample is not on the triangle they name";
}

TEST(Raster, RowZeroIsTheTopOfTheImage) {
  auto& ctx = test::context();
  Scene scene = planeAndSphere();
  Camera cam;  // level camera: the floor fills the bottom half, the sky the top
  cam.eye = {0, 1.0f, 9.5f};
  cam.target = {0, 1.0f, 0};
  Raster raster(ctx, scene);
  DeviceGBuffer dev;
  GBuffer gb;
  raster.render(cam, {0, 5, 0}, 64, 64, dev, &gb);
  EXPECT_FALSE(gb.hasGeometry(0 * 64 + 2));   // top-left corner: sky
  EXPECT_TRUE(gb.hasGeometry(63 * 64 + 2));   // bottom-left corner: floor
}

// The camera pass's geometryRect (DeviceGBuffer; geometryRectOf) holds every pixel it drew geometry into,
// whatever the view: the family's members (far views to close-ups, at a size that is not square), a
// camera inside the scene's box (the whole image), and one looking away from it (no pixel at all); and
// is smaller than the image where the scene is small in it (else it would save the cone path nothing).
TEST(Raster, TheGeometryRectHoldsEveryPixelWithGeometry) {
  auto& ctx = test::context();
  const uint32_t w = 72, h = 40;
  auto check = [&](const Scene& scene, const Camera& cam, const std::string& what) {
    Raster raster(ctx, scene);
    DeviceGBuffer dev;
    GBuffer gb;
    raster.render(cam, scene.boundsMax + glm::vec3(1.0f), w, h, dev, &gb);
    const PixelRect r = dev.geometryRect;
    EXPECT_LE(r.x1, w) << what;
    EXPECT_LE(r.y1, h) << what;
    uint64_t outside = 0, inside = 0;
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        if (!gb.hasGeometry(y * w + x)) continue;
        const bool in = x >= r.x0 && x < r.x1 && y >= r.y0 && y < r.y1;
        outside += !in, inside += in;
      }
    EXPECT_EQ(outside, 0u) << what << ": pixels with geometry outside [" << r.x0 << ", " << r.x1 << ") x [" << r.y0
                           << ", " << r.y1 << ")";
    return std::pair<PixelRect, uint64_t>{r, inside};
  };
  uint32_t smaller = 0;
  for (uint64_t seed = 1; seed <= 12; ++seed) {
    FamilyParams p = familyMember(seed);
    p.triangles = std::min<uint64_t>(p.triangles, 3000);
    const Scene scene = familyScene(p);
    ASSERT_FALSE(scene.cameras.empty());
    const auto [r, inside] = check(scene, scene.cameras.front(), "family:" + std::to_string(seed));
    EXPECT_GT(inside, 0u) << "family:" << seed;
    smaller += uint64_t(r.x1 - r.x0) * (r.y1 - r.y0) < uint64_t(w) * h / 2;
  }
  EXPECT_GE(smaller, 3u) << "the far members' rects are under half the image";
  const Scene scene = planeAndSphere();
  Camera in;  // inside the box: corners behind the camera, the whole image
  in.eye = {0, 1.0f, 2.0f};
  in.target = {0, 1.0f, 0};
  const auto [whole, seen] = check(scene, in, "a camera inside the box");
  EXPECT_EQ(whole.x0, 0u);
  EXPECT_EQ(whole.y0, 0u);
  EXPECT_EQ(whole.x1, w);
  EXPECT_EQ(whole.y1, h);
  EXPECT_GT(seen, 0u);
  Camera away;  // far above the scene, looking up: nothing drawn, an empty rect
  away.eye = {0, 50.0f, 0};
  away.target = {0, 60.0f, 0.1f};
  const auto [none, drawn] = check(scene, away, "a camera looking away");
  EXPECT_EQ(drawn, 0u);
  EXPECT_TRUE(none.x0 >= none.x1 || none.y0 >= none.y1) << none.x0 << " " << none.x1 << " " << none.y0 << " " << none.y1;
}

TEST(Raster, RejectsResolutionsBeyondTheDevice) {
  auto& ctx = test::context();
  Scene scene = planeAndSphere();
  Raster raster(ctx, scene);
  DeviceGBuffer dev;
  uint32_t side = ctx.properties.limits.maxFramebufferWidth + 1;
  EXPECT_THROW(raster.render(Camera{}, {0, 5, 0}, side, 4, dev, nullptr), Error);
}

}  // namespace
}  // namespace cs
