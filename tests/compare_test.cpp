// `coneshadow compare` as a user runs it: every file written, results.csv and results.json carrying the same
// numbers, the cone path exact outside the band, the HTML report pointing only at images that exist.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include "app/compare.h"
#include "app/results_table.h"
#include "app/scaling.h"
#include "app/svg_plot.h"
#include "core/error.h"
#include "method/registry.h"
#include "tests/cli_support.h"

namespace fs = std::filesystem;

namespace {

using cs::test::CliRun;
using cs::test::cli;

std::string readText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// RFC 4180 cells: quoted cells may hold commas and doubled quotes.
void writeText(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

std::vector<std::vector<std::string>> parseCsv(const std::string& text) {
  std::vector<std::vector<std::string>> rows;
  std::vector<std::string> row;
  std::string cell;
  bool quoted = false;
  for (size_t i = 0; i < text.size(); ++i) {
    char c = text[i];
    if (quoted) {
      if (c == '"' && i + 1 < text.size() && text[i + 1] == '"') {
        cell += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        cell += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      row.push_back(cell);
      cell.clear();
    } else if (c == '\n') {
      row.push_back(cell);
      cell.clear();
      rows.push_back(row);
      row.clear();
    } else {
      cell += c;
    }
  }
  if (!cell.empty() || !row.empty()) {
    row.push_back(cell);
    rows.push_back(row);
  }
  return rows;
}

// The JSON row flattened to the CSV's column names, written independently of judge/frame_output.cpp.
void flattenJson(const nlohmann::json& v, const std::string& key, std::map<std::string, nlohmann::json>& out) {
  if (v.is_object()) {
    for (auto it = v.begin(); it != v.end(); ++it) flattenJson(it.value(), key + "." + it.key(), out);
  } else {
    out[key] = v;
  }
}

std::map<std::string, nlohmann::json> flatRow(const nlohmann::json& row) {
  std::map<std::string, nlohmann::json> out;
  for (auto it = row.begin(); it != row.end(); ++it) {
    const std::string& k = it.key();
    if (k == "stages") {
      for (auto& s : it.value()) out["stage." + s.at("name").get<std::string>() + ".ms"] = s.at("ms");
    } else if (k == "error" || k == "stats" || k == "provenance") {
      flattenJson(it.value(), k, out);
    } else {
      out[k] = it.value();
    }
  }
  return out;
}

void expectCellEquals(const std::string& cell, const nlohmann::json& v, const std::string& where) {
  if (v.is_number()) {
    char* end = nullptr;
    double x = std::strtod(cell.c_str(), &end);
    ASSERT_TRUE(!cell.empty() && *end == '\0') << where << ": '" << cell << "' is not a number";
    EXPECT_EQ(x, v.get<double>()) << where;
  } else if (v.is_string()) {
    EXPECT_EQ(cell, v.get<std::string>()) << where;
  } else if (v.is_null()) {
    EXPECT_EQ(cell, "") << where;
  } else {
    EXPECT_EQ(cell, v.dump()) << where;  // booleans, arrays
  }
}

size_t countOf(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

TEST(Compare, TinyBuiltinRunWritesConsistentReports) {
  fs::path out = fs::temp_directory_path() / ("coneshadow_compare_" + std::to_string(::getpid()));
  fs::remove_all(out);
  CliRun r = cli("compare --width 48 --height 32 --views wall,room --frames 1 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("[view 2/2] room:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("frame 1/1"), std::string::npos) << r.out;
  // Progress with the estimated time left, from the second step on.
  EXPECT_NE(r.out.find(" left)"), std::string::npos) << r.out;
  // 2 views x (the reference's own step + every registered method's sweep at its defaults, the
  // reference's row included).
  cs::registerBuiltinMethods();
  size_t settings = 0;
  for (const cs::MethodInfo& m : cs::registeredMethods())
    settings += cs::sweepOf(m, cs::Settings(m.name)).size();
  const std::string steps = " of " + std::to_string(2 * (1 + settings)) + ", about ";
  EXPECT_NE(r.out.find(steps), std::string::npos) << steps << "\n" << r.out;

  for (const char* f : {"results.json", "results.csv", "report.md", "report.html", "speed_vs_error.svg",
                        "speed_vs_error.png", "wall_closeups.png", "room_closeups.png"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  for (auto& e : fs::directory_iterator(out))
    EXPECT_EQ(e.path().filename().string().rfind(".staging", 0), std::string::npos) << "staging left behind";

  nlohmann::json results = nlohmann::json::parse(readText(out / "results.json"));
  ASSERT_TRUE(results.is_array());
  ASSERT_FALSE(results.empty());
  size_t coneRows = 0;
  std::map<std::string, int> views;
  for (auto& row : results) {
    std::string view = row.at("view"), setting = row.at("stats").at("setting");
    views[view]++;
    for (const char* kind : {"shaded", "mask", "diff"})
      EXPECT_TRUE(fs::exists(out / (view + "_" + setting + "_" + kind + ".png"))) << view << " " << setting << " " << kind;
    EXPECT_EQ(row.at("width"), 48);
    EXPECT_FALSE(row.at("device").get<std::string>().empty());
    if (row.at("method") == "cone") {
      ++coneRows;
      EXPECT_EQ(row.at("error").at("misclassified_outside_band"), 0) << setting << " on " << view;
    }
  }
  EXPECT_EQ(views.size(), 2u);
  EXPECT_EQ(views["wall"], views["room"]);

  // Each method's sweep marks one row a view as its default setting; the host-cost table reads those.
  std::map<std::string, int> defaults, rowsOf;
  for (auto& row : results) {
    rowsOf[row.at("method").get<std::string>()]++;
    if (row.at("stats").value("defaults", false)) defaults[row.at("method").get<std::string>()]++;
  }
  for (auto& [method, n] : rowsOf) EXPECT_EQ(defaults[method], 2) << method << ": one default row a view";
  CliRun h = cli("results-table --host-cost " + out.string());
  ASSERT_EQ(h.code, 0) << h.out;
  EXPECT_NE(h.out.find("| scene / view | size | cone@64M / embree | cone@64M / "), std::string::npos) << h.out;
  EXPECT_NE(h.out.find("| builtin / room | 48x32 | "), std::string::npos) << h.out;
  EXPECT_EQ(h.out.find(" ms"), std::string::npos) << "times are the settings table's:\n" << h.out;
  if (coneRows == 0) GTEST_LOG_(INFO) << "built without the cone path: no cone rows to check";
  else EXPECT_EQ(coneRows, 6u) << "cone at three traversal budgets on two views";

  // results.csv: the same rows, field by field, with the same numbers.
  auto csv = parseCsv(readText(out / "results.csv"));
  ASSERT_EQ(csv.size(), results.size() + 1);
  const auto& header = csv[0];
  for (size_t i = 0; i < results.size(); ++i) {
    auto flat = flatRow(results[i]);
    const auto& cells = csv[i + 1];
    ASSERT_EQ(cells.size(), header.size()) << "row " << i;
    size_t filled = 0;
    for (size_t c = 0; c < header.size(); ++c) {
      auto it = flat.find(header[c]);
      if (it == flat.end()) {
        EXPECT_EQ(cells[c], "") << "row " << i << " has " << header[c] << " only in the CSV";
        continue;
      }
      ++filled;
      expectCellEquals(cells[c], it->second, "row " + std::to_string(i) + " " + header[c]);
    }
    EXPECT_EQ(filled, flat.size()) << "row " << i << ": a JSON field is missing from the CSV";
  }

  // The plots: one panel per view, one marker per row (memory: per row with bytes), exact on the floor.
  std::string svg = readText(out / "speed_vs_error.svg");
  EXPECT_NE(svg.find("<svg"), std::string::npos);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_EQ(countOf(svg, "<circle"), results.size());
  EXPECT_EQ(countOf(svg, "<circle"), countOf(svg, "</circle>"));
  EXPECT_NE(svg.find(">0 (exact)</text>"), std::string::npos) << "the floor is labelled 0";
  EXPECT_NE(svg.find(">wall</text>"), std::string::npos) << "a panel per view";
  EXPECT_NE(svg.find(">room</text>"), std::string::npos) << "a panel per view";
  EXPECT_GE(countOf(svg, "<polyline"), 2u) << "a line per method through its settings";
  size_t withBytes = 0;
  for (auto& row : results) withBytes += row.at("bytes").get<uint64_t>() > 0;
  std::string bytesSvg = readText(out / "error_vs_bytes.svg");
  EXPECT_EQ(countOf(bytesSvg, "<circle"), withBytes);
  EXPECT_TRUE(fs::exists(out / "error_vs_bytes.png"));

  // report.md: the verdict first, then a table and a stage table per view.
  std::string md = readText(out / "report.md");
  EXPECT_NE(md.find("device: "), std::string::npos);
  ASSERT_NE(md.find("## Verdict"), std::string::npos);
  EXPECT_LT(md.find("## Verdict"), md.find("## wall"));
  EXPECT_NE(md.find("| wall | "), std::string::npos) << "a verdict row per view";
  EXPECT_NE(md.find("| room | "), std::string::npos) << "a verdict row per view";
  EXPECT_NE(md.find("red: false shadow"), std::string::npos) << "the legend";
  EXPECT_NE(md.find("## wall"), std::string::npos);
  EXPECT_NE(md.find("## room"), std::string::npos);
  for (const char* column : {"| ms per stage (execution order) |", "| false shadow / false light outside band (all) |", "| work |"})
    EXPECT_EQ(countOf(md, column), 2u) << column << ": once per view";
  for (auto& row : results) {
    const std::string setting = row.at("stats").at("setting");
    const size_t view = md.find("## " + row.at("view").get<std::string>());
    const size_t at = md.find("| " + setting + " |", view);
    ASSERT_NE(at, std::string::npos) << setting;
    const std::string line = md.substr(at, md.find('\n', at) - at);
    if (!row.at("stages").empty()) {
      const size_t stagesAt = md.find("| " + setting + " |", md.find("| ms per stage", view));
      ASSERT_NE(stagesAt, std::string::npos) << setting;
      const std::string stages = md.substr(stagesAt, md.find('\n', stagesAt) - stagesAt);
      EXPECT_NE(stages.find(row.at("stages")[0].at("name").get<std::string>() + " "), std::string::npos) << stages;
    }
    if (row.at("method") == "cone") {
      EXPECT_NE(line.find(std::to_string(row.at("stats").at("pairs_tested").get<uint64_t>()) + " nodes visited"),
                std::string::npos) << line;
    }
    if (row.at("method") == "rmsm") {
      EXPECT_NE(line.find(std::to_string(row.at("stats").at("pages_rendered").get<uint64_t>()) + " pages"),
                std::string::npos) << line;
    }
  }
  for (const char* setting : {"rmsm@4M", "rmsm@16M,max4096", "rmsm@16M,analysis8x"}) {
    EXPECT_NE(md.find("| " + std::string(setting) + " |"), std::string::npos) << setting;
  }
  // report.html: the plots inline (their tooltips work), every image it shows exists and links to itself
  // at full size.
  std::string html = readText(out / "report.html");
  EXPECT_EQ(countOf(html, "<svg"), 2u);
  EXPECT_NE(html.find("<title>wall "), std::string::npos) << "the markers' tooltips";
  EXPECT_NE(html.find("class=\"verdict\""), std::string::npos);
  std::regex img("<a href=\"([^\"]+)\"><img[^>]*src=\"([^\"]+)\"");
  size_t images = 0;
  for (auto it = std::sregex_iterator(html.begin(), html.end(), img); it != std::sregex_iterator(); ++it) {
    ++images;
    std::string href = (*it)[1], src = (*it)[2];
    EXPECT_EQ(src.find('/'), std::string::npos) << src;
    EXPECT_TRUE(fs::exists(out / src)) << src;
    EXPECT_TRUE(fs::exists(out / href)) << href;
    EXPECT_EQ(src, href) << "at 48x32 no thumbnails: the image itself, enlarged";
  }
  EXPECT_EQ(images, results.size() * 3 + 2) << "per setting 3, one close-up strip per view";
  EXPECT_NE(html.find("width=\"240\" height=\"160\""), std::string::npos) << "48x32 enlarged 5x";
  EXPECT_NE(md.find("](speed_vs_error.png)"), std::string::npos);
  EXPECT_NE(md.find("](error_vs_bytes.png)"), std::string::npos);
  EXPECT_NE(md.find("](wall_closeups.png)"), std::string::npos);
  EXPECT_NE(md.find("left to right: embree, "), std::string::npos) << "the strip's order is documented";
  fs::remove_all(out);
}

cs::GBuffer litPlane(uint32_t w, uint32_t h) {
  cs::GBuffer gb;
  gb.width = w;
  gb.height = h;
  gb.position.assign(gb.size(), glm::vec4(0, 0, 0, 1));
  gb.normal.assign(gb.size(), glm::vec4(0, 0, 1, 1));
  return gb;
}

TEST(Compare, CloseupWindowHoldsTheShadowBoundary) {
  // 64x40, every sample lit; the reference is dark in a 6x6 square at (45, 25): the only boundary.
  cs::GBuffer gb = litPlane(64, 40);
  std::vector<float> ref(gb.size(), 1.0f);
  for (uint32_t y = 25; y < 31; ++y)
    for (uint32_t x = 45; x < 51; ++x) ref[y * 64 + x] = 0.0f;
  cs::CropWindow c = cs::boundaryWindow(gb, ref);
  EXPECT_EQ(c.width, 16u);
  EXPECT_EQ(c.height, 10u);
  EXPECT_LE(c.x + c.width, 64u);
  EXPECT_LE(c.y + c.height, 40u);
  // Both the left and the right edge of the square lie inside the window.
  EXPECT_LE(c.x, 44u);
  EXPECT_GE(c.x + c.width, 51u);
  EXPECT_LE(c.y, 25u);
  // No boundary at all: the centre window.
  std::vector<float> lit(gb.size(), 1.0f);
  cs::CropWindow centre = cs::boundaryWindow(gb, lit);
  EXPECT_EQ(centre.x, 24u);
  EXPECT_EQ(centre.y, 15u);
}

TEST(Compare, CloseupStripIsNearestNeighbourSideBySide) {
  // Two 4x2 images; crop 2x1 at (1, 1), scale 3, gap 2: each source pixel a 3x3 block.
  auto image = [](uint8_t base) {
    std::vector<uint8_t> rgb(4 * 2 * 3);
    for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = uint8_t(base + i);
    return rgb;
  };
  std::vector<std::vector<uint8_t>> images = {image(0), image(100)};
  uint32_t w = 0, h = 0;
  auto strip = cs::closeupStrip(images, 4, {1, 1, 2, 1}, 3, 2, w, h);
  ASSERT_EQ(w, 2u * 6 + 2);
  ASSERT_EQ(h, 3u);
  ASSERT_EQ(strip.size(), size_t(w) * h * 3);
  auto px = [&](uint32_t x, uint32_t y) { return strip[(size_t(y) * w + x) * 3]; };
  for (uint32_t y = 0; y < 3; ++y) {
    EXPECT_EQ(px(0, y), images[0][(1 * 4 + 1) * 3]);
    EXPECT_EQ(px(2, y), images[0][(1 * 4 + 1) * 3]);
    EXPECT_EQ(px(3, y), images[0][(1 * 4 + 2) * 3]);
    EXPECT_EQ(px(6, y), 0) << "gap";
    EXPECT_EQ(px(8, y), images[1][(1 * 4 + 1) * 3]);
    EXPECT_EQ(px(13, y), images[1][(1 * 4 + 2) * 3]);
  }
}

TEST(Compare, PlotToPngFailureIsAnErrorAndLeavesNoFile) {
  fs::path dir = fs::temp_directory_path() / ("coneshadow_svg_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  writeText(dir / "bad.svg", "this is not an svg");
  try {
    cs::svgToPng((dir / "bad.svg").string(), (dir / "bad.png").string());
    ADD_FAILURE() << "no error for a broken SVG";
  } catch (const cs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("librsvg"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.png"), std::string::npos) << e.what();
  }
  for (auto& e : fs::directory_iterator(dir)) EXPECT_EQ(e.path().filename(), "bad.svg") << "left behind";
  writeText(dir / "ok.svg", cs::logPlotSvg({cs::LogPanel{"x", "y", {{"s", {{1, 2, ""}, {10, 20, ""}}, true}}}}));
  cs::svgToPng((dir / "ok.svg").string(), (dir / "ok.png").string());
  EXPECT_GT(fs::file_size(dir / "ok.png"), 100u);
  fs::remove_all(dir);
}

TEST(Scaling, CopiesGrowByFourUpToTheTriangleBound) {
  EXPECT_EQ(cs::scalingCopies(100, 50), (std::vector<uint32_t>{1}));
  EXPECT_EQ(cs::scalingCopies(100, 1600), (std::vector<uint32_t>{1, 4, 16}));
  EXPECT_EQ(cs::scalingCopies(7540, 10'000'000), (std::vector<uint32_t>{1, 4, 16, 64, 256, 1024}));
}

TEST(Scaling, InstancedCopiesAreTranslatedBeyondTheBounds) {
  cs::Scene s;
  s.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 1}};
  s.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
  s.indices = {0, 1, 2};
  s.computeBounds();
  cs::Scene big = cs::instancedScene(s, 4);
  ASSERT_EQ(big.triangleCount(), 4u);
  ASSERT_EQ(big.positions.size(), 12u);
  EXPECT_EQ(big.positions[0], s.positions[0]) << "copy 0 stays in place";
  for (uint32_t c = 1; c < 4; ++c) {
    glm::vec3 d = big.positions[3 * c] - s.positions[0];
    EXPECT_EQ(d.y, 0.0f);
    EXPECT_TRUE(d.x >= 1.0f || d.z >= 1.0f) << "copy " << c << " overlaps the original";
    for (int k = 0; k < 3; ++k) EXPECT_EQ(big.indices[3 * c + k], 3 * c + s.indices[k]);
  }
}

TEST(Scaling, TinySweepWritesFilesWithCsvMatchingJson) {
  fs::path out = fs::temp_directory_path() / ("coneshadow_scaling_" + std::to_string(::getpid()));
  fs::remove_all(out);
  // Built-in scene (7,540 triangles): 1 and 4 copies under a 40,000-triangle bound.
  CliRun r = cli("compare --scaling --width 24 --height 24 --scaling-sizes=16,24 --scaling-max-triangles 40000 "
                 "--frames 1 --quiet --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* f : {"scaling.md", "scaling.json", "scaling.csv", "scaling_resolution.svg", "scaling_resolution.png",
                        "scaling_triangles.svg", "scaling_triangles.png"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  nlohmann::json doc = nlohmann::json::parse(readText(out / "scaling.json"));
  EXPECT_EQ(doc["provenance"]["schema_version"], 2);
  EXPECT_NE(doc["provenance"]["command_line"].get<std::string>().find("--scaling"), std::string::npos);
  const nlohmann::json& rows = doc.at("rows");
  EXPECT_FALSE(doc.at("device").get<std::string>().empty());
  std::map<std::string, int> perSweep;
  for (auto& row : rows) perSweep[row.at("sweep")]++;
  size_t methods = rows.size() / 4;
  ASSERT_GT(methods, 0u);
  EXPECT_EQ(perSweep["resolution"], int(2 * methods));
  EXPECT_EQ(perSweep["triangles"], int(2 * methods));
  for (auto& row : rows) {
    EXPECT_EQ(row.at("status"), "ok") << row.dump();
    if (row.at("sweep") == "triangles" && row.at("copies") == 4) {
      EXPECT_EQ(row.at("triangles"), 4 * 7540);
    }
    if (row.at("method") == "cone" || row.at("method") == "embree") {
      EXPECT_EQ(row.at("misclassified_outside_band"), 0) << row.dump();
    }
  }
  auto csv = parseCsv(readText(out / "scaling.csv"));
  ASSERT_EQ(csv.size(), rows.size() + 1);
  const auto& header = csv[0];
  for (size_t i = 0; i < rows.size(); ++i) {
    ASSERT_EQ(csv[i + 1].size(), header.size()) << "row " << i;
    ASSERT_EQ(rows[i].size(), header.size()) << "row " << i;
    for (size_t c = 0; c < header.size(); ++c) {
      ASSERT_TRUE(rows[i].contains(header[c])) << header[c];
      expectCellEquals(csv[i + 1][c], rows[i].at(header[c]), "row " + std::to_string(i) + " " + header[c]);
    }
  }
  std::string md = readText(out / "scaling.md");
  EXPECT_NE(md.find("](scaling_triangles.png)"), std::string::npos);
  EXPECT_NE(md.find("| 4 / 30160 |"), std::string::npos) << md;
  fs::remove_all(out);
}

TEST(LightDistances, SweepWritesErrorAndTimeAgainstDistanceForEveryMethod) {
  fs::path out = fs::temp_directory_path() / ("coneshadow_lightdist_" + std::to_string(::getpid()));
  fs::remove_all(out);
  const std::string model = std::string(CONESHADOW_ASSIMP_MODELS) + "/ClearCoat-glTF/ClearCoatTest.gltf";
  CliRun r = cli("compare " + model + " --light-distances 1,1000,100000 --width 32 --height 32 --frames 1 --quiet --out " +
                 out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* f : {"light_distances.md", "light_distances.json", "light_distances.csv", "light_distances.svg",
                        "light_distances.png"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  EXPECT_FALSE(fs::exists(out / "scaling.json"));
  nlohmann::json doc = nlohmann::json::parse(readText(out / "light_distances.json"));
  EXPECT_EQ(doc["provenance"]["scene_path"], model);
  const nlohmann::json& rows = doc.at("rows");
  ASSERT_EQ(rows.size() % 3, 0u);
  const size_t methods = rows.size() / 3;
  ASSERT_GE(methods, 4u);
  std::map<double, int> perDistance;
  const float diag = doc.at("scene_diagonal").get<float>();
  const glm::vec3 centre(doc["scene_centre"][0].get<float>(), doc["scene_centre"][1].get<float>(),
                         doc["scene_centre"][2].get<float>());
  for (auto& row : rows) {
    EXPECT_EQ(row.at("sweep"), "light_distance");
    EXPECT_EQ(row.at("status"), "ok") << row.dump();
    const double k = row.at("light_distance_diagonals").get<double>();
    perDistance[k]++;
    const glm::vec3 light(row["light_x"].get<float>(), row["light_y"].get<float>(), row["light_z"].get<float>());
    EXPECT_NEAR(glm::length(light - centre) / diag, k, 1e-3 * k) << row.dump();
    if (row.at("method") == "cone" || row.at("method") == "embree") {
      EXPECT_EQ(row.at("misclassified_outside_band"), 0) << row.dump();
      EXPECT_GT(row.at("lit_samples").get<uint64_t>(), 100u) << row.dump();
    }
    if (row.at("method") == "cone") {
      EXPECT_GT(row.at("pairs_tested").get<uint64_t>(), 0u);
    }
  }
  EXPECT_EQ(perDistance.size(), 3u);
  auto csv = parseCsv(readText(out / "light_distances.csv"));
  ASSERT_EQ(csv.size(), rows.size() + 1);
  for (size_t i = 0; i < rows.size(); ++i)
    for (size_t c = 0; c < csv[0].size(); ++c)
      expectCellEquals(csv[i + 1][c], rows[i].at(csv[0][c]), "row " + std::to_string(i) + " " + csv[0][c]);
  const std::string md = readText(out / "light_distances.md");
  EXPECT_NE(md.find("| light distance (diagonals) | method |"), std::string::npos) << md;
  EXPECT_NE(md.find("| 100000 | cone |"), std::string::npos) << md;
  fs::remove_all(out);

  for (const char* args : {"compare --light-distances 0", "compare --light-distances 1,x", "render --light-distances 1",
                           "compare --scaling --light-distances 1", "compare --light-distances 1e16"}) {
    CliRun bad = cli(args);
    EXPECT_EQ(bad.code, 2) << args << "\n" << bad.out;
  }
}

nlohmann::json resultRow(const std::string& view, const std::string& method, const std::string& setting, double ms,
                         double outsideBand) {
  return {{"scene", "s"},
          {"view", view},
          {"method", method},
          {"width", 64},
          {"height", 32},
          {"device", "gpu0"},
          {"total_ms", ms},
          {"stats", {{"setting", setting}, {"gpu", "gpu0"}}},
          {"error", {{"misclassified_fraction_outside_band", outsideBand}}}};
}

TEST(ResultsTable, EverySettingHasItsColumnAndTheHostCostTableItsRatiosFromTheSameRun) {
  cs::registerBuiltinMethods();  // the reference's name
  nlohmann::json run = nlohmann::json::array();
  run.push_back(resultRow("a", "embree", "embree", 10, 0));
  run.push_back(resultRow("a", "cone", "cone@64M", 30, 0));
  run.push_back(resultRow("a", "cone", "cone@65.5K", 45, 0));
  run.push_back(resultRow("a", "rmsm", "rmsm@16M", 60, 0.0125));
  run.push_back(resultRow("a", "cubesm", "cubesm@2048", 15, 0.001));
  run.push_back(resultRow("b", "embree", "embree", 20, 0));
  run.push_back(resultRow("b", "cone", "cone@64M", 10, 0));
  run[1]["stats"].update({{"submits_per_frame", 1}, {"host_syncs_per_frame", 1}, {"readback_bytes_per_frame", 4096},
                          {"allocations_per_frame", 0}, {"dispatches_per_frame", 250}, {"defaults", true}});
  run[2]["stats"]["defaults"] = false;
  std::string t = cs::resultsTable({run});
  EXPECT_NE(t.find("Device: `gpu0`"), std::string::npos) << t;
  EXPECT_NE(t.find("| scene / view | size | embree | cone@64M | cone@65.5K | rmsm@16M | cubesm@2048 |\n"),
            std::string::npos) << t;
  EXPECT_NE(t.find("| s / a | 64x32 | 10.0 ms / 0 % | 30.0 ms / 0 % | 45.0 ms / 0 % | 60.0 ms / 1.250 % | 15.0 ms / 0.100 % |"),
            std::string::npos) << t;
  EXPECT_NE(t.find("| s / b | 64x32 | 20.0 ms / 0 % | 10.0 ms / 0 % | - | - | - |"), std::string::npos) << t;
  EXPECT_EQ(t.find("x |"), std::string::npos) << "no ratios in the settings table: they are the host-cost table's";
  std::string h = cs::hostCostTable({run});
  // cone@64M is cone's default (marked), cubesm's only setting is its default; rmsm has none marked: its first.
  EXPECT_NE(h.find("| scene / view | size | cone@64M / embree | cone@64M / rmsm@16M | cone@64M / cubesm@2048 | cone@64M | "
                   "rmsm@16M | cubesm@2048 |"),
            std::string::npos) << h;
  EXPECT_NE(h.find("| s / a | 64x32 | 3.00x | 0.50x | 2.00x | 1 / 1 / 4 / 0 / 250 | - | - |"), std::string::npos) << h;
  EXPECT_NE(h.find("| s / b | 64x32 | 0.50x | - | - | - | - | - |"), std::string::npos) << h;
  EXPECT_EQ(h.find(" ms"), std::string::npos) << "no times in the host-cost table: they are the settings table's";
}

// On a device without a feature a method needs (CONESHADOW_HIDE_FEATURES behaves as one), compare skips
// the sweep points it cannot run and says why in the log and the report; a method named on the command
// line with no point left is an error before any output; render names the feature.
TEST(Compare, SkipsWhatTheDeviceCannotRunAndSaysWhy) {
  const std::string hide = "CONESHADOW_HIDE_FEATURES=geometryShader ";
  fs::path out = fs::temp_directory_path() / ("coneshadow_compare_skip_" + std::to_string(::getpid()));
  fs::remove_all(out);
  CliRun r = cli("compare --methods asm --views wall --width 32 --height 24 --frames 1 --out " + out.string(), hide);
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string why = "asm@32M,id: --asm-id-test on needs the geometryShader feature, which this device lacks";
  EXPECT_NE(r.out.find("skipping " + why.substr(0, why.find(':'))), std::string::npos) << r.out;
  std::ifstream md(out / "report.md");
  const std::string report((std::istreambuf_iterator<char>(md)), {});
  EXPECT_NE(report.find("Not run on this device:\n\n- " + why), std::string::npos) << report;
  std::ifstream rf(out / "results.json");
  const nlohmann::json rows = nlohmann::json::parse(rf);
  size_t asmRows = 0;
  for (const auto& row : rows) {
    ASSERT_TRUE(row.contains("stats") && row["stats"].contains("setting")) << row.dump();
    EXPECT_NE(row["stats"]["setting"], "asm@32M,id");
    asmRows += row.value("method", "") == "asm";
  }
  EXPECT_GT(asmRows, 0u) << "the other asm points ran";
  fs::remove_all(out);

  CliRun rtw = cli("compare --methods rtw --views wall --width 32 --height 24 --frames 1 --out " + out.string(), hide);
  EXPECT_EQ(rtw.code, 1) << rtw.out;
  EXPECT_NE(rtw.out.find("no setting of rtw runs on this device"), std::string::npos) << rtw.out;
  EXPECT_NE(rtw.out.find("geometryShader"), std::string::npos) << rtw.out;
  EXPECT_FALSE(fs::exists(out));
  CliRun render = cli("render --methods rtw --view wall --width 32 --height 24 --out " + out.string(), hide);
  EXPECT_EQ(render.code, 1) << render.out;
  EXPECT_NE(render.out.find("geometryShader"), std::string::npos) << render.out;
  EXPECT_FALSE(fs::exists(out));
  // --animate and --scaling leave such a method out the same way.
  for (const std::string args : {"compare --animate 2 --views wall --width 24 --height 24",
                                 "compare --scaling --width 16 --height 16 --scaling-sizes=16 --scaling-max-triangles 40000"}) {
    CliRun run = cli(args + " --out " + out.string(), hide);
    EXPECT_EQ(run.code, 0) << args << "\n" << run.out;
    EXPECT_NE(run.out.find("skipping rtw: needs the geometryShader feature"), std::string::npos) << args << "\n" << run.out;
    fs::remove_all(out);
  }
  CliRun bad = cli("render --width 16 --height 16 --out " + out.string(), "CONESHADOW_HIDE_FEATURES=warp-drive ");
  EXPECT_EQ(bad.code, 1) << bad.out;
  EXPECT_NE(bad.out.find("CONESHADOW_HIDE_FEATURES names 'warp-drive'"), std::string::npos) << bad.out;
  fs::remove_all(out);
}

TEST(Compare, UnknownMethodIsAUsageErrorNamingIt) {
  fs::path out = fs::temp_directory_path() / ("coneshadow_compare_bad_" + std::to_string(::getpid()));
  fs::remove_all(out);
  CliRun r = cli("compare --methods embree,no-such-method --frames 1 --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("no-such-method"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out));
  CliRun v = cli("compare --views wall,nowhere --width 32 --height 24 --frames 1 --out " + out.string());
  EXPECT_EQ(v.code, 2) << v.out;
  EXPECT_NE(v.out.find("nowhere"), std::string::npos) << v.out;
}

}  // namespace
