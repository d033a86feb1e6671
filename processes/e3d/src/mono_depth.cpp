#include "ips/e3d/mono_depth.hpp"

#include <cmath>

namespace ips::e3d {

MonoDepthParams MonoDepthParams::fromConfig(const Config& section) {
  MonoDepthParams p;
  p.polar = PolarRectificationParams::fromConfig(section);
  p.gap_pairs = section.getInt("gap_pairs", p.gap_pairs);
  p.every_nth = section.getInt("every_nth", p.every_nth);
  p.point_step = section.getInt("point_step", p.point_step);
  p.disparity_sigma_px = section.getDouble("disparity_sigma_px", p.disparity_sigma_px);
  p.max_range_sigma_m = section.getDouble("max_range_sigma_m", p.max_range_sigma_m);
  p.min_baseline_m = section.getDouble("min_baseline_m", p.min_baseline_m);
  if (p.gap_pairs < 1) throw ConfigError(section.path() + ": mono/gap_pairs must be at least 1");
  if (p.every_nth < 1) throw ConfigError(section.path() + ": mono/every_nth must be at least 1");
  if (p.point_step < 1) throw ConfigError(section.path() + ": mono/point_step must be at least 1");
  if (!(p.disparity_sigma_px > 0)) throw ConfigError(section.path() + ": mono/disparity_sigma_px must be > 0");
  if (!(p.max_range_sigma_m > 0)) throw ConfigError(section.path() + ": mono/max_range_sigma_m must be > 0");
  if (!(p.min_baseline_m > 0)) throw ConfigError(section.path() + ": mono/min_baseline_m must be > 0");
  return p;
}

MonoDepth::MonoDepth(VulkanContext& ctx, const CameraIntrinsics& camera, const SgmParams& sgm,
                     const MonoDepthParams& params)
    : camera_(camera), params_(params), matcher_(ctx, params.polar.size, sgm) {}

MonoDepthResult MonoDepth::compute(const cv::Mat& raw_a, const cv::Mat& raw_b, const Eigen::Isometry3d& T_a_b) {
  MonoDepthResult out;
  out.baseline_m = T_a_b.translation().norm();
  if (out.baseline_m < params_.min_baseline_m) return out;
  rect_ = polarRectification(camera_, T_a_b, params_.polar);
  matcher_.setRectification(rect_.maps, cv::Size(camera_.width, camera_.height));
  cv::Mat left;
  const MatchOutput m = matcher_.matchRaw(rect_.left_is_b ? raw_b : raw_a, rect_.left_is_b ? raw_a : raw_b, &left);
  out.matched = true;
  for (int v = 0; v < m.disparity.rows; ++v)
    for (int u = 0; u < m.disparity.cols; ++u) {
      if (!rect_.valid.at<uint8_t>(v, u)) continue;
      ++out.masked;
      const int16_t raw = m.disparity.at<int16_t>(v, u);
      if (raw == kInvalidDisparity) continue;
      ++out.valid;
      if (u % params_.point_step != 0 || v % params_.point_step != 0) continue;
      const double d = double(raw) / kSubpixelScale;
      const Eigen::Vector3d X = rect_.triangulate(u, v, d);
      const Eigen::Vector3d X_off = rect_.triangulate(u, v, d + params_.disparity_sigma_px);
      if (!X.allFinite() || !X_off.allFinite() || (X - X_off).norm() > params_.max_range_sigma_m) continue;
      out.points.push_back(X.cast<float>());
      out.intensity.push_back(left.at<uint8_t>(v, u));
      out.pixels.emplace_back(u, v);
    }
  return out;
}

std::vector<double> depthDifferences(const MonoDepthResult& result, const StereoRectification& rect,
                                     const cv::Mat& stereo_disparity) {
  std::vector<double> out;
  for (const Eigen::Vector3f& X : result.points) {
    const Eigen::Vector3d Xr = rect.R_rect0_cam0 * X.cast<double>();
    if (Xr.z() <= 0) continue;
    const int u = static_cast<int>(std::lround(rect.f * Xr.x() / Xr.z() + rect.cx));
    const int v = static_cast<int>(std::lround(rect.f * Xr.y() / Xr.z() + rect.cy));
    if (u < 0 || v < 0 || u >= stereo_disparity.cols || v >= stereo_disparity.rows) continue;
    const int16_t d = stereo_disparity.at<int16_t>(v, u);
    if (d == kInvalidDisparity || d <= 0) continue;
    const double z_stereo = rect.f * rect.baseline / (double(d) / kSubpixelScale);
    out.push_back(std::abs(Xr.z() - z_stereo) / z_stereo);
  }
  return out;
}

}  // namespace ips::e3d
