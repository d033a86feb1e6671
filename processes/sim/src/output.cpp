#include "ips/sim/output.hpp"

#include <algorithm>
#include <cmath>

#include "ips/calibration.hpp"
#include "ips/log.hpp"

namespace ips::sim {

FixedPointDisparity toFixedPoint(const cv::Mat& gt_disparity) {
  FixedPointDisparity out;
  double max_d = 0;
  cv::minMaxLoc(gt_disparity, nullptr, &max_d);
  out.num_disparities = static_cast<int16_t>(std::min(2047.0, std::ceil(max_d) + 1));
  out.data.create(gt_disparity.rows, gt_disparity.cols, CV_16SC1);
  constexpr int s = FixedPointDisparity::kSubpixelScale;
  for (int y = 0; y < gt_disparity.rows; ++y)
    for (int x = 0; x < gt_disparity.cols; ++x) {
      const float d = gt_disparity.at<float>(y, x);
      out.data.at<int16_t>(y, x) =
          d > 0 && d * s < 32767 ? static_cast<int16_t>(std::lround(d * s)) : FixedPointDisparity::kInvalid;
    }
  return out;
}

std::string truthCalibrationPath(const std::string& calib_path) {
  const std::string suffix = ".calib.yaml";
  const bool has_suffix = calib_path.size() > suffix.size() &&
                          calib_path.compare(calib_path.size() - suffix.size(), suffix.size(), suffix) == 0;
  return (has_suffix ? calib_path.substr(0, calib_path.size() - suffix.size()) : calib_path) + ".true.calib.yaml";
}

void writeCalibrations(const Scenario& scenario, const SensorHead& head, const std::string& calib_path) {
  const StereoCalibration told = head.calibrationForProcesses(scenario);
  saveCalibration(calib_path, told);
  if (told.source != "perturbed") return;
  StereoCalibration truth = head.calibration;
  truth.source = "true";
  const std::string truth_path = truthCalibrationPath(calib_path);
  saveCalibration(truth_path, truth);
  IPS_INFO("the processes get a perturbed calibration (" << calib_path << "); the truth is in " << truth_path);
}

LiveClock::Clock::time_point LiveClock::due(int64_t log_utime, Clock::time_point now) {
  if (!started_) {
    wall0_ = now + kStartDelay - sinceStart(log_utime);
    started_ = true;
  }
  return wall0_ + sinceStart(log_utime);
}

}  // namespace ips::sim
