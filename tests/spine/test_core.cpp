// ips_core: config errors that name file and key, the calibration format's round trip and the geometry of the
// rectification it produces, the command-line parser, PFM files.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/args.hpp"
#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/pfm.hpp"
#include "ips/pose_buffer.hpp"

namespace {

std::string tempPath(const std::string& name) {
  return (testing::TempDir() + "/") + std::to_string(::getpid()) + "_" + name;
}

std::string writeFile(const std::string& name, const std::string& text) {
  std::string p = tempPath(name);
  std::ofstream(p) << text;
  return p;
}

TEST(Config, ValuesAndErrorsNameFileAndKey) {
  std::string p =
      writeFile("c.yaml", "%YAML:1.0\n---\nimu:\n  rate_hz: 200\n  name: mmq50\nscale: 0.5\nflag: 1\nv: [1, 2, 3]\n");
  ips::Config c(p);
  EXPECT_EQ(c.getInt("imu/rate_hz"), 200);
  EXPECT_EQ(c.getString("imu/name"), "mmq50");
  EXPECT_DOUBLE_EQ(c.getDouble("scale"), 0.5);
  EXPECT_TRUE(c.getBool("flag"));
  EXPECT_DOUBLE_EQ(c.getDouble("missing", 7.0), 7.0);
  EXPECT_EQ(c.getMatrix("v", 3, 1)(2, 0), 3.0);
  EXPECT_EQ(c.section("imu").getInt("rate_hz"), 200);
  try {
    c.getDouble("imu/latency_s");
    FAIL();
  } catch (const ips::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(p), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("imu/latency_s"), std::string::npos);
  }
  try {
    c.section("imu").getInt("name");
    FAIL();
  } catch (const ips::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("imu/name"), std::string::npos);  // the full path of the key
  }
  EXPECT_THROW(c.getMatrix("v", 2, 2), ips::ConfigError);
  EXPECT_THROW(ips::Config("/nonexistent/x.yaml"), ips::ConfigError);
  EXPECT_THROW(ips::Config(writeFile("bad.yaml", "%YAML:1.0\n---\na: [1, 2\n")), ips::ConfigError);
}

// A comment after a string value ends it, as in YAML (OpenCV's reader keeps it as part of the value); a '#' inside
// a word stays.
TEST(Config, ACommentAfterAStringIsNotPartOfIt) {
  ips::Config c(writeFile("comment.yaml",
                          "%YAML:1.0\n---\ncost: census  # the matching cost\nframe: \"world\" # quoted\n"
                          "name: cam#2 # a camera\nn: 3 # a number\n"));
  EXPECT_EQ(c.getString("cost"), "census");
  EXPECT_EQ(c.getString("frame"), "world");
  EXPECT_EQ(c.getString("name"), "cam#2");
  EXPECT_EQ(c.getInt("n"), 3);
}

// Keys nothing asked for are listed by their full path (through sections too) and refused naming file and key; a
// sub-tree taken raw (node()) counts as read.
TEST(Config, UnreadKeysAreNamedAndRefused) {
  const std::string p = writeFile("unread.yaml",
                                  "%YAML:1.0\n---\nimu:\n  rate_hz: 200\n  rate_hx: 100\nscale: 0.5\nscael: 2\n"
                                  "raw:\n  a: 1\n  b: [1, 2]\nlist: [1, 2]\n");
  ips::Config c(p);
  EXPECT_EQ(c.unreadKeys().size(), 7u);
  EXPECT_EQ(c.section("imu").getInt("rate_hz"), 200);
  EXPECT_DOUBLE_EQ(c.getDouble("scale", 1.0), 0.5);
  EXPECT_FALSE(c.node("raw").empty());
  EXPECT_TRUE(c.has("list"));
  EXPECT_EQ(c.unreadKeys(), (std::vector<std::string>{"imu/rate_hx", "scael"}));
  try {
    c.refuseUnreadKeys();
    FAIL();
  } catch (const ips::ConfigError& e) {
    EXPECT_EQ(std::string(e.what()),
              p + ": unknown keys 'imu/rate_hx', 'scael' (misspelled, or not a setting of this process)");
  }
  EXPECT_EQ(c.getInt("imu/rate_hx"), 100);
  EXPECT_DOUBLE_EQ(c.getDouble("scael"), 2.0);
  EXPECT_NO_THROW(c.refuseUnreadKeys());
}

