#include "procman/sheriff_config.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <set>
#include <sstream>

namespace ips::procman {
namespace {

enum class Tok { kIdent, kString, kNumber, kAssign, kEnd, kOpen, kClose, kEof };

struct Token {
  Tok type = Tok::kEof;
  std::string value;
  int line = 0, col = 0;
};

const char* tokName(Tok t) {
  switch (t) {
    case Tok::kIdent:
      return "identifier";
    case Tok::kString:
      return "string";
    case Tok::kNumber:
      return "number";
    case Tok::kAssign:
      return "'='";
    case Tok::kEnd:
      return "';'";
    case Tok::kOpen:
      return "'{'";
    case Tok::kClose:
      return "'}'";
    case Tok::kEof:
      return "end of file";
  }
  return "?";
}

class Lexer {
 public:
  Lexer(const std::string& text, const std::string& source) : s_(text), source_(source) {}

  [[noreturn]] void fail(int line, int col, const std::string& msg) const {
    throw ConfigError(source_ + ":" + std::to_string(line) + ":" + std::to_string(col) + ": " + msg);
  }

  Token next() {
    skipSpaceAndComments();
    Token t;
    t.line = line_;
    t.col = col_;
    if (i_ >= s_.size()) return t;
    const char c = s_[i_];
    if (c == '=' || c == ';' || c == '{' || c == '}') {
      t.type = c == '=' ? Tok::kAssign : c == ';' ? Tok::kEnd : c == '{' ? Tok::kOpen : Tok::kClose;
      t.value = std::string(1, c);
      advance();
      return t;
    }
    if (c == '"') {
      advance();
      t.type = Tok::kString;
      for (;;) {
        if (i_ >= s_.size() || s_[i_] == '\n') fail(t.line, t.col, "unterminated string");
        char d = s_[i_];
        advance();
        if (d == '"') break;
        if (d == '\\') {
          if (i_ >= s_.size()) fail(t.line, t.col, "unterminated string");
          const char e = s_[i_];
          advance();
          d = e == 'n' ? '\n' : e == 't' ? '\t' : e == 'r' ? '\r' : e;
        }
        t.value += d;
      }
      return t;
    }
    if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      t.type = Tok::kIdent;
      while (i_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[i_])) || s_[i_] == '_' || s_[i_] == '-')) {
        t.value += s_[i_];
        advance();
      }
      return t;
    }
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '.') {
      t.type = Tok::kNumber;
      while (i_ < s_.size() && (std::isdigit(static_cast<unsigned char>(s_[i_])) || s_[i_] == '.' || s_[i_] == '-')) {
        t.value += s_[i_];
        advance();
      }
      return t;
    }
    fail(line_, col_, std::string("invalid character '") + c + "'");
  }

 private:
  void advance() {
    if (s_[i_] == '\n') {
      ++line_;
      col_ = 1;
    } else {
      ++col_;
    }
    ++i_;
  }
  void skipSpaceAndComments() {
    while (i_ < s_.size()) {
      if (std::isspace(static_cast<unsigned char>(s_[i_]))) {
        advance();
      } else if (s_[i_] == '#') {
        while (i_ < s_.size() && s_[i_] != '\n') advance();
      } else {
        break;
      }
    }
  }
  const std::string& s_;
  std::string source_;
  size_t i_ = 0;
  int line_ = 1, col_ = 1;
};

class Parser {
 public:
  Parser(const std::string& text, const std::string& source) : lex_(text, source) { next(); }

  SheriffConfig parse() {
    while (cur_.type != Tok::kEof) {
      const Token t = expect(Tok::kIdent, "'cmd', 'group' or 'script'");
      if (t.value == "cmd") {
        parseCommand("");
      } else if (t.value == "group") {
        parseGroup("");
      } else if (t.value == "script") {
        parseScript();
      } else {
        lex_.fail(t.line, t.col, "expected 'cmd', 'group' or 'script', got '" + t.value + "'");
      }
    }
    check();
    return std::move(cfg_);
  }

 private:
  void next() { cur_ = lex_.next(); }

  Token expect(Tok type, const std::string& what) {
    if (cur_.type != type)
      lex_.fail(
          cur_.line, cur_.col,
          "expected " + what + ", got " + tokName(cur_.type) + (cur_.value.empty() ? "" : " '" + cur_.value + "'"));
    Token t = cur_;
    next();
    return t;
  }

  void expectWord(const std::string& word) {
    const Token t = expect(Tok::kIdent, "'" + word + "'");
    if (t.value != word) lex_.fail(t.line, t.col, "expected '" + word + "', got '" + t.value + "'");
  }

