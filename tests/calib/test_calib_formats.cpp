// Calibration files of Kalibr, ROS, OpenCV and EuRoC read into the project's calibration: each checked against
// the values written in the original files (the EuRoC data ships the same calibration in EuRoC's and Kalibr's
// form), writers checked by round trip, and the converter's errors.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "ips/calib/formats.hpp"
#include "ips/config.hpp"
#include "ips/shared_data_test.hpp"

namespace {

const std::string kFixtures = CALIB_FIXTURES;
const std::string kEuroc = ips::dataDir() + "/euroc/V1_01_easy";

std::string tempPath(const std::string& name) { return ::testing::TempDir() + "calib_" + name; }

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = tempPath(name);
  std::ofstream(path) << text;
  return path;
}

// The ConfigError message of f(), "" when it does not throw.
template <class F>
std::string errorOf(F f) {
  try {
    f();
  } catch (const ips::ConfigError& e) {
    return e.what();
  }
  return "";
}

void expectSame(const ips::StereoCalibration& a, const ips::StereoCalibration& b, double tol) {
  for (auto [x, y] : {std::pair{&a.cam0, &b.cam0}, std::pair{&a.cam1, &b.cam1}}) {
    EXPECT_EQ(x->width, y->width);
    EXPECT_EQ(x->height, y->height);
    EXPECT_EQ(x->model, y->model);
    EXPECT_LT((x->K - y->K).cwiseAbs().maxCoeff(), tol);
    EXPECT_LT((x->distortion - y->distortion).cwiseAbs().maxCoeff(), tol);
  }
  EXPECT_LT((a.R_cam1_cam0 - b.R_cam1_cam0).cwiseAbs().maxCoeff(), tol);
  EXPECT_LT((a.t_cam1_cam0 - b.t_cam1_cam0).cwiseAbs().maxCoeff(), tol);
  EXPECT_LT((a.T_imu_cam0.matrix() - b.T_imu_cam0.matrix()).cwiseAbs().maxCoeff(), tol);
}

}  // namespace

TEST(CalibFormats, KalibrFormOfEurocEqualsEurocForm) {
  IPS_REQUIRE_SHARED_DATA("euroc/V1_01_easy");
  const ips::StereoCalibration euroc =
      ips::calib::readEuroc(kEuroc + "/mav0/cam0/sensor.yaml", kEuroc + "/mav0/cam1/sensor.yaml");
  const ips::StereoCalibration kalibr = ips::calib::readKalibr(kEuroc + "/calib_openvins/kalibr_imucam_chain.yaml");
  // The values of the files themselves.
  EXPECT_DOUBLE_EQ(kalibr.cam0.K(0, 0), 458.654);
  EXPECT_DOUBLE_EQ(kalibr.cam0.K(1, 2), 248.375);
  EXPECT_DOUBLE_EQ(kalibr.cam1.K(0, 2), 379.999);
  EXPECT_DOUBLE_EQ(kalibr.cam1.distortion(3), -3.55590700e-05);
  EXPECT_EQ(kalibr.cam0.width, 752);
  EXPECT_EQ(kalibr.cam0.model, ips::DistortionModel::kRadialTangential);
  EXPECT_NEAR(kalibr.T_imu_cam0.translation().x(), -0.0216401454975, 1e-12);
  EXPECT_NEAR(kalibr.baseline(), 0.110078, 1e-5);  // the VI-sensor's baseline
  // The same calibration in both forms.
  expectSame(euroc, kalibr, 1e-12);
}

