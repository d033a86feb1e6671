// The filter's parameters from YAML: the filter type by name (config key `type` and the process's --filter), and
// config/filter.yaml against the built-in defaults.
#include <gtest/gtest.h>

#include "ips/filter/params.hpp"
#include "ips/test_support/temp_yaml.hpp"

using ips::test_support::writeTempYaml;

namespace {

using ips::filter::FilterType;

TEST(FilterParams, TheFilterTypeByName) {
  EXPECT_EQ(ips::filter::filterTypeFromString("ekf"), FilterType::Ekf);
  EXPECT_EQ(ips::filter::filterTypeFromString("ukf"), FilterType::Ukf);
  for (const char* bad : {"", "EKF", "ukf ", "kalman"}) EXPECT_FALSE(ips::filter::filterTypeFromString(bad)) << bad;
  for (FilterType t : {FilterType::Ekf, FilterType::Ukf})
    EXPECT_EQ(ips::filter::filterTypeFromString(ips::filter::toString(t)), t);
}

TEST(FilterParams, TypeFromTheConfigAndAnUnknownOneRefused) {
  EXPECT_EQ(ips::filter::loadFilterParams(ips::Config(writeTempYaml("ukf.yaml", "type: ukf\n"))).type, FilterType::Ukf);
  EXPECT_EQ(ips::filter::loadFilterParams(ips::Config(writeTempYaml("none.yaml", "gravity: 9.8\n"))).type,
            FilterType::Ekf);
  try {
    ips::filter::loadFilterParams(ips::Config(writeTempYaml("bad_type.yaml", "type: pf\n")));
    FAIL() << "type pf taken";
  } catch (const ips::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("key 'type' must be 'ekf' or 'ukf', not 'pf'"), std::string::npos) << e.what();
  }
}

TEST(FilterParams, TheOutputFrameByNameAndAnUnknownOneRefused) {
  using ips::filter::OutputFrame;
  for (OutputFrame f : {OutputFrame::World, OutputFrame::Start})
    EXPECT_EQ(ips::filter::outputFrameFromString(ips::filter::toString(f)), f);
  EXPECT_EQ(ips::filter::loadFilterParams(ips::Config(writeTempYaml("none.yaml", "gravity: 9.8\n"))).output_frame,
            OutputFrame::World);
  EXPECT_EQ(
      ips::filter::loadFilterParams(ips::Config(writeTempYaml("start.yaml", "output_frame: start\n"))).output_frame,
      OutputFrame::Start);
  try {
    ips::filter::loadFilterParams(ips::Config(writeTempYaml("bad_frame.yaml", "output_frame: body\n")));
    FAIL() << "output_frame body taken";
  } catch (const ips::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("key 'output_frame' must be 'world' or 'start', not 'body'"),
              std::string::npos)
        << e.what();
  }
}

TEST(FilterParams, TheSensorsFiguresAreTheHeadsNotTheConfigs) {
  for (const char* key : {"imu:\n  rate_hz: 100\n", "process_noise:\n  gyro_bias_psd: 1e-10\n",
                          "tilt:\n  sigma: 0.01\n", "init:\n  sigma_accel_bias: 0.1\n"}) {
    try {
      ips::filter::loadFilterParams(ips::Config(writeTempYaml("sensor_key.yaml", key)));
      FAIL() << key << " taken";
    } catch (const ips::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("calibration file's imu and tilt blocks"), std::string::npos) << e.what();
    }
  }
}

TEST(FilterParams, FromTheHeadsDescription) {
  const ips::filter::FilterParams defaults;
  ips::StereoCalibration calib;
  // Without a description the parameters stay (the library's defaults, the paper's head).
  EXPECT_DOUBLE_EQ(ips::filter::withHeadSensors(defaults, calib).imu.gyro_noise_density,
                   defaults.imu.gyro_noise_density);
  EXPECT_TRUE(ips::filter::withHeadSensors(defaults, calib).use_tilt);
  // EuRoC's ADIS16448 at 10 Hz (as a GPS/INS might deliver it), no tilt sensor.
  ips::ImuDescription imu;
  imu.rate_hz = 10;
  imu.gyro_noise_density = 1.6968e-4;
  imu.gyro_random_walk = 1.9393e-5;
  imu.accel_noise_density = 2e-3;
  imu.accel_random_walk = 3e-3;
  imu.gyro_bias_sigma = 0.1;
  imu.accel_bias_sigma = 0.3;
  calib.imu = imu;
  ips::filter::FilterParams in = defaults;
  in.estimate_tilt_offset = true;
  const ips::filter::FilterParams p = ips::filter::withHeadSensors(in, calib);
  EXPECT_DOUBLE_EQ(p.imu.rate_hz, 10);
  EXPECT_DOUBLE_EQ(p.imu.gyro_noise_density, 1.6968e-4);
  EXPECT_DOUBLE_EQ(p.imu.accel_noise_density, 2e-3);
  EXPECT_DOUBLE_EQ(p.process.gyro_bias_psd, 1.9393e-5 * 1.9393e-5);
  EXPECT_DOUBLE_EQ(p.process.accel_bias_psd, 3e-3 * 3e-3);
  EXPECT_DOUBLE_EQ(p.gap_process.gyro_bias_psd, p.process.gyro_bias_psd);
  EXPECT_DOUBLE_EQ(p.init.sigma_accel_bias, 0.3);
  EXPECT_DOUBLE_EQ(p.init.moving_sigma_gyro_bias, 0.1);
  // A gap is three sample intervals at the least: 0.3 s at 10 Hz, not every interval.
  EXPECT_DOUBLE_EQ(p.imu_gap_s, 0.3);
  EXPECT_FALSE(p.use_tilt);
  EXPECT_FALSE(p.estimate_tilt_offset);
  // With a tilt sensor: its accuracy and resolution.
  ips::TiltDescription tilt;
  tilt.rate_hz = 14;
  tilt.accuracy = 0.01;
  tilt.resolution = 0.002;
  calib.tilt = tilt;
  const ips::filter::FilterParams t = ips::filter::withHeadSensors(in, calib);
  EXPECT_TRUE(t.use_tilt);
  EXPECT_TRUE(t.estimate_tilt_offset);
  EXPECT_DOUBLE_EQ(t.tilt_sigma, 0.01);
  EXPECT_DOUBLE_EQ(t.tilt_offset_noise_sigma, 0.002);
}

// The tracker's rotation floor in pixels becomes radians with camera 0's focal length, and never lowers the floor in
// radians; 0 px leaves it.
TEST(FilterParams, TrackerRotationFloorInPixelsTakesTheHeadsFocalLength) {
  ips::StereoCalibration calib;
  calib.cam0.K(0, 0) = 460, calib.cam0.K(1, 1) = 456;  // EuRoC's cam0: mean 458 px
  ips::filter::FilterParams in;
  EXPECT_DOUBLE_EQ(ips::filter::withHeadSensors(in, calib).tracker_min_sigma_r, in.tracker_min_sigma_r);
  in.tracker_min_sigma_r_px = 0.1;
  EXPECT_DOUBLE_EQ(ips::filter::withHeadSensors(in, calib).tracker_min_sigma_r, 0.1 / 458);
  in.tracker_min_sigma_r = 1e-3;
  EXPECT_DOUBLE_EQ(ips::filter::withHeadSensors(in, calib).tracker_min_sigma_r, 1e-3);
  EXPECT_THROW(
      ips::filter::loadFilterParams(ips::Config(writeTempYaml("floor_px.yaml", "tracker:\n  min_sigma_r_px: -1\n"))),
      ips::ConfigError);
}

}  // namespace
