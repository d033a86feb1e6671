// The lever arm and the calibration's other residual errors (the tracker's scale, the tilt sensor's offsets, the
// camera's alignment) estimated online over the analytic 2-minute walk, both filters. In its own executable, labelled
// slow: two minutes of filtering at 200 Hz take 4 s in Release and 50 s under the sanitizers, whose pass skips slow
// tests; the states' models and Kalman bookkeeping are checked there by test_filter_models.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "ips/eval/filter_testbed.hpp"
#include "ips/log.hpp"

using namespace ips::filter;
using namespace ips::eval;

namespace {

// The whole analytic walk through an estimator given `told` (the sensors are simulated on `sim`'s true head).
std::vector<FilterOutput> runWalk(const AnalyticWalk& walk, SensorSim& sim, const FilterParams& params,
                                  const ips::StereoCalibration& told) {
  Estimator est(params, told);
  return runSimulation(est, sim, 0.0, walk.params().duration_s, true, true, Matrix21d::Zero());
}

double endError(const std::vector<FilterOutput>& out, const SensorSim& sim) {
  return (out.back().state.position - sim.truth(out.back().state.utime).position).norm();
}

}  // namespace

// The lever arm as filter states (FilterParams::estimate_lever_arm): the estimator is given a calibration whose
// camera-to-IMU translation is 3 cm off on every axis (a rough mechanical measurement), the simulated sensors use the
// true one. Over the 2-minute walk the tracker's deltas at the head's turns determine it: the walk turns about the
// vertical (heading changes of the meander, looking around) and nods and rolls by a few degrees, so the horizontal
// components come first and the vertical one more slowly.
TEST(FilterEstimator, LeverArmEstimatedOnlineConvergesToTheTruthOverTheWalk) {
  ips::setLogLevel(ips::LogLevel::Error);
  const AnalyticWalk walk;
  const ips::StereoCalibration truth_calib = testbedCalibration();
  ips::StereoCalibration rough = truth_calib;
  const Eigen::Vector3d offset(0.03, -0.03, 0.03);
  rough.T_imu_cam0.translation() += offset;
  for (FilterType type : {FilterType::Ekf, FilterType::Ukf}) {
    SensorSim sim(walk, SensorSimParams{}, truth_calib, 21);
    FilterParams p;
    p.type = type;
    p.estimate_lever_arm = true;
    const std::vector<FilterOutput> out = runWalk(walk, sim, p, rough);
    ASSERT_FALSE(out.empty());
    const FilterOutput& last = out.back();
    ASSERT_TRUE(last.calibration[kLeverArm]) << toString(type);
    const Eigen::Vector3d error = last.calibration[kLeverArm]->value - truth_calib.T_imu_cam0.translation();
    const Eigen::Vector3d sigma = last.calibration[kLeverArm]->sigma();
    // Within 1 cm of the truth (issue #15's target for a 2-minute walk) from 3 cm off.
    EXPECT_LT(error.cwiseAbs().maxCoeff(), 0.01)
        << toString(type) << " error " << error.transpose() << " sigma " << sigma.transpose();
    // The claimed uncertainty shrank from the configured 3 cm and covers the error.
    EXPECT_LT(sigma.maxCoeff(), 0.01) << toString(type);
    for (int k = 0; k < 3; ++k) EXPECT_LT(std::abs(error(k)), 4.0 * sigma(k)) << toString(type) << " axis " << k;
    std::printf("%s lever arm error [mm] %.4f %.4f %.4f sigma [mm] %.4f %.4f %.4f\n", toString(type).c_str(),
                1e3 * error.x(), 1e3 * error.y(), 1e3 * error.z(), 1e3 * sigma.x(), 1e3 * sigma.y(), 1e3 * sigma.z());
  }
}

