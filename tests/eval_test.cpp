// The error metric on hand-made cases, and the frame's output: PFM row order, PNG, CSV = JSON, no
// partial files on failure, the dump an independent checker reads.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tinyexr.h>

#include "core/error.h"
#include "core/image_io.h"
#include "judge/frame_output.h"
#include "judge/metrics.h"

namespace cs {
namespace {

namespace fs = std::filesystem;

// A fresh directory under the system temp dir, removed at the end of the test.
struct TempDir {
  fs::path path;
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path = fs::temp_directory_path() /
           ("coneshadow_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string file(const std::string& name) const { return (path / name).string(); }
};

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// n samples in one row; lit[i] says whether sample i faces the light (all have geometry but the last
// when `lastEmpty`).
GBuffer rowGBuffer(const std::vector<bool>& lit, bool lastEmpty = false) {
  GBuffer g;
  g.width = uint32_t(lit.size());
  g.height = 1;
  for (size_t i = 0; i < lit.size(); ++i) {
    g.position.push_back(glm::vec4(float(i), 0, 0, 1));
    g.normal.push_back(glm::vec4(0, 1, 0, lit[i] ? 0.7f : 0.0f));
  }
  if (lastEmpty) g.position.back() = glm::vec4(0);
  return g;
}

TEST(Metrics, CountsFalseShadowAndFalseLightOverLitSamplesOnly) {
  //                       0     1     2     3     4     5     6     7
  GBuffer g = rowGBuffer({true, true, true, true, true, true, false, true}, /*lastEmpty=*/true);
  std::vector<float> ref = {1, 1, 0, 0, 1, 0, 1, 0};
  std::vector<float> met = {1, 0, 1, 0, 0.4f, 0.6f, 0, 1};
  // 0 agree lit, 1 false shadow, 2 false light, 3 agree dark, 4 false shadow (0.4), 5 false light (0.6);
  // 6 faces away and 7 has no geometry: not counted whatever they hold.
  ErrorStats s = compareVisibility(g, met, ref, {});
  EXPECT_EQ(s.litSamples, 6u);
  EXPECT_EQ(s.bandSamples, 0u);
  EXPECT_EQ(s.falseShadow, 2u);
  EXPECT_EQ(s.falseLight, 2u);
  EXPECT_EQ(s.misclassified, 4u);
  EXPECT_EQ(s.misclassifiedOutsideBand, 4u);
  EXPECT_DOUBLE_EQ(s.misclassifiedFraction, 4.0 / 6.0);
  EXPECT_DOUBLE_EQ(s.falseShadowFraction, 2.0 / 6.0);
  EXPECT_DOUBLE_EQ(s.falseLightFraction, 2.0 / 6.0);
  EXPECT_NEAR(s.meanAbsError, (0 + 1 + 1 + 0 + 0.6 + 0.6) / 6.0, 1e-7);
}

TEST(Metrics, AFrameWhoseBandHoldsOverOnePercentOfItsLitSamplesIsUndecided) {
  GBuffer g = rowGBuffer(std::vector<bool>(200, true));
  std::vector<float> ref(200, 1.0f), met(200, 1.0f);
  std::vector<uint8_t> band(200, 0);
  band[3] = band[7] = 1;  // 1 % exactly: decided
  ErrorStats s = compareVisibility(g, met, ref, band);
  EXPECT_DOUBLE_EQ(s.bandFraction, 0.01);
  EXPECT_FALSE(s.undecided);
  EXPECT_EQ(s.undecidedReason(), "");
  band[9] = 1;  // 1.5 %: undecided, with its reason
  s = compareVisibility(g, met, ref, band);
  EXPECT_TRUE(s.undecided);
  EXPECT_NE(s.undecidedReason().find("1.5 %"), std::string::npos) << s.undecidedReason();
  const nlohmann::json j = toJson(s);
  EXPECT_EQ(j["undecided"], true);
  EXPECT_DOUBLE_EQ(j["band_fraction"].get<double>(), 0.015);
  // No lit sample: nothing is undecided.
  s = compareVisibility(rowGBuffer(std::vector<bool>(4, false)), std::vector<float>(4, 1), std::vector<float>(4, 1),
                        std::vector<uint8_t>(4, 1));
  EXPECT_FALSE(s.undecided);
}

TEST(Metrics, BandSplitsTheCounts) {
  GBuffer g = rowGBuffer({true, true, true, true, true, false});
  std::vector<float> ref = {1, 1, 0, 0, 1, 1};
  std::vector<float> met = {0, 0, 1, 0, 1, 0};
  std::vector<uint8_t> band = {1, 0, 1, 1, 0, 1};  // band on a not-lit sample (5) is ignored
  ErrorStats s = compareVisibility(g, met, ref, band);
  EXPECT_EQ(s.litSamples, 5u);
  EXPECT_EQ(s.bandSamples, 3u);
  EXPECT_EQ(s.falseShadow, 2u);  // 0 (band), 1
  EXPECT_EQ(s.falseLight, 1u);   // 2 (band)
  EXPECT_EQ(s.falseShadowOutsideBand, 1u);
  EXPECT_EQ(s.falseLightOutsideBand, 0u);
  EXPECT_EQ(s.misclassifiedOutsideBand, 1u);
  EXPECT_DOUBLE_EQ(s.misclassifiedFractionOutsideBand, 1.0 / 2.0);  // of the 2 lit samples outside
  EXPECT_DOUBLE_EQ(s.falseShadowFractionOutsideBand, 1.0 / 2.0);
  EXPECT_DOUBLE_EQ(s.falseLightFractionOutsideBand, 0.0);
  EXPECT_DOUBLE_EQ(s.meanAbsError, 3.0 / 5.0);
  EXPECT_DOUBLE_EQ(s.meanAbsErrorOutsideBand, 1.0 / 2.0);
}

TEST(Metrics, NoLitSamplesGiveZeroFractionsNotNaN) {
  GBuffer g = rowGBuffer({false, false});
  ErrorStats s = compareVisibility(g, {0, 1}, {1, 0}, {});
  EXPECT_EQ(s.litSamples, 0u);
  EXPECT_EQ(s.misclassifiedFraction, 0.0);
  EXPECT_EQ(s.misclassifiedFractionOutsideBand, 0.0);
  EXPECT_EQ(s.meanAbsError, 0.0);
}

TEST(Metrics, MismatchedSizesAreAnError) {
  GBuffer g = rowGBuffer({true, true});
  EXPECT_THROW(compareVisibility(g, {1}, {1, 1}, {}), Error);
  EXPECT_THROW(compareVisibility(g, {1, 1}, {1, 1}, {1}), Error);
}

TEST(Metrics, JsonCarriesEveryField) {
  GBuffer g = rowGBuffer({true, true});
  nlohmann::json j = toJson(compareVisibility(g, {0, 1}, {1, 1}, {0, 0}));
  EXPECT_EQ(j.at("false_shadow").get<uint64_t>(), 1u);
  EXPECT_EQ(j.at("lit_samples").get<uint64_t>(), 2u);
  EXPECT_DOUBLE_EQ(j.at("mean_abs_error").get<double>(), 0.5);
  EXPECT_EQ(j.size(), 19u);
  EXPECT_EQ(j.at("undecided").get<bool>(), false);
  EXPECT_DOUBLE_EQ(j.at("band_fraction").get<double>(), 0.0);
}

TEST(ImageIo, PfmRoundTripKeepsRowOrderAndStoresTheBottomRowFirst) {
  TempDir dir;
  const uint32_t w = 3, h = 2;
  // value = 10 * row + col, row 0 at the top
  std::vector<float> one = {0, 1, 2, 10, 11, 12};
  writePfm(dir.file("one.pfm"), w, h, 1, one);
  PfmImage back = readPfm(dir.file("one.pfm"));
  EXPECT_EQ(back.width, w);
  EXPECT_EQ(back.height, h);
  EXPECT_EQ(back.channels, 1);
  EXPECT_EQ(back.data, one);
  // The raw file: header, then the bottom row (10, 11, 12) first.
  std::string raw = readFile(dir.file("one.pfm"));
  const std::string header = "Pf\n3 2\n-1.0\n";
  ASSERT_EQ(raw.size(), header.size() + 6 * sizeof(float));
  EXPECT_EQ(raw.substr(0, header.size()), header);
  float firstStored;
  std::memcpy(&firstStored, raw.data() + header.size(), sizeof(float));
  EXPECT_EQ(firstStored, 10.0f);

  std::vector<float> rgb(w * h * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = float(i) * 0.5f - 1.0f;
  rgb[4] = std::nanf("");
  writePfm(dir.file("rgb.pfm"), w, h, 3, rgb);
  PfmImage backRgb = readPfm(dir.file("rgb.pfm"));
  EXPECT_EQ(backRgb.channels, 3);
  ASSERT_EQ(backRgb.data.size(), rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i) {
    if (std::isnan(rgb[i])) EXPECT_TRUE(std::isnan(backRgb.data[i]));
    else EXPECT_EQ(backRgb.data[i], rgb[i]) << i;
  }
  EXPECT_EQ(readFile(dir.file("rgb.pfm")).substr(0, 3), "PF\n");
}

TEST(ImageIo, PngIsWrittenAndNonEmpty) {
  TempDir dir;
  std::vector<uint8_t> rgb(5 * 4 * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = uint8_t(i * 7);
  writePng(dir.file("a.png"), 5, 4, rgb);
  std::string bytes = readFile(dir.file("a.png"));
  ASSERT_GT(bytes.size(), 8u);
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_THROW(writePng(dir.file("b.png"), 5, 4, std::vector<uint8_t>(10)), Error);  // wrong size
  EXPECT_FALSE(fs::exists(dir.file("b.png")));
}

TEST(ImageIo, NoFileIsLeftWhenTheDirectoryDoesNotExist) {
  TempDir dir;
  const std::string missing = dir.file("no_such_dir");
  try {
    writePng(missing + "/a.png", 1, 1, {1, 2, 3});
    ADD_FAILURE() << "expected cs::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(missing + "/a.png"), std::string::npos) << e.what();
  }
  EXPECT_THROW(writePfm(missing + "/a.pfm", 1, 1, 1, {1.0f}), Error);
  EXPECT_THROW(writeFileAtomic(missing + "/a.json", "{}"), Error);
  EXPECT_FALSE(fs::exists(missing));
  EXPECT_TRUE(fs::is_empty(dir.path));
}

TEST(ImageIo, FailedRenameLeavesNoTemporaryAndKeepsTheTarget) {
  TempDir dir;
  // The target is an existing non-empty directory: the write succeeds, the rename cannot.
  fs::create_directories(dir.path / "target" / "inside");
  EXPECT_THROW(writeFileAtomic(dir.file("target"), "data"), Error);
  EXPECT_TRUE(fs::is_directory(dir.path / "target" / "inside"));
  size_t entries = 0;
  for (const auto& e : fs::directory_iterator(dir.path)) {
    ++entries;
    EXPECT_EQ(e.path().filename(), "target");
  }
  EXPECT_EQ(entries, 1u);
}

TEST(ImageIo, ReadPfmRejectsGarbageAndTruncation) {
  TempDir dir;
  writeFileAtomic(dir.file("bad.pfm"), "P6\n1 1\n255\nxxx");
  EXPECT_THROW(readPfm(dir.file("bad.pfm")), Error);
  writeFileAtomic(dir.file("short.pfm"), std::string("Pf\n2 2\n-1.0\n") + std::string(7, '\0'));
  EXPECT_THROW(readPfm(dir.file("short.pfm")), Error);
  EXPECT_THROW(readPfm(dir.file("absent.pfm")), Error);
}

// A 2x2 G-buffer: (0,0) lit, (1,0) lit, (0,1) faces away, (1,1) no geometry.
GBuffer tinyGBuffer() {
  GBuffer g;
  g.width = 2;
  g.height = 2;
  g.position = {glm::vec4(0, 0, 0, 1), glm::vec4(1, 0, 0, 1), glm::vec4(0, 0, 1, 1), glm::vec4(0)};
  g.normal = {glm::vec4(0, 1, 0, 1.0f), glm::vec4(0, 1, 0, 0.5f), glm::vec4(0, 1, 0, 0.0f), glm::vec4(0)};
  return g;
}

TEST(FrameOutput, ShadedAndMaskImagesFollowTheDocumentedColours) {
  GBuffer g = tinyGBuffer();
  std::vector<uint8_t> shaded = shadedImage(g, {1, 0, 1, 1});
  // (0,0): 0.8 * (0.15 + 1) = 0.92 -> 0.92^(1/2.2) * 255 = 245
  EXPECT_EQ(shaded[0], uint8_t(std::pow(0.92f, 1 / 2.2f) * 255 + 0.5f));
  // (1,0) shadowed: ambient only, 0.12 -> 97
  EXPECT_EQ(shaded[3], uint8_t(std::pow(0.12f, 1 / 2.2f) * 255 + 0.5f));
  EXPECT_EQ(shaded[9], kBackgroundRgb[0]);
  EXPECT_EQ(shaded[11], kBackgroundRgb[2]);
  std::vector<uint8_t> mask = maskImage(g, {1, 0, 1, 1});
  EXPECT_EQ(mask[0], 255);
  EXPECT_EQ(mask[3], 0);
  EXPECT_EQ(mask[6], kNotLitMaskGrey);
  EXPECT_EQ(mask[9], kNotLitMaskGrey);
}

TEST(FrameOutput, DiffImageMarksFalseShadowRedFalseLightCyanAndBandYellow) {
  GBuffer g;
  g.width = 4;
  g.height = 1;
  g.position.assign(4, glm::vec4(0, 0, 0, 1));
  g.normal.assign(4, glm::vec4(0, 1, 0, 1));
  std::vector<float> ref = {1, 1, 0, 1};
  std::vector<float> met = {1, 0, 1, 0};
  std::vector<uint8_t> band = {0, 0, 0, 1};
  std::vector<uint8_t> diff = diffImage(g, met, ref, band);
  std::vector<uint8_t> shaded = shadedImage(g, ref);
  EXPECT_EQ(diff[0], uint8_t(float(shaded[0]) * 0.5f + 0.5f));  // agree: dimmed
  EXPECT_EQ(std::vector<uint8_t>(diff.begin() + 3, diff.begin() + 6),
            std::vector<uint8_t>(kFalseShadowRgb, kFalseShadowRgb + 3));
  EXPECT_EQ(std::vector<uint8_t>(diff.begin() + 6, diff.begin() + 9),
            std::vector<uint8_t>(kFalseLightRgb, kFalseLightRgb + 3));
  EXPECT_EQ(std::vector<uint8_t>(diff.begin() + 9, diff.begin() + 12),
            std::vector<uint8_t>(kBandDisagreeRgb, kBandDisagreeRgb + 3));
}

TEST(FrameOutput, WriteFrameImagesWritesThreePngs) {
  TempDir dir;
  GBuffer g = tinyGBuffer();
  writeFrameImages(dir.file("img"), "cone", g, {1, 0, 1, 1}, {1, 1, 1, 1}, {});
  for (const char* name : {"cone_shaded.png", "cone_mask.png", "cone_diff.png"})
    EXPECT_GT(fs::file_size(dir.path / "img" / name), 0u) << name;
}

TEST(FrameOutput, ShrunkDiffKeepsEveryErrorPixel) {
  // A 301x203 diff image: random dimmed greys with scattered error pixels, every kind, some blocks mixed.
  const uint32_t W = 301, H = 203;
  std::mt19937 rng(7);
  std::vector<uint8_t> rgb(size_t(W) * H * 3);
  for (size_t i = 0; i < size_t(W) * H; ++i) {
    const uint32_t r = rng() % 1000;
    const uint8_t* c = r < 4 ? kFalseShadowRgb : r < 8 ? kFalseLightRgb : r < 12 ? kBandDisagreeRgb : nullptr;
    const uint8_t grey = uint8_t(rng() % 128);
    for (int k = 0; k < 3; ++k) rgb[3 * i + k] = c ? c[k] : grey;
  }
  const uint32_t factor = shrinkFactor(W, H, 64);
  EXPECT_EQ(factor, 5u);
  EXPECT_EQ(shrinkFactor(48, 32, 256), 1u);
  EXPECT_EQ(shrinkFactor(1024, 768, 256), 4u);
  uint32_t tw = 0, th = 0;
  const std::vector<uint8_t> small = shrinkKeepingErrors(rgb, W, H, factor, tw, th);
  ASSERT_EQ(tw, 61u);
  ASSERT_EQ(th, 41u);
  auto is = [](const uint8_t* p, const uint8_t c[3]) { return p[0] == c[0] && p[1] == c[1] && p[2] == c[2]; };
  size_t errorBlocks = 0;
  for (uint32_t by = 0; by < th; ++by)
    for (uint32_t bx = 0; bx < tw; ++bx) {
      size_t shadow = 0, light = 0, band = 0;
      for (uint32_t y = by * factor; y < std::min(H, (by + 1) * factor); ++y)
        for (uint32_t x = bx * factor; x < std::min(W, (bx + 1) * factor); ++x) {
          const uint8_t* p = &rgb[(size_t(y) * W + x) * 3];
          shadow += is(p, kFalseShadowRgb), light += is(p, kFalseLightRgb), band += is(p, kBandDisagreeRgb);
        }
      const uint8_t* q = &small[(size_t(by) * tw + bx) * 3];
      if (shadow || light) {
        ++errorBlocks;
        EXPECT_TRUE(is(q, shadow >= light ? kFalseShadowRgb : kFalseLightRgb)) << bx << "," << by;
      } else if (band) {
        EXPECT_TRUE(is(q, kBandDisagreeRgb)) << bx << "," << by;
      } else {
        EXPECT_LT(q[0], 128) << "a block without errors is its mean grey";
        EXPECT_EQ(q[0], q[1]);
      }
    }
  EXPECT_GT(errorBlocks, 100u);
  // Factor 1 is the image itself.
  EXPECT_EQ(shrinkKeepingErrors(rgb, W, H, 1, tw, th), rgb);

  // writeFrameImages writes the thumbnails beside the full-size images when asked.
  TempDir dir;
  GBuffer g;
  g.width = 300;
  g.height = 10;
  g.position.assign(g.size(), glm::vec4(0, 0, 0, 1));
  g.normal.assign(g.size(), glm::vec4(0, 0, 1, 1));
  std::vector<float> ref(g.size(), 1.0f), met(g.size(), 1.0f);
  met[5 * 300 + 299] = 0.0f;  // one false shadow in the last, partial block
  EXPECT_EQ(writeFrameImages(dir.file("img"), "m", g, met, ref, {}, 256), 2u);
  for (const char* name : {"m_shaded_thumb.png", "m_mask_thumb.png", "m_diff_thumb.png"})
    EXPECT_GT(fs::file_size(dir.path / "img" / name), 0u) << name;
}

TEST(FrameOutput, DumpHasNaNWhereNoGeometryAndTopRowLastInTheFile) {
  TempDir dir;
  GBuffer g = tinyGBuffer();
  Scene scene;
  scene.name = "tiny";
  scene.positions = {{-1, 0, -2}, {3, 0, 0}, {0, 4, 1}};
  scene.indices = {0, 1, 2};
  Camera cam;
  cam.eye = {0, 2, 5};
  EpsilonPolicy policy = EpsilonPolicy::forScene(scene);
  std::map<std::string, std::vector<float>> vis = {{"embree", {1, 0, 1, 1}}, {"cone/v2", {1, 1, 1, 1}}};
  writeDump(dir.file("dump"), scene, g, cam, glm::vec3(0.5f, 3, 0.25f), policy, vis, {0, 1, 0, 0});

  PfmImage pos = readPfm(dir.file("dump/position.pfm"));
  ASSERT_EQ(pos.channels, 3);
  EXPECT_EQ(pos.data[3], 1.0f);             // pixel (1, 0): x = 1, back in top-first order
  EXPECT_TRUE(std::isnan(pos.data[9]));     // pixel (1, 1): no geometry
  // In the file, the bottom row (pixels (0,1), (1,1)) comes first.
  std::string raw = readFile(dir.file("dump/position.pfm"));
  size_t header = std::string("PF\n2 2\n-1.0\n").size();
  float z;
  std::memcpy(&z, raw.data() + header + 2 * sizeof(float), sizeof(float));
  EXPECT_EQ(z, 1.0f);  // pixel (0, 1) has z = 1

  EXPECT_EQ(readPfm(dir.file("dump/band.pfm")).data, (std::vector<float>{0, 1, 0, 0}));
  EXPECT_EQ(readPfm(dir.file("dump/visibility_embree.pfm")).data, (std::vector<float>{1, 0, 1, 1}));
  EXPECT_TRUE(fs::exists(dir.path / "dump" / "visibility_cone_v2.pfm"));
  EXPECT_EQ(readPfm(dir.file("dump/light.pfm")).data, (std::vector<float>{1.0f, 0.5f, 0.0f, 0.0f}));
  EXPECT_TRUE(std::isnan(readPfm(dir.file("dump/normal.pfm")).data[9]));

  nlohmann::json meta = nlohmann::json::parse(readFile(dir.file("dump/meta.json")));
  EXPECT_EQ(meta.at("width").get<int>(), 2);
  EXPECT_EQ(meta.at("triangles").get<int>(), 1);
  EXPECT_EQ(meta.at("scene").get<std::string>(), "tiny");
  EXPECT_FLOAT_EQ(meta.at("light")[0].get<float>(), 0.5f);
  EXPECT_FLOAT_EQ(meta.at("camera").at("eye")[1].get<float>(), 2.0f);
  EXPECT_FLOAT_EQ(meta.at("epsilon").at("eps").get<float>(), policy.eps);
  EXPECT_FLOAT_EQ(meta.at("bounds").at("max")[1].get<float>(), 4.0f);
  EXPECT_EQ(meta.at("files").at("visibility").at("cone/v2").get<std::string>(), "visibility_cone_v2.pfm");
  EXPECT_NE(meta.at("row_order").get<std::string>().find("bottom row first"), std::string::npos);

  // The EXR twins hold the same floats, rows top first, read back by tinyexr's own loader.
  auto exr = [&](const std::string& file, int& w, int& h) {
    float* rgba = nullptr;
    const char* err = nullptr;
    EXPECT_EQ(LoadEXR(&rgba, &w, &h, dir.file("dump/" + file).c_str(), &err), TINYEXR_SUCCESS) << (err ? err : "");
    if (err) FreeEXRErrorMessage(err);
    std::vector<float> out(rgba, rgba + (rgba ? size_t(w) * h * 4 : 0));
    std::free(rgba);
    return out;
  };
  int w = 0, h = 0;
  std::vector<float> position = exr("position.exr", w, h);
  ASSERT_EQ(w, 2);
  ASSERT_EQ(h, 2);
  ASSERT_EQ(position.size(), 16u);
  EXPECT_EQ(position[4 * 1 + 0], 1.0f);  // pixel (1, 0): x = 1, R channel, top row first
  EXPECT_TRUE(std::isnan(position[4 * 3 + 0]));
  for (size_t i = 0; i < 4; ++i)
    for (int c = 0; c < 3; ++c) {
      const float want = g.hasGeometry(i) ? g.position[i][c] : std::numeric_limits<float>::quiet_NaN();
      if (std::isnan(want)) EXPECT_TRUE(std::isnan(position[4 * i + c]));
      else EXPECT_EQ(position[4 * i + c], want) << i << " " << c;
    }
  std::vector<float> visibility = exr("visibility_embree.exr", w, h);
  ASSERT_EQ(visibility.size(), 16u);
  for (size_t i = 0; i < 4; ++i) EXPECT_EQ(visibility[4 * i], (std::vector<float>{1, 0, 1, 1})[i]) << i;
  std::vector<float> light = exr("light.exr", w, h);
  ASSERT_EQ(light.size(), 16u);
  EXPECT_EQ(light[4], 0.5f);
}

// Splits one CSV line (RFC 4180 quoting).
std::vector<std::string> parseCsvLine(const std::string& line) {
  std::vector<std::string> cells(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') cells.back() += '"', ++i;
      else if (c == '"') quoted = false;
      else cells.back() += c;
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      cells.emplace_back();
    } else {
      cells.back() += c;
    }
  }
  return cells;
}

// The JSON value at a CSV column name ("stage.rays.ms", "error.false_shadow", "stats.a.b").
const nlohmann::json* lookup(const nlohmann::json& row, const std::string& column) {
  if (column.rfind("stage.", 0) == 0) {
    std::string name = column.substr(6, column.size() - 6 - 3);
    for (const auto& s : row.at("stages"))
      if (s.at("name") == name) return &s.at("ms");
    return nullptr;
  }
  const nlohmann::json* at = &row;
  std::stringstream path(column);
  for (std::string key; std::getline(path, key, '.');) {
    if (!at->is_object() || !at->contains(key)) return nullptr;
    at = &at->at(key);
  }
  return at;
}

TEST(FrameOutput, CsvAndJsonHoldTheSameNumbers) {
  FrameResult a;
  a.scene = "room, with a comma";
  a.view = "top";
  a.method = "embree";
  a.width = 640;
  a.height = 480;
  a.device = "cpu \"2 threads\"";
  a.stages = {{"bvh_build", 1.0 / 3.0}, {"rays", 12.125}};
  a.totalMs = 1.0 / 3.0 + 12.125;
  a.bytes = 123456789012ull;
  a.peakBytes = 98765;
  a.stats = {{"rays", 307200}, {"nested", {{"depth", 7}, {"ratio", 0.1}}}, {"list", {1, 2}}};
  GBuffer g = rowGBuffer({true, true, true});
  a.error = compareVisibility(g, {0, 1, 1}, {1, 1, 0}, {0, 0, 1});
  FrameResult b = a;
  b.method = "cone";
  b.stages = {{"sort", 0.5}, {"traverse", 2.75}, {"rays", 1e-9}};
  b.stats = {{"pairs", 42}};

  nlohmann::json json = resultsJson({a, b});
  std::string csv = resultsCsv({a, b});
  std::stringstream lines(csv);
  std::string headerLine, line;
  std::getline(lines, headerLine);
  std::vector<std::string> header = parseCsvLine(headerLine);
  EXPECT_EQ(header[0], "scene");
  EXPECT_NE(std::find(header.begin(), header.end(), "stage.traverse.ms"), header.end());
  EXPECT_NE(std::find(header.begin(), header.end(), "stats.nested.ratio"), header.end());
  EXPECT_NE(std::find(header.begin(), header.end(), "error.false_light_outside_band"), header.end());
  size_t rows = 0, compared = 0;
  while (std::getline(lines, line)) {
    ASSERT_LT(rows, json.size());
    const nlohmann::json& row = json[rows];
    std::vector<std::string> cells = parseCsvLine(line);
    ASSERT_EQ(cells.size(), header.size());
    for (size_t c = 0; c < header.size(); ++c) {
      const nlohmann::json* value = lookup(row, header[c]);
      if (!value) {
        EXPECT_EQ(cells[c], "") << header[c];
        continue;
      }
      ++compared;
      if (value->is_string()) EXPECT_EQ(cells[c], value->get<std::string>()) << header[c];
      else if (value->is_number()) EXPECT_EQ(std::stod(cells[c]), value->get<double>()) << header[c];
      else EXPECT_EQ(nlohmann::json::parse(cells[c]), *value) << header[c];
    }
    ++rows;
  }
  EXPECT_EQ(rows, 2u);
  EXPECT_GT(compared, 50u);

  // And the files on disk say the same.
  TempDir dir;
  writeResults(dir.file("out"), {a, b});
  EXPECT_EQ(nlohmann::json::parse(readFile(dir.file("out/results.json"))), json);
  EXPECT_EQ(readFile(dir.file("out/results.csv")), csv);
}

}  // namespace
}  // namespace cs
