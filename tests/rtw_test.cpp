// shadowmaps/: rectilinear texture warping (paper 004). The warp maps on the CPU (monotone, covering
// [0, 1], culled cells at zero width) and on the GPU against the CPU reference on a real frame; the
// importance functions against hand-computed cases; the warped pass's depth of a known plane; the
// uniform map against the cube map; RTW at a quarter of a cube map's texels on a zoomed view.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.h"
#include "shadowmaps/cube_sm.h"
#include "shadowmaps/rtw.h"
#include "shadowmaps/rtw_shared.h"
#include "tests/shadowmap_test_support.h"
#include "tests/test_context.h"

namespace cs {
namespace {

using namespace smtest;

// ---- warp maps on the CPU ------------------------------------------------------------------------------

void expectValidKnots(const std::vector<float>& importance, const std::vector<float>& knots, const char* what) {
  const size_t n = importance.size();
  ASSERT_EQ(knots.size(), n + 1) << what;
  EXPECT_EQ(knots.front(), 0.0f) << what;
  EXPECT_EQ(knots.back(), 1.0f) << what;
  bool any = false;
  for (float v : importance) any |= v > 0;
  for (size_t k = 0; k < n; ++k) {
    EXPECT_LE(knots[k], knots[k + 1]) << what << ": cell " << k;
    if (!any) {
      EXPECT_FLOAT_EQ(knots[k], float(k) / float(n)) << what << ": no importance is the identity";
    } else if (importance[k] > 0) {
      EXPECT_GT(knots[k + 1], knots[k]) << what << ": live cell " << k << " has no width";
    } else {
      EXPECT_EQ(knots[k + 1], knots[k]) << what << ": culled cell " << k << " has width";
    }
  }
}

TEST(Rtw, KnotsAreMonotoneCoverTheUnitIntervalAndGiveCulledCellsNoWidth) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0, 1);
  for (int trial = 0; trial < 200; ++trial) {
    const size_t n = 2 + trial % 300;
    std::vector<float> imp(n);
    const float zeroShare = float(trial % 5) / 5.0f;  // 0 %, 20 %, ... culled
    for (float& v : imp) v = u(rng) < zeroShare ? 0.0f : std::pow(10.0f, 4 * u(rng) - 2);
    if (trial % 17 == 3) std::fill(imp.begin(), imp.end(), 0.0f);  // nothing in view
    for (float sigma : {0.0f, 1.5f, 6.0f}) expectValidKnots(imp, rtwKnots(imp, sigma), "random importance");
  }
}

// Equation 1 by hand: with no blur, a cell's width is its share of the total importance.
TEST(Rtw, KnotsGiveEachCellItsShareOfTheImportance) {
  const std::vector<float> knots = rtwKnots({1, 3, 0, 4}, 0.0f);
  ASSERT_EQ(knots.size(), 5u);
  EXPECT_FLOAT_EQ(knots[1], 0.125f);
  EXPECT_FLOAT_EQ(knots[2], 0.5f);
  EXPECT_FLOAT_EQ(knots[3], 0.5f);  // the culled cell: zero width
  EXPECT_FLOAT_EQ(knots[4], 1.0f);
  // Uniform importance: the identity.
  const std::vector<float> id = rtwKnots(std::vector<float>(8, 2.5f), 1.5f);
  for (size_t k = 0; k <= 8; ++k) EXPECT_NEAR(id[k], float(k) / 8.0f, 1e-6f);
  // The blur spreads importance between live cells (a spike widens its neighbours) and never into a
  // culled one.
  const std::vector<float> spike = rtwKnots({1, 1, 100, 1, 0, 1}, 1.0f);
  const std::vector<float> sharp = rtwKnots({1, 1, 100, 1, 0, 1}, 0.0f);
  EXPECT_GT(spike[2] - spike[1], sharp[2] - sharp[1]);
  EXPECT_LT(spike[3] - spike[2], sharp[3] - sharp[2]);
  EXPECT_EQ(spike[5], spike[4]);
}

