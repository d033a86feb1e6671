#include "ips/eval/disparity.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace ips::eval {

DisparityErrors disparityErrors(const cv::Mat& estimate, const cv::Mat& truth, const std::vector<double>& thresholds,
                                const cv::Mat& region, double error_scale) {
  if (estimate.type() != CV_32FC1 || truth.type() != CV_32FC1 || estimate.size() != truth.size())
    throw std::invalid_argument("disparityErrors: estimate and truth must be CV_32F maps of one size");
  if (!region.empty() && (region.type() != CV_8UC1 || region.size() != truth.size()))
    throw std::invalid_argument("disparityErrors: the region must be a CV_8U mask of the maps' size");
  DisparityErrors e;
  e.thresholds = thresholds;
  e.bad.assign(thresholds.size(), 0);
  e.bad_valid.assign(thresholds.size(), 0);
  for (int r = 0; r < truth.rows; ++r) {
    const float* est = estimate.ptr<float>(r);
    const float* gt = truth.ptr<float>(r);
    const uint8_t* in = region.empty() ? nullptr : region.ptr<uint8_t>(r);
    for (int c = 0; c < truth.cols; ++c) {
      if (in && !in[c]) continue;
      ++e.pixels;
      const bool ok = std::isfinite(est[c]);
      e.estimated += ok;
      if (!std::isfinite(gt[c])) continue;
      ++e.evaluated;
      const double err = ok ? std::abs(double(est[c]) - gt[c]) * error_scale : INFINITY;
      if (ok) {
        ++e.valid;
        e.abs_error_sum += err;
      }
      for (size_t t = 0; t < thresholds.size(); ++t)
        if (err > thresholds[t]) {
          ++e.bad[t];
          if (ok) ++e.bad_valid[t];
        }
    }
  }
  return e;
}

cv::Mat disparityPixels(const cv::Mat& fixed_point, int invalid_value, double subpixel_scale) {
  if (fixed_point.type() != CV_16SC1) throw std::invalid_argument("disparityPixels: the map must be CV_16S");
  cv::Mat out(fixed_point.size(), CV_32FC1);
  for (int r = 0; r < out.rows; ++r) {
    const int16_t* in = fixed_point.ptr<int16_t>(r);
    float* o = out.ptr<float>(r);
    for (int c = 0; c < out.cols; ++c)
      o[c] = in[c] == invalid_value ? std::numeric_limits<float>::quiet_NaN() : float(in[c] / subpixel_scale);
  }
  return out;
}

cv::Mat truthAtSize(const cv::Mat& truth, cv::Size size) {
  if (truth.type() != CV_32FC1) throw std::invalid_argument("truthAtSize: the truth must be CV_32F");
  if (truth.size() == size) return truth.clone();
  const double sx = double(size.width) / truth.cols, sy = double(size.height) / truth.rows;
  cv::Mat out(size, CV_32FC1);
  for (int r = 0; r < size.height; ++r) {
    const int tr = std::min(truth.rows - 1, int(std::lround((r + 0.5) / sy - 0.5)));
    for (int c = 0; c < size.width; ++c) {
      const int tc = std::min(truth.cols - 1, int(std::lround((c + 0.5) / sx - 0.5)));
      out.at<float>(r, c) = truth.at<float>(tr, tc) * float(sx);
    }
  }
  return out;
}

cv::Mat colourDisparity(const cv::Mat& disparity, double max_disparity) {
  cv::Mat scaled(disparity.size(), CV_8U), valid(disparity.size(), CV_8U);
  for (int y = 0; y < disparity.rows; ++y)
    for (int x = 0; x < disparity.cols; ++x) {
      float d = disparity.at<float>(y, x);
      valid.at<uint8_t>(y, x) = std::isfinite(d) ? 255 : 0;
      scaled.at<uint8_t>(y, x) =
          std::isfinite(d) ? cv::saturate_cast<uint8_t>(255.0 * std::max(0.0, double(d)) / max_disparity) : 0;
    }
  cv::Mat colour;
  cv::applyColorMap(scaled, colour, cv::COLORMAP_JET);
  colour.setTo(cv::Scalar(0, 0, 0), valid == 0);
  return colour;
}

}  // namespace ips::eval
