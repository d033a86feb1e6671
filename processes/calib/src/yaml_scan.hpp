#pragma once
// A small tolerant reader for the calibration YAML of other tools. Their files mix "%YAML:1.0" headers, plain
// YAML maps, flow sequences and block sequences of flow sequences that cv::FileStorage does not always accept;
// this reader understands exactly what the formats need and ignores comments and all other keys.
#include <Eigen/Core>
#include <string>
#include <vector>

namespace ips::calib::yaml {

// The file's text without comments and "%YAML" lines; throws ConfigError if it cannot be read.
std::string load(const std::string& path);

// The numbers of the flow sequence "[a, b, ...]" after `key:` (searched from `from`).
// Errors name the key as `shown` (e.g. "cam0/intrinsics"), `key` when empty.
std::vector<double> numberList(const std::string& text, const std::string& path, const std::string& key,
                               size_t from = 0, const std::string& shown = "");
// A scalar value after `key:` ("" when absent), without quotes.
std::string scalar(const std::string& text, const std::string& key);
// The lines indented below the top-level `name:` (empty when absent).
std::string section(const std::string& text, const std::string& name);
// A matrix written as a block sequence of rows "- [a, b, ...]" below `key:`; empty optional when absent.
bool blockMatrix(const std::string& text, const std::string& path, const std::string& key, int rows, int cols,
                 Eigen::MatrixXd& out);
// ROS style "key: {rows, cols, data: [...]}" or "key:\n  rows: ..\n  data: [...]": the data list.
std::vector<double> dataOf(const std::string& text, const std::string& path, const std::string& key, size_t count);

}  // namespace ips::calib::yaml
