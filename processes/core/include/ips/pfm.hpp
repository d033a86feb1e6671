#pragma once
// Portable Float Map, the format of Middlebury's disparity maps: float pixels, invalid = +inf.
#include <opencv2/core.hpp>
#include <string>

namespace ips {

// Writes a single-channel CV_32F image (top row first in memory; PFM stores bottom row first).
void writePfm(const std::string& path, const cv::Mat& image);
// Reads a greyscale PFM into CV_32F; throws std::runtime_error naming the file on failure.
cv::Mat readPfm(const std::string& path);

}  // namespace ips
