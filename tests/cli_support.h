// Running the coneshadow CLI from a test, as a user would: exit code and everything it printed. Every
// results.json a successful run writes into --out is validated against docs/results.schema.json.
#pragma once
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <sys/wait.h>

#include "tests/json_schema.h"

namespace cs::test {

// The --out folder named in a command line ("--out X" or "--out=X"), or "".
inline std::string outFolderOf(const std::string& args) {
  std::istringstream in(args);
  std::string word, previous;
  while (in >> word) {
    if (previous == "--out") return word;
    if (word.rfind("--out=", 0) == 0) return word.substr(6);
    previous = word;
  }
  return "";
}

// Fails the running test unless <dir>/results.json, when there is one, matches the documented schema.
inline void expectResultsMatchTheSchema(const std::string& dir) {
  namespace fs = std::filesystem;
  const fs::path results = fs::path(dir) / "results.json";
  if (dir.empty() || !fs::exists(results)) return;
  static const JsonSchema schema =
      JsonSchema::fromFile(fs::path(__FILE__).parent_path().parent_path() / "docs" / "results.schema.json");
  std::ifstream f(results);
  const nlohmann::json rows = nlohmann::json::parse(std::string(std::istreambuf_iterator<char>(f), {}), nullptr, false);
  ASSERT_FALSE(rows.is_discarded()) << results << " is not JSON";
  const std::vector<std::string> errors = schema.validate(rows);
  std::string text;
  for (size_t i = 0; i < errors.size() && i < 10; ++i) text += "\n  " + errors[i];
  EXPECT_TRUE(errors.empty()) << results << " does not match docs/results.schema.json (" << errors.size()
                              << " violations):" << text;
}

struct CliRun {
  int code = -1;     // the exit status; -1 when a signal ended it (a crash)
  std::string out;  // stdout and stderr together
};

// `launcher` runs the CLI under another program ("prlimit --as=N "); empty: directly.
inline CliRun cli(const std::string& args, const std::string& launcher = "") {
  std::string cmd = launcher + std::string(CONESHADOW_CLI) + " " + args + " 2>&1";
  CliRun r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (r.code == 0) expectResultsMatchTheSchema(outFolderOf(args));
  return r;
}

}  // namespace cs::test
