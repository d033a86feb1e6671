// The recording readers on a few frames of the shared EuRoC and KITTI excerpts: frame count, stamps, calibration
// and ground truth against the values in the files; bad folders give an error naming the file and line.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "ips/dataset/dataset.hpp"
#include "ips/shared_data_test.hpp"

namespace fs = std::filesystem;
using namespace ips::dataset;
using ips::InertialState;

namespace {

const std::string kData = ips::dataDir();
const std::string kKitti = kData + "/kitti_odometry/06_first51";
const std::string kMh01 = kData + "/euroc/MH_01_easy_first150";
const std::string kV101 = kData + "/euroc/V1_01_easy";

#define REQUIRE_DIR(dir) \
  if (!fs::is_directory(dir)) GTEST_SKIP() << "shared data missing: " << (dir) << " (see ../shared/data)"

// A scratch copy of an EuRoC folder's text files with its images linked, to be broken by a test.
std::string scratchEuroc(const std::string& name) {
  const std::string dir = (fs::temp_directory_path() / ("ips_test_dataset_" + name)).string();
  fs::remove_all(dir);
  for (const char* cam : {"cam0", "cam1"}) {
    fs::create_directories(dir + "/mav0/" + cam);
    fs::copy(kMh01 + "/mav0/" + cam + "/sensor.yaml", dir + "/mav0/" + cam + "/sensor.yaml");
    fs::copy(kMh01 + "/mav0/" + cam + "/data.csv", dir + "/mav0/" + cam + "/data.csv");
    fs::create_directory_symlink(kMh01 + "/mav0/" + cam + "/data", dir + "/mav0/" + cam + "/data");
  }
  return dir;
}

void replaceLine(const std::string& path, int line_number, const std::string& text) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  std::string l;
  while (std::getline(in, l)) lines.push_back(l);
  lines.at(line_number - 1) = text;
  std::ofstream out(path);
  for (const auto& s : lines) out << s << "\n";
}

