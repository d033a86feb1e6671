#pragma once
// E3D's stereo map of a rendered pair scored against the simulator's true disparity, as the main job's report scores
// it (shared by the simulation tools).
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/e3d/sgm.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/e3d/vulkan_context.hpp"

namespace ips::tracker {

constexpr double kBadDisparityPx = 2.0;  // bad 2.0, at full resolution

// E3D at the config's scale with a given right-camera correction, scored against the true disparity (full resolution,
// 0 = nothing seen) as the main job's report scores it: at E3D's scale, bad when invalid or more than 2 px
// (full-resolution px) off.
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
    const cv::Mat& d = out.disparity;
    int64_t evaluated = 0, bad = 0, valid = 0;
    std::vector<double> depth_errors;
    for (int r = 0; r < d.rows; ++r)
      for (int c = 0; c < d.cols; ++c) {
        const int16_t v = d.at<int16_t>(r, c);
        const bool ok = v != e3d::kInvalidDisparity;
        valid += ok;
        // The true disparity where this map pixel samples the full-resolution image.
        const int gr = std::min(gt_full.rows - 1, int(std::lround((r + 0.5) / scale_ - 0.5)));
        const int gc = std::min(gt_full.cols - 1, int(std::lround((c + 0.5) / scale_ - 0.5)));
        const float g = gt_full.at<float>(gr, gc);
        if (!(g > 0)) continue;
        ++evaluated;
        const float full = float(v) / e3d::kSubpixelScale / scale_;
        if (!ok || std::abs(full - g) > kBadDisparityPx) ++bad;
        if (ok && full > 0 && median_depth_error) depth_errors.push_back(std::abs(g - full) / full);
      }
    if (median_depth_error) {
      *median_depth_error = 0;
      if (!depth_errors.empty()) {
        std::nth_element(depth_errors.begin(), depth_errors.begin() + depth_errors.size() / 2, depth_errors.end());
        *median_depth_error = 100.0 * depth_errors[depth_errors.size() / 2];
      }
    }
    return {evaluated ? 100.0 * bad / evaluated : 0.0, 100.0 * valid / (double(d.rows) * d.cols)};
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

}  // namespace ips::tracker
