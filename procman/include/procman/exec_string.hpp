#pragma once
// Turns a procman exec string into what execvp needs, without a shell: words split like a POSIX shell does
// (single quotes, double quotes, backslash), $VAR, ${VAR} and ${VAR:-default} expanded from an environment
// (not inside single quotes), and leading NAME=VALUE words taken as environment settings for the command.
#include <functional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace ips::procman {

class ExecStringError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ExecSpec {
  std::vector<std::pair<std::string, std::string>> env;  // NAME=VALUE words before the program
  std::vector<std::string> argv;                         // argv[0] is the program (looked up in PATH)
};

// `lookup` returns the value of an environment variable ("" when unset). Throws ExecStringError for an
// unterminated quote, a dangling backslash, a bad ${...} or an exec string with no program.
ExecSpec parseExecString(const std::string& exec_str, const std::function<std::string(const std::string&)>& lookup);

// Same, with the process environment (getenv).
ExecSpec parseExecString(const std::string& exec_str);

}  // namespace ips::procman
