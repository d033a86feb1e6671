// Camera to IMU on a simulated head with a known rotation, gyro bias and delay: the delay from the rates' magnitudes
// alone (delay_estimation.hpp), and the rotation, bias and delay together (camera_imu.hpp), also with bad pairs
// among the tracker's rotations and with too little excitation.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>

#include "ips/calib/camera_imu.hpp"
#include "ips/calib/delay_estimation.hpp"
#include "simulated_motion.hpp"

using namespace ips::calib;
using ips::calib::testing::SimulatedMotion;
using ips::calib::testing::simulateMotion;

namespace {

double angleDeg(const Eigen::Matrix3d& R) { return Eigen::AngleAxisd(R).angle() * 180.0 / M_PI; }

}  // namespace

TEST(DelayEstimation, RecoversAKnownDelay) {
  for (int64_t late : {23'400, -41'700, 0}) {
    const SimulatedMotion sim = simulateMotion(60.0, late, 11);
    const DelayEstimate e = estimateCameraImuDelay(sim.gyro, sim.deltas);
    ASSERT_TRUE(e.ok) << "late " << late;
    std::printf("true delay %lld us: estimate %.0f us, correlation %.4f, %zu intervals\n", static_cast<long long>(late),
                e.delay_us, e.correlation, e.intervals);
    EXPECT_NEAR(e.delay_us, static_cast<double>(late), 1000.0) << "late " << late;
    EXPECT_GT(e.correlation, 0.95);
    EXPECT_GT(e.intervals, 500u);
  }
}

