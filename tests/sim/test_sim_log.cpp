// The `sim` process in batch mode: the log holds stereo pairs at 8 Hz, IMU at 200 Hz, tilt at 14 Hz and ground
// truth, in arrival order; the calibration is written beside it; the same seed gives a byte-identical log.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <ips/disparity_map_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/tilt_sample_t.hpp>
#include <iterator>
#include <lcm/lcm-cpp.hpp>
#include <map>

#include "ips/calibration.hpp"

namespace {

std::string runSim(const std::string& name, const std::string& args) {
  const std::string out = testing::TempDir() + "/" + name + ".lcmlog";
  const std::string cmd = std::string(SIM_EXECUTABLE) + " --out " + out + " " + args + " --log-level warn";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return out;
}

// Reads a log and removes it and its calibration (logs are large).
std::string readAndRemove(const std::string& path) {
  std::string data;
  {
    std::ifstream in(path, std::ios::binary);
    data.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  std::remove(path.c_str());
  std::remove((path + ".calib.yaml").c_str());
  return data;
}

}  // namespace

TEST(SimLog, ChannelsRatesAndOrder) {
  const std::string path = runSim("sim_rates", "--duration 1 --seed 3 --gt-disparity-every 4");
  lcm::LogFile log(path, "r");
  ASSERT_TRUE(log.good());
  std::map<std::string, int> count;
  int64_t last_ts = INT64_MIN;
  int64_t first_imu = -1, last_imu = -1;
  std::map<int64_t, int> gt_times;
  std::vector<int64_t> imu_times;
  while (const lcm::LogEvent* e = log.readNextEvent()) {
    ++count[e->channel];
    EXPECT_GE(e->timestamp, last_ts) << "events out of arrival order";
    last_ts = e->timestamp;
    if (e->channel == "STEREO") {
      ips::stereo_pair_t m;
      ASSERT_GE(m.decode(e->data, 0, e->datalen), 0);
      EXPECT_EQ(m.width, 1360);
      EXPECT_EQ(m.height, 1024);
      EXPECT_EQ(m.pixel_format, static_cast<int8_t>(ips::stereo_pair_t::PIXEL_MONO8));
      EXPECT_EQ(m.data_size, 1360 * 1024);
      EXPECT_EQ(m.seq, count["STEREO"] - 1);
    } else if (e->channel == "IMU") {
      ips::imu_sample_t m;
      ASSERT_GE(m.decode(e->data, 0, e->datalen), 0);
      if (first_imu < 0) first_imu = m.utime;
      last_imu = m.utime;
      imu_times.push_back(m.utime);
      EXPECT_NEAR(m.specific_force[2], 9.81, 6.0);  // roughly up, walking
    } else if (e->channel == "GT_POSE") {
      ips::ground_truth_t m;
      ASSERT_GE(m.decode(e->data, 0, e->datalen), 0);
      EXPECT_EQ(gt_times[m.utime]++, 0) << "ground truth twice at " << m.utime;
      EXPECT_NEAR(m.orientation[0] * m.orientation[0] + m.orientation[1] * m.orientation[1] +
                      m.orientation[2] * m.orientation[2] + m.orientation[3] * m.orientation[3],
                  1.0, 1e-9);
    } else if (e->channel == "GT_DISPARITY") {
      ips::disparity_map_t m;
      ASSERT_GE(m.decode(e->data, 0, e->datalen), 0);
      EXPECT_EQ(m.subpixel_scale, 16);
      EXPECT_NEAR(m.baseline_m, 0.2, 0.01);
      EXPECT_GT(m.data[512][680], 16);  // more than 1 px in the middle of a corridor view
    }
  }
  EXPECT_EQ(count["STEREO"], 9);  // 0 .. 1 s at 8 Hz
  EXPECT_EQ(count["IMU"], 201);
  EXPECT_EQ(count["TILT"], 15);
  EXPECT_EQ(count["GT_DISPARITY"], 3);  // pairs 0, 4, 8
  EXPECT_GE(count["GT_POSE"], 201);     // every IMU time plus the tilt times between them
  EXPECT_NEAR(last_imu - first_imu, 1'000'000, 200);
  // Ground truth at every IMU sample time (stamps only carry 20 us jitter around the sample times).
  int matched = 0;
  for (int64_t t : imu_times)
    for (int64_t d = -200; d <= 200; ++d)
      if (gt_times.count(t + d) && (t + d) % 5000 == 0) {
        ++matched;
        break;
      }
  EXPECT_EQ(matched, 201);
  const ips::StereoCalibration cal = ips::loadCalibration(path + ".calib.yaml");
  EXPECT_EQ(cal.cam0.width, 1360);
  EXPECT_NEAR(cal.cam0.K(0, 0), 744.19, 0.01);
  readAndRemove(path);
}

TEST(SimLog, SameSeedGivesByteIdenticalLog) {
  const std::string a = readAndRemove(runSim("sim_seed_a", "--duration 0.3 --seed 11 --gt-disparity-every 2"));
  const std::string b = readAndRemove(runSim("sim_seed_b", "--duration 0.3 --seed 11 --gt-disparity-every 2"));
  const std::string c = readAndRemove(runSim("sim_seed_c", "--duration 0.3 --seed 12 --gt-disparity-every 2"));
  ASSERT_GT(a.size(), 5u * 1360 * 1024);
  EXPECT_TRUE(a == b) << "same seed, different logs";
  EXPECT_FALSE(a == c) << "different seeds, same log";
}

TEST(SimLog, BadOptionsFailCleanly) {
  const std::string base =
      std::string(SIM_EXECUTABLE) + " --log-level error --out " + testing::TempDir() + "/bad.lcmlog";
  EXPECT_NE(std::system((base + " --duration -1").c_str()), 0);
  EXPECT_NE(std::system((base + " --scenario /nonexistent.yaml").c_str()), 0);
  EXPECT_NE(std::system((base + " --no-such-option 1").c_str()), 0);
}