TEST(CalibFormats, ImuNoiseOfEurocAndKalibrFilesAgree) {
  IPS_REQUIRE_SHARED_DATA("euroc/V1_01_easy");
  // EuRoC's imu0/sensor.yaml and the same figures in Kalibr's imu.yaml (OpenVINS's copy).
  const ips::ImuDescription euroc = ips::calib::readImuNoise(kEuroc + "/mav0/imu0/sensor.yaml");
  const ips::ImuDescription kalibr =
      ips::calib::readImuNoise(kEuroc + "/calib_openvins/kalibr_imu_chain.yaml", 0.05, 0.2);
  for (const ips::ImuDescription* d : {&euroc, &kalibr}) {
    EXPECT_DOUBLE_EQ(d->rate_hz, 200.0);
    EXPECT_DOUBLE_EQ(d->gyro_noise_density, 1.6968e-04);
    EXPECT_DOUBLE_EQ(d->gyro_random_walk, 1.9393e-05);
    EXPECT_DOUBLE_EQ(d->accel_noise_density, 2.0e-3);
    EXPECT_DOUBLE_EQ(d->accel_random_walk, 3.0e-3);
  }
  EXPECT_NE(euroc.model.find("ADIS16448"), std::string::npos) << euroc.model;
  // Neither file has the turn-on biases: the given ones, else a MEMS IMU's.
  EXPECT_DOUBLE_EQ(euroc.gyro_bias_sigma, ips::calib::kMemsGyroBiasSigma);
  EXPECT_DOUBLE_EQ(kalibr.gyro_bias_sigma, 0.05);
  EXPECT_DOUBLE_EQ(kalibr.accel_bias_sigma, 0.2);
  const std::string bad = writeTemp("imu_bad.yaml", "rate_hz: 200\ngyroscope_noise_density: fast\n");
  EXPECT_NE(errorOf([&] { ips::calib::readImuNoise(bad); }).find("gyroscope_noise_density' is 'fast'"),
            std::string::npos);
  const std::string missing = writeTemp("imu_missing.yaml", "imu0:\n  update_rate: 100\n");
  EXPECT_NE(errorOf([&] { ips::calib::readImuNoise(missing); }).find("imu0/gyroscope_noise_density' not found"),
            std::string::npos);
}

TEST(CalibFormats, KalibrCamchainWithTcnCnm1AndEquidistantModel) {
  const ips::StereoCalibration c = ips::calib::readKalibr(kFixtures + "/kalibr_imucam_equidistant.yaml");
  EXPECT_EQ(c.cam0.model, ips::DistortionModel::kEquidistant);
  EXPECT_EQ(c.cam1.model, ips::DistortionModel::kEquidistant);
  EXPECT_EQ(c.cam0.width, 848);
  EXPECT_EQ(c.cam0.height, 800);
  EXPECT_DOUBLE_EQ(c.cam0.K(0, 0), 285.5);
  EXPECT_DOUBLE_EQ(c.cam1.K(1, 2), 398.2);
  EXPECT_DOUBLE_EQ(c.cam0.distortion(2), -0.0321);
  EXPECT_DOUBLE_EQ(c.cam1.distortion(3), 0.0077);
  EXPECT_EQ(c.cam0.distortion(4), 0.0);
  // cam1's T_cn_cnm1 is T_cam1_cam0 (a 0.01 rad turn about y, 6.4 cm baseline).
  EXPECT_NEAR(c.R_cam1_cam0(0, 2), 0.009999833334166664, 1e-12);
  EXPECT_NEAR(c.t_cam1_cam0.x(), -0.064, 1e-12);
  EXPECT_NEAR(c.t_cam1_cam0.y(), 0.0002, 1e-12);
  // T_cam_imu maps IMU points into the camera: T_imu_cam0 is its inverse.
  Eigen::Matrix4d T_cam_imu;
  T_cam_imu << 0, -1, 0, 0.02, 1, 0, 0, -0.01, 0, 0, 1, 0.005, 0, 0, 0, 1;
  EXPECT_LT((c.T_imu_cam0.matrix() * T_cam_imu - Eigen::Matrix4d::Identity()).norm(), 1e-12);

  // The project's file holds the fisheye model and reads back the same; fisheye rectification runs on it.
  const std::string out = tempPath("equidistant.yaml");
  ips::saveCalibration(out, c);
  expectSame(c, ips::loadCalibration(out), 1e-12);
  const ips::StereoRectification rect = ips::computeRectification(c);
  EXPECT_NEAR(rect.baseline, c.baseline(), 1e-9);
  EXPECT_EQ(rect.map0x.size(), cv::Size(848, 800));
}

