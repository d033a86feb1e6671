// Tilt sensor to camera 0: the estimator on synthetic stations with a known answer (exact without noise, the
// stations found among moving views, too few refused), and the whole chain on the simulator's calibration recording
// (config/sim_tilt_calib.yaml): the sim process renders the chart at eight static positions with a tilt sensor
// mounted askew with its zero offsets, calibrate_tilt reads the log, and the calibration it writes predicts the
// sensor's noise-free angles within the 0.05 deg.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "ips/calib/tilt_calibration.hpp"
#include "ips/calibration.hpp"
#include "ips/sim/rig.hpp"
#include "ips/sim/sensors.hpp"
#include "ips/test_support/command_output.hpp"

using namespace ips::calib;

namespace {

using ips::test_support::commandOutput;

constexpr double kDeg = M_PI / 180;

// The head's design (ips::sim): camera z forward = body x, camera x right = -body y, camera y down = -body z.
Eigen::Matrix3d cameraInBody() {
  Eigen::Matrix3d R;
  R << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return R;
}

Eigen::Matrix3d bodyInWorld(double roll_deg, double pitch_deg, double yaw_deg) {
  return (Eigen::AngleAxisd(yaw_deg * kDeg, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch_deg * kDeg, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// A plumb chart facing the head (-x): its x to the viewer's right (-y), its y down (-z), its z away (+x).
Eigen::Matrix3d chartInWorld() {
  Eigen::Matrix3d R;
  R.col(0) = -Eigen::Vector3d::UnitY();
  R.col(1) = -Eigen::Vector3d::UnitZ();
  R.col(2) = Eigen::Vector3d::UnitX();
  return R;
}

}  // namespace

TEST(TiltCalibration, SyntheticStationsGiveTheTwoAngles) {
  const Eigen::Matrix3d nominal = cameraInBody();    // R_tilt_cam0 as designed: the tilt axes are the body axes
  const Eigen::Vector3d turn_deg(0.42, -0.31, 0.9);  // about the sensor's x, y and vertical
  const Eigen::Matrix3d truth =
      Eigen::AngleAxisd(turn_deg.norm() * kDeg, turn_deg.normalized()).toRotationMatrix() * nominal;
  const double stations[][3] = {{0, 0, 0}, {10, 0, 3}, {-10, 5, -3}, {0, 10, 0}, {0, -8, 2}, {8, 8, 6}};
  for (double noise_deg : {0.0, 0.03}) {
    std::mt19937 rng(4);
    std::normal_distribution<double> noise(0, noise_deg * kDeg);
    std::vector<ChartView> views;
    std::vector<TiltReading> readings;
    int64_t t = 1'000'000;
    for (const auto& s : stations) {
      const Eigen::Matrix3d R_cam_world = cameraInBody().transpose() * bodyInWorld(s[0], s[1], s[2]).transpose();
      // 4 s still at 4 Hz, the sensor at 14 Hz; then 2 s of moving views that belong to no station.
      for (int k = 0; k <= 16; ++k) {
        ChartView v;
        v.utime = t + k * 250'000;
        v.R_cam_chart = R_cam_world * chartInWorld();
        v.centre_in_camera = Eigen::Vector3d(0.1, 0.0, 1.5);
        // Every other view starts the corner order at the board's other end: the design tells up from down.
        if (k % 2) v.R_cam_chart = v.R_cam_chart * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        views.push_back(v);
      }
      const Eigen::Vector2d angles = tiltAngles(truth * R_cam_world * Eigen::Vector3d::UnitZ());
      for (int64_t u = t; u <= t + 4'000'000; u += 71'429)
        readings.push_back({u, angles.x() + noise(rng), angles.y() + noise(rng)});
      for (int k = 1; k < 8; ++k) {
        ChartView v;
        v.utime = t + 4'000'000 + k * 250'000;
        v.R_cam_chart = Eigen::AngleAxisd(k * 2 * kDeg, Eigen::Vector3d::UnitX()) * R_cam_world * chartInWorld();
        v.centre_in_camera = Eigen::Vector3d(0.1, 0.01 * k, 1.5);
        views.push_back(v);
        readings.push_back({v.utime, 0.5, -0.5});  // the sensor while carried: not at a station
      }
      t += 6'000'000;
    }
    const TiltCalibrationResult r = calibrateTilt(views, readings, nominal);
    ASSERT_TRUE(r.ok) << r.reason;
    EXPECT_EQ(r.stations.size(), 6u);
    std::printf(
        "noise %.2f deg: angles %.5f %.5f %.5f deg (truth %.2f %.2f %.2f), sigma %.5f %.5f %.5f, residual %.5f\n",
        noise_deg, r.angles_deg.x(), r.angles_deg.y(), r.angles_deg.z(), turn_deg.x(), turn_deg.y(), turn_deg.z(),
        r.sigma_deg.x(), r.sigma_deg.y(), r.sigma_deg.z(), r.residual_rms_deg);
    ASSERT_TRUE(r.vertical_estimated);  // tilts of 5-12 deg determine it
    const double tolerance = noise_deg == 0 ? 1e-6 : 0.03;
    EXPECT_NEAR(r.angles_deg.x(), turn_deg.x(), tolerance);
    EXPECT_NEAR(r.angles_deg.y(), turn_deg.y(), tolerance);
    EXPECT_NEAR(r.angles_deg.z(), turn_deg.z(), noise_deg == 0 ? 1e-6 : 5 * r.sigma_deg.z());
    if (noise_deg == 0) {
      EXPECT_LT(Eigen::AngleAxisd(r.R_tilt_cam0.transpose() * truth).angle() / kDeg, 1e-5);
    }
  }
  // Stations that are all level tell nothing about the turn about the vertical: it stays as designed, and the two
  // angles still come out.
  {
    std::vector<ChartView> views;
    std::vector<TiltReading> readings;
    int64_t t = 1'000'000;
    for (const auto& s : stations) {
      const Eigen::Matrix3d R_cam_world =
          cameraInBody().transpose() * bodyInWorld(0.01 * s[0], 0.01 * s[1], s[2]).transpose();
      for (int k = 0; k <= 16; ++k)
        views.push_back(
            {t + k * 250'000, R_cam_world * chartInWorld(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0});
      const Eigen::Vector2d angles = tiltAngles(truth * R_cam_world * Eigen::Vector3d::UnitZ());
      for (int64_t u = t; u <= t + 4'000'000; u += 71'429) readings.push_back({u, angles.x(), angles.y()});
      t += 6'000'000;
    }
    const TiltCalibrationResult level = calibrateTilt(views, readings, nominal);
    ASSERT_TRUE(level.ok) << level.reason;
    EXPECT_FALSE(level.vertical_estimated);
    EXPECT_EQ(level.angles_deg.z(), 0.0);
    // Within 0.1 deg of level: the two angles are the truth's up to what the unestimated 0.9 deg about the vertical
    // mixes in (0.9 deg times 0.1 deg in radians).
    EXPECT_NEAR(level.angles_deg.x(), turn_deg.x(), 0.005);
    EXPECT_NEAR(level.angles_deg.y(), turn_deg.y(), 0.005);
  }
  // Two stations are too few (the answer would have no spread to judge it by).
  std::vector<ChartView> few;
  for (int k = 0; k < 40; ++k)
    few.push_back({1'000'000 + k * 250'000, chartInWorld(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0});
  std::vector<TiltReading> still;
  for (int k = 0; k < 140; ++k) still.push_back({1'000'000 + k * 71'429, 0, 0});
  const TiltCalibrationResult none = calibrateTilt(few, still, nominal);
  EXPECT_FALSE(none.ok);
  EXPECT_NE(none.reason.find("static positions"), std::string::npos) << none.reason;
}

// The sim process renders the recording, calibrate_tilt reads it (label slow: 185 rendered pairs).
TEST(TiltCalibrationSim, ChartAtStaticPositionsGivesTheSensorsAngles) {
  const std::string scenario_path = std::string(IPS_SOURCE_DIR) + "/config/sim_tilt_calib.yaml";
  const std::string log = ::testing::TempDir() + "tilt_calib_test.lcmlog";
  const std::string out_calib = ::testing::TempDir() + "tilt_calib_estimated.yaml";
  ASSERT_EQ(
      std::system((std::string(SIM_EXECUTABLE) + " --scenario " + scenario_path + " --out " + log + " --log-level warn")
                      .c_str()),
      0);
  // The tool starts from the cameras as calibrated (here: their truth) and the tilt sensor as designed, 1 deg per
  // axis off its true mounting (the seed's draw) besides its zero offsets.
  const ips::sim::Scenario scenario = ips::sim::Scenario::load(scenario_path);
  ips::StereoCalibration start = ips::loadCalibration(log + ".calib.yaml");
  start.R_tilt_cam0 = ips::sim::SensorHead::design(scenario).R_tilt_cam0;
  const std::string start_path = ::testing::TempDir() + "tilt_calib_start.yaml";
  ips::saveCalibration(start_path, start);
  const std::string out = commandOutput(std::string(CALIBRATE_TILT) + " --log " + log + " --calib " + start_path +
                                        " --board 9x6 --square 0.1 --out " + out_calib);
  std::printf("%s", out.c_str());
  ASSERT_NE(out.find("angle_x_deg="), std::string::npos) << out;
  EXPECT_NE(out.find("stations=8"), std::string::npos) << out;
  EXPECT_EQ(out.find("vertical_deg=kept"), std::string::npos) << out;  // tilts of 4-13 deg determine it
  const ips::StereoCalibration estimated = ips::loadCalibration(out_calib);
  EXPECT_EQ(estimated.source, "estimated");

  // The sensor as the simulator has it: its mounting (R_tilt_imu) and its zero offsets, noise-free, static.
  const ips::sim::Scenario& sc = scenario;
  const ips::sim::Rig rig(sc);
  const ips::sim::TiltSimulator sensor(sc.tilt, rig.trajectory, rig.head.R_tilt_imu, sc.start_utime, sc.gravity,
                                       sc.seed);
  const Eigen::Matrix3d R_cam_imu = rig.head.T_imu_cam0.linear().transpose();
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> tilt(-15, 15);
  double worst_deg = 0, worst_told_deg = 0;
  const ips::StereoCalibration& told = start;
  for (int k = 0; k < 200; ++k) {
    const double pitch = tilt(rng), roll = tilt(rng);  // one draw per statement
    const Eigen::Matrix3d R_world_body = bodyInWorld(roll, pitch, 0);
    const Eigen::Vector3d up_body = R_world_body.transpose() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector2d truth = tiltAngles(rig.head.R_tilt_imu * up_body) + sensor.offset();
    const Eigen::Vector2d predicted = tiltAngles(estimated.R_tilt_cam0 * R_cam_imu * up_body);
    const Eigen::Vector2d predicted_told = tiltAngles(told.R_tilt_cam0 * R_cam_imu * up_body);
    worst_deg = std::max(worst_deg, (predicted - truth).cwiseAbs().maxCoeff() / kDeg);
    worst_told_deg = std::max(worst_told_deg, (predicted_told - truth).cwiseAbs().maxCoeff() / kDeg);
  }
  std::printf(
      "[ SIM      ] sensor offsets %.3f %.3f deg; worst predicted angle error over +-15 deg: %.4f deg with the "
      "estimate, %.4f deg as designed\n",
      sensor.offset().x() / kDeg, sensor.offset().y() / kDeg, worst_deg, worst_told_deg);
  EXPECT_LT(worst_deg, 0.05);
  std::remove(log.c_str());
  std::remove((log + ".calib.yaml").c_str());
  std::remove(out_calib.c_str());
  std::remove(start_path.c_str());
}
