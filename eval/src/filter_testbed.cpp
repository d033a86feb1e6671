#include "ips/eval/filter_testbed.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "ips/filter/models.hpp"
#include "ips/random_vector.hpp"

namespace ips::eval {

using namespace ips::filter;

StereoCalibration testbedCalibration() {
  StereoCalibration c;
  c.cam0.width = c.cam1.width = 1360;
  c.cam0.height = c.cam1.height = 1024;
  c.cam0.K << 1200, 0, 680, 0, 1200, 512, 0, 0, 1;
  c.cam1.K = c.cam0.K;
  c.t_cam1_cam0 = Eigen::Vector3d(-0.2, 0, 0);
  // Camera looking forward along the body x axis (body: x forward, y left, z up), a few mm off the IMU.
  Eigen::Matrix3d R_imu_cam;
  R_imu_cam << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  c.T_imu_cam0.linear() = expSO3(Eigen::Vector3d(0.004, -0.003, 0.002)) * R_imu_cam;
  c.T_imu_cam0.translation() = Eigen::Vector3d(0.06, 0.10, -0.03);
  // Tilt sensor mounted level in the body with a small misalignment.
  const Eigen::Matrix3d R_tilt_imu = expSO3(Eigen::Vector3d(0.003, 0.002, 0.3));
  c.R_tilt_cam0 = R_tilt_imu * c.T_imu_cam0.linear();
  return c;
}

filter::NavState navStateOf(const InertialState& g) {
  filter::NavState n;
  static_cast<InertialState&>(n) = g;
  return n;
}

SensorSim::SensorSim(const AnalyticWalk& walk, const SensorSimParams& p, const StereoCalibration& calib, uint32_t seed)
    : walk_(walk), p_(p), calib_(calib), rng_(seed) {}

Eigen::Vector3d SensorSim::noise3() {
  return drawVector3([&] { return n01_(rng_); });
}

NavState SensorSim::truth(int64_t utime) const {
  NavState n;
  static_cast<KinematicState&>(n) = walk_.at(utime * 1e-6);
  n.utime = utime;
  n.gyro_bias = p_.gyro_bias;
  n.accel_bias = p_.accel_bias;
  return n;
}

NavState SensorSim::sampleAround(const NavState& truth, const Matrix21d& P) {
  Vector21d z;
  for (int i = 0; i < 21; ++i) z(i) = n01_(rng_);
  const Matrix21d L = Eigen::LLT<Matrix21d>(P).matrixL();
  return boxplus(truth, (L * z).eval());
}

ImuSample SensorSim::imu(int64_t utime) {
  const KinematicState s = walk_.at(utime * 1e-6);
  ImuSample m;
  m.utime = utime;
  const double sg = p_.gyro_noise_density * std::sqrt(p_.imu_rate_hz);
  const double sa = p_.accel_noise_density * std::sqrt(p_.imu_rate_hz);
  m.angular_rate = s.angular_rate + p_.gyro_bias + sg * noise3();
  m.specific_force = s.specificForce(p_.gravity) + p_.accel_bias + sa * noise3();
  return m;
}

TiltSample SensorSim::tilt(int64_t utime) {
  const KinematicState s = walk_.at(utime * 1e-6);
  const Eigen::Matrix3d R_body_tilt = calib_.T_imu_cam0.linear() * calib_.R_tilt_cam0.transpose();
  // An accelerometer-type inclinometer: it senses the specific force (no response lag modelled here).
  const Eigen::Vector2d z =
      TiltMeasurement::predict(s.orientation, R_body_tilt, s.acceleration + Eigen::Vector3d(0, 0, p_.gravity));
  TiltSample m;
  m.utime = utime;
  m.angle_x = z.x() + p_.tilt_offset.x() + p_.tilt_sigma * n01_(rng_);
  m.angle_y = z.y() + p_.tilt_offset.y() + p_.tilt_sigma * n01_(rng_);
  return m;
}

TrackerDelta SensorSim::delta(int64_t utime_prev, int64_t utime) {
  const KinematicState s0 = walk_.at(utime_prev * 1e-6), s1 = walk_.at(utime * 1e-6);
  PoseClone c0, c1;
  c0.position = s0.position, c0.orientation = s0.orientation;
  c1.position = s1.position, c1.orientation = s1.orientation;
  const Eigen::Isometry3d T = DeltaMeasurement::predict(c0, c1, calib_.T_imu_cam0);
  TrackerDelta d;
  d.utime = utime;
  d.utime_prev = utime_prev;
  d.translation = (1.0 + p_.tracker_scale_error) * T.translation() + p_.tracker_sigma_t * noise3();
  d.rotation = Eigen::Quaterniond(expSO3(p_.tracker_sigma_r * noise3()) * T.linear()).normalized();
  d.covariance.setZero();
  d.covariance.diagonal() << Eigen::Vector3d::Constant(p_.tracker_sigma_t * p_.tracker_sigma_t),
      Eigen::Vector3d::Constant(p_.tracker_sigma_r * p_.tracker_sigma_r);
  return d;
}

std::vector<FilterOutput> runSimulation(Estimator& est, SensorSim& sim, double t_start_s, double t_end_s,
                                        bool use_tracker, bool use_tilt, const Matrix21d& P0) {
  const int64_t t0 = static_cast<int64_t>(std::llround(t_start_s * 1e6));
  const int64_t t1 = static_cast<int64_t>(std::llround(t_end_s * 1e6));
  if (!P0.isZero()) {
    // Start from a sample of the initial distribution around the truth, so that the errors match P0.
    est.initialize(sim.sampleAround(sim.truth(t0), P0), P0);
  }
  const int64_t imu_dt = static_cast<int64_t>(std::llround(1e6 / sim.params().imu_rate_hz));
  const int64_t tilt_dt = static_cast<int64_t>(std::llround(1e6 / sim.params().tilt_rate_hz));
  const int64_t img_dt = static_cast<int64_t>(std::llround(1e6 / sim.params().image_rate_hz));
  int64_t next_imu = t0 + imu_dt, next_tilt = t0 + tilt_dt / 2, next_img = t0 + img_dt / 3;
  int64_t last_img = INT64_MIN;
  std::vector<FilterOutput> out;
  while (true) {
    const int64_t t = std::min({next_imu, use_tilt ? next_tilt : INT64_MAX, use_tracker ? next_img : INT64_MAX});
    if (t > t1) break;
    if (t == next_imu) {
      est.addImu(sim.imu(t));
      next_imu += imu_dt;
    } else if (t == next_tilt) {
      est.addTilt(sim.tilt(t));
      next_tilt += tilt_dt;
    } else {
      est.addImageTime(t);
      if (last_img != INT64_MIN) est.addTrackerDelta(sim.delta(last_img, t));
      last_img = t;
      next_img += img_dt;
    }
    for (FilterOutput& o : est.takeOutputs()) out.push_back(std::move(o));
  }
  est.flush();
  for (FilterOutput& o : est.takeOutputs()) out.push_back(std::move(o));
  return out;
}

}  // namespace ips::eval