// The tracker's scale error as a filter state (FilterParams::estimate_delta_scale): the simulated tracker's steps are
// 0.3 % too long (a disparity offset it has not found in full), the IMU's accelerations observe the scale over the
// walk, weakly. Both filters: the estimate comes within 3 sigmas of the truth, the sigma shrinks from the configured
// 0.5 % (to 0.32 % in two minutes, with the random walk of delta_scale/psd),
// and the end position is nearer the truth than the same filter's without the state.
TEST(FilterEstimator, TrackerScaleErrorEstimatedOnlineOverTheWalk) {
  ips::setLogLevel(ips::LogLevel::Error);
  const AnalyticWalk walk;
  const ips::StereoCalibration calib = testbedCalibration();
  SensorSimParams sp;
  sp.tracker_scale_error = 0.003;
  for (FilterType type : {FilterType::Ekf, FilterType::Ukf}) {
    double end_error[2] = {0, 0};
    for (bool estimate : {false, true}) {
      SensorSim sim(walk, sp, calib, 23);
      FilterParams p;
      p.type = type;
      p.estimate_delta_scale = estimate;
      const std::vector<FilterOutput> out = runWalk(walk, sim, p, calib);
      ASSERT_FALSE(out.empty());
      const FilterOutput& last = out.back();
      end_error[estimate] = endError(out, sim);
      ASSERT_EQ(last.calibration[kDeltaScale].has_value(), estimate) << toString(type);
      if (!estimate) continue;
      const double scale = last.calibration[kDeltaScale]->value(0),
                   scale_sigma = last.calibration[kDeltaScale]->sigma()(0);
      std::printf("%s scale %.5f sigma %.5f (truth %.5f); end error %.3f m without, %.3f m with\n",
                  toString(type).c_str(), scale, scale_sigma, sp.tracker_scale_error, end_error[0], end_error[1]);
      EXPECT_LT(scale_sigma, 0.75 * p.delta_scale_sigma) << toString(type);
      EXPECT_LT(std::abs(scale - sp.tracker_scale_error), 3.0 * scale_sigma) << toString(type);
    }
    EXPECT_LT(end_error[1], end_error[0]) << toString(type);
  }
}

// The tilt sensor's constant offsets as filter states (FilterParams::estimate_tilt_offset): the simulated sensor reads
// 6 and -4 mrad off (within its 0.5 deg accuracy) besides its white noise. Over the walk, whose turns tell the
// accelerometer's bias from the attitude, the offsets are found within 3 of their sigmas, which shrink to a quarter
// of the configured 8.7 mrad, and roll and pitch stay within their sigmas (both filters).
TEST(FilterEstimator, TiltOffsetEstimatedOnlineOverTheWalk) {
  ips::setLogLevel(ips::LogLevel::Error);
  const AnalyticWalk walk;
  const ips::StereoCalibration calib = testbedCalibration();
  SensorSimParams sp;
  sp.tilt_offset = Eigen::Vector2d(0.006, -0.004);
  for (FilterType type : {FilterType::Ekf, FilterType::Ukf}) {
    double nees_mean[2] = {0, 0};  // roll and pitch, without and with the offsets as states
    for (bool estimate : {false, true}) {
      SensorSim sim(walk, sp, calib, 29);
      FilterParams p;
      p.type = type;
      p.estimate_tilt_offset = estimate;
      const std::vector<FilterOutput> out = runWalk(walk, sim, p, calib);
      ASSERT_FALSE(out.empty());
      // Roll and pitch: the attitude error's horizontal components (world x, y), NEES of 2 dof.
      double sum = 0;
      int n = 0;
      for (size_t i = 0; i < out.size(); i += 100) {
        const NavState truth = sim.truth(out[i].state.utime);
        const Eigen::Vector3d e = logQuat(truth.orientation * out[i].state.orientation.conjugate());
        const Eigen::Matrix2d P = out[i].covariance.block<2, 2>(kErrTh, kErrTh);
        sum += e.head<2>().dot(P.ldlt().solve(e.head<2>()));
        ++n;
      }
      nees_mean[estimate] = sum / n;
      const FilterOutput& last = out.back();
      ASSERT_EQ(last.calibration[kTiltOffset].has_value(), estimate);
      if (!estimate) continue;
      const Eigen::Vector2d offset = last.calibration[kTiltOffset]->value;
      const Eigen::Vector2d offset_sigma = last.calibration[kTiltOffset]->sigma();
      std::printf(
          "%s tilt offset [mrad] %.3f %.3f sigma %.3f %.3f (truth 6, -4); roll/pitch NEES %.2f without, %.2f with\n",
          toString(type).c_str(), 1e3 * offset.x(), 1e3 * offset.y(), 1e3 * offset_sigma.x(), 1e3 * offset_sigma.y(),
          nees_mean[0], nees_mean[1]);
      EXPECT_LT(offset_sigma.maxCoeff(), 0.25 * p.tilt_sigma) << toString(type);
      for (int k = 0; k < 2; ++k)
        EXPECT_LT(std::abs(offset(k) - sp.tilt_offset(k)), 3.0 * offset_sigma(k)) << toString(type);
    }
    EXPECT_LT(nees_mean[1], 2.0 * 2.0) << toString(type);  // mean 2 for consistent roll and pitch
  }
}

