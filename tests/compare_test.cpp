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

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

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

// The JSON row flattened to the CSV's column names, written independently of eval/frame_output.cpp.
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
    } else if (k == "error" || k == "stats") {
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

  for (const char* f : {"results.json", "results.csv", "report.md", "report.html", "speed_vs_error.svg"})
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
  if (coneRows == 0) GTEST_LOG_(INFO) << "built without the cone path: no cone rows to check";
  else EXPECT_EQ(coneRows, 4u) << "cone at two traversal budgets on two views";

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

  // The plot: an SVG with one marker per row.
  std::string svg = readText(out / "speed_vs_error.svg");
  EXPECT_NE(svg.find("<svg"), std::string::npos);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_EQ(countOf(svg, "<circle"), results.size());
  EXPECT_EQ(countOf(svg, "<circle"), countOf(svg, "</circle>"));
  EXPECT_NE(svg.find(">0</text>"), std::string::npos) << "the floor is labelled 0";

  // report.md: a table per view; report.html: every image it shows exists.
  std::string md = readText(out / "report.md");
  EXPECT_NE(md.find("device: "), std::string::npos);
  EXPECT_NE(md.find("## wall"), std::string::npos);
  EXPECT_NE(md.find("## room"), std::string::npos);
  std::string html = readText(out / "report.html");
  std::regex img("<img[^>]*src=\"([^\"]+)\"");
  size_t images = 0;
  for (auto it = std::sregex_iterator(html.begin(), html.end(), img); it != std::sregex_iterator(); ++it) {
    ++images;
    std::string src = (*it)[1];
    EXPECT_EQ(src.find('/'), std::string::npos) << src;
    EXPECT_TRUE(fs::exists(out / src)) << src;
  }
  EXPECT_EQ(images, results.size() * 3 + 1);
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
