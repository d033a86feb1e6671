#include "ips/config.hpp"

#include <yaml.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>
#include <sstream>

namespace ips {

namespace {

// OpenCV's YAML reader loops forever on some files (21 bytes are enough: a header, then a document that is
// one plain scalar running over two lines). Every file is therefore first read by libyaml, a parser fuzzed
// for years, and only a well-formed stream of one document that is a map (every configuration and calibration
// of the project is) reaches cv::FileStorage. OpenCV writes its header as "%YAML:1.0", which is not YAML; that
// line is blanked (kept as a line, so that libyaml's line numbers match the file's).
void checkWellFormedYaml(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path + ": cannot open (" + std::strerror(errno) + ")");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (text.rfind("%YAML:", 0) == 0) {
    const size_t eol = text.find('\n');
    text.replace(0, eol == std::string::npos ? text.size() : eol, "");
  }
  yaml_parser_t parser;
  if (!yaml_parser_initialize(&parser)) throw ConfigError(path + ": cannot initialise the YAML parser");
  yaml_parser_set_input_string(&parser, reinterpret_cast<const unsigned char*>(text.data()), text.size());
  std::string error;
  int depth = 0, documents = 0;
  bool has_map = false;
  for (bool done = false; !done;) {
    yaml_event_t event;
    if (!yaml_parser_parse(&parser, &event)) {
      error = path + ":" + std::to_string(parser.problem_mark.line + 1) +
              ": not valid YAML: " + (parser.problem ? parser.problem : "parse error") +
              (parser.context ? std::string(" ") + parser.context : std::string());
      break;
    }
    done = event.type == YAML_STREAM_END_EVENT;
    // One document: OpenCV's reader also hangs on a second one ("---" after an indented map, then "-:"), and no
    // configuration or calibration of the project has two.
    if (event.type == YAML_DOCUMENT_START_EVENT && ++documents > 1)
      error = path + ":" + std::to_string(event.start_mark.line + 1) +
              ": not valid YAML here: a second document (---); a configuration is one map of keys";
    // The first node of each document (depth 0) must open a map.
    if (depth == 0 &&
        (event.type == YAML_SCALAR_EVENT || event.type == YAML_SEQUENCE_START_EVENT || event.type == YAML_ALIAS_EVENT))
      error = path + ":" + std::to_string(event.start_mark.line + 1) +
              ": not valid YAML: a configuration must be a map of keys";
    if (depth == 0 && event.type == YAML_MAPPING_START_EVENT) has_map = true;
    if (event.type == YAML_MAPPING_START_EVENT || event.type == YAML_SEQUENCE_START_EVENT) ++depth;
    if (event.type == YAML_MAPPING_END_EVENT || event.type == YAML_SEQUENCE_END_EVENT) --depth;
    yaml_event_delete(&event);
    if (!error.empty()) break;
  }
  yaml_parser_delete(&parser);
  if (error.empty() && !has_map)
    error = path + ": holds no keys (an empty file?): a configuration must be a map of keys";
  if (!error.empty()) throw ConfigError(error);
}

}  // namespace

namespace {

// Values written back as YAML that cv::FileStorage reads to the same value: the shortest decimal that round-trips,
// with a point so that it reads as a real.
std::string yamlDouble(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  std::string s(buf, r.ptr);
  if (s.find_first_of(".eE") == std::string::npos) s += ".0";
  return s;
}

std::string yamlString(const std::string& v) {
  std::string s = "\"";
  for (char c : v) {
    if (c == '"' || c == '\\') s += '\\';
    s += c;
  }
  return s + "\"";
}

// A row as a sequence; a matrix as OpenCV's !!opencv-matrix, whose shape a reader keeps.
std::string yamlMatrix(const cv::Mat& m) {
  std::string data = "[";
  for (int r = 0; r < m.rows; ++r)
    for (int c = 0; c < m.cols; ++c) data += (data.size() > 1 ? ", " : "") + yamlDouble(m.at<double>(r, c));
  data += "]";
  if (m.rows == 1) return data;
  return "!!opencv-matrix\nrows: " + std::to_string(m.rows) + "\ncols: " + std::to_string(m.cols) +
         "\ndt: d\ndata: " + data;
}

}  // namespace

