#include "ips/mapper/stereo_points.hpp"

#include <cmath>

namespace ips::mapper {

double rangeForDepthSigma(const MapperParams& params, double focal_px, double baseline_m) {
  return std::sqrt(params.max_depth_sigma_m * focal_px * baseline_m / params.disparity_sigma_px);
}

PointSet triangulate(const DisparityImage& map, const HeadGeometry& head, const Eigen::Isometry3d& T_world_body,
                     const MapperParams& params) {
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
  for (int v = 0; v < map.disparity.rows; v += params.pixel_step) {
    const float* row = map.disparity.ptr<float>(v);
    for (int u = 0; u < map.disparity.cols; u += params.pixel_step) {
      const double d = row[u];
      if (!(d >= min_disparity && d <= max_disparity)) continue;  // also NaN and invalid
      const double z = fb / d;
      const Eigen::Vector3d X_rect((u - map.cx) * z / map.focal_px, (v - map.cy) * z / map.focal_px, z);
      out.points.push_back(T_world_rect * X_rect);
      out.intensity.push_back(has_grey ? map.grey.at<uint8_t>(v, u) : 0);
    }
  }
  return out;
}

}  // namespace ips::mapper
