// The lever arm estimated online over the analytic 2-minute walk, both filters. In its own executable, labelled slow:
// two minutes of filtering at 200 Hz take 4 s in Release and 50 s under the sanitizers, whose pass skips slow tests;
// the lever arm's models and Kalman bookkeeping are checked there by test_filter_models.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "ips/eval/filter_testbed.hpp"
#include "ips/log.hpp"

using namespace ips::filter;
using namespace ips::eval;

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
    Estimator est(p, rough);
    const std::vector<FilterOutput> out =
        runSimulation(est, sim, 0.0, walk.params().duration_s, true, true, Matrix21d::Zero());
    ASSERT_FALSE(out.empty());
    const FilterOutput& last = out.back();
    ASSERT_TRUE(last.lever_arm_estimated) << toString(type);
    const Eigen::Vector3d error = last.lever_arm - truth_calib.T_imu_cam0.translation();
    const Eigen::Vector3d sigma = last.lever_arm_covariance.diagonal().cwiseSqrt();
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