Config::Config(const std::string& path) : path_(path), reads_(std::make_shared<Reads>()) {
  checkWellFormedYaml(path);
  try {
    fs_.open(path, cv::FileStorage::READ | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    throw ConfigError(path + ": cannot parse: " + e.err);
  } catch (const std::exception& e) {
    // OpenCV's reader also lets standard exceptions out (std::length_error from a key it misreads): found by
    // tests/fuzz/fuzz_config, the input is in its corpus.
    throw ConfigError(path + ": cannot parse: " + e.what());
  }
  if (!fs_.isOpened()) throw ConfigError(path + ": cannot open as YAML");
  root_ = fs_.root();
}

Config::Config(std::string path, cv::FileStorage fs, cv::FileNode root, std::string prefix)
    : path_(std::move(path)), fs_(std::move(fs)), root_(std::move(root)), prefix_(std::move(prefix)) {}

cv::FileNode Config::node(const std::string& key) const {
  cv::FileNode n = lookup(key);
  if (reads_) reads_->subtrees.insert(prefix_ + key);
  return n;
}

namespace {

// Leaves of a YAML tree (values and sequences) under `path`.
void collectLeaves(const cv::FileNode& n, const std::string& path, std::vector<std::string>* out) {
  if (!n.isMap()) {
    out->push_back(path);
    return;
  }
  for (auto it = n.begin(); it != n.end(); ++it) {
    const cv::FileNode child = *it;
    collectLeaves(child, path.empty() ? child.name() : path + "/" + child.name(), out);
  }
}

}  // namespace

std::vector<std::string> Config::unreadKeys() const {
  std::vector<std::string> leaves, unread;
  collectLeaves(root_, prefix_.empty() ? "" : prefix_.substr(0, prefix_.size() - 1), &leaves);
  for (const std::string& leaf : leaves) {
    bool read = reads_ && reads_->keys.count(leaf) > 0;
    // A leaf under a sub-tree taken raw was read with it.
    for (size_t slash = leaf.find('/'); !read && slash != std::string::npos; slash = leaf.find('/', slash + 1))
      read = reads_->subtrees.count(leaf.substr(0, slash)) > 0;
    if (!read && reads_ && reads_->subtrees.count(leaf) > 0) read = true;
    if (!read) unread.push_back(leaf);
  }
  return unread;
}

void Config::refuseUnreadKeys() const {
  const std::vector<std::string> unread = unreadKeys();
  if (unread.empty()) return;
  std::string list;
  for (const std::string& k : unread) list += (list.empty() ? "'" : ", '") + k + "'";
  throw ConfigError(path_ + ": unknown key" + (unread.size() > 1 ? "s " : " ") + list +
                    " (misspelled, or not a setting of this process)");
}

cv::FileNode Config::lookup(const std::string& key) const {
  if (reads_) reads_->keys.insert(prefix_ + key);
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

bool Config::has(const std::string& key) const { return !lookup(key).empty(); }

void Config::fail(const std::string& key, const std::string& what) const {
  throw ConfigError(path_ + ": key '" + prefix_ + key + "' " + what);
}

cv::FileNode Config::required(const std::string& key) const {
  cv::FileNode n = lookup(key);
  if (n.empty()) fail(key, "is missing");
  return n;
}

double Config::getDouble(const std::string& key) const {
  cv::FileNode n = required(key);
  if (!n.isReal() && !n.isInt()) fail(key, "must be a number");
  const double v = static_cast<double>(n);
  // No parameter of a sensor head or a method is infinite or undefined: .nan and .inf are typing errors that
  // would otherwise turn every state into NaN without a word.
  if (!std::isfinite(v)) fail(key, "must be a finite number, not " + std::to_string(v));
  record(key, yamlDouble(v), false);
  return v;
}

int Config::getInt(const std::string& key) const {
  cv::FileNode n = required(key);
  if (!n.isInt()) fail(key, "must be an integer");
  record(key, std::to_string(static_cast<int>(n)), false);
  return static_cast<int>(n);
}

bool Config::getBool(const std::string& key) const {
  cv::FileNode n = required(key);
  std::optional<bool> v;
  if (n.isInt()) v = static_cast<int>(n) != 0;
  if (n.isString()) {
    std::string s = static_cast<std::string>(n);
    // OpenCV keeps a trailing comment in a plain scalar ("on: true  # why" reads "true  # why"); YAML ends the
    // scalar at the blank before '#'.
    if (const size_t hash = s.find(" #"); hash != std::string::npos) s.erase(hash);
    s.erase(s.find_last_not_of(" \t") + 1);
    if (s == "true" || s == "yes" || s == "on") v = true;
    if (s == "false" || s == "no" || s == "off") v = false;
  }
  if (!v) fail(key, "must be true/false or 0/1");
  record(key, *v ? "true" : "false", false);
  return *v;
}

namespace {

// OpenCV's reader keeps a comment after a plain string (`cost: census  # ...` reads "census  # ..."), where YAML
// ends the value at a blank followed by '#'. The reader does not tell a quoted value from a plain one, so a blank
// and '#' end a quoted string too.
std::string withoutTrailingComment(std::string s) {
  for (size_t i = 1; i < s.size(); ++i) {
    if (s[i] == '#' && (s[i - 1] == ' ' || s[i - 1] == '\t')) {
      s.erase(i);
      break;
    }
  }
  s.erase(s.find_last_not_of(" \t") + 1);
  return s;
}

}  // namespace

std::string Config::getString(const std::string& key) const {
  cv::FileNode n = required(key);
  if (!n.isString()) fail(key, "must be a string");
  const std::string value = withoutTrailingComment(static_cast<std::string>(n));
  record(key, yamlString(value), false);
  return value;
}

cv::Mat Config::getMat(const std::string& key) const {
  cv::FileNode n = required(key);
  // An !!opencv-matrix is a map (rows, cols, dt, data): read whole.
  if (reads_) reads_->subtrees.insert(prefix_ + key);
  cv::Mat m;
  if (n.isSeq()) {
    std::vector<double> v;
    for (const auto& e : n) {
      if (!e.isReal() && !e.isInt()) fail(key, "must be a sequence of numbers");
      v.push_back(static_cast<double>(e));
      if (!std::isfinite(v.back())) fail(key, "must hold finite numbers only");
    }
    if (v.empty()) {
      record(key, "[]", false);
      return cv::Mat(1, 0, CV_64F);  // [] : a row of no numbers
    }
    cv::Mat row = cv::Mat(v, true).reshape(1, 1);
    record(key, yamlMatrix(row), false);
    return row;
  }
  try {
    n >> m;
  } catch (const std::exception&) {  // cv::Exception and what OpenCV lets through from the standard library
    fail(key, "must be a matrix");
  }
  if (m.empty()) fail(key, "must be a matrix");
  m.convertTo(m, CV_64F);
  if (!cv::checkRange(m)) fail(key, "must hold finite numbers only");
  record(key, yamlMatrix(m), false);
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

double Config::getDouble(const std::string& key, double fallback) const {
  if (has(key)) return getDouble(key);
  record(key, yamlDouble(fallback), true);
  return fallback;
}
int Config::getInt(const std::string& key, int fallback) const {
  if (has(key)) return getInt(key);
  record(key, std::to_string(fallback), true);
  return fallback;
}
bool Config::getBool(const std::string& key, bool fallback) const {
  if (has(key)) return getBool(key);
  record(key, fallback ? "true" : "false", true);
  return fallback;
}
std::string Config::getString(const std::string& key, const std::string& fallback) const {
  if (has(key)) return getString(key);
  record(key, yamlString(fallback), true);
  return fallback;
}

void Config::record(const std::string& key, std::string yaml, bool is_default) const {
  if (reads_) reads_->values[prefix_ + key] = {std::move(yaml), is_default};
}

namespace {

// The effective settings as a tree of maps, printed in key order.
struct YamlTree {
  std::map<std::string, YamlTree> children;
  std::optional<std::pair<std::string, bool>> value;
  bool raw = false;
};

void printTree(const YamlTree& t, int depth, std::ostringstream& out) {
  const std::string indent(2 * depth, ' ');
  for (const auto& [name, child] : t.children) {
    if (child.raw) {
      out << indent << "# " << name << ": taken whole from the file\n";
    } else if (child.value) {
      // A matrix's continuation lines sit under its key.
      std::string v = child.value->first;
      for (size_t at = v.find('\n'); at != std::string::npos; at = v.find('\n', at + 1))
        v.insert(at + 1, indent + "  ");
      out << indent << name << ": " << v << (child.value->second ? "  # default" : "") << "\n";
    } else {
      out << indent << name << ":\n";
      printTree(child, depth + 1, out);
    }
  }
}

}  // namespace

std::string Config::effectiveYaml() const {
  YamlTree root;
  auto at = [&root](const std::string& path) -> YamlTree& {
    YamlTree* t = &root;
    std::stringstream ss(path);
    std::string part;
    while (std::getline(ss, part, '/')) t = &t->children[part];
    return *t;
  };
  if (reads_) {
    for (const auto& [key, value] : reads_->values) at(key).value = value;
    for (const std::string& key : reads_->subtrees)
      if (!reads_->values.count(key)) at(key).raw = true;  // a matrix is read whole too, and has its value
  }
  std::ostringstream out;
  out << "%YAML:1.0\n# " << path_
      << " as this process uses it: every setting it reads, its default where the file has none\n";
  printTree(root, 0, out);
  return out.str();
}

Config Config::section(const std::string& key) const {
  cv::FileNode n = required(key);
  if (!n.isMap()) fail(key, "must be a map");
  Config sub(path_, fs_, n, prefix_ + key + "/");
  sub.reads_ = reads_;
  return sub;
}

}  // namespace ips
