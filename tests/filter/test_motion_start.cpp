// The start in motion from the tracker's deltas (ips/filter/motion_start.hpp): on the analytic walk against its
// closed-form truth (gyro bias, velocity, gravity), with a delta that contradicts the IMU refused; and through the
// estimator, which then starts at the chain's first image with its attitude and bias right.
#include <gtest/gtest.h>

#include <cmath>

#include "ips/eval/filter_testbed.hpp"
#include "ips/filter/estimator.hpp"
#include "ips/filter/motion_start.hpp"
#include "ips/log.hpp"

using namespace ips::filter;
using namespace ips::eval;

namespace {

// 20 Hz deltas and 200 Hz IMU from t0 on (mid-walk: the head is moving), with a gyro bias a MEMS gyro's turn-on
// leaves (0.08 rad/s on one axis, as the EuRoC MAV's ADIS16448 shows).
struct Window {
  MotionStartInput input;
  NavState truth;  // at the chain's first image
};

SensorSimParams movingHead() {
  SensorSimParams p;
  p.gyro_bias = Eigen::Vector3d(-0.003, 0.02, 0.08);
  p.accel_bias = Eigen::Vector3d::Zero();
  p.image_rate_hz = 20.0;
  p.tracker_sigma_t = 3e-4;
  p.tracker_sigma_r = 1e-4;
  return p;
}

Window makeWindow(SensorSim& sim, const ips::StereoCalibration& calib, int64_t t0, int deltas) {
  Window w;
  const int64_t image_us = 50'000, imu_us = 5'000;
  for (int64_t t = t0 - imu_us; t <= t0 + deltas * image_us + imu_us; t += imu_us) w.input.imu.push_back(sim.imu(t));
  for (int k = 1; k <= deltas; ++k) w.input.deltas.push_back(sim.delta(t0 + (k - 1) * image_us, t0 + k * image_us));
  w.input.T_imu_cam0 = calib.T_imu_cam0;
  w.input.gyro_noise_density = sim.params().gyro_noise_density;
  w.input.accel_noise_density = sim.params().accel_noise_density;
  w.truth = sim.truth(t0);
  return w;
}

}  // namespace

TEST(MotionStart, RecoversBiasVelocityAndGravityOnTheWalk) {
  const AnalyticWalk walk;
  const ips::StereoCalibration calib = testbedCalibration();
  SensorSim sim(walk, movingHead(), calib, 7);
  const Window w = makeWindow(sim, calib, 30'000'000, 20);  // 1 s of walking, 30 s into the walk
  std::string why;
  const auto start = estimateMotionStart(w.input, &why);
  ASSERT_TRUE(start) << why;
  EXPECT_EQ(start->utime, 30'000'000);
  // The gyro bias from 20 deltas of 0.1 mrad each: to a few 1e-4 rad/s, and within its own 4 sigma.
  const Eigen::Vector3d bias_error = start->gyro_bias - sim.params().gyro_bias;
  EXPECT_LT(bias_error.norm(), 1e-3) << start->gyro_bias.transpose();
  for (int a = 0; a < 3; ++a) EXPECT_LT(std::fabs(bias_error[a]), 4 * std::sqrt(start->gyro_bias_covariance(a, a)));
  // Velocity and gravity in the body frame at the first image.
  const Eigen::Matrix3d R_wb = w.truth.orientation.toRotationMatrix();
  const Eigen::Vector3d v_body = R_wb.transpose() * w.truth.velocity;
  const Eigen::Vector3d g_body = R_wb.transpose() * Eigen::Vector3d(0, 0, -9.81);
  EXPECT_LT((start->velocity_body - v_body).norm(), 0.01)
      << start->velocity_body.transpose() << " / " << v_body.transpose();
  const double tilt_error = std::acos(std::clamp(start->gravity_body.normalized().dot(g_body.normalized()), -1.0, 1.0));
  // [rad]: the tracker's 0.3 mm per delta over 1 s; and within 3 sigma of the fit's own uncertainty across gravity.
  const Eigen::Matrix3d P_g = start->covariance.bottomRightCorner<3, 3>();
  const Eigen::Vector3d n = g_body.normalized();
  const double tilt_sigma = std::sqrt((P_g - n * (n.transpose() * P_g * n) * n.transpose()).trace() / 2) / 9.81;
  EXPECT_LT(tilt_error, 2e-3);
  EXPECT_LT(tilt_error, 3 * tilt_sigma) << "sigma " << tilt_sigma;
  EXPECT_LT(start->gravity_error, 0.01);
}

