#include "ips/args.hpp"

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace ips {

Args::Args(int argc, char** argv, std::string summary) : summary_(std::move(summary)) {
  program_ = argc > 0 ? argv[0] : "program";
  auto slash = program_.rfind('/');
  if (slash != std::string::npos) program_ = program_.substr(slash + 1);
  for (int i = 1; i < argc; ++i) argv_.emplace_back(argv[i]);
}

Args& Args::option(const std::string& name, const std::string& value_name, const std::string& help,
                   const std::string& default_value) {
  specs_[name] = Spec{value_name, help, default_value, false, false, false, {}};
  order_.push_back(name);
  return *this;
}

Args& Args::required(const std::string& name, const std::string& value_name, const std::string& help) {
  specs_[name] = Spec{value_name, help, "", false, true, false, {}};
  order_.push_back(name);
  return *this;
}

Args& Args::flag(const std::string& name, const std::string& help) {
  specs_[name] = Spec{"", help, "", true, false, false, {}};
  order_.push_back(name);
  return *this;
}

Args& Args::repeated(const std::string& name, const std::string& value_name, const std::string& help) {
  specs_[name] = Spec{value_name, help, "", false, false, true, {}};
  order_.push_back(name);
  return *this;
}

Args& Args::alias(const std::string& spelling, const std::string& name) {
  auto it = specs_.find(name);
  if (it == specs_.end())
    throw ArgError(program_ + ": internal: alias '" + spelling + "' of undeclared '" + name + "'");
  it->second.aliases.push_back(spelling);
  aliases_[spelling] = name;
  return *this;
}

Args& Args::section(const std::string& title) {
  order_.push_back("\n" + title);
  return *this;
}

Args& Args::usage(const std::string& text) {
  usage_ = text;
  return *this;
}

Args& Args::epilog(const std::string& text) {
  epilog_ = text;
  return *this;
}

std::string Args::canonical(const std::string& spelling) const {
  if (specs_.count(spelling)) return spelling;
  auto a = aliases_.find(spelling);
  return a == aliases_.end() ? "" : a->second;
}

Args& Args::positionals(const std::string& name, const std::string& help, size_t min_count, size_t max_count) {
  positional_name_ = name;
  positional_help_ = help;
  positional_min_ = min_count;
  positional_max_ = max_count;
  return *this;
}

bool Args::parse() {
  for (size_t i = 0; i < argv_.size(); ++i) {
    std::string a = argv_[i];
    if (a == "--help" || a == "-h") {
      std::fputs(help().c_str(), stdout);
      return false;
    }
    // "--name", "--name=value", or a declared short spelling ("-u"); "-" alone and negative numbers are positional.
    const bool long_option = a.rfind("--", 0) == 0;
    const bool short_option =
        !long_option && a.size() > 1 && a[0] == '-' && std::isalpha(static_cast<unsigned char>(a[1]));
    if (!long_option && !short_option) {
      positional_.push_back(a);
      continue;
    }
    std::string value;
    bool inline_value = false;
    const auto eq = long_option ? a.find('=') : std::string::npos;
    if (eq != std::string::npos) {
      value = a.substr(eq + 1);
      a = a.substr(0, eq);
      inline_value = true;
    }
    const std::string name = canonical(a);
    if (name.empty()) throw ArgError(program_ + ": unknown option '" + a + "' (see --help)");
    const Spec& spec = specs_.at(name);
    if (spec.is_flag) {
      if (inline_value) throw ArgError(program_ + ": option '" + a + "' takes no value");
      values_[name] = {"1"};
      continue;
    }
    if (!inline_value) {
      if (i + 1 >= argv_.size())
        throw ArgError(program_ + ": option '" + a + "' needs a value (" + spec.value_name + ")");
      value = argv_[++i];
    }
    if (spec.is_repeated)
      values_[name].push_back(value);
    else
      values_[name] = {value};  // given twice, the last one holds
  }
  if (positional_.size() < positional_min_ || positional_.size() > positional_max_) {
    if (positional_max_ == 0 && !positional_.empty())
      throw ArgError(program_ + ": unexpected argument '" + positional_.front() + "' (see --help)");
    throw ArgError(program_ + ": expected " + std::to_string(positional_min_) +
                   (positional_max_ != positional_min_ ? " to " + std::to_string(positional_max_) : "") + " " +
                   positional_name_ + " argument(s), got " + std::to_string(positional_.size()));
  }
  for (const auto& name : order_) {
    auto s = specs_.find(name);
    if (s != specs_.end() && s->second.is_required && !values_.count(name))
      throw ArgError(program_ + ": option '" + name + "' is required (see --help)");
  }
  return true;
}

std::string Args::get(const std::string& name) const {
  auto v = values_.find(name);
  if (v != values_.end()) return v->second.back();
  auto s = specs_.find(name);
  if (s == specs_.end()) throw ArgError(program_ + ": internal: option '" + name + "' was not declared");
  return s->second.default_value;
}

bool Args::has(const std::string& name) const { return values_.count(name) > 0 || !get(name).empty(); }

double Args::getDouble(const std::string& name) const {
  const std::string v = get(name);
  char* end = nullptr;
  double d = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0') throw ArgError(program_ + ": option '" + name + "' needs a number, got '" + v + "'");
  return d;
}

long long Args::getInt(const std::string& name) const {
  const std::string v = get(name);
  char* end = nullptr;
  long long n = std::strtoll(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0') throw ArgError(program_ + ": option '" + name + "' needs an integer, got '" + v + "'");
  return n;
}

bool Args::getFlag(const std::string& name) const { return values_.count(name) > 0; }

std::vector<std::string> Args::getAll(const std::string& name) const {
  if (!specs_.count(name)) throw ArgError(program_ + ": internal: option '" + name + "' was not declared");
  auto v = values_.find(name);
  return v == values_.end() ? std::vector<std::string>{} : v->second;
}

std::string Args::help() const {
  constexpr size_t kHelpColumn = 30;
  std::ostringstream os;
  os << program_ << ": " << summary_ << "\n\nUsage: ";
  if (!usage_.empty()) {
    os << usage_;
  } else {
    os << program_ << " [options]";
    if (positional_max_ > 0) os << " " << positional_name_ << (positional_max_ > 1 ? "..." : "");
  }
  os << "\n";
  if (order_.empty() || order_.front()[0] != '\n') os << "\nOptions:\n";
  for (const auto& name : order_) {
    if (name[0] == '\n') {
      os << "\n" << name.substr(1) << ":\n";
      continue;
    }
    const Spec& s = specs_.at(name);
    // Short spellings before the name ("-u, --lcm-url URL"), old long ones after the help.
    std::string left = "  ";
    std::string others;
    for (const auto& a : s.aliases) {
      if (a.rfind("--", 0) == 0)
        others += (others.empty() ? "" : ", ") + a;
      else
        left += a + ", ";
    }
    left += name + (s.is_flag ? "" : " " + s.value_name);
    os << left;
    if (left.size() < kHelpColumn)
      os << std::string(kHelpColumn - left.size(), ' ');
    else
      os << "\n" << std::string(kHelpColumn, ' ');
    // A help text of several lines continues under its first line.
    for (char c : s.help) {
      os << c;
      if (c == '\n') os << std::string(kHelpColumn, ' ');
    }
    if (s.is_repeated) os << " (repeatable)";
    if (s.is_required) os << " (required)";
    if (!s.default_value.empty()) os << " [default: " << s.default_value << "]";
    if (!others.empty()) os << " (also " << others << ")";
    os << "\n";
  }
  if (positional_max_ > 0) os << "  " << positional_name_ << "  " << positional_help_ << "\n";
  os << "  -h, --help                  this text\n";
  if (!epilog_.empty()) os << "\n" << epilog_ << (epilog_.back() == '\n' ? "" : "\n");
  return os.str();
}

std::vector<int> parseIntList(const std::string& text, const std::string& what, int min_value) {
  std::vector<int> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    size_t used = 0;
    int value = 0;
    try {
      value = std::stoi(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size() || value < min_value)
      throw ArgError(what + ": '" + item + "' is not an integer >= " + std::to_string(min_value));
    out.push_back(value);
  }
  if (out.empty()) throw ArgError(what + ": no values in '" + text + "'");
  return out;
}

}  // namespace ips
