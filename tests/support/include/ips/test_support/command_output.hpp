#pragma once
// Runs a command line through the shell (a tool under test, as a user runs it) and returns what it printed on
// standard output; empty when it could not be started.
#include <cstdio>
#include <string>

namespace ips::test_support {

inline std::string commandOutput(const std::string& command) {
  std::string out;
  FILE* p = popen(command.c_str(), "r");
  if (!p) return out;
  char buf[512];
  while (fgets(buf, sizeof buf, p)) out += buf;
  pclose(p);
  return out;
}

}  // namespace ips::test_support
