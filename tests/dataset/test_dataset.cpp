// The recording readers on a few frames of the shared EuRoC and KITTI excerpts: frame count, stamps, calibration
// and ground truth against the values in the files; bad folders give an error naming the file and line.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "ips/dataset/dataset.hpp"
#include "ips/shared_data_test.hpp"

namespace fs = std::filesystem;
using namespace ips::dataset;

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
  const GroundTruthPose& g1 = r.ground_truth[1];
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
  EXPECT_TRUE(r.imu.empty());                     // the excerpt holds no imu0/data.csv
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
  EXPECT_TRUE(r.ground_truth.front().has_state);
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
