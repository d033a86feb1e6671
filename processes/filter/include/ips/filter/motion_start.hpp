#pragma once
// The start of the filter while the head moves, from the IMU and the tracker's first deltas (a visual-inertial
// initialisation): the gyro bias from the tracker's rotations against the gyro's over the same intervals, then the
// body's velocity and the gravity vector at the first image from the tracker's chained positions against the doubly
// integrated specific force. Both are linear least squares; their covariances come from the deltas' and the IMU's
// noise.
//
// Why: a head that moves from the start has no rest to average gravity and the gyro bias over. The mean specific
// force over a window tilts gravity by the window's net acceleration, and a MEMS gyro's turn-on bias (several deg/s
// on the EuRoC MAV's ADIS16448) is unknown until the tracker's rotations are compared with the gyro's. Started on
// such guesses, the filter corrects its attitude by degrees at its first deltas: the trajectory after the start is
// turned by that correction against its first pose.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "ips/filter/estimator.hpp"

namespace ips::filter {

struct MotionStartInput {
  // IMU samples covering [deltas.front().utime_prev, deltas.back().utime] (zero-order hold: sample k's values hold
  // until sample k + 1), latency-corrected stamps.
  std::vector<ImuSample> imu;
  // Consecutive valid deltas: each one's utime_prev is the previous one's utime.
  std::vector<TrackerDelta> deltas;
  Eigen::Isometry3d T_imu_cam0 = Eigen::Isometry3d::Identity();
  double gyro_noise_density = 0;   // [rad/s/sqrt(Hz)]
  double accel_noise_density = 0;  // [m/s^2/sqrt(Hz)]
  double gravity = 9.81;
  // |estimated gravity| must be within this share of `gravity`: a larger misfit means the deltas or the IMU do not
  // describe the same motion (a bad delta, a wrong calibration) and the start waits for more.
  double max_gravity_error = 0.05;
};

struct MotionStart {
  int64_t utime = 0;  // the first image of the chain: the state's time
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
  Eigen::Matrix3d gyro_bias_covariance = Eigen::Matrix3d::Zero();
  double gyro_bias_variance_factor = 1;  // the fit's chi-square per degree of freedom (at least 1), in the covariance
  // In the body frame at utime: the velocity of the body and the gravity vector (pointing down; with the
  // accelerometer's bias in it), with the covariance of both (order v, g).
  Eigen::Vector3d velocity_body = Eigen::Vector3d::Zero();
  Eigen::Vector3d gravity_body = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  double gravity_error = 0;  // | |gravity_body| / gravity - 1 |
};

// nullopt (and the reason in *why) when the input cannot give a start: too few deltas, the IMU does not cover them,
// a singular system, or the gravity misfit above.
std::optional<MotionStart> estimateMotionStart(const MotionStartInput& in, std::string* why = nullptr);

}  // namespace ips::filter
