// One scene on the device (core/scene.h GeometryRevision, raster/raster.h DeviceScene): the revision
// follows the geometry's contents, the one geometry policy holds at every upload, the camera pass's copy
// is uploaded once per revision and the shadow maps' depth passes draw from it instead of their own.
#include <cmath>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/scene.h"
#include "method/registry.h"
#include "harness/harness.h"
#include "raster/raster.h"
#include "tests/test_context.h"

namespace cs {
namespace {

TEST(GeometryRevision, FollowsTheContentsNotTheObject) {
  Scene a = builtinScene();
  Scene b = builtinScene();
  const GeometryRevision r = geometryRevision(a);
  EXPECT_TRUE(r.known());
  EXPECT_FALSE(GeometryRevision{}.known());
  EXPECT_EQ(r, geometryRevision(b));  // another object, the same geometry
  b.positions[7].y += 1e-3f;          // an edit in place
  EXPECT_NE(geometryRevision(b), r);
  EXPECT_EQ(geometryRevision(b).indices, r.indices);  // the topology kept its key
  b.positions[7].y -= 1e-3f;
  std::swap(b.indices[0], b.indices[1]);
  EXPECT_NE(geometryRevision(b).indices, r.indices);
}

TEST(GeometryCheck, BadIndicesAreErrorsAndNonFiniteTrianglesAreDropped) {
  Scene s;
  s.name = "probe";
  s.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {NAN, 0, 0}};
  s.indices = {0, 1, 2, 0, 3, 2};
  const GeometryCheck c = checkGeometry(s);
  EXPECT_EQ(c.droppedTriangles, 1u);
  EXPECT_EQ(c.lo, glm::vec3(0, 0, 0));
  EXPECT_EQ(c.hi, glm::vec3(1, 1, 0));
  EXPECT_FALSE(finiteTriangle(s, 1));
  s.indices.push_back(1);
  try {
    checkGeometry(s);
    ADD_FAILURE() << "7 indices accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("scene 'probe': its index count 7 is not a multiple of 3"), std::string::npos)
        << e.what();
  }
  s.indices = {0, 1, 9};
  try {
    checkGeometry(s);
    ADD_FAILURE() << "index 9 of 4 vertices accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("index 2 = 9 is past the 4 vertices"), std::string::npos) << e.what();
  }
}

// The frame harness computes the revision once and hands the camera pass's geometry to every method; a
// depth pass then keeps no copy of its own (its bytes drop by exactly the shared geometry's), uploads
// nothing while the revision stays, and rebuilds when a vertex moves.
TEST(DeviceScene, TheCameraPassCopyIsUploadedOncePerRevisionAndSharedByTheShadowMaps) {
  registerBuiltinMethods();
  auto& ctx = test::context();
  Scene scene = builtinScene();
  Raster raster(ctx, scene);
  const DeviceScene& shared = raster.deviceScene();
  EXPECT_EQ(shared.revision, geometryRevision(scene));
  EXPECT_EQ(shared.indexCount, scene.indices.size());
  FrameSpec spec;
  spec.camera = *scene.findCamera("wall");
  spec.view = "wall";
  spec.light = scene.lights.front().position;
  spec.width = 40;
  spec.height = 32;
  std::unique_ptr<PreparedFrame> frame = prepareFrame(ctx, raster, scene, spec);
  ASSERT_EQ(frame->input.deviceScene, &shared);
  EXPECT_EQ(frame->input.revision, shared.revision);
  // An upload happens once per revision.
  DeviceScene mine;
  EXPECT_GT(mine.update(ctx, scene, geometryRevision(scene)), 0.0);
  EXPECT_EQ(mine.update(ctx, scene, geometryRevision(scene)), 0.0);
  EXPECT_EQ(mine.bytes(), shared.bytes());

  for (const char* name : {"cubesm", "rmsm"}) {
    const MethodInfo* m = findMethod(name);
    ASSERT_NE(m, nullptr) << name;
    std::unique_ptr<ShadowMethod> withShared = m->make(&ctx, Settings(name));
    std::unique_ptr<ShadowMethod> withOwn = m->make(&ctx, Settings(name));
    FrameInput own = frame->input;
    own.deviceScene = nullptr;
    const MethodOutput a = withShared->run(frame->input);
    const MethodOutput b = withOwn->run(own);
    EXPECT_EQ(a.visibility, b.visibility) << name << ": the same mask from either copy";
    EXPECT_EQ(b.bytesAllocated - a.bytesAllocated, shared.bytes()) << name;
    auto uploaded = [](const MethodOutput& o) {
      for (const StageTime& s : o.stages)
        if (s.name == "upload") return true;
      return false;
    };
    EXPECT_TRUE(uploaded(a)) << name << ": the first frame builds its draw clusters";
    EXPECT_FALSE(uploaded(withShared->run(frame->input))) << name << ": the same revision rebuilds nothing";
  }

  // A moved vertex is a new revision: the camera pass uploads it again, the frame carries it.
  scene.positions[3].x += 0.25f;
  raster.setGeometry(scene);
  EXPECT_EQ(shared.revision, geometryRevision(scene));
  std::unique_ptr<PreparedFrame> moved = prepareFrame(ctx, raster, scene, spec);
  EXPECT_EQ(moved->input.deviceScene, &shared);
  EXPECT_NE(moved->input.revision, frame->input.revision);
}

// The one policy at the device copy: a triangle with a non-finite vertex is written as (0, 0, 0), the
// others as they are, and the camera pass draws the same G-buffer as without it.
TEST(DeviceScene, ATriangleWithANonFiniteVertexDrawsNothing) {
  auto& ctx = test::context();
  Scene scene = builtinScene();
  const Camera camera = *scene.findCamera("wall");
  const glm::vec3 light = scene.lights.front().position;
  Raster raster(ctx, scene);
  DeviceGBuffer dev;
  GBuffer before, after;
  raster.render(camera, light, 48, 40, dev, &before);
  // A far vertex appended, then a triangle over the whole view that uses it, poisoned with a NaN.
  Scene poisoned = scene;
  const uint32_t v = uint32_t(poisoned.positions.size());
  poisoned.positions.push_back(camera.eye + 0.5f * (camera.target - camera.eye));
  poisoned.positions.push_back(glm::vec3(NAN, 0, 0));
  poisoned.positions.push_back(camera.eye + 0.5f * (camera.target - camera.eye) + glm::vec3(1, 0, 0));
  for (int k = 0; k < 3; ++k) poisoned.normals.push_back(glm::vec3(0, 0, 1));
  poisoned.indices.insert(poisoned.indices.end(), {v, v + 1, v + 2});
  raster.setGeometry(poisoned);
  EXPECT_EQ(raster.deviceScene().check.droppedTriangles, 1u);
  const std::vector<uint32_t> uploaded =
      vk::download<uint32_t>(ctx, raster.deviceScene().indices, poisoned.indices.size());
  const size_t last = poisoned.indices.size() - 3;
  EXPECT_EQ(std::vector<uint32_t>(uploaded.begin(), uploaded.begin() + last),
            std::vector<uint32_t>(poisoned.indices.begin(), poisoned.indices.begin() + last));
  EXPECT_EQ(std::vector<uint32_t>(uploaded.begin() + last, uploaded.end()), std::vector<uint32_t>(3, 0u));
  raster.render(camera, light, 48, 40, dev, &after);
  EXPECT_EQ(before.position, after.position);
  EXPECT_EQ(before.normal, after.normal);
}

}  // namespace
}  // namespace cs
