// A method's settings as the user gave them, and the typed readers every method parses them with.
// Values stay text until the method that declared them reads them; every reader throws UsageError naming
// the method and the flag, so a bad value is exit 2 before any work, whoever reads it.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/error.h"

namespace cs {

class Settings {
 public:
  Settings() = default;
  explicit Settings(std::string method) : method_(std::move(method)) {}

  const std::string& method() const { return method_; }
  // name: the flag without its dashes ("sm-resolution"); value: "" for a switch.
  void set(const std::string& name, const std::string& value) { values_[name] = value; }
  Settings with(const std::string& name, const std::string& value) const {
    Settings s = *this;
    s.set(name, value);
    return s;
  }
  Settings without(const std::string& name) const {
    Settings s = *this;
    s.values_.erase(name);
    return s;
  }
  bool has(const std::string& name) const { return values_.count(name) != 0; }
  const std::map<std::string, std::string>& values() const { return values_; }

  // Typed readers: the fallback when the setting is absent, else the parsed value or a UsageError.
  uint32_t count(const std::string& name, uint32_t lo, uint32_t hi, uint32_t fallback) const;
  uint64_t bytes(const std::string& name, uint64_t fallback) const;  // "64M", "512K", "4096"
  double number(const std::string& name, double lo, double hi, double fallback) const;
  bool onOff(const std::string& name, bool fallback) const;          // on/off (also true/false, 1/0)
  bool present(const std::string& name) const { return has(name); } // a switch
  // One of `choices`, matched without regard to case; returns the choice's own spelling. A near miss is
  // answered with "did you mean".
  std::string choice(const std::string& name, const std::vector<std::string>& choices, const std::string& fallback) const;

 private:
  [[noreturn]] void bad(const std::string& name, const std::string& wants) const;
  std::string method_;
  std::map<std::string, std::string> values_;
};

// The candidate closest to `given` (edit distance, ignoring case) when it is close enough to be a likely
// typo, else "".
std::string closestMatch(const std::string& given, const std::vector<std::string>& candidates);
// " (did you mean X?)" or "".
std::string didYouMean(const std::string& given, const std::vector<std::string>& candidates);
bool equalsIgnoringCase(const std::string& a, const std::string& b);

// "64M", "4096", "1.5G", "512K" (binary suffixes): a size in bytes >= 1, or UsageError naming `flag`.
uint64_t parseByteSize(const std::string& flag, const std::string& value);

// The other way: "64M", "4M", "65.5K", "512", for labels.
std::string byteSizeLabel(uint64_t bytes);

}  // namespace cs
