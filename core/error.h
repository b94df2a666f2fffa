// One error type for setup failures and bad input: what went wrong, where, and what to do.
// The CLI prints it as one line and exits non-zero; it is never compiled out.
#pragma once
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>

namespace cs {

struct Error : std::runtime_error {
  std::string where;  // file, stage or call that failed
  std::string hint;   // what the user can do about it (may be empty)
  Error(std::string what, std::string where_ = {}, std::string hint_ = {})
      : std::runtime_error(format(what, where_, hint_)), where(std::move(where_)), hint(std::move(hint_)) {}

  static std::string format(const std::string& what, const std::string& where, const std::string& hint) {
    std::string s;
    if (!where.empty()) s += where + ": ";
    s += what;
    if (!hint.empty()) s += " (" + hint + ")";
    return s;
  }
};

// Bad input on the command line (an unknown option, a value out of range, a setting no chosen method
// takes): the CLI prints it as one line and exits 2, before any heavy work.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Where an internal check or a Vulkan call failed, for a message: `what` ("internal check", "Vulkan"),
// with the source file and line only under CONESHADOW_DEBUG=1 (a user's message names no source path).
inline std::string sourceWhere(const char* what, const char* file, int line) {
  const char* debug = std::getenv("CONESHADOW_DEBUG");
  if (debug && *debug && std::string(debug) != "0") return std::string(what) + " at " + file + ":" + std::to_string(line);
  return what;
}

// CHECK-style helper that prints both values; stays in release builds.
#define CS_CHECK(cond, msg)                                                                  \
  do {                                                                                       \
    if (!(cond)) {                                                                           \
      std::ostringstream cs_check_os_;                                                       \
      cs_check_os_ << msg;                                                                   \
      throw ::cs::Error(cs_check_os_.str(), ::cs::sourceWhere("internal check", __FILE__, __LINE__)); \
    }                                                                                        \
  } while (0)

#define CS_CHECK_EQ(a, b)                                                                    \
  CS_CHECK((a) == (b), "check failed: " #a " == " #b " (" << (a) << " vs " << (b) << ")")

}  // namespace cs
