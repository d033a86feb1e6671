#pragma once
// Depth from one camera (paper, section 6): two exposures of the left camera, polar-rectified for their relative
// pose (ips/polar_rectification.hpp) and matched by the same StereoMatcher as a stereo pair, then triangulated.
// Useful when one camera fails, and for baselines longer than the head's. The pose comes from the navigation filter.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/e3d/sgm.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/e3d/vulkan_context.hpp"
#include "ips/polar_rectification.hpp"

namespace ips::e3d {

struct MonoDepthParams {
  PolarRectificationParams polar;
  int gap_pairs = 2;   // the earlier exposure is the one this many pairs before
  int every_nth = 48;  // pairs whose seq is a multiple of this get a map
  int point_step = 4;  // every point_step-th polar row and column becomes a point
  // A point is kept while a disparity error of disparity_sigma_px (columns) moves it by at most max_range_sigma_m,
  // the rule the mapper applies to the stereo maps' points (its max_depth_sigma_m, disparity_sigma_px).
  double disparity_sigma_px = 0.25;
  double max_range_sigma_m = 0.10;
  double min_baseline_m = 0.05;

  // Keys of section `mono` (absent: these defaults): gap_pairs, every_nth, point_step, disparity_sigma_px,
  // max_range_sigma_m, min_baseline_m,
  // and the polar keys (PolarRectificationParams::fromConfig). Throws ConfigError when one is out of range.
  static MonoDepthParams fromConfig(const Config& section);
};

struct MonoDepthResult {
  bool matched = false;                 // false: the baseline was below min_baseline_m (nothing else is set)
  double baseline_m = 0;                // distance between the two exposures
  std::vector<Eigen::Vector3f> points;  // camera a's frame [m]
  std::vector<uint8_t> intensity;       // grey value of the polar left image at the point's pixel
  std::vector<cv::Point> pixels;        // the point's polar pixel (column = distance, row = angle)
  int64_t masked = 0, valid = 0;        // polar pixels in the mask, and those with a disparity
};

// Points from one camera against a stereo map of the earlier exposure (`stereo_disparity`, the matcher's CV_16S of
// `rect`, the head's rectification at the map's scale): per point seen by the map, |z - z_stereo| / z_stereo in the
// rectified left frame. A cross-check of two depths with independent errors (the head's baseline against the
// motion); points outside the map or on invalid pixels are left out.
std::vector<double> depthDifferences(const MonoDepthResult& result, const StereoRectification& rect,
                                     const cv::Mat& stereo_disparity);

class MonoDepth {
 public:
  // Allocates a matcher of the polar size; throws std::invalid_argument as StereoMatcher does.
  MonoDepth(VulkanContext& ctx, const CameraIntrinsics& camera, const SgmParams& sgm, const MonoDepthParams& params);

  // raw_a, raw_b: the camera's raw 8-bit images at the earlier and the later exposure; T_a_b: the later camera's pose
  // in the earlier one's frame. The result's last polar rectification stays available through rectification().
  MonoDepthResult compute(const cv::Mat& raw_a, const cv::Mat& raw_b, const Eigen::Isometry3d& T_a_b);

  const PolarRectification& rectification() const { return rect_; }
  const MonoDepthParams& params() const { return params_; }

 private:
  CameraIntrinsics camera_;
  MonoDepthParams params_;
  StereoMatcher matcher_;
  PolarRectification rect_;
};

}  // namespace ips::e3d
