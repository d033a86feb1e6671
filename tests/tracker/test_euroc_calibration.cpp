// EuRoC sensor.yaml reading and conversion into the project's calibration format.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "ips/config.hpp"
#include "ips/tracker/euroc_calibration.hpp"
#include "test_util.hpp"

using namespace ips::tracker;

namespace {
const std::string kCam0 = test::dataDir() + "/euroc/V1_01_easy/mav0/cam0/sensor.yaml";
const std::string kCam1 = test::dataDir() + "/euroc/V1_01_easy/mav0/cam1/sensor.yaml";

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}
}  // namespace

TEST(EurocCalibration, ReadsTheSensorFileValues) {
  IPS_REQUIRE_SHARED_DATA("euroc/V1_01_easy/mav0");
  const EurocCamera c = readEurocCamera(kCam0);
  EXPECT_EQ(c.width, 752);
  EXPECT_EQ(c.height, 480);
  EXPECT_DOUBLE_EQ(c.fu, 458.654);
  EXPECT_DOUBLE_EQ(c.cv, 248.375);
  ASSERT_EQ(c.distortion.size(), 4u);
  EXPECT_DOUBLE_EQ(c.distortion[0], -0.28340811);
  EXPECT_DOUBLE_EQ(c.distortion[3], 1.76187114e-05);
  EXPECT_DOUBLE_EQ(c.T_BS(0, 3), -0.0216401454975);
  EXPECT_DOUBLE_EQ(c.T_BS(2, 2), 0.999660727178);
  EXPECT_DOUBLE_EQ(c.T_BS(3, 3), 1.0);
}

TEST(EurocCalibration, StereoGeometryMatchesTheKnownHead) {
  IPS_REQUIRE_SHARED_DATA("euroc/V1_01_easy/mav0");
  const ips::StereoCalibration calib = calibrationFromEuroc(kCam0, kCam1);
  // The VI-sensor: about 11 cm baseline, camera 1 to the right of camera 0 (t_cam1_cam0 x < 0).
  EXPECT_NEAR(calib.baseline(), 0.110, 0.001);
  EXPECT_LT(calib.t_cam1_cam0.x(), -0.109);
  EXPECT_NEAR((calib.R_cam1_cam0 * calib.R_cam1_cam0.transpose() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  // T_imu_cam0 is cam0's T_BS; the composition with cam1's T_BS gives back cam1's.
  const EurocCamera c1 = readEurocCamera(kCam1);
  Eigen::Isometry3d T_c0_c1 = Eigen::Isometry3d::Identity();
  T_c0_c1.linear() = calib.R_cam1_cam0.transpose();
  T_c0_c1.translation() = -calib.R_cam1_cam0.transpose() * calib.t_cam1_cam0;
  EXPECT_LT(((calib.T_imu_cam0 * T_c0_c1).matrix() - c1.T_BS).norm(), 1e-6);
}

TEST(EurocCalibration, SurvivesTheProjectFormat) {
  IPS_REQUIRE_SHARED_DATA("euroc/V1_01_easy/mav0");
  const ips::StereoCalibration calib = calibrationFromEuroc(kCam0, kCam1);
  const std::string path = ::testing::TempDir() + "euroc_calib.yaml";
  ips::saveCalibration(path, calib);
  const ips::StereoCalibration back = ips::loadCalibration(path);
  EXPECT_LT((back.cam0.K - calib.cam0.K).norm(), 1e-9);
  EXPECT_LT((back.cam1.distortion - calib.cam1.distortion).norm(), 1e-12);
  EXPECT_LT((back.t_cam1_cam0 - calib.t_cam1_cam0).norm(), 1e-12);
  EXPECT_LT((back.T_imu_cam0.matrix() - calib.T_imu_cam0.matrix()).norm(), 1e-9);
}

TEST(EurocCalibration, BadFilesNameFileAndKey) {
  EXPECT_THROW(readEurocCamera("/nonexistent/sensor.yaml"), ips::ConfigError);
  const std::string text =
      "%YAML:1.0\nT_BS:\n  cols: 4\n  rows: 4\n  data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n"
      "resolution: [752, 480]\ncamera_model: pinhole\nintrinsics: [458.6, 457.2, 367.2, 248.3]\n"
      "distortion_model: radial-tangential\ndistortion_coefficients: [-0.28, 0.07, 0.0001, 0.00001]\n";
  EXPECT_NO_THROW(readEurocCamera(writeTemp("ok.yaml", text)));
  std::string no_intr = text;
  no_intr.replace(no_intr.find("intrinsics"), 10, "intrinsicz");
  try {
    readEurocCamera(writeTemp("bad1.yaml", no_intr));
    FAIL() << "no exception";
  } catch (const ips::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("intrinsics"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("bad1.yaml"), std::string::npos);
  }
  std::string equi = text;
  equi.replace(equi.find("radial-tangential"), 17, "equidistant");
  EXPECT_THROW(readEurocCamera(writeTemp("bad2.yaml", equi)), ips::ConfigError);
  std::string short_tbs = text;
  short_tbs.replace(short_tbs.find("0, 0, 0, 1]"), 11, "0, 0, 1]");
  EXPECT_THROW(readEurocCamera(writeTemp("bad3.yaml", short_tbs)), ips::ConfigError);
}
