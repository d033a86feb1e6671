#include "procman/exec_string.hpp"

#include <cctype>
#include <cstdlib>

namespace ips::procman {
namespace {

bool isNameStart(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }
bool isNameChar(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// Expands a $ at s[i] into out; returns the index after the reference. A $ not followed by a name stays.
size_t expandVariable(const std::string& s, size_t i, std::string& out,
                      const std::function<std::string(const std::string&)>& lookup) {
  if (i + 1 < s.size() && s[i + 1] == '{') {
    const size_t close = s.find('}', i + 2);
    if (close == std::string::npos) throw ExecStringError("exec string: unterminated ${ in: " + s);
    const std::string inside = s.substr(i + 2, close - i - 2);
    // ${NAME} or ${NAME:-default} (the default when NAME is unset or empty, taken literally).
    const size_t dash = inside.find(":-");
    const std::string name = inside.substr(0, dash);
    if (name.empty() || !isNameStart(name[0])) throw ExecStringError("exec string: bad variable ${" + inside + "}");
    for (char c : name)
      if (!isNameChar(c)) throw ExecStringError("exec string: bad variable ${" + inside + "}");
    const std::string value = lookup(name);
    out += (value.empty() && dash != std::string::npos) ? inside.substr(dash + 2) : value;
    return close + 1;
  }
  if (i + 1 < s.size() && isNameStart(s[i + 1])) {
    size_t end = i + 1;
    while (end < s.size() && isNameChar(s[end])) ++end;
    out += lookup(s.substr(i + 1, end - i - 1));
    return end;
  }
  out += '$';
  return i + 1;
}

}  // namespace

ExecSpec parseExecString(const std::string& s, const std::function<std::string(const std::string&)>& lookup) {
  std::vector<std::string> words;
  std::string word;
  bool in_word = false;
  size_t i = 0;
  while (i < s.size()) {
    const char c = s[i];
    if (std::isspace(static_cast<unsigned char>(c))) {
      if (in_word) words.push_back(word);
      word.clear();
      in_word = false;
      ++i;
    } else if (c == '\'') {
      const size_t close = s.find('\'', i + 1);
      if (close == std::string::npos) throw ExecStringError("exec string: unterminated ' in: " + s);
      word += s.substr(i + 1, close - i - 1);
      in_word = true;
      i = close + 1;
    } else if (c == '"') {
      in_word = true;
      ++i;
      bool closed = false;
      while (i < s.size()) {
        const char d = s[i];
        if (d == '"') {
          closed = true;
          ++i;
          break;
        }
        if (d == '\\' && i + 1 < s.size() && (s[i + 1] == '"' || s[i + 1] == '\\' || s[i + 1] == '$')) {
          word += s[i + 1];
          i += 2;
        } else if (d == '$') {
          i = expandVariable(s, i, word, lookup);
        } else {
          word += d;
          ++i;
        }
      }
      if (!closed) throw ExecStringError("exec string: unterminated \" in: " + s);
    } else if (c == '\\') {
      if (i + 1 >= s.size()) throw ExecStringError("exec string: dangling backslash in: " + s);
      word += s[i + 1];
      in_word = true;
      i += 2;
    } else if (c == '$') {
      const size_t before = word.size();
      i = expandVariable(s, i, word, lookup);
      // An unquoted expansion to nothing does not make a word on its own (as in a shell).
      in_word = in_word || word.size() != before;
    } else {
      word += c;
      in_word = true;
      ++i;
    }
  }
  if (in_word) words.push_back(word);

  ExecSpec spec;
  size_t w = 0;
  for (; w < words.size(); ++w) {
    const std::string& candidate = words[w];
    const size_t eq = candidate.find('=');
    if (eq == std::string::npos || eq == 0 || !isNameStart(candidate[0])) break;
    bool name_ok = true;
    for (size_t k = 0; k < eq; ++k) name_ok = name_ok && isNameChar(candidate[k]);
    if (!name_ok) break;
    spec.env.emplace_back(candidate.substr(0, eq), candidate.substr(eq + 1));
  }
  spec.argv.assign(words.begin() + static_cast<std::ptrdiff_t>(w), words.end());
  if (spec.argv.empty()) throw ExecStringError("exec string names no program: '" + s + "'");
  return spec;
}

ExecSpec parseExecString(const std::string& exec_str) {
  return parseExecString(exec_str, [](const std::string& name) {
    const char* v = std::getenv(name.c_str());
    return std::string(v ? v : "");
  });
}

}  // namespace ips::procman
