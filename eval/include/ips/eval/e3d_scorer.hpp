#pragma once
// E3D's stereo map of a rendered pair scored against the simulator's true disparity (shared by the simulation
// tools).
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/e3d/sgm.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/e3d/vulkan_context.hpp"
#include "ips/eval/disparity.hpp"

namespace ips::eval {

constexpr double kBadDisparityPx = 2.0;  // bad 2.0, at full resolution

// E3D at the config's scale with a given right-camera correction, scored against the true disparity (full resolution,
// 0 = nothing seen) at E3D's scale: bad when invalid or more than 2 full-resolution pixels off (the main job's report
// counts in E3D's own pixels instead, as benchmarks at a reduced resolution do).
class E3dScorer {
 public:
  // With ctx null the scorer makes its own Vulkan context.
  E3dScorer(const StereoCalibration& calib, const std::string& config, e3d::VulkanContext* ctx = nullptr)
      : calib_(calib) {
    const Config cfg(config);
    params_ = e3d::SgmParams::fromConfig(cfg.has("sgm") ? cfg.section("sgm") : cfg);
    scale_ = cfg.getDouble("process/output_scale", 1.0);
    if (!ctx) {
      own_ctx_ = std::make_unique<e3d::VulkanContext>();
      ctx = own_ctx_.get();
    }
    ctx_ = ctx;
    rect_ = scaledRectification(calib, scale_);
    matcher_ = std::make_unique<e3d::StereoMatcher>(*ctx_, rect_.size, params_);
    setCorrection({});
  }
  void setCorrection(const RightCameraCorrection& c) {
    rect_ = scaledRectification(calib_, scale_, c);
    matcher_->setRectification(rect_, cv::Size(calib_.cam0.width, calib_.cam0.height));
  }
  // (bad 2.0 [%], density [%]); median_depth_error [%] when given: the median over valid pixels with a true
  // disparity of |z - z_true| / z_true = |d_true - d| / d.
  std::pair<double, double> score(const cv::Mat& raw0, const cv::Mat& raw1, const cv::Mat& gt_full,
                                  double* median_depth_error = nullptr) {
    const e3d::MatchOutput out = matcher_->matchRaw(raw0, raw1);
    last_match_ms_ = out.total_ms;
    const cv::Mat d = disparityPixels(out.disparity, e3d::kInvalidDisparity, e3d::kSubpixelScale);
    cv::Mat seen = gt_full.clone();
    seen.setTo(std::numeric_limits<float>::quiet_NaN(), ~(gt_full > 0));  // 0: nothing seen there
    const cv::Mat g = truthAtSize(seen, d.size());
    const DisparityErrors e = disparityErrors(d, g, {kBadDisparityPx}, cv::Mat(), 1.0 / scale_);
    if (median_depth_error) {
      // |z - z_true| / z_true = |d_true - d| / d over the valid pixels with a true disparity.
      std::vector<double> depth_errors;
      for (int r = 0; r < d.rows; ++r)
        for (int c = 0; c < d.cols; ++c) {
          const float v = d.at<float>(r, c), t = g.at<float>(r, c);
          if (std::isfinite(v) && std::isfinite(t) && v > 0) depth_errors.push_back(std::abs(t - v) / v);
        }
      *median_depth_error = 0;
      if (!depth_errors.empty()) {
        std::nth_element(depth_errors.begin(), depth_errors.begin() + depth_errors.size() / 2, depth_errors.end());
        *median_depth_error = 100.0 * depth_errors[depth_errors.size() / 2];
      }
    }
    return {e.badPct(0), e.densityPct()};
  }

  // Wall time of the last score's matching (upload, rectification, SGM, download) [ms].
  double lastMatchMs() const { return last_match_ms_; }
  cv::Size size() const { return rect_.size; }

 private:
  double last_match_ms_ = 0;
  StereoCalibration calib_;
  e3d::SgmParams params_;
  double scale_ = 1;
  StereoRectification rect_;
  std::unique_ptr<e3d::VulkanContext> own_ctx_;
  e3d::VulkanContext* ctx_ = nullptr;
  std::unique_ptr<e3d::StereoMatcher> matcher_;
};

}  // namespace ips::eval