std::string errorOf(const std::string& dir) {
  try {
    readEuroc(dir, ReadOptions{});
  } catch (const DatasetError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(DatasetKitti, FramesStampsCalibrationAndPosesMatchTheFiles) {
  REQUIRE_DIR(kKitti);
  EXPECT_EQ(detectFormat(kKitti), "kitti");
  ReadOptions o;
  o.first = 1;
  o.last = 4;
  const Recording r = readKitti(kKitti, o);
  ASSERT_EQ(r.frames.size(), 4u);
  // times.txt: 0, 0.1044989, 0.2077935 s, ...; the head's clock adds kKittiClockOffsetUs.
  EXPECT_EQ(r.frames[0].utime, kKittiClockOffsetUs + 104499);
  EXPECT_EQ(r.frames[1].utime, kKittiClockOffsetUs + 207794);
  EXPECT_EQ(r.frames[0].index, 1);
  EXPECT_EQ(fs::path(r.frames[3].left_path).filename(), "000004.png");
  EXPECT_NE(r.frames[3].right_path.find("image_1"), std::string::npos);
  EXPECT_TRUE(r.imu.empty());
  // calib.txt: P0 = [707.0912 0 601.8873 0; 0 707.0912 183.1104 0; 0 0 1 0], P1(0,3) = -379.8145.
  EXPECT_EQ(r.calib.cam0.width, 1226);
  EXPECT_EQ(r.calib.cam0.height, 370);
  EXPECT_DOUBLE_EQ(r.calib.cam0.K(0, 0), 707.0912);
  EXPECT_DOUBLE_EQ(r.calib.cam0.K(0, 2), 601.8873);
  EXPECT_DOUBLE_EQ(r.calib.cam1.K(1, 2), 183.1104);
  EXPECT_NEAR(r.calib.t_cam1_cam0.x(), -379.8145 / 707.0912, 1e-12);
  EXPECT_EQ(r.calib.cam0.distortion.norm(), 0.0);
  EXPECT_TRUE(r.calib.T_imu_cam0.isApprox(Eigen::Isometry3d::Identity()));
  // poses/06.txt row 1 (frame 1): t = (-0.01401751, -0.02820321, 1.198998), kept with one sample before.
  ASSERT_GE(r.ground_truth.size(), 5u);
  const InertialState& g1 = r.ground_truth[1];
  EXPECT_EQ(g1.utime, r.frames[0].utime);
  EXPECT_NEAR(g1.position.x(), -1.401751e-02, 1e-9);
  EXPECT_NEAR(g1.position.z(), 1.198998, 1e-9);
  EXPECT_NEAR(g1.orientation.toRotationMatrix()(0, 1), 7.196824e-04, 1e-6);
  // Body = camera 0 on KITTI: the camera's pose is the ground truth itself.
  EXPECT_TRUE(cameraPose(g1, r.calib).translation().isApprox(g1.position));
}

TEST(DatasetEuroc, FramesStampsAndCalibrationMatchTheFiles) {
  REQUIRE_DIR(kMh01);
  EXPECT_EQ(detectFormat(kMh01), "euroc");
  ReadOptions o;
  o.last = 2;
  const Recording r = readEuroc(kMh01, o);
  ASSERT_EQ(r.frames.size(), 3u);
  // cam0/data.csv: 1403636584763555584, 1403636584813555456 ns -> microseconds (rounded).
  EXPECT_EQ(r.frames[0].utime, 1403636584763556);
  EXPECT_EQ(r.frames[1].utime, 1403636584813555);
  EXPECT_NE(r.frames[0].left_path.find("cam0/data/1403636584763555584.png"), std::string::npos);
  EXPECT_NE(r.frames[0].right_path.find("cam1/data/1403636584763555584.png"), std::string::npos);
  // cam0/sensor.yaml: intrinsics [458.654, 457.296, 367.215, 248.375], k1 -0.28340811, T_BS(0,3) -0.0216401454975.
  EXPECT_EQ(r.calib.cam0.width, 752);
  EXPECT_EQ(r.calib.cam0.height, 480);
  EXPECT_DOUBLE_EQ(r.calib.cam0.K(0, 0), 458.654);
  EXPECT_DOUBLE_EQ(r.calib.cam0.K(1, 2), 248.375);
  EXPECT_DOUBLE_EQ(r.calib.cam0.distortion(0), -0.28340811);
  EXPECT_NEAR(r.calib.T_imu_cam0.translation().x(), -0.0216401454975, 1e-12);
  EXPECT_NEAR(r.calib.baseline(), 0.110, 0.001);  // the VI-Sensor's 11 cm
  // The ADIS16448 at 200 Hz over the three frames' 0.1 s, with one sample on each side for interpolation; its
  // description from imu0/sensor.yaml.
  ASSERT_GE(r.imu.size(), 21u);
  EXPECT_LE(r.imu.size(), 23u);
  EXPECT_LE(r.imu.front().utime, r.frames.front().utime);
  EXPECT_GE(r.imu.back().utime, r.frames.back().utime);
  ASSERT_TRUE(r.calib.imu.has_value());
  EXPECT_DOUBLE_EQ(r.calib.imu->rate_hz, 200.0);
  EXPECT_DOUBLE_EQ(r.calib.imu->gyro_noise_density, 1.6968e-04);
  EXPECT_DOUBLE_EQ(r.calib.imu->gyro_random_walk, 1.9393e-05);
  EXPECT_DOUBLE_EQ(r.calib.imu->accel_noise_density, 2.0e-3);
  EXPECT_DOUBLE_EQ(r.calib.imu->accel_random_walk, 3.0e-3);
  EXPECT_FALSE(r.calib.tilt.has_value());  // the VI-Sensor has no inclinometer
  // Without the IMU (the cameras alone): neither samples nor a description.
  o.imu = false;
  const Recording cameras = readEuroc(kMh01, o);
  EXPECT_TRUE(cameras.imu.empty());
  EXPECT_FALSE(cameras.calib.imu.has_value());
  // Ground truth: the 200 Hz TUM file covers the frames; its first line is 1403636583.76356 s.
  EXPECT_NE(r.ground_truth_source.find("MH_01_easy_tum_window.txt"), std::string::npos);
  ASSERT_GE(r.ground_truth.size(), 20u);
  EXPECT_LE(r.ground_truth.front().utime, r.frames.front().utime);
  EXPECT_GE(r.ground_truth.back().utime, r.frames.back().utime);
}

TEST(DatasetEuroc, ImuAndStateGroundTruthOfV101) {
  REQUIRE_DIR(kV101);
  ReadOptions o;
  o.last = 3;
  const Recording r = readEuroc(kV101, o);
  ASSERT_EQ(r.frames.size(), 4u);
  // 200 Hz IMU over the 0.15 s of four frames, plus one sample on each side for interpolation.
  ASSERT_GE(r.imu.size(), 30u);
  EXPECT_LE(r.imu.size(), 33u);
  // imu0/data.csv line 2: 1403715273262142976 ns, gyro x -0.0020943951023931952, accel x 9.0874956666666655.
  EXPECT_EQ(r.imu.front().utime, 1403715273262143);
  EXPECT_DOUBLE_EQ(r.imu.front().angular_rate.x(), -0.0020943951023931952);
  EXPECT_DOUBLE_EQ(r.imu.front().specific_force.x(), 9.0874956666666655);
  // The official TUM file starts a second after these frames; the re-estimated csv covers them, with biases.
  EXPECT_NE(r.ground_truth_source.find("vicon2gt"), std::string::npos);
  ASSERT_FALSE(r.ground_truth.empty());
  EXPECT_TRUE(r.ground_truth_has_state);
  EXPECT_DOUBLE_EQ(r.ground_truth.front().gyro_bias.z(), 0.0770299);
}

TEST(DatasetEuroc, BadFoldersNameTheFileAndLine) {
  REQUIRE_DIR(kMh01);
  std::string dir = scratchEuroc("badline");
  replaceLine(dir + "/mav0/cam0/data.csv", 3, "1403636584813555456;not_a_csv_line");
  EXPECT_NE(errorOf(dir).find("cam0/data.csv:3:"), std::string::npos) << errorOf(dir);

  dir = scratchEuroc("order");
  replaceLine(dir + "/mav0/cam1/data.csv", 4, "1403636584700000000,1403636584863555584.png");
  EXPECT_NE(errorOf(dir).find("cam1/data.csv:4: time stamp"), std::string::npos) << errorOf(dir);

  dir = scratchEuroc("missing");
  fs::remove(dir + "/mav0/cam1/sensor.yaml");
  EXPECT_NE(errorOf(dir).find("cam1/sensor.yaml"), std::string::npos) << errorOf(dir);

  dir = scratchEuroc("size");
  EXPECT_THROW(loadImage(kMh01 + "/mav0/cam0/data/1403636584763555584.png", 1226, 370), DatasetError);
  EXPECT_THROW(readRecording("tum", dir, ReadOptions{}), DatasetError);
  EXPECT_THROW(detectFormat(dir + "/mav0"), DatasetError);
  for (const char* n : {"badline", "order", "missing", "size"})
    fs::remove_all(fs::temp_directory_path() / (std::string("ips_test_dataset_") + n));
}

namespace {

// A KITTI raw drive in its layout, made for the test from the odometry excerpt's first frames: its rectified images
// as image_00 / image_01 of a synced drive, its projection matrices as P_rect_0x, a camera-velodyne-OXTS mounting, and
// OXTS lines whose position and attitude are the excerpt's poses of camera 0 carried to the OXTS unit and written as
// latitude, longitude, altitude, roll, pitch, yaw (the devkit's Mercator projection inverted), and whose inertial
// values are the field's number plus a hundredth of the sample's index. body_in_world: the OXTS poses (east, north,
// up).
struct KittiRawFixture {
  std::string drive;
  std::vector<Eigen::Isometry3d> body_in_world;
  Eigen::Isometry3d T_imu_cam0 = Eigen::Isometry3d::Identity();
  std::vector<int64_t> utimes;
};

std::string fmt(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.12e", v);
  return b;
}

// `name`: the test's own folder (ctest runs the tests of this file side by side).
KittiRawFixture makeKittiRawDrive(const std::string& name, int frames) {
  KittiRawFixture fx;
  const std::string date = (fs::temp_directory_path() / ("ips_test_kitti_raw_" + name) / "2011_09_30").string();
  fs::remove_all(date);
  fx.drive = date + "/2011_09_30_drive_0020_sync";
  for (const char* sub : {"/image_00/data", "/image_01/data", "/oxts/data"}) fs::create_directories(fx.drive + sub);
  const std::string seq = kKitti + "/sequences/06";
  // Calibration: the excerpt's P0 / P1, a small rectifying rotation, a velodyne 0.27 m behind and 0.08 m above the
  // camera, the OXTS 0.81 m behind and 0.32 m to the right of the velodyne (KITTI's car, rounded).
  const Eigen::Matrix3d R_rect = Eigen::AngleAxisd(0.01, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Eigen::Isometry3d T_cam_velo = Eigen::Isometry3d::Identity(), T_velo_imu = Eigen::Isometry3d::Identity();
  T_cam_velo.linear() << 0, -1, 0, 0, 0, -1, 1, 0, 0;  // velodyne x forward, y left, z up; camera x right, y down
  T_cam_velo.translation() = Eigen::Vector3d(0.0, -0.08, -0.27);
  T_velo_imu.linear() = Eigen::AngleAxisd(0.002, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_velo_imu.translation() = Eigen::Vector3d(-0.81, 0.32, -0.80);
  auto row = [](const Eigen::MatrixXd& m) {
    std::string s;
    for (int r = 0; r < m.rows(); ++r)
      for (int c = 0; c < m.cols(); ++c) s += " " + fmt(m(r, c));
    return s;
  };
  {
    std::ifstream calib(seq + "/calib.txt");
    std::string p0, p1;
    std::getline(calib, p0);
    std::getline(calib, p1);
    std::ofstream out(date + "/calib_cam_to_cam.txt");
    out << "calib_time: 09-Jan-2012 13:57:47\ncorner_dist: 9.950000e-02\n";
    out << "S_00: 1.392000e+03 5.120000e+02\nS_rect_00: 1.226000e+03 3.700000e+02\n";
    out << "R_rect_00:" << row(R_rect) << "\n";
    out << "P_rect_00:" << p0.substr(3) << "\nP_rect_01:" << p1.substr(3) << "\n";
    std::ofstream(date + "/calib_velo_to_cam.txt")
        << "calib_time: 15-Mar-2012 11:37:16\nR:" << row(T_cam_velo.linear()) << "\nT:" << row(T_cam_velo.translation())
        << "\ndelta_f: 0 0\ndelta_c: 0 0\n";
    std::ofstream(date + "/calib_imu_to_velo.txt") << "calib_time: 25-May-2012 16:47:16\nR:" << row(T_velo_imu.linear())
                                                   << "\nT:" << row(T_velo_imu.translation()) << "\n";
  }
  Eigen::Isometry3d T_rect = Eigen::Isometry3d::Identity();
  T_rect.linear() = R_rect;
  fx.T_imu_cam0 = (T_rect * T_cam_velo * T_velo_imu).inverse();
  // The world: east, north, up; the first camera looking north-east, level.
  Eigen::Isometry3d T_w_c0 = Eigen::Isometry3d::Identity();
  T_w_c0.linear() = Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                    (Eigen::Matrix3d() << 1, 0, 0, 0, 0, 1, 0, -1, 0).finished();
  std::ifstream poses(kKitti + "/poses/06.txt");
  std::ofstream t0(fx.drive + "/image_00/timestamps.txt"), t1(fx.drive + "/image_01/timestamps.txt"),
      to(fx.drive + "/oxts/timestamps.txt");
  const double lat0 = 49.011, lon0 = 8.4235, alt0 = 112.9, er = 6378137.0, scale = std::cos(lat0 * M_PI / 180);
  const double mx0 = scale * lon0 * M_PI * er / 180, my0 = scale * er * std::log(std::tan((90 + lat0) * M_PI / 360));
  for (int k = 0; k < frames; ++k) {
    Eigen::Matrix<double, 3, 4> m;
    for (int i = 0; i < 12; ++i) poses >> m(i / 4, i % 4);
    Eigen::Isometry3d T_c00_ck = Eigen::Isometry3d::Identity();
    T_c00_ck.linear() = m.leftCols<3>();
    T_c00_ck.translation() = m.col(3);
    // The rectified camera 0 of the odometry excerpt is the raw drive's rectified camera 0.
    const Eigen::Isometry3d T_w_b = T_w_c0 * T_c00_ck * fx.T_imu_cam0.inverse();
    fx.body_in_world.push_back(T_w_b);
    char name[32];
    std::snprintf(name, sizeof name, "%010d.png", k);
    char odo[16];
    std::snprintf(odo, sizeof odo, "%06d.png", k);
    fs::copy(seq + "/image_0/" + odo, fx.drive + "/image_00/data/" + name);
    fs::copy(seq + "/image_1/" + odo, fx.drive + "/image_01/data/" + name);
    // 10 Hz, the right camera 0.2 ms after the left, the OXTS sample 1.5 ms before them.
    const int us = 964389 + k * 103500;
    const int sec = 25 + us / 1000000, frac = us % 1000000;
    char stamp[64];
    std::snprintf(stamp, sizeof stamp, "2011-09-30 12:40:%02d.%06d000\n", sec, frac);
    t0 << stamp;
    std::snprintf(stamp, sizeof stamp, "2011-09-30 12:40:%02d.%06d000\n", sec + (frac + 200) / 1000000,
                  (frac + 200) % 1000000);
    t1 << stamp;
    std::snprintf(stamp, sizeof stamp, "2011-09-30 12:40:%02d.%06d000\n", sec, frac - 1500);
    to << stamp;
    fx.utimes.push_back(((int64_t(15247) * 24 + 12) * 60 + 40) * 60'000'000LL + sec * 1'000'000LL + frac);
    // Position and attitude of the OXTS unit.
    const Eigen::Vector3d p = T_w_b.translation();
    const double lon = (mx0 + p.x()) * 180 / (scale * M_PI * er);
    const double lat = 360 / M_PI * std::atan(std::exp((my0 + p.y()) / (scale * er))) - 90;
    const Eigen::Vector3d ypr = T_w_b.linear().eulerAngles(2, 1, 0);
    std::snprintf(name, sizeof name, "%010d.txt", k);
    std::ofstream o(fx.drive + "/oxts/data/" + name);
    o << fmt(lat) << " " << fmt(lon) << " " << fmt(alt0 + p.z()) << " " << fmt(ypr[2]) << " " << fmt(ypr[1]) << " "
      << fmt(ypr[0]);
    for (int i = 6; i < 30; ++i) o << " " << (i < 25 ? fmt(i + 0.01 * k) : std::to_string(i));
    o << "\n";
  }
  return fx;
}

}  // namespace

TEST(DatasetKittiRaw, DriveLayoutCalibrationOxtsPosesAndInertialFields) {
  REQUIRE_DIR(kKitti);
  const KittiRawFixture fx = makeKittiRawDrive("layout", 8);
  EXPECT_EQ(detectFormat(fx.drive), "kitti_raw");
  ReadOptions o;
  o.first = 1;
  o.last = 6;
  const Recording r = readRecording("kitti_raw", fx.drive, o);
  ASSERT_EQ(r.frames.size(), 6u);
  EXPECT_EQ(r.frames[0].utime, fx.utimes[1]);
  EXPECT_EQ(r.frames[0].index, 1);
  EXPECT_NE(r.frames[0].left_path.find("image_00/data/0000000001.png"), std::string::npos);
  // The synced drive's images are rectified: the pinhole pair of P_rect_00 / P_rect_01.
  EXPECT_EQ(r.calib.cam0.width, 1226);
  EXPECT_DOUBLE_EQ(r.calib.cam0.K(0, 0), 707.0912);
  EXPECT_DOUBLE_EQ(r.calib.cam1.K(1, 2), 183.1104);
  EXPECT_EQ(r.calib.cam0.distortion.norm(), 0.0);
  EXPECT_NEAR(r.calib.baseline(), 379.8145 / 707.0912, 1e-9);
  EXPECT_LT((r.calib.T_imu_cam0.matrix() - fx.T_imu_cam0.matrix()).norm(), 1e-9);
  // Ground truth: the OXTS poses back from latitude, longitude, altitude, roll, pitch and yaw, relative to the first
  // OXTS sample of the drive (the world's origin), within the projection's arithmetic.
  // The OXTS samples 2-6 lie within frames 1-6 (each 1.5 ms before its frame), with one on each side: 1-7.
  ASSERT_EQ(r.ground_truth.size(), 7u);
  const Eigen::Vector3d origin = fx.body_in_world[0].translation();
  for (size_t i = 0; i < r.ground_truth.size(); ++i) {
    const size_t k = i + 1;
    const InertialState& g = r.ground_truth[i];
    EXPECT_LT((g.position - (fx.body_in_world[k].translation() - origin)).norm(), 1e-4) << k;
    EXPECT_LT(Eigen::AngleAxisd(g.orientation.toRotationMatrix().transpose() * fx.body_in_world[k].linear()).angle(),
              1e-9)
        << k;
    EXPECT_EQ(g.utime, fx.utimes[k] - 1500);
  }
  // The camera's pose from the ground truth is the excerpt's (the mounting undone exactly).
  const Eigen::Isometry3d c1 = cameraPose(r.ground_truth[0], r.calib), c2 = cameraPose(r.ground_truth[1], r.calib);
  const Eigen::Isometry3d excerpt_c1_c2 =
      (fx.body_in_world[1] * fx.T_imu_cam0).inverse() * (fx.body_in_world[2] * fx.T_imu_cam0);
  EXPECT_LT(((c1.inverse() * c2).matrix() - excerpt_c1_c2.matrix()).norm(), 1e-4);
  // The inertial fields: ax ay az are fields 12-14 (1-based), wx wy wz 18-20.
  ASSERT_EQ(r.imu.size(), 7u);
  EXPECT_NEAR(r.imu[1].specific_force.x(), 11 + 0.02, 1e-9);  // sample 2
  EXPECT_NEAR(r.imu[1].specific_force.z(), 13 + 0.02, 1e-9);
  EXPECT_NEAR(r.imu[1].angular_rate.y(), 18 + 0.02, 1e-9);
  // The IMU's rate from its stamps (103.5 ms: 9.66 Hz) and its noise measured from the samples (a linear ramp here:
  // nothing above the sensors' own floor).
  ASSERT_TRUE(r.calib.imu.has_value());
  EXPECT_NEAR(r.calib.imu->rate_hz, 1e6 / 103500, 1e-6);
  EXPECT_NEAR(r.calib.imu->accel_noise_density, 0.005, 1e-9);
  EXPECT_FALSE(r.calib.tilt.has_value());
}

TEST(DatasetKittiRaw, BadDrivesNameTheFile) {
  REQUIRE_DIR(kKitti);
  const KittiRawFixture fx = makeKittiRawDrive("bad", 3);
  ReadOptions o;
  auto errorOf = [&]() -> std::string {
    try {
      readKittiRaw(fx.drive, o);
    } catch (const DatasetError& e) {
      return e.what();
    }
    return "";
  };
  std::ofstream(fx.drive + "/oxts/data/0000000001.txt") << "49.0 8.4 112.0\n";
  EXPECT_NE(errorOf().find("oxts/data/0000000001.txt:1: expected 30 values"), std::string::npos) << errorOf();
  fs::remove(fx.drive + "/../calib_imu_to_velo.txt");
  EXPECT_NE(errorOf().find("calib_imu_to_velo.txt: missing"), std::string::npos) << errorOf();
}
