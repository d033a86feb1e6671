#pragma once
// Turns a procman exec string into what execvp needs, without a shell, by the rules of the upstream procman
// deputy (github.com/ashuang/procman, src/procman/exec_string_utils.cpp), so a configuration behaves the same
// under either deputy:
//  1. Split into words at white space. A ' or " opens a quote that only the same character closes (the other
//     one is literal inside); a backslash takes the next character literally, inside quotes too. An unclosed
//     quote runs to the end; a backslash at the very end stays a backslash.
//  2. Leading words that contain '=' (after quote removal) set environment variables NAME=VALUE (split at the
//     first '='; the value is not expanded).
//  3. In every other word, after quote removal (so quotes do not protect from expansion), $NAME and ${NAME}
//     are replaced by the variable's value when it is set (also when empty); an unset variable, a bare $,
//     and anything else after ${ (such as ${NAME:-default}) stay literally as written. A backslash left in a
//     word after step 1 (from "\\") is kept and the character after it dropped, as upstream does.
// Where upstream differs and we do not follow: its splitter drops a last word of a single character
// ("sleep 5" runs "sleep"); ours keeps it.
#include <functional>
#include <optional>
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

// Value of an environment variable, nullopt when unset.
using EnvLookup = std::function<std::optional<std::string>(const std::string&)>;

// Throws ExecStringError for an exec string that names no program (only assignments or nothing) and for an
// assignment with an empty name.
ExecSpec parseExecString(const std::string& exec_str, const EnvLookup& lookup);

// Same, with the process environment (getenv).
ExecSpec parseExecString(const std::string& exec_str);

}  // namespace ips::procman
