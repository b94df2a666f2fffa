// The compare report as a browser shows it: a small compare, tools/screenshot_report.sh (headless
// Chromium) and the screenshot decoded and checked for the legend, the plots and the page's margin; the
// report's thumbnails checked against the full-size images, error pixel by error pixel.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>

#include <gtest/gtest.h>
#include <stb_image.h>  // implementation compiled once, in core/tinygltf_impl.cpp
#include <unistd.h>

#include "judge/frame_output.h"
#include "tests/cli_support.h"

namespace fs = std::filesystem;

namespace {

struct Region {
  size_t nonWhite = 0, pixels = 0;
  std::set<uint32_t> colours;
};

Region scan(const unsigned char* rgb, int width, int x0, int y0, int x1, int y1) {
  Region r;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const unsigned char* p = rgb + (size_t(y) * width + x) * 3;
      r.colours.insert(uint32_t(p[0]) << 16 | uint32_t(p[1]) << 8 | p[2]);
      r.nonWhite += p[0] < 245 || p[1] < 245 || p[2] < 245;
      r.pixels++;
    }
  return r;
}

bool hasColour(const unsigned char* rgb, int width, int height, uint32_t colour) {
  for (size_t i = 0; i < size_t(width) * height; ++i) {
    const unsigned char* p = rgb + i * 3;
    if ((uint32_t(p[0]) << 16 | uint32_t(p[1]) << 8 | p[2]) == colour) return true;
  }
  return false;
}

uint32_t packed(const uint8_t c[3]) { return uint32_t(c[0]) << 16 | uint32_t(c[1]) << 8 | c[2]; }

std::string readText(const fs::path& p) {
  std::ifstream f(p);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

// Every false-shadow or false-light pixel of a full-size diff PNG lands in a thumbnail pixel of an error
// colour; returns the error pixels counted in the full-size image.
size_t expectThumbnailKeepsErrors(const fs::path& full, const fs::path& thumb) {
  int w = 0, h = 0, n = 0, tw = 0, th = 0;
  unsigned char* a = stbi_load(full.string().c_str(), &w, &h, &n, 3);
  unsigned char* b = stbi_load(thumb.string().c_str(), &tw, &th, &n, 3);
  size_t errors = 0;
  EXPECT_TRUE(a && b) << full << " " << thumb;
  if (a && b) {
    const int factor = (w + tw - 1) / tw;
    EXPECT_EQ((h + factor - 1) / factor, th);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const uint32_t c = uint32_t(a[(size_t(y) * w + x) * 3]) << 16 | uint32_t(a[(size_t(y) * w + x) * 3 + 1]) << 8 |
                           a[(size_t(y) * w + x) * 3 + 2];
        if (c != packed(cs::kFalseShadowRgb) && c != packed(cs::kFalseLightRgb)) continue;
        ++errors;
        const unsigned char* q = b + (size_t(y / factor) * tw + x / factor) * 3;
        const uint32_t t = uint32_t(q[0]) << 16 | uint32_t(q[1]) << 8 | q[2];
        EXPECT_TRUE(t == packed(cs::kFalseShadowRgb) || t == packed(cs::kFalseLightRgb))
            << thumb.filename() << ": error pixel " << x << "," << y << " lost";
      }
  }
  stbi_image_free(a);
  stbi_image_free(b);
  return errors;
}

TEST(ReportScreenshot, ChromiumShowsVerdictLegendPlotsAndThumbnailsThatKeepEveryErrorPixel) {
  if (std::system("command -v chromium >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "chromium is not installed (tools/setup.sh installs it)";
  fs::path dir = fs::temp_directory_path() / ("coneshadow_shot_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  // 320x200: the images are shrunk 2x for the page, and the 512² cube map misclassifies fur samples.
  cs::test::CliRun r = cs::test::cli("compare --width 320 --height 200 --frames 1 --views fur "
                                     "--methods embree,cone,cubesm --quiet --out " + (dir / "report").string());
  ASSERT_EQ(r.code, 0) << r.out;

  // The page's structure: the verdict before the plots, both plots inline (tooltips), thumbnails linked.
  const std::string html = readText(dir / "report" / "report.html");
  const size_t verdict = html.find("<table class=\"verdict\">"), plot = html.find("<svg");
  ASSERT_NE(verdict, std::string::npos);
  ASSERT_NE(plot, std::string::npos);
  EXPECT_LT(verdict, plot);
  EXPECT_NE(html.find("<polyline", plot), std::string::npos) << "a line per method";
  EXPECT_NE(html.find("fur_cubesm@512_diff_thumb.png"), std::string::npos);

  // Thumbnails keep every error pixel of the full-size diff, counted pixel by pixel.
  size_t errors = 0;
  for (const char* setting : {"cubesm@512", "cubesm@1024", "cubesm@2048", "cone@64M"}) {
    const fs::path full = dir / "report" / ("fur_" + std::string(setting) + "_diff.png");
    const fs::path thumb = dir / "report" / ("fur_" + std::string(setting) + "_diff_thumb.png");
    ASSERT_TRUE(fs::exists(thumb)) << thumb;
    errors += expectThumbnailKeepsErrors(full, thumb);
  }
  EXPECT_GT(errors, 0u) << "the cube maps misclassify some fur samples at 320x200";

  const fs::path script = fs::path(__FILE__).parent_path().parent_path() / "tools" / "screenshot_report.sh";
  const fs::path png = dir / "shot.png";
  const std::string cmd = script.string() + " " + (dir / "report").string() + " " + png.string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  ASSERT_TRUE(fs::exists(png));

  int w = 0, h = 0, n = 0;
  unsigned char* rgb = stbi_load(png.string().c_str(), &w, &h, &n, 3);
  ASSERT_NE(rgb, nullptr) << stbi_failure_reason();
  EXPECT_EQ(w, 1400);
  EXPECT_EQ(h, 2400);
  if (w == 1400 && h == 2400) {
    // The legend's swatches and the plots' legend entries, in their exact colours.
    for (const uint8_t* c : {cs::kFalseShadowRgb, cs::kFalseLightRgb, cs::kBandDisagreeRgb})
      EXPECT_TRUE(hasColour(rgb, w, h, packed(c))) << "legend swatch " << std::hex << packed(c);
    for (uint32_t c : {0x1f77b4u, 0xd62728u, 0x2ca02cu})
      EXPECT_TRUE(hasColour(rgb, w, h, c)) << "plot legend " << std::hex << c;
    // Nothing overflows the 1400 px window: the page keeps a white margin at its right edge.
    Region right = scan(rgb, w, 1388, 0, 1400, h);
    EXPECT_EQ(right.nonWhite, 0u) << "something is drawn past the page's right margin";
    Region page = scan(rgb, w, 0, 0, w, h);
    EXPECT_GE(page.colours.size(), 64u) << "the page looks blank";
  }
  stbi_image_free(rgb);
  fs::remove_all(dir);
}

}  // namespace
