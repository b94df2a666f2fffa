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
#include "method/registry.h"

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
  const nlohmann::json& error = row.at("error");
  if (error.value("undecided", false))  // older results lack the key: decided as they were read then
    return fixed(ms, ms < 10 ? 2 : 1) + " ms / undecided (band " +
           fixed(error.at("band_fraction").get<double>() * 100.0, 1) + " %)";
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
  std::ostringstream os;
  os << "Device: ";
  for (size_t i = 0; i < devices.size(); ++i) os << (i ? "; " : "") << "`" << devices[i] << "`";
  os << " (Embree on the host CPU). Cells: median ms per frame / % of the lit samples misclassified outside the "
        "ambiguity band, or \"undecided\" where the band covers over 1 % of them.\n\n"
     << "| scene / view | size |";
  for (auto& s : settings) os << " " << s << " |";
  os << "\n| --- | --- |";
  for (size_t i = 0; i < settings.size(); ++i) os << " ---: |";
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
      os << "| " << v << " | " << size << " |";
      for (auto* r : rows) os << " " << (r ? cell(*r) : "-") << " |";
      os << "\n";
    }
  }
  return os.str();
}

std::string hostCostTable(const std::vector<nlohmann::json>& runs) {
  // Each method's default setting (the row its sweep marks "defaults", else its first), methods in
  // first-seen order; the reference's row is its only one. The first other method is the subject of
  // the ratios (the registry lists the cone path first).
  const std::string reference = referenceMethod().name;
  std::vector<std::string> methods, defaults;
  for (auto& run : runs)
    for (auto& row : run) {
      const std::string m = row.at("method").get<std::string>();
      const bool marked = row.contains("stats") && row["stats"].value("defaults", false);
      auto it = std::find(methods.begin(), methods.end(), m);
      if (it == methods.end()) {
        methods.push_back(m);
        defaults.push_back(settingOf(row));
      } else if (marked) {
        defaults[size_t(it - methods.begin())] = settingOf(row);
      }
    }
  size_t subject = methods.size();
  for (size_t k = 0; k < methods.size() && subject == methods.size(); ++k)
    if (methods[k] != reference) subject = k;
  std::vector<size_t> peers;  // the reference first, then the others
  for (size_t k = 0; k < methods.size(); ++k)
    if (methods[k] == reference) peers.insert(peers.begin(), k);
    else if (k != subject) peers.push_back(k);
  std::ostringstream os;
  os << "| scene / view | size |";
  if (subject < methods.size())
    for (size_t p : peers) os << " " << defaults[subject] << " / " << defaults[p] << " |";
  for (size_t k = 0; k < methods.size(); ++k)
    if (methods[k] != reference) os << " " << defaults[k] << " |";
  os << "\n| --- | --- |";
  const size_t columns = (subject < methods.size() ? peers.size() : 0) + methods.size() -
                         size_t(std::count(methods.begin(), methods.end(), reference));
  for (size_t k = 0; k < columns; ++k) os << " ---: |";
  os << "\n";
  auto viewOf = [](const nlohmann::json& row) {
    return row.at("scene").get<std::string>() + " / " + row.at("view").get<std::string>();
  };
  auto sizeOf = [](const nlohmann::json& row) {
    return std::to_string(row.at("width").get<int>()) + "x" + std::to_string(row.at("height").get<int>());
  };
  for (auto& run : runs) {
    std::vector<std::pair<std::string, std::string>> keys;  // (view, size) in first-seen order
    for (auto& row : run) {
      std::pair<std::string, std::string> k{viewOf(row), sizeOf(row)};
      if (std::find(keys.begin(), keys.end(), k) == keys.end()) keys.push_back(k);
    }
    for (auto& [view, size] : keys) {
      auto find = [&](size_t method) -> const nlohmann::json* {
        for (auto& row : run)
          if (viewOf(row) == view && sizeOf(row) == size && row.at("method").get<std::string>() == methods[method] &&
              settingOf(row) == defaults[method])
            return &row;
        return nullptr;
      };
      os << "| " << view << " | " << size << " |";
      if (subject < methods.size())
        for (size_t p : peers) {
          const nlohmann::json *c = find(subject), *q = find(p);
          const bool ok = c && q && q->at("total_ms").get<double>() > 0;
          os << " " << (ok ? fixed(c->at("total_ms").get<double>() / q->at("total_ms").get<double>(), 2) + "x" : "-")
             << " |";
        }
      for (size_t k = 0; k < methods.size(); ++k) {
        if (methods[k] == reference) continue;
        const nlohmann::json* r = find(k);
        const nlohmann::json* st = r && r->contains("stats") ? &r->at("stats") : nullptr;
        if (!st || !st->contains("submits_per_frame")) {
          os << " - |";
          continue;
        }
        auto u = [&](const char* key) { return std::to_string(st->at(key).get<uint64_t>()); };
        os << " " << u("submits_per_frame") << " / " << u("host_syncs_per_frame") << " / "
           << fixed(double(st->at("readback_bytes_per_frame").get<uint64_t>()) / 1024.0, 0) << " / "
           << u("allocations_per_frame") << " / " << u("dispatches_per_frame") << " |";
      }
      os << "\n";
    }
  }
  return os.str();
}

std::vector<nlohmann::json> readResults(const std::vector<std::string>& dirs) {
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
  return runs;
}

int runResultsTable(const std::vector<std::string>& dirs, std::ostream& out, bool hostCost) {
  if (dirs.empty()) throw UsageError("results-table needs one or more folders written by coneshadow compare");
  const std::vector<nlohmann::json> runs = readResults(dirs);
  try {
    out << (hostCost ? hostCostTable(runs) : resultsTable(runs));
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("malformed results: ") + e.what(), dirs.front());
  }
  return kExitOk;
}

}  // namespace cs
