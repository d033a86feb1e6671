#include "ips/args.hpp"

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
  specs_[name] = Spec{value_name, help, default_value, false, false};
  order_.push_back(name);
  return *this;
}

Args& Args::required(const std::string& name, const std::string& value_name, const std::string& help) {
  specs_[name] = Spec{value_name, help, "", false, true};
  order_.push_back(name);
  return *this;
}

Args& Args::flag(const std::string& name, const std::string& help) {
  specs_[name] = Spec{"", help, "", true, false};
  order_.push_back(name);
  return *this;
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
    if (a.rfind("--", 0) == 0) {
      std::string value;
      bool inline_value = false;
      auto eq = a.find('=');
      if (eq != std::string::npos) {
        value = a.substr(eq + 1);
        a = a.substr(0, eq);
        inline_value = true;
      }
      auto it = specs_.find(a);
      if (it == specs_.end()) throw ArgError(program_ + ": unknown option '" + a + "' (see --help)");
      if (it->second.is_flag) {
        if (inline_value) throw ArgError(program_ + ": option '" + a + "' takes no value");
        values_[a] = "1";
      } else {
        if (!inline_value) {
          if (i + 1 >= argv_.size())
            throw ArgError(program_ + ": option '" + a + "' needs a value (" + it->second.value_name + ")");
          value = argv_[++i];
        }
        values_[a] = value;
      }
    } else {
      positional_.push_back(a);
    }
  }
  if (positional_.size() < positional_min_ || positional_.size() > positional_max_) {
    if (positional_max_ == 0 && !positional_.empty())
      throw ArgError(program_ + ": unexpected argument '" + positional_.front() + "' (see --help)");
    throw ArgError(program_ + ": expected " + std::to_string(positional_min_) +
                   (positional_max_ != positional_min_ ? " to " + std::to_string(positional_max_) : "") + " " +
                   positional_name_ + " argument(s), got " + std::to_string(positional_.size()));
  }
  for (const auto& name : order_) {
    if (specs_[name].is_required && !values_.count(name))
      throw ArgError(program_ + ": option '" + name + "' is required (see --help)");
  }
  return true;
}

std::string Args::get(const std::string& name) const {
  auto v = values_.find(name);
  if (v != values_.end()) return v->second;
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

std::string Args::help() const {
  std::ostringstream os;
  os << program_ << ": " << summary_ << "\n\nUsage: " << program_ << " [options]";
  if (positional_max_ > 0) os << " " << positional_name_ << (positional_max_ > 1 ? "..." : "");
  os << "\n\nOptions:\n";
  for (const auto& name : order_) {
    const Spec& s = specs_.at(name);
    std::string left = "  " + name + (s.is_flag ? "" : " " + s.value_name);
    os << left;
    if (left.size() < 30)
      os << std::string(30 - left.size(), ' ');
    else
      os << "\n" << std::string(30, ' ');
    // A help text of several lines continues under its first line.
    for (char c : s.help) {
      os << c;
      if (c == '\n') os << std::string(30, ' ');
    }
    if (s.is_required) os << " (required)";
    if (!s.default_value.empty()) os << " [default: " << s.default_value << "]";
    os << "\n";
  }
  if (positional_max_ > 0) os << "  " << positional_name_ << "  " << positional_help_ << "\n";
  os << "  --help                      this text\n";
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
