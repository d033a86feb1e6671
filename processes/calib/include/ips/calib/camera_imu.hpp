#pragma once
// Camera to IMU: the rotation between the IMU's and camera 0's frames and the time offset between their stamps,
// estimated together from a recording in which the head turns about all axes (the paper's section 3: "comparing
// both, measured IMU angle velocities and calculated angular velocities from the camera"). The camera's side is the
// stereo tracker's rotation over each pair interval; the IMU's side is the gyro integrated over the same interval
// shifted by the delay. The translation (lever arm) is not observable from rotations: it is measured mechanically or
// estimated by the filter.
//
// Model, for each tracker interval [t0, t1] (camera stamps):
//   R_tracker = R_cam_imu * G(t0 - d, t1 - d; b) * R_cam_imu^T
// G: the gyro's rates minus a constant bias b integrated (body at t1 in body at t0, the tracker_delta_t convention);
// d: the delay (> 0: camera stamps late against the IMU's, as in delay_estimation.hpp). Residual: the rotation
// vector of R_tracker^T * (model), in the camera frame. Steps:
//   1. d from the correlation of the rates' magnitudes (delay_estimation.hpp): independent of the unknown rotation;
//   2. R_cam_imu in closed form (Kabsch) from the intervals' rotation vectors, camera against IMU;
//   3. Gauss-Newton on (rotation, b, d) together, intervals with residuals beyond a robust bound left out;
//      the covariance from the normal equations scaled by the residuals' spread.
#include <Eigen/Core>
#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "ips/calib/delay_estimation.hpp"

namespace ips::calib {

struct CameraImuConfig {
  DelayEstimatorConfig coarse;  // step 1's search (range, grid, intervals needed)
  int iterations = 15;          // Gauss-Newton iterations at most
  // Intervals whose residual exceeds this many robust standard deviations (1.4826 * median absolute residual) are
  // left out: a tracker delta from a bad pair must not bend the estimate.
  double outlier_sigmas = 4.0;
  double min_rotation_deg = 0.5;  // intervals turning less carry no direction for step 2 (still used in step 3)
  // The rotation when it is known already (from a calibration): step 2 is skipped and step 3 fits the bias and the
  // delay alone. For a running system, whose motion (a walk: turns about the vertical, the gait's sway) need not
  // determine the rotation, but whose calibration gives it.
  std::optional<Eigen::Matrix3d> known_R_imu_cam;
};

struct CameraImuEstimate {
  bool ok = false;
  std::string reason;                                            // why not ok
  Eigen::Matrix3d R_imu_cam = Eigen::Matrix3d::Identity();       // the rotation part of StereoCalibration::T_imu_cam0
  Eigen::Vector3d rotation_sigma_deg = Eigen::Vector3d::Zero();  // 1 sigma per axis of the IMU frame (0 when known)
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();           // [rad/s] in the IMU frame, over the recording
  double delay_us = 0, delay_sigma_us = 0;
  double coarse_delay_us = 0, coarse_correlation = 0;  // step 1
  double residual_rms_deg = 0;                         // per interval and axis, of the intervals kept
  size_t intervals = 0;                                // used in the final fit
  size_t rejected = 0;                                 // left out as outliers
};

// gyro and deltas in any order; deltas with no positive interval or not covered by the gyro are skipped.
// Throws std::invalid_argument on a bad configuration.
CameraImuEstimate calibrateCameraImu(const std::vector<GyroSample>& gyro, const std::vector<TrackerRotation>& deltas,
                                     const CameraImuConfig& config = {});

}  // namespace ips::calib