TEST(MotionStart, RefusesDeltasTheImuContradicts) {
  const AnalyticWalk walk;
  const ips::StereoCalibration calib = testbedCalibration();
  SensorSim sim(walk, movingHead(), calib, 8);
  Window w = makeWindow(sim, calib, 40'000'000, 20);
  // Steps in millimetres (a calibration's baseline in the wrong unit): positions and the IMU's acceleration
  // disagree.
  for (TrackerDelta& d : w.input.deltas) d.translation *= 1000.0;
  std::string why;
  EXPECT_FALSE(estimateMotionStart(w.input, &why));
  EXPECT_NE(why.find("gravity misfit"), std::string::npos) << why;
  // A chain with a hole is no chain.
  Window broken = makeWindow(sim, calib, 40'000'000, 20);
  broken.input.deltas.erase(broken.input.deltas.begin() + 5);
  EXPECT_FALSE(estimateMotionStart(broken.input, &why));
  EXPECT_NE(why.find("chain"), std::string::npos) << why;
}

TEST(MotionStart, EstimatorStartsAtTheFirstImageOfAMovingHead) {
  ips::setLogLevel(ips::LogLevel::Error);
  const AnalyticWalk walk;
  const ips::StereoCalibration calib = testbedCalibration();
  SensorSimParams sp = movingHead();
  SensorSim sim(walk, sp, calib, 9);
  FilterParams params;
  params.init.moving_sigma_gyro_bias = 0.1;  // a turn-on bias of 0.08 rad/s is within the prior
  params.reorder_window_us = 100'000;
  Estimator est(params, calib);
  // Messages from 30 s into the walk on, as they come: IMU at 200 Hz, images at 20 Hz, each delta 30 ms after its
  // image (the tracker's latency).
  const int64_t t0 = 30'000'000, image_us = 50'000;
  std::vector<std::pair<int64_t, TrackerDelta>> pending;
  for (int64_t t = t0; t <= t0 + 3'000'000; t += 5'000) {
    est.addImu(sim.imu(t));
    if ((t - t0) % image_us == 0) {
      est.addImageTime(t);
      if (t > t0) pending.emplace_back(t + 30'000, sim.delta(t - image_us, t));
    }
    while (!pending.empty() && pending.front().first <= t) {
      est.addTrackerDelta(pending.front().second);
      pending.erase(pending.begin());
    }
  }
  ASSERT_TRUE(est.initialized());
  EXPECT_EQ(est.startsInMotion(), 1);
  const std::vector<FilterOutput> out = est.takeOutputs();
  ASSERT_FALSE(out.empty());
  // The states begin at the first image, not after the window.
  EXPECT_LE(out.front().state.utime, t0 + 5'000);
  // Roll and pitch right from the start (the heading is a convention: compare the tilt of the body's axes).
  const NavState& first = out.front().state;
  const Eigen::Vector3d up_est = first.orientation.conjugate() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_true = sim.truth(first.utime).orientation.conjugate() * Eigen::Vector3d::UnitZ();
  EXPECT_LT(std::acos(std::clamp(up_est.dot(up_true), -1.0, 1.0)), 2e-3);
  EXPECT_LT((out.back().state.gyro_bias - sp.gyro_bias).norm(), 1e-3) << out.back().state.gyro_bias.transpose();
  EXPECT_EQ(est.counters()[kSensorTracker].rejected, 0);
  EXPECT_EQ(est.counters()[kSensorTracker].too_late, 0);
}
