#include "ips/image_file.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace ips {

cv::Mat loadGrey(const std::string& path) {
  cv::Mat img = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (img.empty()) throw std::runtime_error("cannot read image '" + path + "'");
  if (img.depth() == CV_16U) img.convertTo(img, CV_8U, 1.0 / 256);
  cv::Mat grey;
  if (img.channels() == 3)
    cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
  else if (img.channels() == 4)
    cv::cvtColor(img, grey, cv::COLOR_BGRA2GRAY);
  else
    grey = img;
  return grey;
}

}  // namespace ips
