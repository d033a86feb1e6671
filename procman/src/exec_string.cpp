#include "procman/exec_string.hpp"

#include <cctype>
#include <cstdlib>

namespace ips::procman {
namespace {

bool isNameStart(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }
bool isNameChar(char c) { return isNameStart(c) || std::isdigit(static_cast<unsigned char>(c)); }

// Step 1: words, quotes and backslashes removed.
std::vector<std::string> splitWords(const std::string& s) {
  std::vector<std::string> words;
  size_t i = 0;
  while (true) {
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    if (i >= s.size()) break;
    std::string word;
    char quote = 0;
    for (; i < s.size(); ++i) {
      const char c = s[i];
      if (c == '\\') {
        word += i + 1 < s.size() ? s[++i] : '\\';
      } else if (quote == 0 && (c == '\'' || c == '"')) {
        quote = c;
      } else if (quote != 0 && c == quote) {
        quote = 0;
      } else if (quote == 0 && std::isspace(static_cast<unsigned char>(c))) {
        break;
      } else {
        word += c;
      }
    }
    words.push_back(word);
  }
  return words;
}

// Step 3: variables of one word.
std::string expandVariables(const std::string& w, const EnvLookup& lookup) {
  std::string out;
  size_t i = 0;
  while (i < w.size()) {
    const char c = w[i++];
    if (c == '\\') {
      out += '\\';
      if (i < w.size()) ++i;  // upstream keeps the backslash and drops what follows it
      continue;
    }
    if (c != '$') {
      out += c;
      continue;
    }
    const size_t dollar = i - 1;
    const bool braces = i < w.size() && w[i] == '{';
    if (braces) ++i;
    const size_t name_start = i;
    if (i < w.size() && isNameStart(w[i])) {
      ++i;
      while (i < w.size() && isNameChar(w[i])) ++i;
    }
    const std::string name = w.substr(name_start, i - name_start);
    bool ok = !name.empty();
    if (braces) {
      // Upstream consumes the character after the name whatever it is; only '}' completes the reference.
      ok = ok && i < w.size() && w[i] == '}';
      if (i < w.size()) ++i;
    }
    std::optional<std::string> value;
    if (ok) value = lookup(name);
    if (value)
      out += *value;
    else
      out += w.substr(dollar, i - dollar);
  }
  return out;
}

}  // namespace

ExecSpec parseExecString(const std::string& s, const EnvLookup& lookup) {
  const std::vector<std::string> words = splitWords(s);
  ExecSpec spec;
  size_t w = 0;
  for (; w < words.size(); ++w) {
    const size_t eq = words[w].find('=');
    if (eq == std::string::npos) break;
    if (eq == 0) throw ExecStringError("exec string: assignment without a name '" + words[w] + "' in: " + s);
    spec.env.emplace_back(words[w].substr(0, eq), words[w].substr(eq + 1));
  }
  for (; w < words.size(); ++w) spec.argv.push_back(expandVariables(words[w], lookup));
  if (spec.argv.empty()) throw ExecStringError("exec string names no program: '" + s + "'");
  return spec;
}

ExecSpec parseExecString(const std::string& exec_str) {
  return parseExecString(exec_str, [](const std::string& name) -> std::optional<std::string> {
    const char* v = std::getenv(name.c_str());
    if (!v) return std::nullopt;
    return std::string(v);
  });
}

}  // namespace ips::procman
