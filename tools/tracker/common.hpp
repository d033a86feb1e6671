#pragma once
// Small helpers shared by the tracker tools: argument parsing and image loading.
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <string>

namespace ips::tracker::tools {

// "--key value" pairs after the positional arguments; a key without a value is an error.
inline std::map<std::string, std::string> parseOptions(int argc, char** argv, int first,
                                                       std::vector<std::string>* positional = nullptr) {
  std::map<std::string, std::string> opts;
  for (int i = first; i < argc; ++i) {
    std::string a = argv[i];
    if (a.rfind("--", 0) == 0) {
      if (a == "--help" || a == "-h") {
        opts["help"] = "1";
        continue;
      }
      if (i + 1 >= argc) throw std::invalid_argument("option " + a + " needs a value");
      opts[a.substr(2)] = argv[++i];
    } else if (positional) {
      positional->push_back(a);
    } else {
      throw std::invalid_argument("unexpected argument '" + a + "'");
    }
  }
  return opts;
}

inline cv::Mat loadGray(const std::string& path) {
  cv::Mat img = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (img.empty()) throw std::runtime_error("cannot read image '" + path + "'");
  return img;
}

}  // namespace ips::tracker::tools
