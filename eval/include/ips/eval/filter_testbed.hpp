#pragma once
// An analytic test bed for the filter: the simulator's closed-form walk (ips/sim/analytic_walk.hpp: exact position,
// velocity, acceleration, attitude, body angular rate) and the filter's sensors generated from it with the paper's
// figures (MMQ-50 IMU, tilt sensor, a stereo tracker's relative pose with noise), without rendering: for what needs
// closed-form truth and speed, the models' Jacobian tests and Monte Carlo runs of the filter alone (traj_eval,
// filter_bench) by the hundred.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <random>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/filter/estimator.hpp"
#include "ips/filter/state.hpp"
#include "ips/sim/analytic_walk.hpp"
#include "ips/sim/simulation.hpp"

namespace ips::eval {

// The walk is the simulator's closed-form one (ips/sim/analytic_walk.hpp).
using sim::AnalyticWalk;
using sim::WalkParams;

// The simulator's truth as the filter's state (for NEES and starting a filter on the truth).
filter::NavState navStateOf(const InertialState& truth);

struct SensorSimParams {
  double imu_rate_hz = 200.0;
  double gyro_noise_density = 8.7e-5;  // MMQ-50
  double accel_noise_density = 4.9e-3;
  Eigen::Vector3d gyro_bias = Eigen::Vector3d(0.002, -0.001, 0.0015);  // [rad/s] constant truth
  Eigen::Vector3d accel_bias = Eigen::Vector3d(0.02, -0.015, 0.01);    // [m/s^2]
  double tilt_rate_hz = 14.0;
  double tilt_sigma = 1.75e-3;                            // [rad] white noise per angle
  Eigen::Vector2d tilt_offset = Eigen::Vector2d::Zero();  // [rad] constant offsets of the two angles
  double image_rate_hz = 8.0;
  double tracker_sigma_t = 0.002;  // [m] per axis per delta
  double tracker_sigma_r = 1e-4;   // [rad] per axis per delta
  double tracker_scale_error = 0;  // the deltas' translations are (1 + this) times the true ones
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