TEST(DelayEstimation, TooLittleDataGivesNoEstimate) {
  const SimulatedMotion sim = simulateMotion(1.0, 10'000, 1);
  const DelayEstimate e = estimateCameraImuDelay(sim.gyro, sim.deltas);
  EXPECT_FALSE(e.ok);
  EXPECT_THROW(estimateCameraImuDelay(sim.gyro, sim.deltas, DelayEstimatorConfig{100, 0, 20, 0}),
               std::invalid_argument);
}

TEST(CameraImuCalibration, RecoversRotationBiasAndDelayTogether) {
  for (int64_t late : {23'400, -41'700}) {
    const SimulatedMotion sim = simulateMotion(60.0, late, 11);
    const CameraImuEstimate e = calibrateCameraImu(sim.gyro, sim.deltas);
    ASSERT_TRUE(e.ok) << e.reason;
    const double rotation_error_deg = angleDeg(e.R_imu_cam * sim.R_cam_imu);
    std::printf(
        "true delay %lld us: %.1f us (sigma %.1f, coarse %.0f); rotation error %.5f deg (sigma %.5f); "
        "bias error %.2e rad/s; residual %.4f deg; %zu intervals\n",
        static_cast<long long>(late), e.delay_us, e.delay_sigma_us, e.coarse_delay_us, rotation_error_deg,
        e.rotation_sigma_deg.norm(), (e.gyro_bias - sim.gyro_bias).norm(), e.residual_rms_deg, e.intervals);
    // What the noise allows (the tracker's 0.5 mrad per axis and interval over 600 intervals of about 3 deg gives
    // 0.03 deg per axis), checked against the estimate's own sigma: the fit is unbiased and its sigma honest. The
    // issue's 0.05 deg is checked on the rendered simulation with the real tracker (test_camera_imu_sim).
    EXPECT_LT(rotation_error_deg, 4 * e.rotation_sigma_deg.norm());
    EXPECT_LT(e.rotation_sigma_deg.norm(), 0.08);
    EXPECT_NEAR(e.delay_us, static_cast<double>(late), 4 * e.delay_sigma_us);
    EXPECT_NEAR(e.delay_us, static_cast<double>(late), 1000.0);
    EXPECT_LT((e.gyro_bias - sim.gyro_bias).norm(), 5e-4);  // 0.03 deg/s of a 0.5 deg/s bias
    // The residual is the tracker's noise (0.5 mrad = 0.029 deg per axis) plus the integrated gyro noise
    // (5 mrad/s per sample over 20 samples of 5 ms: 0.11 mrad).
    EXPECT_LT(e.residual_rms_deg, 0.035);
    EXPECT_EQ(e.rejected, 0u);
    // The joint fit improves on the magnitudes' delay, which is biased by the gyro bias and the difference between
    // the angle of a rotation and the norm of the integrated rate.
    EXPECT_LT(std::fabs(e.delay_us - late), std::fabs(e.coarse_delay_us - late));
  }
}

TEST(CameraImuCalibration, BadPairsAreLeftOut) {
  const int64_t late = 12'300;
  const SimulatedMotion sim = simulateMotion(60.0, late, 5, 13);  // every 13th rotation 3 deg wrong: 46 of 600
  const CameraImuEstimate e = calibrateCameraImu(sim.gyro, sim.deltas);
  ASSERT_TRUE(e.ok) << e.reason;
  EXPECT_EQ(e.rejected, 46u);
  EXPECT_LT(angleDeg(e.R_imu_cam * sim.R_cam_imu), 4 * e.rotation_sigma_deg.norm());
  EXPECT_NEAR(e.delay_us, static_cast<double>(late), 4 * e.delay_sigma_us);
}

TEST(CameraImuCalibration, TurningAboutOneAxisIsNotEnough) {
  SimulatedMotion sim = simulateMotion(60.0, 0, 3);
  // The same intervals, but the head turned only about the IMU's z axis: the rotation about it is not determined.
  for (auto& g : sim.gyro) g.rate = Eigen::Vector3d(0, 0, g.rate.z() * 3);
  for (auto& d : sim.deltas) {
    const double dt = (d.utime - d.utime_prev) * 1e-6;
    const double angle = 3 * ips::calib::testing::simulatedOmega((d.utime - 1'700'000'000'000'000) * 1e-6).z() * dt;
    d.rotation =
        Eigen::Quaterniond(sim.R_cam_imu * Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                           sim.R_cam_imu.transpose());
  }
  const CameraImuEstimate e = calibrateCameraImu(sim.gyro, sim.deltas);
  EXPECT_FALSE(e.ok);
  EXPECT_NE(e.reason.find("one axis"), std::string::npos) << e.reason;
  // Too short a recording: no delay, so no estimate, with the reason.
  const SimulatedMotion brief = simulateMotion(1.0, 0, 3);
  const CameraImuEstimate none = calibrateCameraImu(brief.gyro, brief.deltas);
  EXPECT_FALSE(none.ok);
  EXPECT_NE(none.reason.find("no delay"), std::string::npos) << none.reason;
}

namespace {

// A walker's turns: about the IMU's vertical (z) alone, the gait's yaw sway and slow turns.
Eigen::Vector3d turnsAboutTheVertical(double t) {
  return {0, 0, 0.35 * std::sin(2 * M_PI * 0.9 * t) + 0.25 * std::sin(2 * M_PI * 0.07 * t + 0.4)};
}

}  // namespace

// Where the motion does not determine the rotation (one axis), a known rotation (the calibration's) still gives the
// bias and the delay: what the filter uses online on a walk.
TEST(CameraImuCalibration, KnownRotationGivesTheDelayFromTurnsAboutOneAxis) {
  const int64_t late = 3'000;
  const SimulatedMotion sim = simulateMotion(60.0, late, 7, 0, turnsAboutTheVertical);
  EXPECT_FALSE(calibrateCameraImu(sim.gyro, sim.deltas).ok);
  CameraImuConfig config;
  config.known_R_imu_cam = sim.R_cam_imu.transpose();
  const CameraImuEstimate e = calibrateCameraImu(sim.gyro, sim.deltas, config);
  ASSERT_TRUE(e.ok) << e.reason;
  std::printf("turns about one axis, rotation known: delay %.1f us (sigma %.1f, true %lld), bias error %.2e rad/s\n",
              e.delay_us, e.delay_sigma_us, static_cast<long long>(late), (e.gyro_bias - sim.gyro_bias).norm());
  EXPECT_NEAR(e.delay_us, static_cast<double>(late), 4 * e.delay_sigma_us);
  EXPECT_NEAR(e.delay_us, static_cast<double>(late), 300.0);
  EXPECT_EQ(e.rotation_sigma_deg, Eigen::Vector3d::Zero());
  EXPECT_TRUE(e.R_imu_cam.isApprox(sim.R_cam_imu.transpose(), 1e-12));
  // The bias about the axis turned is determined (the others only through the tracker's still axes, also here).
  EXPECT_NEAR(e.gyro_bias.z(), sim.gyro_bias.z(), 5e-4);
}