// The effective settings: the file's values and the defaults asked for (marked), nested by section, as YAML that reads
// back to the same values (reals to the last bit, matrices with their shape, strings with quotes, booleans with a
// trailing comment).
TEST(Config, EffectiveSettingsReadBackToTheSameValues) {
  const std::string p = writeFile("effective.yaml",
                                  "%YAML:1.0\n---\nimu:\n  rate_hz: 200\nscale: 0.1\non: true  # why\n"
                                  "K: !!opencv-matrix\n  rows: 2\n  cols: 2\n  dt: d\n  data: [1, 2, 3, 4.5]\n");
  ips::Config c(p);
  EXPECT_EQ(c.section("imu").getInt("rate_hz"), 200);
  EXPECT_DOUBLE_EQ(c.section("imu").getDouble("noise", 1.0 / 3.0), 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(c.getDouble("scale"), 0.1);
  EXPECT_TRUE(c.getBool("on"));
  EXPECT_EQ(c.getString("name", "a \"b\""), "a \"b\"");
  EXPECT_FALSE(c.getBool("off", false));
  const cv::Mat K = c.getMat("K");
  const std::string yaml = c.effectiveYaml();
  EXPECT_NE(yaml.find("\nimu:\n  noise: 0.3333333333333333  # default\n  rate_hz: 200\n"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("\nscale: 0.1\n"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("\noff: false  # default\n"), std::string::npos) << yaml;

  ips::Config back(writeFile("effective_back.yaml", yaml));
  EXPECT_EQ(back.getInt("imu/rate_hz"), 200);
  EXPECT_EQ(back.getDouble("imu/noise"), 1.0 / 3.0);  // exactly
  EXPECT_EQ(back.getDouble("scale"), 0.1);
  EXPECT_TRUE(back.getBool("on"));
  EXPECT_FALSE(back.getBool("off"));
  EXPECT_EQ(back.getString("name"), "a \"b\"");
  const cv::Mat K2 = back.getMat("K");
  ASSERT_EQ(K2.rows, 2);
  ASSERT_EQ(K2.cols, 2);
  EXPECT_EQ(cv::norm(K, K2, cv::NORM_INF), 0.0);
  EXPECT_TRUE(back.unreadKeys().empty());
}

TEST(Config, MalformedYamlIsAnErrorNotAHang) {
  // 21 bytes on which cv::FileStorage alone loops forever (an unterminated flow sequence after the header).
  const std::string p = writeFile("hang.yaml", "%YAML:1.\n---L:0\n[---\n");
  try {
    ips::Config c(p);
    FAIL() << "a malformed file was accepted";
  } catch (const ips::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(p + ":"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not valid YAML"), std::string::npos) << e.what();
  }
}

TEST(Config, InputsThatBrokeOpenCvsReaderAreConfigErrors) {
  // Found by tests/fuzz/fuzz_config: cv::FileStorage throws std::length_error on this well-formed YAML.
  EXPECT_THROW(ips::Config(IPS_SOURCE_DIR "/tests/fuzz/corpus/fuzz_config/opencv_length_error.yaml"), ips::ConfigError);
  EXPECT_THROW(ips::Config(IPS_SOURCE_DIR "/tests/fuzz/corpus/fuzz_config/opencv_hang_21_bytes.yaml"),
               ips::ConfigError);
  // cv::FileStorage loops forever on a second document after an indented map (" s: 1", "---", "-:"): refused first.
  const std::string second = IPS_SOURCE_DIR "/tests/fuzz/corpus/fuzz_config/opencv_hang_second_document.yaml";
  try {
    ips::Config c(second);
    FAIL() << "a second document was accepted";
  } catch (const ips::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(second + ":3: not valid YAML here: a second document"), std::string::npos)
        << e.what();
  }
  // A file as OpenCV writes it (its header, then "---") is one document.
  EXPECT_NO_THROW(ips::Config(writeFile("opencv_header.yaml", "%YAML:1.0\n---\na: 1\n")));
}

TEST(Config, NonFiniteNumbersAreErrorsNamingTheKey) {
  const std::string p = writeFile("nan.yaml",
                                  "%YAML:1.0\n---\ninit:\n  heading_rad: .nan\ngravity: .inf\n"
                                  "position: [0, .nan, 1]\n");
  ips::Config c(p);
  for (const char* key : {"init/heading_rad", "gravity"}) {
    try {
      c.getDouble(key);
      FAIL() << key;
    } catch (const ips::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(c.getMatrix("position", 3, 1), ips::ConfigError);
}

TEST(Config, EveryShippedConfigurationIsWellFormed) {
  int files = 0;
  for (const char* dir : {IPS_SOURCE_DIR "/config", IPS_SOURCE_DIR "/tests"}) {
    for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
      // Not project configurations: fuzz inputs, and other tools' files (Kalibr, ROS) that the converters read.
      const std::string path = entry.path().string();
      if (entry.path().extension() != ".yaml" || path.find("/fuzz/") != std::string::npos ||
          path.find("/data/") != std::string::npos)
        continue;
      EXPECT_NO_THROW(ips::Config c(entry.path().string())) << entry.path();
      ++files;
    }
  }
  EXPECT_GT(files, 5);
}

ips::StereoCalibration exampleHead() {
  ips::StereoCalibration c;
  for (ips::CameraIntrinsics* cam : {&c.cam0, &c.cam1}) {
    cam->width = 1360;
    cam->height = 1024;
    cam->K << 744, 0, 680, 0, 744, 512, 0, 0, 1;
    cam->distortion << -0.2, 0.05, 0.001, -0.0005, 0.0;
  }
  c.cam1.K(0, 2) = 684;
  c.cam1.serial = "02-2110A";
  // The right camera 0.2 m to the right, slightly rotated.
  c.R_cam1_cam0 = Eigen::AngleAxisd(0.01, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  c.t_cam1_cam0 = -c.R_cam1_cam0 * Eigen::Vector3d(0.2, 0.002, -0.001);
  c.T_imu_cam0.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  c.T_imu_cam0.translation() = Eigen::Vector3d(0.05, 0.0, -0.02);
  return c;
}

TEST(Calibration, SaveLoadRoundTrip) {
  ips::StereoCalibration c = exampleHead();
  std::string p = tempPath("calib.yaml");
  ips::saveCalibration(p, c);
  ips::StereoCalibration r = ips::loadCalibration(p);
  EXPECT_EQ(r.cam0.width, 1360);
  EXPECT_NEAR((r.cam1.K - c.cam1.K).norm(), 0, 1e-12);
  EXPECT_NEAR((r.cam0.distortion - c.cam0.distortion).norm(), 0, 1e-12);
  EXPECT_NEAR((r.R_cam1_cam0 - c.R_cam1_cam0).norm(), 0, 1e-9);
  EXPECT_NEAR((r.t_cam1_cam0 - c.t_cam1_cam0).norm(), 0, 1e-12);
  EXPECT_NEAR((r.T_imu_cam0.matrix() - c.T_imu_cam0.matrix()).norm(), 0, 1e-9);
  EXPECT_EQ(r.cam1.serial, "02-2110A");
}

TEST(Calibration, ImuAndTiltDescriptionsRoundTripAndErrors) {
  ips::StereoCalibration c = exampleHead();
  EXPECT_FALSE(c.imu || c.tilt);
  const std::string plain = tempPath("plain.calib.yaml");
  ips::saveCalibration(plain, c);
  EXPECT_FALSE(ips::loadCalibration(plain).imu.has_value());  // written only when there is one
  ips::ImuDescription imu;
  imu.model = "ADIS16448";
  imu.rate_hz = 200;
  imu.gyro_noise_density = 1.6968e-4;
  imu.gyro_random_walk = 1.9393e-5;
  imu.accel_noise_density = 2e-3;
  imu.accel_random_walk = 3e-3;
  imu.gyro_bias_sigma = 0.1;
  imu.accel_bias_sigma = 0.3;
  c.imu = imu;
  ips::TiltDescription tilt;
  tilt.rate_hz = 14;
  tilt.accuracy = 8.7e-3;
  tilt.resolution = 1.75e-3;
  c.tilt = tilt;
  const std::string p = tempPath("imu.calib.yaml");
  ips::saveCalibration(p, c);
  const ips::StereoCalibration r = ips::loadCalibration(p);
  ASSERT_TRUE(r.imu && r.tilt);
  EXPECT_EQ(r.imu->model, "ADIS16448");
  EXPECT_DOUBLE_EQ(r.imu->gyro_noise_density, 1.6968e-4);
  EXPECT_DOUBLE_EQ(r.imu->gyro_random_walk, 1.9393e-5);
  EXPECT_DOUBLE_EQ(r.imu->accel_noise_density, 2e-3);
  EXPECT_DOUBLE_EQ(r.imu->accel_random_walk, 3e-3);
  EXPECT_DOUBLE_EQ(r.imu->gyro_bias_sigma, 0.1);
  EXPECT_DOUBLE_EQ(r.imu->accel_bias_sigma, 0.3);
  EXPECT_DOUBLE_EQ(r.tilt->accuracy, 8.7e-3);
  EXPECT_DOUBLE_EQ(r.tilt->resolution, 1.75e-3);
  // A noise density of zero would make the filter trust every sample absolutely: refused, naming the key.
  c.imu->accel_noise_density = 0;
  ips::saveCalibration(p, c);
  try {
    ips::loadCalibration(p);
    FAIL();
  } catch (const ips::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("imu/accel_noise_density"), std::string::npos) << e.what();
  }
}

TEST(Calibration, MissingKeyIsNamed) {
  std::string p = writeFile("incomplete.yaml", "%YAML:1.0\n---\ncam0:\n  width: 10\n");
  try {
    ips::loadCalibration(p);
    FAIL();
  } catch (const ips::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("cam0/height"), std::string::npos) << e.what();
  }
}

TEST(Calibration, RectifiedGeometryPutsMatchesOnOneRow) {
  // A 3D point seen by both cameras lands on the same rectified row, with x_left - x_right = f * b / Z.
  ips::StereoCalibration c = exampleHead();
  ips::StereoRectification rect = ips::computeRectification(c);
  EXPECT_NEAR(rect.baseline, c.baseline(), 1e-9);
  for (const Eigen::Vector3d& X0 : {Eigen::Vector3d(0.3, -0.2, 2.0), Eigen::Vector3d(-1.0, 0.5, 6.0)}) {
    Eigen::Vector3d X1 = c.R_cam1_cam0 * X0 + c.t_cam1_cam0;
    Eigen::Vector3d r0 = rect.R_rect0_cam0 * X0, r1 = rect.R_rect1_cam1 * X1;
    double u0 = rect.f * r0.x() / r0.z() + rect.cx, v0 = rect.f * r0.y() / r0.z() + rect.cy;
    double u1 = rect.f * r1.x() / r1.z() + rect.cx, v1 = rect.f * r1.y() / r1.z() + rect.cy;
    EXPECT_NEAR(v0, v1, 1e-6);
    EXPECT_NEAR(u0 - u1, rect.f * rect.baseline / r0.z(), 1e-6);
    // The maps send that rectified pixel to where the raw (distorted) camera sees the point.
    std::vector<cv::Point3d> obj{{X0.x(), X0.y(), X0.z()}};
    std::vector<cv::Point2d> raw;
    cv::projectPoints(obj, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), c.cam0.cvK(), c.cam0.cvDistortion(), raw);
    const float mx = rect.map0x.at<float>(static_cast<int>(std::lround(v0)), static_cast<int>(std::lround(u0)));
    const float my = rect.map0y.at<float>(static_cast<int>(std::lround(v0)), static_cast<int>(std::lround(u0)));
    EXPECT_NEAR(mx, raw[0].x, 1.5);  // within the rounding of the rectified pixel
    EXPECT_NEAR(my, raw[0].y, 1.5);
  }
}

TEST(Calibration, VignettingGainRoundTripAndErrors) {
  ips::StereoCalibration c = exampleHead();
  c.cam1.vignetting_gain = Eigen::Vector3d(2, 1, -0.25);
  const std::string p = tempPath("vignetting.calib.yaml");
  ips::saveCalibration(p, c);
  const ips::StereoCalibration r = ips::loadCalibration(p);
  EXPECT_FALSE(r.cam0.hasVignetting());  // written only when there is one, absent = none
  EXPECT_NEAR((r.cam1.vignetting_gain - c.cam1.vignetting_gain).norm(), 0, 1e-12);
  EXPECT_DOUBLE_EQ(r.cam1.flatFieldGain(0.5), 1 + 2 * 0.5 + 0.25 - 0.25 * 0.125);
  // A gain that turns negative inside the image would invert greys: refused, naming the key.
  c.cam1.vignetting_gain = Eigen::Vector3d(-3, 0, 0);
  ips::saveCalibration(p, c);
  try {
    ips::loadCalibration(p);
    FAIL();
  } catch (const ips::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("cam1/vignetting_gain"), std::string::npos) << e.what();
  }
}

TEST(Calibration, RayAngleOfEveryPixelThroughBothLensModels) {
  // rayTan2Image's ray of a pixel, projected back through the lens (OpenCV's projectPoints), lands on the pixel.
  ips::CameraIntrinsics radtan = exampleHead().cam0, fisheye = radtan;
  fisheye.model = ips::DistortionModel::kEquidistant;
  fisheye.distortion << 0.02, -0.01, 0.003, -0.001, 0;
  for (const ips::CameraIntrinsics& cam : {radtan, fisheye}) {
    const cv::Mat tan2 = ips::rayTan2Image(cam);
    ASSERT_EQ(tan2.size(), cv::Size(cam.width, cam.height));
    for (const cv::Point pixel : {cv::Point(0, 0), cv::Point(1359, 1023), cv::Point(680, 512), cv::Point(100, 900)}) {
      // The ray at the pixel's angle, in the pixel's direction from the principal point (distortion is radial
      // about it up to the small tangential terms, so the direction is found by a 1-D search).
      const double t = tan2.at<float>(pixel);
      const auto miss = [&](double phi) {
        std::vector<cv::Point3d> ray{{std::sqrt(t) * std::cos(phi), std::sqrt(t) * std::sin(phi), 1.0}};
        std::vector<cv::Point2d> image;
        if (cam.model == ips::DistortionModel::kEquidistant)
          cv::fisheye::projectPoints(ray, image, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cam.cvK(), cam.cvDistortion());
        else
          cv::projectPoints(ray, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cam.cvK(), cam.cvDistortion(), image);
        return std::hypot(image[0].x - pixel.x, image[0].y - pixel.y);
      };
      // Every 0.1 deg, then 1/1000 of that about the best.
      const double coarse = 2 * M_PI / 3600;
      double best = 1e9, best_phi = 0;
      for (int k = 0; k < 3600; ++k)
        if (miss(k * coarse) < best) best = miss(best_phi = k * coarse);
      for (int k = -1000; k <= 1000; ++k) best = std::min(best, miss(best_phi + k * coarse / 1000));
      EXPECT_LT(best, 0.05) << pixel << " fisheye " << (cam.model == ips::DistortionModel::kEquidistant);
    }
  }
}

TEST(Calibration, FlatFieldGainOfEachRectifiedPixelIsThatOfTheRawPixelItSamples) {
  // Natural vignetting (gain (1 + t)^2): the gain at a rectified pixel is that of the raw pixel its map samples,
  // whose ray comes from undistorting that pixel (rayTan2Image, independent of the rectification's rotations), at
  // full and half scale and with a right-camera correction that turns, scales and moves the right map.
  ips::StereoCalibration c = exampleHead();
  for (ips::CameraIntrinsics* cam : {&c.cam0, &c.cam1}) cam->vignetting_gain = Eigen::Vector3d(2, 1, 0);
  const cv::Mat raw_tan2[2] = {ips::rayTan2Image(c.cam0), ips::rayTan2Image(c.cam1)};
  ips::RightCameraCorrection correction;
  correction.rotation = Eigen::Vector3d(0.002, 0.003, -0.001);
  correction.focal_scale = 0.001;
  correction.disparity_offset_px = 1.5;
  for (const ips::RightCameraCorrection& right : {ips::RightCameraCorrection{}, correction})
    for (double scale : {1.0, 0.5}) {
      const ips::StereoRectification rect = ips::scaledRectification(c, scale, right);
      ASSERT_TRUE(rect.hasFlatField());
      ASSERT_EQ(rect.gain1.size(), rect.size);
      for (const cv::Point pixel : {cv::Point(rect.size.width / 2, rect.size.height / 2), cv::Point(10, 10),
                                    cv::Point(rect.size.width - 20, rect.size.height - 30)})
        for (int cam = 0; cam < 2; ++cam) {
          const cv::Mat& map_x = cam == 0 ? rect.map0x : rect.map1x;
          const cv::Mat& map_y = cam == 0 ? rect.map0y : rect.map1y;
          cv::Mat t;
          cv::getRectSubPix(raw_tan2[cam], cv::Size(1, 1), cv::Point2f(map_x.at<float>(pixel), map_y.at<float>(pixel)),
                            t);
          const double expected = (1 + t.at<float>(0)) * (1 + t.at<float>(0));
          const float gain = (cam == 0 ? rect.gain0 : rect.gain1).at<float>(pixel);
          EXPECT_NEAR(gain, expected, 0.003 * expected) << pixel << " camera " << cam << " scale " << scale;
        }
    }
  // Without vignetting_gain there are no gains, and rectifyPair is cv::remap as before.
  EXPECT_FALSE(ips::computeRectification(exampleHead()).hasFlatField());
}

TEST(Args, OptionsFlagsAndErrors) {
  const char* argv[] = {"prog", "--calib", "c.yaml", "--rate=8", "--verbose", "pos"};
  ips::Args a(6, const_cast<char**>(argv), "test");
  a.required("--calib", "FILE", "calibration").option("--rate", "HZ", "rate", "4").option("--n", "N", "n", "3");
  a.flag("--verbose", "talk").positionals("X", "input", 1, 1);
  ASSERT_TRUE(a.parse());
  EXPECT_EQ(a.get("--calib"), "c.yaml");
  EXPECT_DOUBLE_EQ(a.getDouble("--rate"), 8.0);
  EXPECT_EQ(a.getInt("--n"), 3);
  EXPECT_TRUE(a.getFlag("--verbose"));
  EXPECT_EQ(a.positional().at(0), "pos");

  const char* bad[] = {"prog", "--nope", "1"};
  ips::Args b(3, const_cast<char**>(bad), "test");
  b.option("--rate", "HZ", "rate");
  EXPECT_THROW(b.parse(), ips::ArgError);
  const char* missing[] = {"prog"};
  ips::Args m(1, const_cast<char**>(missing), "test");
  m.required("--calib", "FILE", "calibration");
  EXPECT_THROW(m.parse(), ips::ArgError);
  const char* notnum[] = {"prog", "--rate", "fast"};
  ips::Args n(3, const_cast<char**>(notnum), "test");
  n.option("--rate", "HZ", "rate");
  ASSERT_TRUE(n.parse());
  EXPECT_THROW(n.getDouble("--rate"), ips::ArgError);
}

TEST(Args, HelpOfSeveralLinesIsIndented) {
  const char* argv[] = {"prog"};
  ips::Args a(1, const_cast<char**>(argv), "test");
  a.option("--cost", "NAME", "matching cost\n(default census)", "census");
  const std::string help = a.help();
  EXPECT_NE(help.find("  --cost NAME                 matching cost\n" + std::string(30, ' ') +
                      "(default census) [default: census]\n"),
            std::string::npos)
      << help;
}

// The spellings the upstream procman tools accept: short forms, old long names, options given several times.
TEST(Args, AliasesAndRepeatedOptions) {
  const char* argv[] = {"prog", "-u", "udpm://a", "--start", "x", "--lcmurl=udpm://b", "--start", "y", "-v", "-"};
  ips::Args a(10, const_cast<char**>(argv), "test");
  a.section("Actions").repeated("--start", "NAME", "start NAME");
  a.section("Options").option("--lcm-url", "URL", "LCM URL").alias("-u", "--lcm-url").alias("--lcmurl", "--lcm-url");
  a.flag("--verbose", "talk").alias("-v", "--verbose").positionals("FILE", "input", 0, 1);
  a.usage("prog [options] ACTION...").epilog("Exit status: 0 done.");
  ASSERT_TRUE(a.parse());
  EXPECT_EQ(a.get("--lcm-url"), "udpm://b");  // given twice, the last holds
  EXPECT_EQ(a.getAll("--start"), (std::vector<std::string>{"x", "y"}));
  EXPECT_TRUE(a.getFlag("--verbose"));
  EXPECT_EQ(a.positional(), std::vector<std::string>{"-"});
  const std::string help = a.help();
  EXPECT_NE(help.find("Usage: prog [options] ACTION...\n\nActions:\n  --start NAME"), std::string::npos) << help;
  EXPECT_NE(help.find("\nOptions:\n  -u, --lcm-url URL           LCM URL (also --lcmurl)\n"), std::string::npos)
      << help;
  EXPECT_NE(help.find("start NAME (repeatable)"), std::string::npos) << help;
  EXPECT_EQ(help.substr(help.size() - 21), "Exit status: 0 done.\n");

  const char* unknown_short[] = {"prog", "-x"};
  ips::Args b(2, const_cast<char**>(unknown_short), "test");
  b.flag("--verbose", "talk").alias("-v", "--verbose");
  try {
    b.parse();
    FAIL() << "-x accepted";
  } catch (const ips::ArgError& e) {
    EXPECT_STREQ(e.what(), "prog: unknown option '-x' (see --help)");
  }
  const char* negative[] = {"prog", "-3"};
  ips::Args c(2, const_cast<char**>(negative), "test");
  c.positionals("N", "a number", 1, 1);
  ASSERT_TRUE(c.parse());
  EXPECT_EQ(c.positional().front(), "-3");
}

TEST(Args, IntegerListsAndTheirErrors) {
  EXPECT_EQ(ips::parseIntList("1,2,4,8", "--gaps", 1), (std::vector<int>{1, 2, 4, 8}));
  EXPECT_EQ(ips::parseIntList("-3", "--offsets", -5), (std::vector<int>{-3}));
  for (const char* bad : {"", "1,,2", "1,x", "2.5", "0"})
    EXPECT_THROW(ips::parseIntList(bad, "--gaps", 1), ips::ArgError) << "'" << bad << "'";
}

TEST(Pfm, RoundTripKeepsInfAndOrientation) {
  cv::Mat d(3, 4, CV_32FC1);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) d.at<float>(r, c) = r * 10.0f + c + 0.25f;
  d.at<float>(0, 0) = INFINITY;
  std::string p = tempPath("d.pfm");
  ips::writePfm(p, d);
  cv::Mat r = ips::readPfm(p);
  ASSERT_EQ(r.size(), d.size());
  EXPECT_TRUE(std::isinf(r.at<float>(0, 0)));
  EXPECT_EQ(r.at<float>(2, 3), 23.25f);
  EXPECT_THROW(ips::readPfm(writeFile("x.pfm", "P6\n1 1\n255\n")), std::runtime_error);
}

}  // namespace