  void parseGroup(const std::string& parent) {
    const Token name = expect(Tok::kString, "group name string");
    if (name.value.find('/') != std::string::npos) lex_.fail(name.line, name.col, "'/' is not allowed in a group name");
    if (name.value.find_first_not_of(" \t") == std::string::npos) lex_.fail(name.line, name.col, "empty group name");
    const std::string path = parent.empty() ? name.value : parent + "/" + name.value;
    if (std::find(cfg_.groups.begin(), cfg_.groups.end(), path) == cfg_.groups.end()) cfg_.groups.push_back(path);
    expect(Tok::kOpen, "'{'");
    while (cur_.type == Tok::kIdent) {
      const Token t = cur_;
      next();
      if (t.value == "cmd")
        parseCommand(path);
      else if (t.value == "group")
        parseGroup(path);
      else
        lex_.fail(t.line, t.col, "expected 'cmd' or 'group', got '" + t.value + "'");
    }
    expect(Tok::kClose, "'}'");
  }

  void parseCommand(const std::string& group) {
    CommandConfig cmd;
    cmd.group = group;
    cmd.line = cur_.line;
    const Token id = expect(Tok::kString, "command id string");
    if (id.value.empty()) lex_.fail(id.line, id.col, "empty command id");
    if (id.value.find('/') != std::string::npos) lex_.fail(id.line, id.col, "'/' is not allowed in a command id");
    cmd.id = id.value;
    expect(Tok::kOpen, "'{'");
    std::set<std::string> seen;
    while (cur_.type == Tok::kIdent) {
      const Token key = cur_;
      next();
      expect(Tok::kAssign, "'='");
      const Token value = cur_;
      if (value.type != Tok::kString && value.type != Tok::kNumber && value.type != Tok::kIdent)
        lex_.fail(value.line, value.col, "expected a value for '" + key.value + "'");
      next();
      expect(Tok::kEnd, "';'");
      if (!seen.insert(key.value == "host" ? "deputy" : key.value).second)
        lex_.fail(key.line, key.col, "attribute '" + key.value + "' given twice");
      if (key.value == "exec") {
        cmd.exec = value.value;
      } else if (key.value == "deputy" || key.value == "host") {
        cmd.deputy = value.value;
      } else if (key.value == "group") {
        cmd.group = group.empty() ? value.value : group + "/" + value.value;
      } else if (key.value == "auto_respawn") {
        if (value.value == "true" || value.value == "1")
          cmd.auto_respawn = true;
        else if (value.value == "false" || value.value == "0")
          cmd.auto_respawn = false;
        else
          lex_.fail(value.line, value.col, "auto_respawn must be \"true\" or \"false\", got '" + value.value + "'");
      } else if (key.value == "stop_signal") {
        cmd.stop_signal = static_cast<int>(number(value, 1, 64));
        if (cmd.stop_signal != number(value, 1, 64)) lex_.fail(value.line, value.col, "stop_signal must be an integer");
      } else if (key.value == "stop_time_allowed") {
        cmd.stop_time_allowed = number(value, 0.0, 3600.0);
      } else {
        lex_.fail(key.line, key.col, "unknown command attribute '" + key.value + "'");
      }
    }
    expect(Tok::kClose, "'}'");
    if (cmd.exec.empty()) lex_.fail(id.line, id.col, "command '" + cmd.id + "' has no exec");
    cfg_.commands.push_back(cmd);
  }

