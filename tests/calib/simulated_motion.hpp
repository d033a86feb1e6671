#pragma once
// A simulated sensor head for the camera-IMU tests: an analytic angular velocity, the gyro sampled from it at
// 200 Hz with white noise and a constant bias, and stereo tracker rotations at 10 Hz in a camera frame rotated
// against the IMU, whose stamps are late by a known amount.
#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <vector>

#include "ips/calib/delay_estimation.hpp"
#include "ips/random_vector.hpp"

namespace ips::calib::testing {

// Angular velocity of the simulated head in the IMU frame [rad/s]: smooth, non-periodic within the test.
inline Eigen::Vector3d simulatedOmega(double t) {
  return {0.5 * std::sin(2 * M_PI * 0.31 * t) + 0.2 * std::sin(2 * M_PI * 1.13 * t + 1.0),
          0.4 * std::sin(2 * M_PI * 0.53 * t + 0.5) + 0.15 * std::sin(2 * M_PI * 1.7 * t),
          0.3 * std::sin(2 * M_PI * 0.71 * t + 2.0) + 0.1};
}

// The head's camera frame: turned by 90 deg twice against the IMU (OpenCV camera axes on an x-forward, z-up
// body), then by a small mounting error.
inline Eigen::Matrix3d simulatedRCamImu() {
  return (Eigen::AngleAxisd(0.012, Eigen::Vector3d(0.3, -0.8, 0.5).normalized()) *
          Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

struct SimulatedMotion {
  std::vector<GyroSample> gyro;
  std::vector<TrackerRotation> deltas;
  Eigen::Matrix3d R_cam_imu = simulatedRCamImu();
  Eigen::Vector3d gyro_bias{0.004, -0.007, 0.002};  // [rad/s], about 0.2-0.4 deg/s: a MEMS gyro's turn-on bias
};

// IMU at 200 Hz stamped on true time; tracker at 10 Hz whose stamps are late by camera_late_us. A non-zero
// outlier_every turns every n-th tracker rotation by a wrong 3 deg (a bad pair).
// omega: the head's angular velocity in the IMU frame over time (default: turns about all axes).
inline SimulatedMotion simulateMotion(double duration_s, int64_t camera_late_us, unsigned seed, int outlier_every = 0,
                                      Eigen::Vector3d (*omega)(double) = simulatedOmega) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gyro_noise(0, 0.005), tracker_noise(0, 0.0005);
  SimulatedMotion s;
  const double dt = 5e-4;  // integration step of the true attitude (mid-point rule: error O(dt^3) per step)
  Eigen::Quaterniond q_w_b = Eigen::Quaterniond::Identity();
  Eigen::Quaterniond q_prev_frame = q_w_b;
  const int64_t t0 = 1'700'000'000'000'000;
  int step = 0;
  for (double t = 0; t <= duration_s + 1e-9; t += dt, ++step) {
    if (step % 10 == 0) {  // 200 Hz
      Eigen::Vector3d w = omega(t) + s.gyro_bias;
      for (int i = 0; i < 3; ++i) w[i] += gyro_noise(rng);
      s.gyro.push_back({t0 + static_cast<int64_t>(std::llround(t * 1e6)), w});
    }
    if (step % 200 == 0 && step > 0) {                                                    // 10 Hz image pairs
      const Eigen::Matrix3d R_b = (q_prev_frame.conjugate() * q_w_b).toRotationMatrix();  // body at now in body at prev
      Eigen::Matrix3d R_cam = s.R_cam_imu * R_b * s.R_cam_imu.transpose();
      const Eigen::Vector3d n = ips::drawVector3([&] { return tracker_noise(rng); });
      R_cam = R_cam * Eigen::AngleAxisd(n.norm(), n.normalized()).toRotationMatrix();
      if (outlier_every > 0 && (step / 200) % outlier_every == 0)
        R_cam = R_cam * Eigen::AngleAxisd(3 * M_PI / 180, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
      const int64_t now = t0 + static_cast<int64_t>(std::llround(t * 1e6)) + camera_late_us;
      s.deltas.push_back({now - 100'000, now, Eigen::Quaterniond(R_cam)});
      q_prev_frame = q_w_b;
    }
    // Exact attitude propagation with the mid-point rate.
    const Eigen::Vector3d w = omega(t + dt / 2) * dt;
    q_w_b = (q_w_b * Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()))).normalized();
  }
  return s;
}

}  // namespace ips::calib::testing