TEST(PoseBuffer, InterpolatesBetweenStatesAndSaysWhenItCannot) {
  ips::PoseBuffer buffer(0.1, 10.0);
  ips::Pose a, b, c;
  a.utime = 1000000;
  b.utime = 1050000;
  b.T_world_body.translation() = Eigen::Vector3d(1, 2, 0);
  b.T_world_body.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  b.covariance.setIdentity();
  c.utime = 1500000;  // 0.45 s after b: a gap
  ASSERT_TRUE(buffer.add(a));
  ASSERT_TRUE(buffer.add(b));
  ips::Pose out;
  ASSERT_EQ(buffer.at(1010000, &out), ips::PoseBuffer::Lookup::kFound);
  EXPECT_TRUE(out.T_world_body.translation().isApprox(Eigen::Vector3d(0.2, 0.4, 0), 1e-12));
  EXPECT_NEAR(Eigen::AngleAxisd(out.T_world_body.linear()).angle(), 0.04, 1e-12);
  EXPECT_EQ(out.covariance, a.covariance) << "the nearer state's covariance";
  EXPECT_EQ(buffer.at(1060000, &out), ips::PoseBuffer::Lookup::kNotYet);
  EXPECT_EQ(buffer.at(900000, &out), ips::PoseBuffer::Lookup::kTooOld);
  ASSERT_TRUE(buffer.add(c));
  EXPECT_EQ(buffer.at(1200000, &out), ips::PoseBuffer::Lookup::kGap);
  EXPECT_FALSE(buffer.add(a)) << "time going back starts the buffer over";
  EXPECT_EQ(buffer.newestUtime(), a.utime);
}
