#pragma once
// The simulated sensor head: its geometry (the calibration written for the other processes, drawn once per
// seed), and the IMU and tilt sensor sampled from the trajectory with the configured errors. All times are
// integer microseconds on the head's common clock; t [s] = (utime - start_utime) * 1e-6.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>

#include "ips/calibration.hpp"
#include "ips/sim/rng.hpp"
#include "ips/sim/scenario.hpp"
#include "ips/sim/trajectory.hpp"

namespace ips::sim {

// The IMU's and the tilt sensor's figures as the head's description gives them to the processes (its data sheet):
// what the calibration file written for them carries under `imu` and `tilt`.
ImuDescription imuDescription(const ImuFigures& f);
TiltDescription tiltDescription(const TiltFigures& f);

struct SensorHead {
  StereoCalibration calibration;  // the true geometry (project calibration format)
  Eigen::Isometry3d T_imu_cam0 = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_cam0_cam1 = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d R_tilt_imu = Eigen::Matrix3d::Identity();
  // The right camera's turn after calibration (CameraFigures::relative_rotation_step_deg, _drift_deg_per_min) [rad].
  Eigen::Vector3d cam1_step = Eigen::Vector3d::Zero();
  double cam1_step_s = 0;
  Eigen::Vector3d cam1_drift_per_s = Eigen::Vector3d::Zero();

  // Intrinsics from the camera figures; the IMU and tilt misalignments are drawn from the seed.
  static SensorHead make(const Scenario& scenario);
  // The calibration the processes are given: the true one (source "true") or, with calibration_errors, the true
  // one with errors drawn from the seed (source "perturbed"). The renderer always uses the truth.
  StereoCalibration calibrationForProcesses(const Scenario& scenario) const;
  // The head as designed (what a user knows before calibrating: the data sheets and the drawing): pinhole cameras of
  // the nominal focal length centred on the image without distortion, parallel at the nominal baseline, the IMU and
  // the tilt sensor aligned with the head's axes at the drawn lever arm; source "design". The calibration tools
  // start from it.
  static StereoCalibration design(const Scenario& scenario);
  // Pose of camera 0 / camera 1 in the world when the body is at T_world_imu.
  Eigen::Isometry3d cam0InWorld(const Eigen::Isometry3d& T_world_imu) const { return T_world_imu * T_imu_cam0; }
  // t [s] since the scenario start: the right camera as turned by then.
  Eigen::Isometry3d cam1InWorld(const Eigen::Isometry3d& T_world_imu, double t) const {
    Eigen::Isometry3d turned = Eigen::Isometry3d::Identity();
    turned.linear() = cam1Turn(t);
    return T_world_imu * T_imu_cam0 * T_cam0_cam1 * turned;
  }
  // Rotation of the right camera at t against its calibrated orientation (R_cam1calibrated_cam1now).
  Eigen::Matrix3d cam1Turn(double t) const;
};

// Sample time k of a sensor at rate_hz: integer microseconds, exactly reproducible.
inline int64_t sampleUtime(int64_t start_utime, int64_t k, double rate_hz) {
  return start_utime + std::llround(static_cast<double>(k) * 1e6 / rate_hz);
}

struct ImuMeasurement {
  int64_t seq = 0;
  int64_t utime_true = 0;                                    // when the sample was taken
  int64_t utime_stamp = 0;                                   // what the sensor's time stamp says (offset and jitter)
  int64_t utime_arrival = 0;                                 // when the message is delivered (latency)
  Eigen::Vector3d angular_rate = Eigen::Vector3d::Zero();    // [rad/s] measured, IMU frame
  Eigen::Vector3d specific_force = Eigen::Vector3d::Zero();  // [m/s^2] measured, IMU frame
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();       // [rad/s] true bias in this sample
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();      // [m/s^2]
};

class ImuSimulator {
 public:
  ImuSimulator(const ImuFigures& figures, const Trajectory& trajectory, int64_t start_utime, uint64_t seed);
  ImuMeasurement next();  // samples 0, 1, 2, ... in order

  // Per-sample white-noise standard deviations implied by the figures (rate noise density * sqrt(rate)).
  double gyroNoiseSigma() const { return gyro_sigma_; }
  double accelNoiseSigma() const { return accel_sigma_; }

 private:
  ImuFigures f_;
  const Trajectory& traj_;
  int64_t start_utime_;
  Rng rng_;
  int64_t k_ = 0;
  double gyro_sigma_, accel_sigma_, gyro_walk_, accel_walk_;
  Eigen::Vector3d bg_, ba_;
};

struct TiltMeasurement {
  int64_t seq = 0;
  int64_t utime_true = 0;
  int64_t utime_stamp = 0;
  int64_t utime_arrival = 0;
  double angle_x = 0, angle_y = 0;            // [rad] measured (tilt_sample_t semantics)
  double true_angle_x = 0, true_angle_y = 0;  // [rad] inclination of the sensor against gravity alone
};

// Inclination angles of the tilt frame's x and y axes against the horizontal, from a specific force in
// the tilt frame (at rest: f = +g up).
Eigen::Vector2d inclination(const Eigen::Vector3d& specific_force_tilt);

class TiltSimulator {
 public:
  TiltSimulator(const TiltFigures& figures, const Trajectory& trajectory, const Eigen::Matrix3d& R_tilt_imu,
                int64_t start_utime, double gravity, uint64_t seed);
  TiltMeasurement next();

  Eigen::Vector2d offset() const { return offset_; }  // [rad] constant error of this sensor

 private:
  Eigen::Vector3d forceAt(double t) const;

  TiltFigures f_;
  const Trajectory& traj_;
  Eigen::Matrix3d R_tilt_imu_;
  int64_t start_utime_;
  double gravity_;
  Rng rng_;
  int64_t k_ = 0;
  double t_filter_ = 0;
  Eigen::Vector3d filtered_;
  Eigen::Vector2d offset_;
};

}  // namespace ips::sim