// The camera's alignment against the IMU as filter states (FilterParams::estimate_camera_alignment): the estimator is
// given a calibration whose camera-to-IMU rotation is 1.5 mrad off about each axis (beyond a good calibration's, as
// a knock would leave it), the simulated sensors use the true one. Every step of the tracker is turned by that much.
// Over the 2-minute walk the IMU's accelerations and turns observe it: the rotation is found within 3 of its sigmas,
// which shrink below the configured 1 mrad on every axis (both filters; measured: 0.68, 0.83, 0.63 mrad, the error
// 0.14, 1.20, -1.12 mrad). The analytic walk's loop brings the end point back near the start, where a turned step
// has cancelled itself: the end error is 4-5 cm with and without the states.
TEST(FilterEstimator, CameraAlignmentEstimatedOnlineOverTheWalk) {
  ips::setLogLevel(ips::LogLevel::Error);
  const AnalyticWalk walk;
  const ips::StereoCalibration truth_calib = testbedCalibration();
  ips::StereoCalibration told = truth_calib;
  const Eigen::Vector3d misalignment(0.0015, -0.0015, 0.0015);  // true = told * Exp(misalignment), camera frame
  told.T_imu_cam0.linear() = truth_calib.T_imu_cam0.linear() * expSO3(-misalignment);
  for (FilterType type : {FilterType::Ekf, FilterType::Ukf}) {
    double end_error[2] = {0, 0};  // without and with the states, for the printout
    for (bool estimate : {false, true}) {
      SensorSim sim(walk, SensorSimParams{}, truth_calib, 31);
      FilterParams p;
      p.type = type;
      p.estimate_camera_alignment = estimate;
      const std::vector<FilterOutput> out = runWalk(walk, sim, p, told);
      ASSERT_FALSE(out.empty());
      const FilterOutput& last = out.back();
      end_error[estimate] = endError(out, sim);
      ASSERT_EQ(last.calibration[kCameraAlignment].has_value(), estimate);
      if (!estimate) continue;
      const Eigen::Vector3d error = last.calibration[kCameraAlignment]->value - misalignment;
      const Eigen::Vector3d alignment_sigma = last.calibration[kCameraAlignment]->sigma();
      std::printf(
          "%s camera alignment error [mrad] %.3f %.3f %.3f sigma %.3f %.3f %.3f; end error %.3f m without, "
          "%.3f m with\n",
          toString(type).c_str(), 1e3 * error.x(), 1e3 * error.y(), 1e3 * error.z(), 1e3 * alignment_sigma.x(),
          1e3 * alignment_sigma.y(), 1e3 * alignment_sigma.z(), end_error[0], end_error[1]);
      for (int k = 0; k < 3; ++k) {
        EXPECT_LT(std::abs(error(k)), 3.0 * alignment_sigma(k)) << toString(type) << " axis " << k;
        EXPECT_LT(alignment_sigma(k), p.camera_alignment_sigma) << toString(type) << " axis " << k;
      }
    }
  }
}
