// The delay estimation tool on a recorded LCM log: simulated IMU and tracker messages written with
// lcm::LogFile, camera stamps late by a known amount; the tool must report that delay.
#include <gtest/gtest.h>

#include <cstdio>
#include <ips/imu_sample_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <string>

#include "simulated_motion.hpp"

namespace {

std::string run(const std::string& command) {
  std::string out;
  FILE* p = popen(command.c_str(), "r");
  if (!p) return out;
  char buf[512];
  while (fgets(buf, sizeof buf, p)) out += buf;
  pclose(p);
  return out;
}

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

TEST(DelayTool, ReportsTheDelayOfARecordedLog) {
  const int64_t late = 31'500;
  const auto sim = ips::drivers::testing::simulateMotion(40.0, late, 5);
  const std::string path = ::testing::TempDir() + "delay_tool_test.lcmlog";
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
  const std::string out = run(std::string(IPS_DELAY_TOOL) + " --log " + path);
  const auto at = out.find("delay_us=");
  ASSERT_NE(at, std::string::npos) << out;
  const double delay = std::stod(out.substr(at + 9));
  EXPECT_NEAR(delay, static_cast<double>(late), 1000.0) << out;
  std::remove(path.c_str());
  EXPECT_NE(run(std::string(IPS_DELAY_TOOL) + " --log /nonexistent.lcmlog 2>&1").find("cannot open"),
            std::string::npos);
}
