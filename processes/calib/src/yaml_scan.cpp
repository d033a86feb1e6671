#include "yaml_scan.hpp"

#include <fstream>
#include <regex>
#include <sstream>

#include "ips/config.hpp"

namespace ips::calib::yaml {

std::string load(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw ConfigError(path + ": cannot open calibration file");
  std::string line, out;
  while (std::getline(f, line)) {
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.rfind("%YAML", 0) == 0) continue;
    out += line + "\n";
  }
  return out;
}

namespace {

std::vector<double> numbers(std::string body, const std::string& path, const std::string& key) {
  for (char& ch : body)
    if (ch == ',' || ch == '\n') ch = ' ';
  std::istringstream in(body);
  std::vector<double> values;
  std::string tok;
  while (in >> tok) {
    try {
      size_t used = 0;
      values.push_back(std::stod(tok, &used));
      if (used != tok.size()) throw std::invalid_argument(tok);
    } catch (const std::exception&) {
      throw ConfigError(path + ": key '" + key + "' holds '" + tok + "', not a number");
    }
  }
  return values;
}

}  // namespace

std::vector<double> numberList(const std::string& text, const std::string& path, const std::string& key, size_t from,
                               const std::string& shown) {
  const std::string name = shown.empty() ? key : shown;
  const std::regex re("(^|[\\s{,])" + key + "\\s*:\\s*\\[([^\\]]*)\\]");
  std::smatch m;
  const std::string rest = text.substr(std::min(from, text.size()));
  if (!std::regex_search(rest, m, re)) throw ConfigError(path + ": key '" + name + "' with a [ ... ] list not found");
  return numbers(m[2].str(), path, name);
}

std::string scalar(const std::string& text, const std::string& key) {
  const std::regex re("(^|\\n)\\s*" + key + "\\s*:[ \\t]*([^\\n]*)");
  std::smatch m;
  if (!std::regex_search(text, m, re)) return "";
  std::string v = m[2].str();
  while (!v.empty() && (v.back() == ' ' || v.back() == '\t')) v.pop_back();
  if (v.size() >= 2 && (v.front() == '"' || v.front() == '\'')) v = v.substr(1, v.size() - 2);
  return v;
}

std::string section(const std::string& text, const std::string& name) {
  std::istringstream in(text);
  std::string line, out;
  bool inside = false;
  while (std::getline(in, line)) {
    const bool top = !line.empty() && line[0] != ' ' && line[0] != '\t';
    if (top) {
      if (inside) break;
      inside = line.rfind(name + ":", 0) == 0;
      continue;
    }
    if (inside) out += line + "\n";
  }
  return out;
}

bool blockMatrix(const std::string& text, const std::string& path, const std::string& key, int rows, int cols,
                 Eigen::MatrixXd& out) {
  const std::regex re("(^|\\n)\\s*" + key + "\\s*:[ \\t]*\\n((\\s*-\\s*\\[[^\\]]*\\][ \\t]*\\n?)+)");
  std::smatch m;
  if (!std::regex_search(text, m, re)) {
    // Also the flow form "key: [[..], [..]]".
    const std::regex flow("(^|\\n)\\s*" + key + "\\s*:\\s*\\[((\\s*\\[[^\\]]*\\]\\s*,?)+)\\s*\\]");
    if (!std::regex_search(text, m, flow)) return false;
  }
  std::string body = m[2].str();
  // Only the numbers inside the brackets of each row.
  std::vector<double> values;
  const std::regex row("\\[([^\\]]*)\\]");
  for (auto it = std::sregex_iterator(body.begin(), body.end(), row); it != std::sregex_iterator(); ++it) {
    const auto r = numbers((*it)[1].str(), path, key);
    if (static_cast<int>(r.size()) != cols)
      throw ConfigError(path + ": key '" + key + "' needs rows of " + std::to_string(cols) + " numbers");
    values.insert(values.end(), r.begin(), r.end());
  }
  if (static_cast<int>(values.size()) != rows * cols)
    throw ConfigError(path + ": key '" + key + "' needs " + std::to_string(rows) + " rows");
  out.resize(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) out(r, c) = values[static_cast<size_t>(r * cols + c)];
  return true;
}

std::vector<double> dataOf(const std::string& text, const std::string& path, const std::string& key, size_t count) {
  const std::regex re("(^|\\n)\\s*" + key + "\\s*:");
  std::smatch m;
  if (!std::regex_search(text, m, re)) throw ConfigError(path + ": key '" + key + "' not found");
  const size_t from = static_cast<size_t>(m.position(0) + m.length(0));
  const auto values = numberList(text, path, "data", from);
  if (values.size() != count)
    throw ConfigError(path + ": key '" + key + "/data' needs " + std::to_string(count) + " numbers, has " +
                      std::to_string(values.size()));
  return values;
}

}  // namespace ips::calib::yaml