TEST(Rtw, WarpAndUnwarpInvertEachOtherInsideEveryLiveCell) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(0, 1);
  const uint32_t n = 64;
  std::vector<float> imp(n);
  for (float& v : imp) v = u(rng) < 0.2f ? 0.0f : u(rng);
  const std::vector<float> k = rtwKnots(imp, 1.5f);
  for (int i = 0; i < 20000; ++i) {
    const float s = u(rng);
    const uint32_t c = sm::rtwCell(s, n);
    ASSERT_LT(c, n);
    const float w = sm::rtwWarpIn(s, c, n, k[c], k[c + 1]);
    EXPECT_GE(w, k[c] - 1e-6f);
    EXPECT_LE(w, k[c + 1] + 1e-6f);
    if (k[c + 1] > k[c] + 1e-4f) {
      EXPECT_NEAR(sm::rtwUnwarpIn(w, c, n, k[c], k[c + 1]), s, 2e-5f) << s;
    } else {
      EXPECT_EQ(sm::rtwUnwarpIn(w, c, n, k[c], k[c]), float(c) / float(n));  // culled: the cell's start
    }
  }
  EXPECT_EQ(sm::rtwCell(1.0f, n), n - 1);  // the last cell holds its right end
  EXPECT_EQ(sm::rtwCell(-0.5f, n), 0u);
}

// ---- importance functions (§5) ------------------------------------------------------------------------

TEST(Rtw, ImportanceFunctionsMatchHandComputedCases) {
  // I_D = 1 / q, q clamped to the near plane.
  EXPECT_FLOAT_EQ(sm::rtwDistanceImportance(4.0f, 0.1f), 0.25f);
  EXPECT_FLOAT_EQ(sm::rtwDistanceImportance(0.01f, 0.1f), 10.0f);
  EXPECT_FLOAT_EQ(sm::rtwDistanceImportance(-3.0f, 0.5f), 2.0f);  // behind the eye: as the near plane
  // I_SN = 1 + beta · clamp(-N·v, 0, 1).
  EXPECT_FLOAT_EQ(sm::rtwNormalImportance(1.0f, 2.0f), 3.0f);     // facing the eye
  EXPECT_FLOAT_EQ(sm::rtwNormalImportance(0.5f, 2.0f), 2.0f);     // at 60°
  EXPECT_FLOAT_EQ(sm::rtwNormalImportance(-0.7f, 2.0f), 1.0f);    // facing away
  EXPECT_FLOAT_EQ(sm::rtwNormalImportance(1.0f, 0.0f), 1.0f);     // beta 0: off
  // I_E: a jump beyond constant bias + slope · d · texel angle is an edge; an empty neighbour is not.
  const float texel = 2.0f / 64;  // a 64² depth image
  EXPECT_TRUE(sm::rtwDepthEdge(5.0f, 3.0f, 0.01f, texel, RTW_EDGE_SLOPE));   // 2 > 0.01 + 4·5·texel = 0.635
  EXPECT_FALSE(sm::rtwDepthEdge(5.0f, 4.5f, 0.01f, texel, RTW_EDGE_SLOPE));  // 0.5 < 0.01 + 4·5·texel
  EXPECT_FALSE(sm::rtwDepthEdge(5.0f, 5.0f, 0.0f, texel, RTW_EDGE_SLOPE));
  EXPECT_FALSE(sm::rtwDepthEdge(5.0f, SM_EMPTY_DEPTH, 0.01f, texel, RTW_EDGE_SLOPE));
  EXPECT_TRUE(sm::rtwDepthEdge(5.0f, 4.3f, 0.01f, texel, RTW_EDGE_SLOPE));   // 0.7 > 0.635 (d the larger)
}

TEST(Rtw, ImportanceListsParseAndWhatCannotWorkIsAUsageError) {
  EXPECT_EQ(parseRtwFunctions("view,distance", RtwAnalysis::Backward), RTW_VIEW | RTW_DISTANCE);
  EXPECT_EQ(parseRtwFunctions(" Normal , VIEW ", RtwAnalysis::Hybrid), RTW_VIEW | RTW_NORMAL);
  EXPECT_EQ(parseRtwFunctions("edge", RtwAnalysis::Forward), RTW_EDGE);
  EXPECT_EQ(parseRtwFunctions("view,distance,edge,normal", RtwAnalysis::Forward),
            RTW_VIEW | RTW_DISTANCE | RTW_EDGE | RTW_NORMAL);
  EXPECT_EQ(parseRtwFunctions("uniform", RtwAnalysis::Backward), RTW_UNIFORM);
  EXPECT_THROW(parseRtwFunctions("view,sharpness", RtwAnalysis::Backward), UsageError);
  EXPECT_THROW(parseRtwFunctions("", RtwAnalysis::Backward), UsageError);
  EXPECT_THROW(parseRtwFunctions("uniform,view", RtwAnalysis::Backward), UsageError);
  EXPECT_THROW(parseRtwFunctions("view,edge", RtwAnalysis::Backward), UsageError);  // no depth image
  EXPECT_THROW(parseRtwFunctions("distance", RtwAnalysis::Backward), UsageError);   // the view is implied
  // The analyses' defaults.
  RtwOptions o;
  EXPECT_EQ(rtwFunctions(o), RTW_VIEW | RTW_DISTANCE | RTW_NORMAL);
  o.analysis = RtwAnalysis::Forward;
  EXPECT_EQ(rtwFunctions(o), RTW_VIEW | RTW_DISTANCE | RTW_EDGE | RTW_NORMAL);
}

