#include "ips/mapper/stereo_points.hpp"

#include <cmath>
#include <opencv2/imgproc.hpp>

namespace ips::mapper {

double rangeForDepthSigma(const MapperParams& params, double focal_px, double baseline_m) {
  return std::sqrt(params.max_depth_sigma_m * focal_px * baseline_m / params.disparity_sigma_px);
}

cv::Mat greySpread(const cv::Mat& grey, int window) {
  cv::Mat g, mean, mean_sq;
  grey.convertTo(g, CV_32F);
  const cv::Size box(window, window);
  cv::boxFilter(g, mean, CV_32F, box, cv::Point(-1, -1), true, cv::BORDER_REFLECT);
  cv::boxFilter(g.mul(g), mean_sq, CV_32F, box, cv::Point(-1, -1), true, cv::BORDER_REFLECT);
  cv::Mat variance = mean_sq - mean.mul(mean);
  cv::max(variance, 0.0, variance);  // rounding can leave a flat window a hair below zero
  cv::Mat spread;
  cv::sqrt(variance, spread);
  return spread;
}

PointSet triangulate(const DisparityImage& map, const HeadGeometry& head, const Eigen::Isometry3d& T_world_body,
                     const MapperParams& params, bool alignment_points) {
  PointSet out;
  out.max_range_m = rangeForDepthSigma(params, map.focal_px, map.baseline_m);
  // Disparity below which a point is cut: z = f b / d <= max_range.
  const double fb = map.focal_px * map.baseline_m;
  const double min_disparity = fb / out.max_range_m;
  const double max_disparity = params.min_range_m > 0 ? fb / params.min_range_m : INFINITY;
  // One transform from the rectified left frame to the world.
  Eigen::Isometry3d T_body_rect = head.T_body_cam0;
  T_body_rect.linear() = head.T_body_cam0.linear() * head.R_rect0_cam0.transpose();
  const Eigen::Isometry3d T_world_rect = T_world_body * T_body_rect;
  const bool has_grey = !map.grey.empty() && map.grey.size() == map.disparity.size();
  const cv::Mat spread = alignment_points && has_grey ? greySpread(map.grey, params.texture_window_px) : cv::Mat();
  for (int v = 0; v < map.disparity.rows; v += params.pixel_step) {
    const float* row = map.disparity.ptr<float>(v);
    for (int u = 0; u < map.disparity.cols; u += params.pixel_step) {
      const double d = row[u];
      if (!(d >= min_disparity && d <= max_disparity)) continue;  // also NaN and invalid
      const double z = fb / d;
      const Eigen::Vector3d X_rect((u - map.cx) * z / map.focal_px, (v - map.cy) * z / map.focal_px, z);
      const Eigen::Vector3d X_world = T_world_rect * X_rect;
      out.points.push_back(X_world);
      out.intensity.push_back(has_grey ? map.grey.at<uint8_t>(v, u) : 0);
      if (alignment_points && (spread.empty() || spread.at<float>(v, u) >= params.alignment_min_grey_spread))
        out.alignment_points.push_back(X_world);
    }
  }
  return out;
}

}  // namespace ips::mapper