  double number(const Token& t, double lo, double hi) {
    double v = 0;
    try {
      size_t used = 0;
      v = std::stod(t.value, &used);
      if (used != t.value.size()) throw std::invalid_argument(t.value);
    } catch (const std::exception&) {
      lex_.fail(t.line, t.col, "expected a number, got '" + t.value + "'");
    }
    if (v < lo || v > hi)
      lex_.fail(t.line, t.col,
                "value " + t.value + " out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return v;
  }

  void parseScript() {
    Script script;
    const Token name = expect(Tok::kString, "script name string");
    script.name = name.value;
    for (const auto& s : cfg_.scripts)
      if (s.name == script.name) lex_.fail(name.line, name.col, "script '" + script.name + "' defined twice");
    expect(Tok::kOpen, "'{'");
    while (cur_.type == Tok::kIdent) {
      const Token verb = cur_;
      next();
      ScriptAction a;
      if (verb.value == "start" || verb.value == "stop" || verb.value == "restart") {
        a.type = verb.value == "start"  ? ActionType::kStart
                 : verb.value == "stop" ? ActionType::kStop
                                        : ActionType::kRestart;
        const Token kind = expect(Tok::kIdent, "'everything', 'group' or 'cmd'");
        if (kind.value != "everything" && kind.value != "group" && kind.value != "cmd")
          lex_.fail(kind.line, kind.col, "expected 'everything', 'group' or 'cmd', got '" + kind.value + "'");
        a.target_kind = kind.value;
        if (kind.value != "everything") a.target = expect(Tok::kString, "name string").value;
        if (cur_.type == Tok::kIdent) {
          expectWord("wait");
          a.wait_status = waitStatus();
        }
        expect(Tok::kEnd, "';'");
      } else if (verb.value == "wait") {
        const Token kind = expect(Tok::kIdent, "'ms', 'cmd' or 'group'");
        if (kind.value == "ms") {
          a.type = ActionType::kWaitMs;
          a.delay_ms = static_cast<int>(number(expect(Tok::kNumber, "milliseconds"), 0, 86400000));
        } else if (kind.value == "cmd" || kind.value == "group") {
          a.type = ActionType::kWaitStatus;
          a.target_kind = kind.value;
          a.target = expect(Tok::kString, "name string").value;
          expectWord("status");
          a.wait_status = waitStatus();
        } else {
          lex_.fail(kind.line, kind.col, "expected 'ms', 'cmd' or 'group', got '" + kind.value + "'");
        }
        expect(Tok::kEnd, "';'");
      } else if (verb.value == "run_script") {
        a.type = ActionType::kRunScript;
        a.target = expect(Tok::kString, "script name string").value;
        expect(Tok::kEnd, "';'");
      } else {
        lex_.fail(verb.line, verb.col, "unknown script action '" + verb.value + "'");
      }
      a_lines_.push_back(verb);
      script.actions.push_back(a);
    }
    expect(Tok::kClose, "'}'");
    cfg_.scripts.push_back(script);
  }

  std::string waitStatus() {
    const Token t = expect(Tok::kString, "\"running\" or \"stopped\"");
    if (t.value != "running" && t.value != "stopped")
      lex_.fail(t.line, t.col, "expected \"running\" or \"stopped\", got \"" + t.value + "\"");
    return t.value;
  }

  void check() {
    std::set<std::pair<std::string, std::string>> ids;
    for (const auto& c : cfg_.commands)
      if (!ids.insert({c.deputy, c.id}).second)
        lex_.fail(c.line, 1, "command id '" + c.id + "' used twice on deputy '" + c.deputy + "'");
    size_t k = 0;
    for (const auto& s : cfg_.scripts) {
      for (const auto& a : s.actions) {
        const Token& where = a_lines_[k++];
        if (a.target_kind == "cmd" && std::none_of(cfg_.commands.begin(), cfg_.commands.end(),
                                                   [&](const CommandConfig& c) { return c.id == a.target; }))
          lex_.fail(where.line, where.col, "script '" + s.name + "': no command '" + a.target + "'");
        if (a.target_kind == "group" && !cfg_.hasGroup(a.target))
          lex_.fail(where.line, where.col, "script '" + s.name + "': no group '" + a.target + "'");
        if (a.type == ActionType::kRunScript && !cfg_.findScript(a.target))
          lex_.fail(where.line, where.col, "script '" + s.name + "': no script '" + a.target + "'");
      }
    }
  }

  Lexer lex_;
  Token cur_;
  SheriffConfig cfg_;
  std::vector<Token> a_lines_;  // position of each script action, in order, for error messages
};

}  // namespace

std::string ScriptAction::describe() const {
  switch (type) {
    case ActionType::kStart:
    case ActionType::kStop:
    case ActionType::kRestart: {
      std::string s = type == ActionType::kStart ? "start " : type == ActionType::kStop ? "stop " : "restart ";
      s += target_kind;
      if (target_kind != "everything") s += " \"" + target + "\"";
      if (!wait_status.empty()) s += " wait \"" + wait_status + "\"";
      return s;
    }
    case ActionType::kWaitMs:
      return "wait ms " + std::to_string(delay_ms);
    case ActionType::kWaitStatus:
      return "wait " + target_kind + " \"" + target + "\" status \"" + wait_status + "\"";
    case ActionType::kRunScript:
      return "run_script \"" + target + "\"";
  }
  return "?";
}

const Script* SheriffConfig::findScript(const std::string& name) const {
  for (const auto& s : scripts)
    if (s.name == name) return &s;
  return nullptr;
}

bool groupContains(const std::string& path, const std::string& group) {
  if (path.empty()) return true;
  return group == path ||
         (group.size() > path.size() && group.compare(0, path.size(), path) == 0 && group[path.size()] == '/');
}

bool SheriffConfig::hasGroup(const std::string& path) const {
  for (const auto& g : groups)
    if (g == path) return true;
  for (const auto& c : commands)
    if (groupContains(path, c.group) && !path.empty()) return true;
  return false;
}

SheriffConfig parseSheriffConfig(const std::string& text, const std::string& source) {
  return Parser(text, source).parse();
}

SheriffConfig loadSheriffConfig(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the sheriff config");
  std::stringstream ss;
  ss << in.rdbuf();
  return parseSheriffConfig(ss.str(), path);
}

}  // namespace ips::procman