TEST(Rtw, SettingsOutsideTheirLimitsAreErrorsNamingTheSetting) {
  auto message = [](RtwOptions o) -> std::string {
    try {
      makeRtw(test::context(), o);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  RtwOptions o;
  o.resolution = 8;
  EXPECT_NE(message(o).find("--rtw-resolution"), std::string::npos) << message(o);
  o.resolution = 1u << 15;  // 4 GiB a face
  EXPECT_NE(message(o).find("--rtw-resolution"), std::string::npos) << message(o);
  o = RtwOptions{};
  o.resolution = 64;
  o.cells = 65;
  EXPECT_NE(message(o).find("--rtw-cells"), std::string::npos) << message(o);
  o.cells = 1;
  EXPECT_NE(message(o).find("--rtw-cells"), std::string::npos) << message(o);
  o.cells = 32;
  o.analysis = RtwAnalysis::Forward;
  o.forwardResolution = 16;
  EXPECT_NE(message(o).find("--rtw-forward-res"), std::string::npos) << message(o);
  o.forwardResolution = 0;
  EXPECT_EQ(message(o), "");
}

// ---- on the GPU ---------------------------------------------------------------------------------------

// The knots rtw_warp.comp builds equal the CPU reference's on a real frame: importance from the desired
// view alone (1 in every cell a lit sample projects to), collapsed by the maximum, blurred, Equation 1.
TEST(Rtw, GpuWarpMapsMatchTheCpuReferenceOnARealFrame) {
  Frame f = builtinFrame("room", 160, 128);
  RtwOptions o;
  o.resolution = 256;
  o.cells = 64;
  o.functions = RTW_VIEW;
  o.blurSigma = 1.5f;
  o.keepWarp = true;
  MethodOutput out = makeRtw(test::context(), o)->run(f.input());
  const auto& gpu = out.stats["warp_knots"];
  ASSERT_EQ(gpu.size(), 12u);
  const uint32_t n = o.cells;
  std::vector<float> cells(6 * n * n, 0.0f);
  for (size_t i = 0; i < f.host.size(); ++i) {
    const glm::vec3 d = glm::vec3(f.host.position[i]) - f.light;
    if (!f.host.isLit(i) || glm::length(d) <= 2 * f.eps) continue;
    const uint32_t face = sm::cubeFace(d);
    const glm::vec2 st = sm::faceST(sm::faceSpace(face, d));
    cells[face * n * n + sm::rtwCell(st.y, n) * n + sm::rtwCell(st.x, n)] = 1.0f;
  }
  size_t culled = 0, live = 0;
  for (uint32_t face = 0; face < 6; ++face)
    for (uint32_t axis = 0; axis < 2; ++axis) {
      std::vector<float> collapsed(n, 0.0f);
      for (uint32_t y = 0; y < n; ++y)
        for (uint32_t x = 0; x < n; ++x)
          collapsed[axis == 0 ? x : y] = std::max(collapsed[axis == 0 ? x : y], cells[face * n * n + y * n + x]);
      const std::vector<float> want = rtwKnots(collapsed, o.blurSigma);
      const std::vector<float> got = gpu[face * 2 + axis].get<std::vector<float>>();
      ASSERT_EQ(got.size(), n + 1);
      for (uint32_t k = 0; k <= n; ++k) EXPECT_NEAR(got[k], want[k], 2e-5f) << "face " << face << " axis " << axis << " knot " << k;
      for (uint32_t k = 0; k < n; ++k) {
        culled += got[k + 1] == got[k];
        live += got[k + 1] > got[k];
      }
    }
  EXPECT_GT(culled, 0u) << "the room's view must leave parts of the faces empty";
  EXPECT_GT(live, 0u);
  EXPECT_EQ(out.stats["culled_samples"], 0) << "the backward analysis gives every sample's cell importance";
}

// The warped pass stores, per texel, the exact distance to the rendered triangle's plane along the
// texel's unwarped centre ray; with the receiver-plane bias, the lookup compares a sample's plane along
// the same ray. Inside a closed box around the light nothing is shadowed: under a strong warp, with no
// slope bias and a constant bias of a thousandth of the scene's epsilon, no sample may read as shadowed —
// the stored depth matches the analytic plane to within that. The slope-scaled comparison of the same
// map (no plane bias) shows the test can fail.
TEST(Rtw, TheWarpedDepthOfAPlaneIsItsAnalyticDistance) {
  const glm::vec3 lo = kBoxLo, hi = kBoxHi;
  Frame f = boxFrame(160, 120);
  RtwOptions o;
  o.resolution = 512;
  o.cells = 128;
  o.pcf = false;
  o.slopeBias = 0;
  o.constantBias = 1e-3f;
  o.planeBias = true;
  MethodOutput out = makeRtw(test::context(), o)->run(f.input());
  EXPECT_GT(out.stats["mer_max"].get<double>(), 2.0 * o.resolution) << "the warp must be strong";
  // False shadows away from the box's edges: at a concave edge a tap's ray may hit the other wall first
  // (closer than the sample's plane along that ray), which no bias policy of a depth map avoids.
  auto falseShadowsAwayFromEdges = [&](const std::vector<float>& vis, size_t& lit) {
    size_t wrong = 0;
    lit = 0;
    for (size_t i = 0; i < f.host.size(); ++i) {
      if (!f.host.isLit(i)) continue;
      const glm::vec3 p(f.host.position[i]);
      int onFaces = 0;
      for (int a = 0; a < 3; ++a) onFaces += std::min(std::abs(p[a] - lo[a]), std::abs(p[a] - hi[a])) < 0.02f;
      if (onFaces > 1) continue;
      ++lit;
      wrong += vis[i] < 0.5f;
    }
    return wrong;
  };
  size_t lit = 0;
  const size_t plane = falseShadowsAwayFromEdges(out.visibility, lit);
  o.planeBias = false;
  const std::vector<float> slope = makeRtw(test::context(), o)->run(f.input()).visibility;
  size_t unused = 0;
  const size_t flat = falseShadowsAwayFromEdges(slope, unused);
  std::printf("box around the light, away from its edges: false shadow with the plane bias %zu, slope comparison %zu "
              "of %zu\n", plane, flat, lit);
  EXPECT_GT(lit, 15000u);
  EXPECT_EQ(plane, 0u);
  EXPECT_GT(flat, lit / 20);
}

// Uniform importance is the identity warp: the RTW lookup is a cube map of the same resolution (the
// cube map over whole faces, as RTW's faces are), the same bias and PCF.
TEST(Rtw, AnUnwarpedMapLooksUpAsTheCubeMap) {
  Frame f = renderFrame(squareAbovePlane(), squareCamera(), kSquareLight, 160, 128);
  RtwOptions ro;
  ro.resolution = 256;
  ro.functions = RTW_UNIFORM;
  ro.keepWarp = true;
  MethodOutput rtw = makeRtw(test::context(), ro)->run(f.input());
  for (const auto& axis : rtw.stats["warp_knots"]) {
    const auto k = axis.get<std::vector<float>>();
    for (size_t i = 0; i < k.size(); ++i) ASSERT_NEAR(k[i], float(i) / float(k.size() - 1), 1e-6f);
  }
  EXPECT_EQ(rtw.stats["mer_max"], 256);
  CubeSmOptions co;
  co.resolution = 256;
  co.fitFaces = false;
  MethodOutput cube = makeCubeShadowMap(test::context(), co)->run(f.input());
  size_t lit = 0, differ = 0, binaryDiffer = 0;
  for (size_t i = 0; i < f.host.size(); ++i) {
    if (!f.host.isLit(i)) continue;
    ++lit;
    differ += std::abs(rtw.visibility[i] - cube.visibility[i]) > 1e-3f;
    binaryDiffer += (rtw.visibility[i] >= 0.5f) != (cube.visibility[i] >= 0.5f);
  }
  std::printf("uniform rtw vs cubesm 256²: %zu of %zu lit samples differ, %zu across 0.5\n", differ, lit, binaryDiffer);
  EXPECT_GT(lit, 10000u);
  EXPECT_LE(differ, lit / 1000);
  EXPECT_LE(binaryDiffer, lit / 2000);
  const double er = f.compare(rtw.visibility).misclassifiedFraction, ec = f.compare(cube.visibility).misclassifiedFraction;
  EXPECT_NEAR(er, ec, 0.1 * ec + 1e-4);
}

// Paper 004's Fig. 1 claim on zoomed views (a narrow field of view onto a shadow edge, where a 2048²
// cube map's texels span several pixels): RTW at a quarter of the cube map's texels, at its defaults,
// misclassifies less — on the analytic square's shadow and on the built-in scene's "edge" view. Without
// tessellation the straight warped edges misplace the shadow's edge (printed, not asserted).
TEST(Rtw, BeatsTheCubeMapAtAQuarterOfItsTexelsOnZoomedViews) {
  Camera zoom;
  zoom.eye = {2.3f, 0.9f, 2.4f};
  zoom.target = {1.325f, 0.0f, 0.5f};  // on the shadow's edge x = 1.325 (the square's edge x = 1 seen from the light)
  zoom.yfov = 0.05f;
  zoom.znear = 0.05f;
  zoom.zfar = 60.0f;
  std::vector<Frame> frames;
  frames.push_back(renderFrame(squareAbovePlane(), zoom, kSquareLight, 192, 160));
  frames.push_back(builtinFrame("edge", 192, 160));
  for (Frame& f : frames) {
    CubeSmOptions co;
    co.resolution = 2048;
    co.fitFaces = false;
    MethodOutput cube = makeCubeShadowMap(test::context(), co)->run(f.input());
    RtwOptions ro;
    ro.resolution = 1024;
    MethodOutput rtw = makeRtw(test::context(), ro)->run(f.input());
    ro.tessellation = 0;
    MethodOutput straight = makeRtw(test::context(), ro)->run(f.input());
    const ErrorStats ec = f.compare(cube.visibility), er = f.compare(rtw.visibility), es = f.compare(straight.visibility);
    std::printf("%s zoomed: cubesm 2048² %.5f, rtw 1024² %.5f (MER %lld), untessellated %.5f\n", f.scene.name.c_str(),
                ec.misclassifiedFraction, er.misclassifiedFraction, rtw.stats["mer_max"].get<long long>(),
                es.misclassifiedFraction);
    EXPECT_GT(ec.misclassified, 60u) << f.scene.name << ": the cube map must alias visibly on this view";
    EXPECT_LT(er.misclassifiedFraction, 0.5 * ec.misclassifiedFraction) << f.scene.name;
    EXPECT_GT(rtw.stats["mer_max"].get<double>(), 4.0 * co.resolution) << f.scene.name << ": the finest cell";
    EXPECT_EQ(rtw.stats["culled_samples"], 0) << f.scene.name;
  }
}

// The forward analysis reads the light's low-resolution depth image, whose view test sees texel centres:
// on a view narrower than one of its texels it alone would cull the very cells the samples lie in. The
// samples' coverage floor keeps every lit sample in a live cell.
TEST(Rtw, TheForwardAnalysisLeavesNoLitSampleInACulledCell) {
  Frame f = builtinFrame("edge", 96, 80);
  RtwOptions o;
  o.resolution = 512;
  o.analysis = RtwAnalysis::Forward;
  MethodOutput out = makeRtw(test::context(), o)->run(f.input());
  const ErrorStats e = f.compare(out.visibility);
  std::printf("forward analysis on the edge view: %llu lit samples in culled cells, misclassified %.5f (outside the band %llu)\n",
              (unsigned long long)out.stats["culled_samples"].get<uint64_t>(), e.misclassifiedFraction,
              (unsigned long long)e.misclassifiedOutsideBand);
  EXPECT_EQ(out.stats["culled_samples"], 0);
  EXPECT_LT(e.misclassifiedFraction, 0.02);
}

// A frame the RTW path must also get right: nothing lit gives all ones, and the culled faces draw nothing.
TEST(Rtw, AFrameWithoutLitSamplesIsAllLit) {
  Camera away = squareCamera();
  away.target = away.eye + glm::vec3(0, 1, 0.2f);
  Frame f = renderFrame(squareAbovePlane(), away, kSquareLight, 64, 48);
  ASSERT_EQ(f.host.litCount(), 0u);
  MethodOutput out = makeRtw(test::context(), RtwOptions{})->run(f.input());
  EXPECT_EQ(out.visibility, std::vector<float>(f.host.size(), 1.0f));
  EXPECT_EQ(out.stats["active_faces"], 0);
}

// The importance functions weigh samples by the view: a frame without a camera is refused, not guessed.
TEST(Rtw, AFrameWithoutItsCameraIsRefusedWhenTheFunctionsNeedIt) {
  Frame f = renderFrame(squareAbovePlane(), squareCamera(), kSquareLight, 64, 48);
  FrameInput in = f.input();
  in.camera = nullptr;
  EXPECT_THROW(makeRtw(test::context(), RtwOptions{})->run(in), Error);
  RtwOptions view;
  view.functions = RTW_VIEW;
  EXPECT_NO_THROW(makeRtw(test::context(), view)->run(in));
}

}  // namespace
}  // namespace cs
