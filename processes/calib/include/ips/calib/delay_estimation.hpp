#pragma once
// Estimates the constant time offset between the camera stream and the IMU stream from recorded data: the
// angular rate seen by the stereo tracker (rotation of each delta over its interval) against the gyro.
// Both are compared by magnitude, |w|, which does not depend on the (possibly not yet calibrated) rotation
// between camera and IMU frames. For each candidate delay d the gyro is averaged over each tracker interval
// shifted by d (the tracker sees the mean rate over its interval, not a point value), and the delay with the
// highest correlation between the two magnitude series wins, refined to sub-step by a parabola.
//
// Sign: delay_us > 0 means camera stamps are late by delay_us against IMU stamps (the motion the tracker
// reports for [t0, t1] happened at [t0 - d, t1 - d] on the IMU's time line): add it to the camera's delay_us
// in config/camera.yaml (or subtract it from the IMU's).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <utility>
#include <vector>

namespace ips::calib {

struct GyroSample {
  int64_t utime;
  Eigen::Vector3d rate;  // [rad/s]
};

struct TrackerRotation {
  int64_t utime_prev, utime;
  Eigen::Quaterniond rotation;  // X_prev = R * X_now (tracker_delta_t convention)
};

struct DelayEstimatorConfig {
  int64_t max_delay_us = 200'000;  // search range +-
  int64_t step_us = 1'000;         // grid step before the parabola refinement
  size_t min_intervals = 20;       // fewer usable tracker intervals: no estimate
  double min_rate = 0.0;           // [rad/s] intervals slower than this are left out (noise only)
};

struct DelayEstimate {
  bool ok = false;
  double delay_us = 0;
  double correlation = 0;                        // at the best delay (1 = perfect)
  size_t intervals = 0;                          // tracker intervals used
  std::vector<std::pair<double, double>> curve;  // (delay_us, correlation) over the grid
};

DelayEstimate estimateCameraImuDelay(const std::vector<GyroSample>& gyro, const std::vector<TrackerRotation>& deltas,
                                     const DelayEstimatorConfig& config = {});

}  // namespace ips::calib
