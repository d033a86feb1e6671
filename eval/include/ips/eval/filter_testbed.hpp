#pragma once
// An analytic test bed for the filter: a closed-form walk with exact derivatives (position, velocity, acceleration,
// attitude, body angular rate) and sensors generated from it with the paper's figures (MMQ-50 IMU, tilt sensor, a
// stereo tracker's relative pose with noise). The simulator (ips_sim) renders the whole head; this is for what needs
// closed-form truth and speed: the models' Jacobian tests, and Monte Carlo runs of the filter alone (traj_eval,
// filter_bench) by the hundred.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <random>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/filter/estimator.hpp"
#include "ips/filter/state.hpp"

namespace ips::eval {

// An open meander (not a closed loop, so heading drift shows in the end point): x = forward_speed * s +
// amp_x sin(W s), y = amp_y (1 - cos(W s)) in the path time s, which stands still for rest_s and ramps up
// smoothly (C2) over ramp_s: ~90 m in 2 minutes of walking.
struct WalkParams {
  double duration_s = 125.0;   // rest + the paper's 2-minute walk
  double rest_s = 3.0;         // standing still at the start (static initialisation)
  double ramp_s = 2.0;         // smooth start
  double forward_speed = 0.6;  // [m/s]
  double period_s = 40.0;      // of the meander
  double amp_x = 2.0;          // [m]
  double amp_y = 4.0;          // [m]
  double step_hz = 1.8;        // gait: vertical bounce and sway
  double bounce_m = 0.025;
  double sway_m = 0.02;
  double head_yaw_rad = 0.15;  // looking around
  double head_pitch_rad = 0.05;
  double head_roll_rad = 0.03;
  bool at_rest = false;  // a still head (for the static initialisation), attitude from the fixed angles
  double rest_roll_rad = 0.0, rest_pitch_rad = 0.0, rest_yaw_rad = 0.0;
};

struct TruthSample {
  int64_t utime = 0;
  Eigen::Vector3d p, v, a;  // world
  Eigen::Quaterniond q;     // body to world
  Eigen::Vector3d w;        // body angular rate
};

class AnalyticWalk {
 public:
  explicit AnalyticWalk(const WalkParams& p = {}) : p_(p) {}
  // Path time s(t) and its first two derivatives.
  void pathTime(double t, double* s, double* ds, double* dds) const;
  TruthSample at(double t_s) const;
  const WalkParams& params() const { return p_; }
  // Path length between t0 and t1 (numerically, 1 ms steps).
  double distance(double t0_s, double t1_s) const;

 private:
  WalkParams p_;
};

struct SensorSimParams {
  double imu_rate_hz = 200.0;
  double gyro_noise_density = 8.7e-5;  // MMQ-50
  double accel_noise_density = 4.9e-3;
  Eigen::Vector3d gyro_bias = Eigen::Vector3d(0.002, -0.001, 0.0015);  // [rad/s] constant truth
  Eigen::Vector3d accel_bias = Eigen::Vector3d(0.02, -0.015, 0.01);    // [m/s^2]
  double tilt_rate_hz = 14.0;
  double tilt_sigma = 1.75e-3;  // [rad]
  double image_rate_hz = 8.0;
  double tracker_sigma_t = 0.002;  // [m] per axis per delta
  double tracker_sigma_r = 1e-4;   // [rad] per axis per delta
  double gravity = 9.81;
};

// A head calibration with a realistic camera-IMU-tilt mounting (used wherever no calibration file is given).
StereoCalibration testbedCalibration();

class SensorSim {
 public:
  SensorSim(const AnalyticWalk& walk, const SensorSimParams& p, const StereoCalibration& calib, uint32_t seed);
  filter::ImuSample imu(int64_t utime);
  filter::TiltSample tilt(int64_t utime);
  // Relative pose of camera 0 between two image times with noise; its covariance is the one used.
  filter::TrackerDelta delta(int64_t utime_prev, int64_t utime);
  // The exact navigation state (biases = the simulated constants).
  filter::NavState truth(int64_t utime) const;
  const SensorSimParams& params() const { return p_; }
  // A draw from N(truth, P) on the error state (for starting a Monte Carlo run consistently).
  filter::NavState sampleAround(const filter::NavState& truth, const filter::Matrix21d& P);

 private:
  const AnalyticWalk& walk_;
  SensorSimParams p_;
  StereoCalibration calib_;
  std::mt19937 rng_;
  std::normal_distribution<double> n01_{0.0, 1.0};
  Eigen::Vector3d noise3();
};

// Feeds a whole simulated run to an estimator in time order (IMU, tilt, images + deltas). If P0 is not zero
// the estimator starts at t_start from a draw of N(truth, P0), else it initialises itself (static start).
// Returns the posterior outputs.
std::vector<filter::FilterOutput> runSimulation(filter::Estimator& est, SensorSim& sim, double t_start_s,
                                                double t_end_s, bool use_tracker, bool use_tilt,
                                                const filter::Matrix21d& P0);

}  // namespace ips::eval
