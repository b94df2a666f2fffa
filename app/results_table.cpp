// `coneshadow results-table`: see results_table.h.
#include "app/results_table.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <ostream>
#include <sstream>

#include "app/cli.h"
#include "core/error.h"

namespace cs {

namespace {

std::string fixed(double v, int prec) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << v;
  return os.str();
}

std::string settingOf(const nlohmann::json& row) {
  if (row.contains("stats") && row["stats"].contains("setting")) return row["stats"]["setting"].get<std::string>();
  return row.at("method").get<std::string>();
}

// "12.3 ms / 0 %": the median time and misclassified lit samples outside the band.
std::string cell(const nlohmann::json& row) {
  double ms = row.at("total_ms").get<double>();
  double out = row.at("error").at("misclassified_fraction_outside_band").get<double>() * 100.0;
  return fixed(ms, ms < 10 ? 2 : 1) + " ms / " + (out == 0 ? std::string("0") : fixed(out, 3)) + " %";
}

}  // namespace

std::string resultsTable(const std::vector<nlohmann::json>& runs) {
  std::vector<std::string> settings, devices;
  for (auto& run : runs)
    for (auto& row : run) {
      std::string s = settingOf(row);
      if (std::find(settings.begin(), settings.end(), s) == settings.end()) settings.push_back(s);
      std::string d = row.contains("stats") && row["stats"].contains("gpu") ? row["stats"]["gpu"].get<std::string>()
                                                                           : row.value("device", "");
      if (!d.empty() && std::find(devices.begin(), devices.end(), d) == devices.end()) devices.push_back(d);
    }
  std::string cone;
  for (auto& s : settings)
    if (s.rfind("cone", 0) == 0) {
      cone = s;
      break;
    }
  std::ostringstream os;
  os << "Device: ";
  for (size_t i = 0; i < devices.size(); ++i) os << (i ? "; " : "") << "`" << devices[i] << "`";
  os << " (Embree on the host CPU). Cells: median ms per frame / % of the lit samples misclassified outside the "
        "ambiguity band; ratios: "
     << (cone.empty() ? "cone" : cone) << " time over Embree's and over rmsm@16M's, same run.\n\n"
     << "| scene / view | size |";
  for (auto& s : settings) os << " " << s << " |";
  os << " cone / Embree | cone / rmsm@16M |\n| --- | --- |";
  for (size_t i = 0; i < settings.size() + 2; ++i) os << " ---: |";
  os << "\n";
  for (auto& run : runs) {
    std::vector<std::string> views;
    for (auto& row : run) {
      std::string v = row.at("scene").get<std::string>() + " / " + row.at("view").get<std::string>();
      if (std::find(views.begin(), views.end(), v) == views.end()) views.push_back(v);
    }
    for (auto& v : views) {
      std::vector<const nlohmann::json*> rows(settings.size(), nullptr);
      std::string size;
      for (auto& row : run) {
        if (row.at("scene").get<std::string>() + " / " + row.at("view").get<std::string>() != v) continue;
        size = std::to_string(row.at("width").get<int>()) + "x" + std::to_string(row.at("height").get<int>());
        auto it = std::find(settings.begin(), settings.end(), settingOf(row));
        rows[size_t(it - settings.begin())] = &row;
      }
      auto msOf = [&](const std::string& s) -> double {
        auto it = std::find(settings.begin(), settings.end(), s);
        const nlohmann::json* r = it == settings.end() ? nullptr : rows[size_t(it - settings.begin())];
        return r ? r->at("total_ms").get<double>() : 0.0;
      };
      auto ratio = [&](const std::string& peer) {
        double c = msOf(cone), p = msOf(peer);
        return c > 0 && p > 0 ? fixed(c / p, 2) + "x" : std::string("-");
      };
      os << "| " << v << " | " << size << " |";
      for (auto* r : rows) os << " " << (r ? cell(*r) : "-") << " |";
      os << " " << ratio("embree") << " | " << ratio("rmsm@16M") << " |\n";
    }
  }
  return os.str();
}

int runResultsTable(const std::vector<std::string>& dirs, std::ostream& out) {
  if (dirs.empty()) throw UsageError("results-table needs one or more folders written by coneshadow compare");
  std::vector<nlohmann::json> runs;
  for (auto& d : dirs) {
    const std::string path = (std::filesystem::path(d) / "results.json").string();
    std::ifstream in(path);
    if (!in) throw Error("cannot read the compare results", path, "run coneshadow compare --out " + d + " first");
    try {
      runs.push_back(nlohmann::json::parse(in));
    } catch (const std::exception& e) {
      throw Error(std::string("malformed results: ") + e.what(), path);
    }
    if (!runs.back().is_array()) throw Error("malformed results: not an array of rows", path);
  }
  try {
    out << resultsTable(runs);
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("malformed results: ") + e.what(), dirs.front());
  }
  return kExitOk;
}

}  // namespace cs
