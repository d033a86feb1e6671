#pragma once
// YAML configuration read with cv::FileStorage. Every error names the file and the key, so that a user
// with a wrong deployment file knows what to fix.
#include <Eigen/Core>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace ips {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A view of one node of a YAML file. Keys may be nested paths separated by '/', e.g. "imu/rate_hz".
class Config {
 public:
  // Opens a YAML file; throws ConfigError if it does not exist or does not parse.
  explicit Config(const std::string& path);

  const std::string& path() const { return path_; }
  bool has(const std::string& key) const;

  // Required values: throw ConfigError("<file>: key '<key>' ...") when missing or of the wrong type.
  double getDouble(const std::string& key) const;
  int getInt(const std::string& key) const;
  bool getBool(const std::string& key) const;
  // Without a trailing comment ("census  # the cost" reads "census"; a blank and '#' end a quoted value too).
  std::string getString(const std::string& key) const;
  cv::Mat getMat(const std::string& key) const;
  // A matrix of exactly rows x cols (written either as !!opencv-matrix or as a flat sequence).
  Eigen::MatrixXd getMatrix(const std::string& key, int rows, int cols) const;

  // Optional values: the default when the key is absent; ConfigError when present but wrong.
  double getDouble(const std::string& key, double fallback) const;
  int getInt(const std::string& key, int fallback) const;
  bool getBool(const std::string& key, bool fallback) const;
  std::string getString(const std::string& key, const std::string& fallback) const;

  // A sub-tree (a YAML map) as a Config of its own, for passing sections to libraries.
  Config section(const std::string& key) const;

  // The raw node (empty when absent); the whole sub-tree counts as read.
  cv::FileNode node(const std::string& key) const;

  // The file's keys (full paths, leaves: values and sequences) that nothing has asked for through this Config or
  // its sections: misspelled or stale keys, which would otherwise silently leave their defaults in place.
  std::vector<std::string> unreadKeys() const;
  // Throws ConfigError naming the file and every unread key. A process calls it once it has read its settings.
  void refuseUnreadKeys() const;

  // The settings as they are used: every key asked for through this Config or its sections, with the value in use
  // (the file's, or the caller's default, marked "# default"), as YAML that a Config reads back to the same values.
  // Keys taken as a raw node() are listed as a comment.
  std::string effectiveYaml() const;

 private:
  Config(std::string path, cv::FileStorage fs, cv::FileNode root, std::string prefix);
  cv::FileNode lookup(const std::string& key) const;  // marks the key as read
  cv::FileNode required(const std::string& key) const;
  void record(const std::string& key, std::string yaml, bool is_default) const;
  [[noreturn]] void fail(const std::string& key, const std::string& what) const;

  std::string path_;
  cv::FileStorage fs_;
  cv::FileNode root_;
  std::string prefix_;  // for error messages of sections
  // Shared by a Config and its sections: full key paths asked for, and those whose whole sub-tree was taken raw.
  struct Reads {
    std::set<std::string> keys, subtrees;
    // Full key path -> the value in use, written as YAML, and whether it is the caller's default.
    std::map<std::string, std::pair<std::string, bool>> values;
  };
  std::shared_ptr<Reads> reads_;
};

}  // namespace ips