TEST(CalibFormats, RosCameraInfoFixture) {
  const ips::StereoCalibration c =
      ips::calib::readRosCameraInfo(kFixtures + "/ros_left.yaml", kFixtures + "/ros_right.yaml");
  EXPECT_EQ(c.cam0.width, 640);
  EXPECT_DOUBLE_EQ(c.cam0.K(0, 0), 500.5);
  EXPECT_DOUBLE_EQ(c.cam0.K(1, 2), 240.75);
  EXPECT_DOUBLE_EQ(c.cam1.K(0, 2), 322.5);
  EXPECT_DOUBLE_EQ(c.cam0.distortion(4), 0.01);
  EXPECT_DOUBLE_EQ(c.cam1.distortion(0), -0.24);
  EXPECT_LT((c.R_cam1_cam0 - Eigen::Matrix3d::Identity()).norm(), 1e-15);
  EXPECT_NEAR(c.t_cam1_cam0.x(), -0.12, 1e-12);  // Tx / fx' = -57.6 / 480
  EXPECT_NEAR(c.t_cam1_cam0.tail<2>().norm(), 0.0, 1e-15);
}

TEST(CalibFormats, RosCameraInfoRoundTripOfEuroc) {
  IPS_REQUIRE_SHARED_DATA("euroc/V1_01_easy");
  const ips::StereoCalibration euroc =
      ips::calib::readEuroc(kEuroc + "/mav0/cam0/sensor.yaml", kEuroc + "/mav0/cam1/sensor.yaml");
  const std::string left = tempPath("left.yaml"), right = tempPath("right.yaml");
  ips::calib::writeRosCameraInfo(left, right, euroc);
  ips::StereoCalibration back = ips::calib::readRosCameraInfo(left, right);
  back.T_imu_cam0 = euroc.T_imu_cam0;  // camera_info has no IMU
  // Rotation and translation come back through the rectification (R1, R2, P2), to rounding.
  expectSame(euroc, back, 1e-9);
}

TEST(CalibFormats, OpenCvStereoCalibFixtureAndRoundTrip) {
  const std::vector<std::string> files = {kFixtures + "/opencv_intrinsics.yml", kFixtures + "/opencv_extrinsics.yml"};
  const ips::StereoCalibration c = ips::calib::readOpenCvStereo(files, cv::Size(1280, 720), 1000.0);  // T in mm
  EXPECT_EQ(c.cam0.width, 1280);
  EXPECT_EQ(c.cam1.height, 720);
  EXPECT_DOUBLE_EQ(c.cam0.K(0, 0), 700.25);
  EXPECT_DOUBLE_EQ(c.cam1.K(1, 2), 362.5);
  EXPECT_DOUBLE_EQ(c.cam0.distortion(4), -0.02);
  EXPECT_DOUBLE_EQ(c.cam1.distortion(2), -0.0003);
  EXPECT_NEAR(c.R_cam1_cam0(0, 2), 0.01999866669333308, 1e-12);
  EXPECT_NEAR(c.t_cam1_cam0.x(), -0.1505, 1e-12);
  EXPECT_NEAR(c.t_cam1_cam0.z(), -0.00125, 1e-12);

  const std::string in = tempPath("intrinsics.yml"), ex = tempPath("extrinsics.yml");
  ips::calib::writeOpenCvStereo(in, ex, c);
  expectSame(c, ips::calib::readOpenCvStereo({ex, in}, cv::Size(1280, 720)), 1e-12);
  // Rational terms the project's model cannot hold are refused, naming the file and key.
  std::string text;
  {
    std::ifstream f(files[0]);
    std::stringstream ss;
    ss << f.rdbuf();
    text = ss.str();
  }
  text.replace(text.find("-0.02, 0., 0., 0."), 17, "-0.02, 0.5, 0., 0.");
  const std::string rational = writeTemp("rational.yml", text);
  const std::string err = errorOf([&] { ips::calib::readOpenCvStereo({rational, files[1]}, cv::Size(1280, 720)); });
  EXPECT_NE(err.find(rational), std::string::npos) << err;
  EXPECT_NE(err.find("'D1'"), std::string::npos) << err;
}

