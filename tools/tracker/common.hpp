#pragma once
// The image loader of the tracker tools: the file as 8-bit grey, as the tracker takes it.
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <string>

namespace ips::tracker::tools {

inline cv::Mat loadGray(const std::string& path) {
  cv::Mat img = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (img.empty()) throw std::runtime_error("cannot read image '" + path + "'");
  return img;
}

}  // namespace ips::tracker::tools
