#pragma once
// The E3D tests' access to the shared stereo scenes (../shared/data/stereo) and their map comparison.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#include "ips/data_dir.hpp"

namespace ips::e3d_test {

// A scene's image as grey (the scenes are stored in colour).
inline cv::Mat loadGrey(const std::string& scene, const std::string& file) {
  cv::Mat img = cv::imread(ips::dataDir() + "/stereo/" + scene + "/" + file, cv::IMREAD_COLOR);
  if (img.empty()) throw std::runtime_error("missing test image " + scene + "/" + file);
  cv::Mat grey;
  cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
  return grey;
}

// Number of pixels where the two CV_16S maps differ.
inline int differences(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::compare(a, b, diff, cv::CMP_NE);
  return cv::countNonZero(diff);
}

}  // namespace ips::e3d_test
