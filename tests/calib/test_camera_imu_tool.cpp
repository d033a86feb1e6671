// calibrate_camera_imu on a recorded LCM log: simulated IMU and tracker messages written with lcm::LogFile, the
// camera turned against the IMU and its stamps late by known amounts; the tool must report both and write them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <ips/imu_sample_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <opencv2/core.hpp>
#include <string>

#include "ips/calibration.hpp"
#include "ips/test_support/command_output.hpp"
#include "simulated_motion.hpp"

namespace {

using ips::test_support::commandOutput;

template <class Msg>
void write(lcm::LogFile& log, const std::string& channel, int64_t utime, const Msg& m) {
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  lcm::LogEvent e;
  e.timestamp = utime;
  e.channel = channel;
  e.datalen = static_cast<int32_t>(bytes.size());
  e.data = bytes.data();
  log.writeEvent(&e);
}

}  // namespace

TEST(CameraImuTool, ReportsAndWritesTheRotationAndDelayOfARecordedLog) {
  const int64_t late = 31'500;
  const auto sim = ips::calib::testing::simulateMotion(40.0, late, 5);
  const std::string path = ::testing::TempDir() + "camera_imu_tool_test.lcmlog";
  {
    lcm::LogFile log(path, "w");
    ASSERT_TRUE(log.good());
    size_t d = 0;
    int64_t seq = 0;
    for (const auto& g : sim.gyro) {
      // Interleaved roughly in arrival order, as a logger would record them.
      while (d < sim.deltas.size() && sim.deltas[d].utime <= g.utime) {
        ips::tracker_delta_t m{};
        m.utime = sim.deltas[d].utime;
        m.utime_prev = sim.deltas[d].utime_prev;
        m.seq = static_cast<int64_t>(d);
        m.valid = true;
        const auto& q = sim.deltas[d].rotation;
        m.rotation[0] = q.w();
        m.rotation[1] = q.x();
        m.rotation[2] = q.y();
        m.rotation[3] = q.z();
        write(log, "TRACKER_DELTA", m.utime, m);
        ++d;
      }
      ips::imu_sample_t m{};
      m.utime = g.utime;
      m.seq = seq++;
      for (int i = 0; i < 3; ++i) m.angular_rate[i] = g.rate[i];
      m.specific_force[2] = 9.81;
      write(log, "IMU", m.utime, m);
    }
  }
  // The head's calibration as designed: the camera's axes turned by 90 deg twice, without the mounting error.
  ips::StereoCalibration designed;
  for (ips::CameraIntrinsics* cam : {&designed.cam0, &designed.cam1}) {
    cam->width = 640;
    cam->height = 480;
    cam->K << 500, 0, 320, 0, 500, 240, 0, 0, 1;
  }
  designed.t_cam1_cam0 = Eigen::Vector3d(-0.2, 0, 0);
  designed.T_imu_cam0.linear() =
      (Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitZ()))
          .toRotationMatrix()
          .transpose();
  designed.T_imu_cam0.translation() = Eigen::Vector3d(0.05, 0.01, -0.06);
  const std::string calib_in = ::testing::TempDir() + "camera_imu_designed.yaml";
  const std::string calib_out = ::testing::TempDir() + "camera_imu_estimated.yaml";
  // As calibrate_stereo leaves it: its figures in a block of the file, which the next tool must keep.
  ips::saveCalibration(calib_in, designed, [](cv::FileStorage& fs) {
    fs << "calibration_figures"
       << "{"
       << "rms_px" << 0.125 << "views"
       << "["
       << "{"
       << "name"
       << "left01.jpg"
       << "}"
       << "]"
       << "}";
  });
  const std::string out = commandOutput(std::string(IPS_CAMERA_IMU_TOOL) + " --log " + path + " --calib " + calib_in +
                                        " --out " + calib_out);
  // The last line: the figures a script reads.
  const auto at = out.rfind("delay_us=");
  ASSERT_NE(at, std::string::npos) << out;
  EXPECT_EQ(out.find('\n', at), out.size() - 1) << out;
  const double delay = std::stod(out.substr(at + 9));
  EXPECT_NEAR(delay, static_cast<double>(late), 1000.0) << out;
  EXPECT_NE(out.find("change against"), std::string::npos) << out;
  const ips::StereoCalibration estimated = ips::loadCalibration(calib_out);
  EXPECT_EQ(estimated.source, "estimated");
  // Within 4 sigma of the truth (sigma as the tool reports it: its largest axis, 0.04 deg on these 40 s).
  const double sigma_deg = std::stod(out.substr(out.rfind("rotation_sigma_deg=") + 19));
  EXPECT_LT(sigma_deg, 0.06) << out;
  EXPECT_LT(Eigen::AngleAxisd(estimated.T_imu_cam0.linear() * sim.R_cam_imu).angle() * 180 / M_PI,
            4 * std::sqrt(3.0) * sigma_deg)
      << out;
  EXPECT_TRUE(estimated.T_imu_cam0.translation().isApprox(designed.T_imu_cam0.translation()));  // mechanical, kept
  {
    cv::FileStorage written(calib_out, cv::FileStorage::READ);
    EXPECT_DOUBLE_EQ(static_cast<double>(written["calibration_figures"]["rms_px"]), 0.125);
    EXPECT_EQ(static_cast<std::string>(written["calibration_figures"]["views"][0]["name"]), "left01.jpg");
    EXPECT_NEAR(static_cast<double>(written["camera_imu_figures"]["delay_us"]), delay, 1.0);
  }
  std::remove(path.c_str());
  std::remove(calib_in.c_str());
  std::remove(calib_out.c_str());
  EXPECT_NE(commandOutput(std::string(IPS_CAMERA_IMU_TOOL) + " --log /nonexistent.lcmlog 2>&1").find("cannot open"),
            std::string::npos);
}
