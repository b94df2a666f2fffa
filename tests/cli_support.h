// Running the coneshadow CLI from a test, as a user would: exit code and everything it printed.
#pragma once
#include <cstdio>
#include <string>

#include <sys/wait.h>

namespace cs::test {

struct CliRun {
  int code = -1;
  std::string out;  // stdout and stderr together
};

inline CliRun cli(const std::string& args) {
  std::string cmd = std::string(CONESHADOW_CLI) + " " + args + " 2>&1";
  CliRun r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace cs::test