TEST(CalibFormats, BadFilesNameFileAndKey) {
  const std::string kalibr_path = kFixtures + "/kalibr_imucam_equidistant.yaml";
  std::string text;
  {
    std::ifstream f(kalibr_path);
    std::stringstream ss;
    ss << f.rdbuf();
    text = ss.str();
  }
  auto without = [&](const std::string& what, const std::string& with) {
    std::string t = text;
    const size_t at = t.find(what);
    EXPECT_NE(at, std::string::npos) << what;
    return t.replace(at, what.size(), with);
  };
  struct Case {
    std::string name, text, key;
  };
  const std::vector<Case> cases = {
      {"no_intrinsics.yaml", without("intrinsics: [285.5", "intrinsix: [285.5"), "cam0/intrinsics"},
      {"omni.yaml", without("camera_model: pinhole", "camera_model: omni"), "cam0/camera_model"},
      {"model.yaml", without("distortion_model: equidistant", "distortion_model: fov"), "cam0/distortion_model"},
      {"short_coeffs.yaml", without("[-0.0123, 0.0456, -0.0321, 0.0087]", "[-0.0123, 0.0456]"),
       "cam0/distortion_coeffs"},
      {"nan.yaml", without("424.3", "abc"), "cam0/intrinsics"},
      {"not_rigid.yaml", without("[0.0, -1.0, 0.0, 0.02]", "[0.0, -2.0, 0.0, 0.02]"), "cam0/T_cam_imu"},
      {"no_cam1.yaml", text.substr(0, text.find("cam1:")), "cam1"},
  };
  for (const auto& c : cases) {
    const std::string path = writeTemp(c.name, c.text);
    const std::string err = errorOf([&] { ips::calib::readKalibr(path); });
    EXPECT_NE(err.find(path), std::string::npos) << c.name << ": " << err;
    EXPECT_NE(err.find("'" + c.key + "'"), std::string::npos) << c.name << ": " << err;
    EXPECT_EQ(err.find('\n'), std::string::npos) << c.name << ": " << err;
  }
  EXPECT_NE(errorOf([&] {
              ips::calib::readRosCameraInfo(kFixtures + "/ros_left.yaml", "/nonexistent.yaml");
            }).find("/nonexistent.yaml"),
            std::string::npos);
  const std::string ros_bad = writeTemp("ros_bad.yaml", "image_width: 640\nimage_height: 480\n");
  EXPECT_NE(errorOf([&] { ips::calib::readRosCameraInfo(ros_bad, ros_bad); }).find("'camera_matrix'"),
            std::string::npos);
}

TEST(CalibConvert, ConvertsAndFailsWithOneLine) {
  const std::string out = tempPath("converted.yaml"), err = tempPath("stderr.txt");
  const std::string ok = std::string(CALIB_CONVERT) + " --from ros " + kFixtures + "/ros_left.yaml " + kFixtures +
                         "/ros_right.yaml --out " + out + " > /dev/null 2> " + err;
  ASSERT_EQ(std::system(ok.c_str()), 0);
  expectSame(ips::calib::readRosCameraInfo(kFixtures + "/ros_left.yaml", kFixtures + "/ros_right.yaml"),
             ips::loadCalibration(out), 1e-12);

  const std::string bad = writeTemp("bad_kalibr.yaml", "cam0:\n  camera_model: pinhole\n");
  const int status =
      std::system((std::string(CALIB_CONVERT) + " --from kalibr " + bad + " --out " + out + " 2> " + err).c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_NE(WEXITSTATUS(status), 0);
  std::ifstream f(err);
  std::string line, extra;
  std::getline(f, line);
  EXPECT_FALSE(std::getline(f, extra)) << "one line only, got also: " << extra;
  EXPECT_NE(line.find(bad), std::string::npos) << line;
  EXPECT_NE(line.find("'cam0/intrinsics'"), std::string::npos) << line;
}
