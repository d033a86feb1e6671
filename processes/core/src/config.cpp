#include "ips/config.hpp"

#include <sstream>

namespace ips {

Config::Config(const std::string& path) : path_(path) {
  try {
    fs_.open(path, cv::FileStorage::READ | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    throw ConfigError(path + ": cannot parse: " + e.err);
  }
  if (!fs_.isOpened()) throw ConfigError(path + ": cannot open config file");
  root_ = fs_.root();
}

Config::Config(std::string path, cv::FileStorage fs, cv::FileNode root, std::string prefix)
    : path_(std::move(path)), fs_(std::move(fs)), root_(std::move(root)), prefix_(std::move(prefix)) {}

cv::FileNode Config::node(const std::string& key) const {
  cv::FileNode n = root_;
  std::stringstream ss(key);
  std::string part;
  while (std::getline(ss, part, '/')) {
    if (!n.isMap()) return cv::FileNode();
    n = n[part];
    if (n.empty()) return cv::FileNode();
  }
  return n;
}

bool Config::has(const std::string& key) const { return !node(key).empty(); }

void Config::fail(const std::string& key, const std::string& what) const {
  throw ConfigError(path_ + ": key '" + prefix_ + key + "' " + what);
}

cv::FileNode Config::required(const std::string& key) const {
  cv::FileNode n = node(key);
  if (n.empty()) fail(key, "is missing");
  return n;
}

double Config::getDouble(const std::string& key) const {
  cv::FileNode n = required(key);
  if (!n.isReal() && !n.isInt()) fail(key, "must be a number");
  return static_cast<double>(n);
}

int Config::getInt(const std::string& key) const {
  cv::FileNode n = required(key);
  if (!n.isInt()) fail(key, "must be an integer");
  return static_cast<int>(n);
}

bool Config::getBool(const std::string& key) const {
  cv::FileNode n = required(key);
  if (n.isInt()) return static_cast<int>(n) != 0;
  if (n.isString()) {
    std::string s = static_cast<std::string>(n);
    if (s == "true" || s == "yes" || s == "on") return true;
    if (s == "false" || s == "no" || s == "off") return false;
  }
  fail(key, "must be true/false or 0/1");
}

std::string Config::getString(const std::string& key) const {
  cv::FileNode n = required(key);
  if (!n.isString()) fail(key, "must be a string");
  return static_cast<std::string>(n);
}

cv::Mat Config::getMat(const std::string& key) const {
  cv::FileNode n = required(key);
  cv::Mat m;
  if (n.isSeq()) {
    std::vector<double> v;
    for (const auto& e : n) {
      if (!e.isReal() && !e.isInt()) fail(key, "must be a sequence of numbers");
      v.push_back(static_cast<double>(e));
    }
    return cv::Mat(v, true).reshape(1, 1);
  }
  try {
    n >> m;
  } catch (const cv::Exception&) {
    fail(key, "must be a matrix");
  }
  if (m.empty()) fail(key, "must be a matrix");
  m.convertTo(m, CV_64F);
  return m;
}

Eigen::MatrixXd Config::getMatrix(const std::string& key, int rows, int cols) const {
  cv::Mat m = getMat(key);
  if (static_cast<int>(m.total()) != rows * cols) {
    fail(key, "must have " + std::to_string(rows) + "x" + std::to_string(cols) + " elements, has " +
                  std::to_string(m.total()));
  }
  m = m.reshape(1, rows);
  Eigen::MatrixXd out(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) out(r, c) = m.at<double>(r, c);
  return out;
}

double Config::getDouble(const std::string& key, double fallback) const { return has(key) ? getDouble(key) : fallback; }
int Config::getInt(const std::string& key, int fallback) const { return has(key) ? getInt(key) : fallback; }
bool Config::getBool(const std::string& key, bool fallback) const { return has(key) ? getBool(key) : fallback; }
std::string Config::getString(const std::string& key, const std::string& fallback) const {
  return has(key) ? getString(key) : fallback;
}

Config Config::section(const std::string& key) const {
  cv::FileNode n = required(key);
  if (!n.isMap()) fail(key, "must be a map");
  return Config(path_, fs_, n, prefix_ + key + "/");
}

}  // namespace ips
