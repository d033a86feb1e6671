#pragma once
// What the `sim` process makes of the simulation besides encoding messages: ground-truth disparity in the fixed
// point of a DISPARITY map, the calibration files beside a log, and the pacing of live mode. Plain types, no LCM.
#include <chrono>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

#include "ips/sim/scenario.hpp"
#include "ips/sim/sensors.hpp"

namespace ips::sim {

// Ground-truth disparity (CV_32F, 0 = nothing seen) as 1/16 px integers (CV_16S), kInvalid where nothing was seen
// or the value does not fit; num_disparities covers the largest, at most 2047.
struct FixedPointDisparity {
  static constexpr int kSubpixelScale = 16;
  static constexpr int16_t kInvalid = -1;
  cv::Mat data;
  int16_t num_disparities = 0;
};
FixedPointDisparity toFixedPoint(const cv::Mat& gt_disparity);

// FILE.calib.yaml -> FILE.true.calib.yaml (any other name: NAME.true.calib.yaml).
std::string truthCalibrationPath(const std::string& calib_path);
// FILE.calib.yaml is what the processes are given. When it is perturbed, the truth goes beside it as
// FILE.true.calib.yaml, for evaluation only.
void writeCalibrations(const Scenario& scenario, const SensorHead& head, const std::string& calib_path);

// Live mode's clock: each event is due at its log time over `rate`, the clock starting half a second after the
// first event is taken (the samples between two frames are generated with the later frame).
class LiveClock {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr auto kStartDelay = std::chrono::milliseconds(500);
  static constexpr auto kLate = std::chrono::milliseconds(50);  // published later than this counts as late

  LiveClock(int64_t start_utime, double rate) : start_utime_(start_utime), rate_(rate) {}
  // When the event with this log time is due; the first call, at `now`, starts the clock.
  Clock::time_point due(int64_t log_utime, Clock::time_point now);
  static bool late(Clock::time_point due, Clock::time_point now) { return now - due > kLate; }

 private:
  Clock::duration sinceStart(int64_t log_utime) const {
    return std::chrono::microseconds(static_cast<int64_t>((log_utime - start_utime_) / rate_));
  }
  int64_t start_utime_;
  double rate_;
  bool started_ = false;
  Clock::time_point wall0_;
};

}  // namespace ips::sim
