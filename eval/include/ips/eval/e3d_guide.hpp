#pragma once
// E3D in the same run as the tracker, for the tools that measure the tracker with and without E3D's disparity
// map (tracker_sim_eval, track_log --e3d-config): the e3d process's matcher (Vulkan; lavapipe without a GPU) on
// each raw pair, at the config's output_scale, turned into the tracker's DisparityGuide exactly as the tracker
// process turns a DISPARITY message into one.
#include <memory>
#include <stdexcept>
#include <string>

#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/e3d/sgm.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/e3d/vulkan_context.hpp"
#include "ips/tracker/matching.hpp"

namespace ips::eval {

class E3dGuide {
 public:
  // `tracker_rect`: the tracker's rectification (tracker::StereoTracker::rectification()); the map must belong to it.
  E3dGuide(const StereoCalibration& calib, const std::string& e3d_config, const StereoRectification& tracker_rect) {
    const Config cfg(e3d_config);
    const e3d::SgmParams params = e3d::SgmParams::fromConfig(cfg.has("sgm") ? cfg.section("sgm") : cfg);
    const double scale = cfg.getDouble("process/output_scale", 1.0);
    if (!(scale > 0 && scale <= 1)) throw ConfigError(cfg.path() + ": key 'process/output_scale' must be in (0, 1]");
    rect_ = scaledRectification(calib, scale);
    // The device as the e3d process chooses it ($IPS_VK_DEVICE, else the best GPU, else lavapipe).
    ctx_ = std::make_unique<e3d::VulkanContext>();
    matcher_ = std::make_unique<e3d::StereoMatcher>(*ctx_, rect_.size, params);
    matcher_->setRectification(rect_, cv::Size(calib.cam0.width, calib.cam0.height));
    const auto s = tracker::guideScale(tracker_rect, rect_.f, rect_.cx, rect_.cy, rect_.baseline, rect_.size);
    if (!s) throw std::invalid_argument("E3dGuide: E3D's rectification is not the tracker's (rectification_alpha 0?)");
    guide_.scale = *s;
    guide_.subpixel_scale = e3d::kSubpixelScale;
    guide_.invalid_value = e3d::kInvalidDisparity;
  }

  // The map of a raw pair; `ms` gets E3D's time for it.
  const tracker::DisparityGuide& match(const cv::Mat& raw_left, const cv::Mat& raw_right, double* ms = nullptr) {
    e3d::MatchOutput out = matcher_->matchRaw(raw_left, raw_right);
    guide_.disparity = out.disparity.clone();
    if (ms) *ms = out.total_ms;
    return guide_;
  }

 private:
  StereoRectification rect_;
  std::unique_ptr<e3d::VulkanContext> ctx_;
  std::unique_ptr<e3d::StereoMatcher> matcher_;
  tracker::DisparityGuide guide_;
};

}  // namespace ips::eval
