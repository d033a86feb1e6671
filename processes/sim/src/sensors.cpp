#include "ips/sim/sensors.hpp"

#include <algorithm>
#include <cmath>

#include "ips/random_vector.hpp"
#include "ips/rotation.hpp"

namespace ips::sim {

namespace {

constexpr double kDeg = M_PI / 180;
constexpr double kMg = 9.80665e-3;  // 1 mg in m/s^2 (the datasheet's g)

Eigen::Matrix3d smallRotation(Rng& rng, double sigma_rad) {
  return expSO3(sigma_rad * drawVector3([&] { return rng.normal(); }));
}

double quantize(double v, double lsb) { return lsb > 0 ? std::round(v / lsb) * lsb : v; }

// Nominal mounting: camera z (forward) along body x, camera x (right) along body -y, camera y (down) along -z.
Eigen::Matrix3d nominalHeadCamera() {
  Eigen::Matrix3d R_head_cam;
  R_head_cam << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return R_head_cam;
}

}  // namespace

ImuDescription imuDescription(const ImuFigures& f) {
  ImuDescription d;
  d.model = "simulated MMQ-50 (sim scenario imu figures)";
  d.rate_hz = f.rate_hz;
  d.gyro_noise_density = f.gyro_arw_deg_sqrt_h * kDeg / 60.0;  // deg/sqrt(h) -> rad/s/sqrt(Hz)
  d.accel_noise_density = f.accel_vrw_mg_sqrt_hz * kMg;
  d.gyro_random_walk = f.gyro_bias_walk_deg_s_sqrt_s * kDeg;
  d.accel_random_walk = f.accel_bias_walk_mg_sqrt_s * kMg;
  d.gyro_bias_sigma = f.gyro_bias_deg_s * kDeg;
  d.accel_bias_sigma = f.accel_bias_mg * kMg;
  return d;
}

TiltDescription tiltDescription(const TiltFigures& f) {
  TiltDescription d;
  d.model = "simulated PEI-Z260 (sim scenario tilt figures)";
  d.rate_hz = f.rate_hz;
  d.accuracy = f.accuracy_deg * kDeg;
  d.resolution = f.resolution_deg * kDeg;
  return d;
}

SensorHead SensorHead::make(const Scenario& s) {
  const CameraFigures& c = s.camera;
  SensorHead head;
  StereoCalibration& cal = head.calibration;
  cal.cam0.width = cal.cam1.width = c.width;
  cal.cam0.height = cal.cam1.height = c.height;
  cal.cam0.K << c.focal_px, 0, (c.width - 1) * 0.5 + c.principal_offset_left.x(), 0, c.focal_px,
      (c.height - 1) * 0.5 + c.principal_offset_left.y(), 0, 0, 1;
  const double f1 = c.focal_px * c.focal_ratio_right;
  cal.cam1.K << f1, 0, (c.width - 1) * 0.5 + c.principal_offset_right.x(), 0, f1,
      (c.height - 1) * 0.5 + c.principal_offset_right.y(), 0, 0, 1;
  cal.cam0.distortion = c.distortion_left;
  cal.cam1.distortion = c.distortion_right;
  cal.cam0.serial = "SIM-LEFT";
  cal.cam1.serial = "SIM-RIGHT";
  // The renderer's natural vignetting, cos^4 theta = 1 / (1 + tan^2 theta)^2, is undone exactly by the flat-field
  // gain (1 + t)^2 = 1 + 2 t + t^2 (CameraIntrinsics::vignetting_gain).
  if (c.vignetting) cal.cam0.vignetting_gain = cal.cam1.vignetting_gain = Eigen::Vector3d(2, 1, 0);

  const Eigen::Vector3d rv = c.relative_rotation_deg * kDeg;
  const Eigen::Matrix3d R10 = expSO3(rv);
  const Eigen::Vector3d c1_in_cam0 = Eigen::Vector3d(c.baseline_m, 0, 0) + c.baseline_offset_m;
  cal.R_cam1_cam0 = R10;
  cal.t_cam1_cam0 = -R10 * c1_in_cam0;
  head.T_cam0_cam1.linear() = R10.transpose();
  head.T_cam0_cam1.translation() = c1_in_cam0;

  const Eigen::Matrix3d R_head_cam = nominalHeadCamera();
  Rng rng(streamSeed(s.seed, kStreamHead));
  const Eigen::Matrix3d R_imu_head = smallRotation(rng, s.imu.misalignment_mrad * 1e-3);
  head.T_imu_cam0.linear() = R_imu_head * R_head_cam;
  head.T_imu_cam0.translation() = s.imu.lever_arm_m;
  head.R_tilt_imu = smallRotation(rng, s.tilt.misalignment_deg * kDeg) * R_imu_head.transpose();
  cal.T_imu_cam0 = head.T_imu_cam0;
  cal.R_tilt_cam0 = head.R_tilt_imu * head.T_imu_cam0.linear();
  cal.imu = imuDescription(s.imu);
  cal.tilt = tiltDescription(s.tilt);
  head.cam1_step = c.relative_rotation_step_deg * kDeg;
  head.cam1_step_s = c.relative_rotation_step_s;
  head.cam1_drift_per_s = c.relative_rotation_drift_deg_per_min * kDeg / 60.0;
  return head;
}

StereoCalibration SensorHead::design(const Scenario& s) {
  const CameraFigures& c = s.camera;
  StereoCalibration cal;
  for (CameraIntrinsics* cam : {&cal.cam0, &cal.cam1}) {
    cam->width = c.width;
    cam->height = c.height;
    cam->K << c.focal_px, 0, (c.width - 1) * 0.5, 0, c.focal_px, (c.height - 1) * 0.5, 0, 0, 1;
  }
  cal.t_cam1_cam0 = Eigen::Vector3d(-c.baseline_m, 0, 0);
  cal.T_imu_cam0.linear() = nominalHeadCamera();
  cal.T_imu_cam0.translation() = s.imu.lever_arm_m;
  cal.R_tilt_cam0 = nominalHeadCamera();
  cal.imu = imuDescription(s.imu);
  cal.tilt = tiltDescription(s.tilt);
  cal.source = "design";
  return cal;
}

Eigen::Matrix3d SensorHead::cam1Turn(double t) const {
  const Eigen::Vector3d r =
      cam1_drift_per_s * std::max(t, 0.0) + (t >= cam1_step_s ? cam1_step : Eigen::Vector3d::Zero());
  return expSO3(r);
}

StereoCalibration SensorHead::calibrationForProcesses(const Scenario& s) const {
  StereoCalibration told = calibration;
  const CalibrationErrors& e = s.calibration_errors;
  if (!e.any()) {
    told.source = "true";
    return told;
  }
  told.source = "perturbed";
  Rng rng(streamSeed(s.seed, kStreamCalibration));
  for (CameraIntrinsics* cam : {&told.cam0, &told.cam1}) {
    const double scale = 1 + rng.normal() * e.focal_rel;
    cam->K(0, 0) *= scale;
    cam->K(1, 1) *= scale;
    cam->K(0, 2) += rng.normal() * e.principal_px;
    cam->K(1, 2) += rng.normal() * e.principal_px;
  }
  // The right camera turned about its own centre: rotation and translation of cam1-from-cam0 both turn.
  const Eigen::Matrix3d dR_stereo = smallRotation(rng, e.stereo_rotation_deg * kDeg);
  told.R_cam1_cam0 = dR_stereo * told.R_cam1_cam0;
  told.t_cam1_cam0 = dR_stereo * told.t_cam1_cam0;
  told.T_imu_cam0.linear() = smallRotation(rng, e.imu_rotation_deg * kDeg) * told.T_imu_cam0.linear();
  told.R_tilt_cam0 = smallRotation(rng, e.tilt_rotation_deg * kDeg) * told.R_tilt_cam0;
  return told;
}

ImuSimulator::ImuSimulator(const ImuFigures& f, const Trajectory& trajectory, int64_t start_utime, uint64_t seed)
    : f_(f), traj_(trajectory), start_utime_(start_utime), rng_(streamSeed(seed, kStreamImu)) {
  const double arw = f.gyro_arw_deg_sqrt_h * kDeg / 60.0;  // rad/s/sqrt(Hz) = rad/sqrt(s)
  gyro_sigma_ = arw * std::sqrt(f.rate_hz);
  accel_sigma_ = f.accel_vrw_mg_sqrt_hz * kMg * std::sqrt(f.rate_hz);
  gyro_walk_ = f.gyro_bias_walk_deg_s_sqrt_s * kDeg / std::sqrt(f.rate_hz);
  accel_walk_ = f.accel_bias_walk_mg_sqrt_s * kMg / std::sqrt(f.rate_hz);
  for (int i = 0; i < 3; ++i) bg_[i] = rng_.normal() * f.gyro_bias_deg_s * kDeg;
  for (int i = 0; i < 3; ++i) ba_[i] = rng_.normal() * f.accel_bias_mg * kMg;
}

ImuMeasurement ImuSimulator::next() {
  ImuMeasurement m;
  m.seq = k_;
  m.utime_true = sampleUtime(start_utime_, k_, f_.rate_hz);
  m.utime_stamp = m.utime_true + std::llround(f_.stamp_offset_us + f_.jitter_us * rng_.normal());
  m.utime_arrival = m.utime_true + std::llround(f_.latency_us);
  if (k_ > 0)
    for (int i = 0; i < 3; ++i) {
      bg_[i] += gyro_walk_ * rng_.normal();
      ba_[i] += accel_walk_ * rng_.normal();
    }
  const KinematicState s = traj_.state((m.utime_true - start_utime_) * 1e-6);
  const Eigen::Vector3d specific_force = s.specificForce(traj_.gravity());
  const double gyro_max = f_.gyro_range_deg_s * kDeg, accel_max = f_.accel_range_g * 9.80665;
  for (int i = 0; i < 3; ++i) {
    const double w = s.angular_rate[i] + bg_[i] + gyro_sigma_ * rng_.normal();
    const double a = specific_force[i] + ba_[i] + accel_sigma_ * rng_.normal();
    m.angular_rate[i] = quantize(std::clamp(w, -gyro_max, gyro_max), f_.gyro_lsb_deg_s * kDeg);
    m.specific_force[i] = quantize(std::clamp(a, -accel_max, accel_max), f_.accel_lsb_mg * kMg);
  }
  m.gyro_bias = bg_;
  m.accel_bias = ba_;
  ++k_;
  return m;
}

Eigen::Vector2d inclination(const Eigen::Vector3d& f) {
  return {std::atan2(f.x(), std::hypot(f.y(), f.z())), std::atan2(f.y(), std::hypot(f.x(), f.z()))};
}

TiltSimulator::TiltSimulator(const TiltFigures& f, const Trajectory& trajectory, const Eigen::Matrix3d& R_tilt_imu,
                             int64_t start_utime, double gravity, uint64_t seed)
    : f_(f),
      traj_(trajectory),
      R_tilt_imu_(R_tilt_imu),
      start_utime_(start_utime),
      gravity_(gravity),
      rng_(streamSeed(seed, kStreamTilt)) {
  offset_ = {rng_.normal() * f.accuracy_deg * kDeg, rng_.normal() * f.accuracy_deg * kDeg};
  filtered_ = forceAt(0);  // settled at the start
}

Eigen::Vector3d TiltSimulator::forceAt(double t) const {
  return R_tilt_imu_ * traj_.state(t).specificForce(traj_.gravity());
}

TiltMeasurement TiltSimulator::next() {
  TiltMeasurement m;
  m.seq = k_;
  m.utime_true = sampleUtime(start_utime_, k_, f_.rate_hz);
  m.utime_stamp = m.utime_true + std::llround(f_.stamp_offset_us + f_.jitter_us * rng_.normal());
  m.utime_arrival = m.utime_true + std::llround(f_.latency_us);
  const double t = (m.utime_true - start_utime_) * 1e-6;
  // The sensing element follows the specific force as a first-order low pass: exact step response over
  // 1 ms sub-steps with the input held at the sub-step's mid-point.
  if (f_.time_constant_s > 0) {
    while (t_filter_ < t - 1e-12) {
      const double dt = std::min(1e-3, t - t_filter_);
      const double a = 1.0 - std::exp(-dt / f_.time_constant_s);
      filtered_ += a * (forceAt(t_filter_ + 0.5 * dt) - filtered_);
      t_filter_ += dt;
    }
  } else {
    filtered_ = forceAt(t);
    t_filter_ = t;
  }
  const Eigen::Vector2d angles = inclination(filtered_);
  const KinematicState s = traj_.state(t);
  const Eigen::Vector3d up_in_tilt = R_tilt_imu_ * (s.orientation.conjugate() * Eigen::Vector3d(0, 0, gravity_));
  const Eigen::Vector2d truth = inclination(up_in_tilt);
  const double res = f_.resolution_deg * kDeg;
  m.angle_x = quantize(angles.x() + offset_.x() + f_.noise_deg * kDeg * rng_.normal(), res);
  m.angle_y = quantize(angles.y() + offset_.y() + f_.noise_deg * kDeg * rng_.normal(), res);
  m.true_angle_x = truth.x();
  m.true_angle_y = truth.y();
  ++k_;
  return m;
}

}  // namespace ips::sim
