// Method settings: see settings.h.
#include "method/settings.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <sstream>

namespace cs {

namespace {

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Edits (insert, delete, substitute, swap two neighbours) from a to b.
size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::vector<size_t>> d(a.size() + 1, std::vector<size_t>(b.size() + 1));
  for (size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (size_t i = 1; i <= a.size(); ++i)
    for (size_t j = 1; j <= b.size(); ++j) {
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  return d[a.size()][b.size()];
}

std::string numberText(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace

bool equalsIgnoringCase(const std::string& a, const std::string& b) { return lower(a) == lower(b); }

std::string closestMatch(const std::string& given, const std::vector<std::string>& candidates) {
  const std::string g = lower(given);
  std::string best;
  size_t bestDistance = SIZE_MAX;
  for (const std::string& c : candidates) {
    const std::string lc = lower(c);
    // A prefix of a longer name ("--sm-res" for "--sm-resolution") is a likely typo too.
    const size_t d = (lc.size() > g.size() + 2 && lc.rfind(g, 0) == 0 && g.size() >= 4) ? 1 : editDistance(g, lc);
    if (d < bestDistance) {
      bestDistance = d;
      best = c;
    }
  }
  // Close: at most a third of the name's letters wrong (and at least one allowed).
  return bestDistance <= std::max<size_t>(1, g.size() / 3) ? best : std::string();
}

std::string didYouMean(const std::string& given, const std::vector<std::string>& candidates) {
  const std::string m = closestMatch(given, candidates);
  return m.empty() ? std::string() : " (did you mean " + m + "?)";
}

uint64_t parseByteSize(const std::string& flag, const std::string& v) {
  char* end = nullptr;
  errno = 0;
  const double x = std::strtod(v.c_str(), &end);
  double mult = 1;
  const std::string suffix = lower(end ? std::string(end) : "");
  bool ok = !v.empty() && errno == 0 && end != v.c_str();
  if (suffix == "k" || suffix == "kib") mult = 1024.0;
  else if (suffix == "m" || suffix == "mib") mult = 1024.0 * 1024;
  else if (suffix == "g" || suffix == "gib") mult = 1024.0 * 1024 * 1024;
  else if (!suffix.empty()) ok = false;
  // >= 1: "0.5" is no size.
  if (!ok || !(x * mult >= 1) || x * mult > 1e15)
    throw UsageError(flag + " wants a positive size in bytes (e.g. 64M, 512K, 4096), got '" + v + "'");
  return uint64_t(x * mult);
}

std::string byteSizeLabel(uint64_t bytes) {
  auto fmt = [](double v, const char* suffix) {
    std::ostringstream os;
    if (v == std::floor(v)) os << uint64_t(v) << suffix;
    else os << std::fixed << std::setprecision(1) << v << suffix;
    return os.str();
  };
  if (bytes >= (1ull << 30) && bytes % (1ull << 30) == 0) return fmt(double(bytes >> 30), "G");
  if (bytes >= (1ull << 20)) return fmt(std::round(double(bytes) / (1 << 20) * 10) / 10, "M");
  if (bytes >= 1024) return fmt(std::round(double(bytes) / 1024 * 10) / 10, "K");
  return std::to_string(bytes);
}

void Settings::bad(const std::string& name, const std::string& wants) const {
  auto it = values_.find(name);
  throw UsageError((method_.empty() ? "" : method_ + ": ") + "--" + name + " " + wants + ", got '" +
                   (it == values_.end() ? "" : it->second) + "'");
}

uint32_t Settings::count(const std::string& name, uint32_t lo, uint32_t hi, uint32_t fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  errno = 0;
  char* end = nullptr;
  const long long x = std::strtoll(it->second.c_str(), &end, 10);
  if (it->second.empty() || *end != '\0' || errno || x < lo || x > hi)
    bad(name, "wants a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return uint32_t(x);
}

uint64_t Settings::bytes(const std::string& name, uint64_t fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  return parseByteSize((method_.empty() ? "" : method_ + ": ") + "--" + name, it->second);
}

double Settings::number(const std::string& name, double lo, double hi, double fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  char* end = nullptr;
  errno = 0;
  const double x = std::strtod(it->second.c_str(), &end);
  if (it->second.empty() || *end != '\0' || errno || !(x >= lo && x <= hi))
    bad(name, "wants a number in [" + numberText(lo) + ", " + numberText(hi) + "]");
  return x;
}

bool Settings::onOff(const std::string& name, bool fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  const std::string v = lower(it->second);
  if (v == "on" || v == "true" || v == "1" || v == "yes") return true;
  if (v == "off" || v == "false" || v == "0" || v == "no") return false;
  bad(name, "takes on or off");
}

std::string Settings::choice(const std::string& name, const std::vector<std::string>& choices,
                             const std::string& fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  for (const std::string& c : choices)
    if (equalsIgnoringCase(c, it->second)) return c;
  std::string all;
  for (const std::string& c : choices) all += (all.empty() ? "" : ", ") + c;
  throw UsageError((method_.empty() ? "" : method_ + ": ") + "--" + name + ": unknown value '" + it->second + "'" +
                   didYouMean(it->second, choices) + " (one of: " + all + ")");
}

}  // namespace cs
