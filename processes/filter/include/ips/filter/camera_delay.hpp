#pragma once
// The camera's delay against the IMU, estimated while the system runs (the paper's camera-to-IMU delay of section 3,
// online): the tracker's rotation over each pair interval against the gyro integrated over the same interval shifted
// by the delay, the rotation between camera and IMU taken from the calibration (ips/calib/camera_imu.hpp with the
// rotation known: a walk turns mostly about the vertical, which would not determine it).
//
// The result is a latency schedule for the camera's stamps. A new estimate holds for stamps from apply_after_us past
// the newest delta it used: no image can have come that far ahead of the tracker's deltas (its backlog is bounded
// below that), so every stamp keeps the latency it was first corrected with, and since the schedule depends on the
// stamps alone a replay gives the live run's.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <map>

#include "ips/calib/delay_estimation.hpp"
#include "ips/filter/params.hpp"

namespace ips::filter {

class CameraDelayEstimator {
 public:
  // A new latency applies to camera stamps this far past the newest delta its estimate used: beyond the tracker's
  // worst backlog (max_backlog_s, 1 s) and the filter's clone wait (clone_wait_us, 1.5 s).
  static constexpr int64_t kApplyAfterUs = 2'000'000;
  // An estimate replaces the latency in use when they differ by more than this many of its standard deviations.
  static constexpr double kSignificantSigmas = 3.0;
  // The gyro kept before the first delta has come: far more than the tracker takes for its first pair.
  static constexpr int64_t kGyroBeforeDeltasUs = 10'000'000;

  CameraDelayEstimator(const CameraDelayParams& params, const Eigen::Matrix3d& R_imu_cam, int64_t initial_latency_us);

  // Gyro samples on the IMU's (latency-corrected) time line, in stamp order.
  void addGyro(int64_t utime, const Eigen::Vector3d& rate);
  // A valid tracker delta: its camera stamps as they came (no latency removed), X_prev = R X_now.
  void addDelta(int64_t utime_prev, int64_t utime, const Eigen::Quaterniond& rotation);
  // The latency to subtract from camera stamp utime.
  int64_t latencyAt(int64_t utime) const;

  struct Figures {
    bool applied = false;   // an estimate is in the schedule (none: the configured latency was right)
    double delay_us = 0;    // the newest estimate (applied or not)
    double sigma_us = 0;    // its standard deviation
    size_t intervals = 0;   // tracker intervals it used
    int64_t estimates = 0;  // runs of the estimation
  };
  const Figures& figures() const { return figures_; }

 private:
  void estimate();

  CameraDelayParams params_;
  Eigen::Matrix3d R_imu_cam_;
  std::deque<calib::GyroSample> gyro_;
  std::deque<calib::TrackerRotation> deltas_;
  std::map<int64_t, int64_t> schedule_;  // camera stamp from which a latency holds -> that latency
  int since_estimate_ = 0;
  // An estimation is due once the gyro covers the deltas up to this stamp plus the search range.
  bool due_ = false;
  int64_t due_up_to_ = 0;
  Figures figures_;
};

}  // namespace ips::filter
