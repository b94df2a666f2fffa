// The compare report as a browser shows it: a tiny compare, tools/screenshot_report.sh (headless
// Chromium), and the screenshot decoded and checked for the plot and the images where the page puts them.
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>

#include <gtest/gtest.h>
#include <stb_image.h>  // implementation compiled once, in core/tinygltf_impl.cpp
#include <unistd.h>

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

TEST(ReportScreenshot, ChromiumShowsThePlotAndTheImages) {
  if (std::system("command -v chromium >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "chromium is not installed (tools/setup.sh installs it)";
  fs::path dir = fs::temp_directory_path() / ("coneshadow_shot_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  cs::test::CliRun r = cs::test::cli("compare --width 48 --height 48 --frames 1 --views wall "
                                     "--methods embree,cone,cubesm --quiet --out " + (dir / "report").string());
  ASSERT_EQ(r.code, 0) << r.out;

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
    // The page: title and device lines, the plot (720 px wide, about 455 px tall) from y ~ 150, then the
    // view's table with three 160 px images per row from y ~ 650, then the close-up strip.
    Region plot = scan(rgb, w, 0, 150, 720, 600);
    EXPECT_GT(plot.nonWhite, plot.pixels / 50) << "plot area nearly white";
    EXPECT_GE(plot.colours.size(), 8u) << "plot area has too few colours";
    Region table = scan(rgb, w, 0, 650, w, 1700);
    EXPECT_GT(table.nonWhite, table.pixels / 10) << "image area nearly white";
    EXPECT_GE(table.colours.size(), 32u) << "image area has too few colours";
    Region below = scan(rgb, w, 0, 2200, w, 2400);
    EXPECT_LT(below.nonWhite, below.pixels / 2) << "the page should end before the window does";
  }
  stbi_image_free(rgb);
  fs::remove_all(dir);
}

}  // namespace
