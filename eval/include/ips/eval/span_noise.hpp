#pragma once
// How large the errors of an estimate, its ground truth and the head's IMU each are over time spans from one frame
// interval up, with none of the three taken as the reference: the three-cornered hat (Gray and Allan 1974) on
// second differences of the body's position, p(t + T) - 2 p(t) + p(t - T), which all three measure (the IMU by
// integrating its accelerations twice: the start's position and velocity drop out). Where the three errors are
// independent, the variances of their pairwise differences give each one's variance. A filter can take from the IMU
// what the estimate lacks only at the spans where the IMU's figure is below the estimate's; at longer ones the IMU's
// bias and attitude errors grow as T^2.
#include <Eigen/Geometry>
#include <cmath>
#include <vector>

#include "ips/eval/trajectory.hpp"
#include "ips/filter/estimator.hpp"

namespace ips::eval {

struct SpanNoiseInput {
  // The body (IMU frame) in a z-up world, sampled at least as finely as the estimate, its steps removed
  // (removePositionSteps). Its attitude also turns the IMU's specific force into the world, so the IMU's figure
  // includes the truth's attitude error (mrad: g times it, times T^2).
  Trajectory truth;
  // Camera 0 in any frame; aligned to the truth here by SE(3) after carrying it to the body. May be empty: then the
  // second differences are taken at the truth's samples and only the truth's and the IMU's difference is found.
  Trajectory estimate;
  std::vector<filter::ImuSample> imu;
  Eigen::Isometry3d T_imu_cam0 = Eigen::Isometry3d::Identity();
  double gravity = 9.81;  // [m/s^2]; its error is fitted with the accelerometer's bias
};

struct SpanNoise {
  int span_frames = 0;  // T in the estimate's samples
  double span_s = 0;    // T in seconds, the median over the centres
  size_t centres = 0;   // centre samples used (each with both neighbours T away, within half an interval)
  // RMS per axis [m] of the differences of the second differences, pairwise; without an estimate only truth_vs_imu
  // (the IMU's and the truth's errors together: an upper bound of each), the others NaN.
  double truth_vs_estimate = NAN, truth_vs_imu = 0, estimate_vs_imu = NAN;
  // truth_vs_imu per world axis [m]: an error of the truth's attitude turns gravity into x and y only.
  Eigen::Vector3d truth_vs_imu_axes = Eigen::Vector3d::Zero();
  // Each one's RMS per axis [m] by the hat; NaN where its variance comes out negative (the errors are correlated,
  // or one is far below the others and lost in their scatter), and without an estimate.
  double truth = NAN, estimate = NAN, imu = NAN;
  // The accelerometer bias [m/s^2, body] and gravity's error [m/s^2] fitted at this span: least squares of the IMU's
  // second differences against the mean of the truth's and the estimate's.
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
  double gravity_error = 0;
};

// What white accelerometer noise of `density` [m/s^2/sqrt(Hz)] alone gives the IMU's second difference over +-T, per
// axis [m]: density sqrt(2 T^3 / 3), from the double integral's triangle kernel T - |s|. The data sheet's figure
// beside the measured one.
double imuWhiteNoiseSecondDifference(double density, double span_s);

// One entry per span (in the estimate's samples, or the truth's without one; each >= 1) that has at least 10 centres.
// Throws std::invalid_argument when the truth, a given estimate or the IMU has fewer than three samples.
std::vector<SpanNoise> spanNoise(const SpanNoiseInput& in, const std::vector<int>& spans_frames);

}  // namespace ips::eval
