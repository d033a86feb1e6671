// Writes the seed corpus of the fuzz targets (tests/fuzz/corpus/<target>/): one valid encoding of each message
// type, a few good IMU frames and tilt lines, and the project's own configuration files are the seeds the
// fuzzers mutate. Run again when a message type changes:  build/bin/fuzz_seeds tests/fuzz/corpus
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/health_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/integrity_t.hpp>
#include <ips/keyframe_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/stereo_time_t.hpp>
#include <ips/tilt_sample_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <string>
#include <vector>
#if __has_include(<procman_lcm/orders_t.hpp>)
#define IPS_FUZZ_PROCMAN 1
#include "ips/test_support/procman_samples.hpp"
#endif

#include "ips/drivers/mmq50.hpp"
#include "ips/drivers/pei_z260.hpp"
#include "ips/framework/image.hpp"
#include "ips/test_support/sample_messages.hpp"

namespace fs = std::filesystem;

namespace {

void writeBytes(const fs::path& file, const std::vector<uint8_t>& bytes) {
  fs::create_directories(file.parent_path());
  std::ofstream(file, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

template <class Msg>
void writeMessage(const fs::path& dir, const Msg& m, const std::string& prefix = "fuzz_decode_") {
  writeBytes(dir / (prefix + std::string(Msg::getTypeName())) / "valid", ips::test_support::encodeMessage(m));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_seeds DIR\n");
    return 2;
  }
  const fs::path dir = argv[1];
  writeMessage(dir, ips::fw::makeStereoPair(1000, 1, cv::Mat(4, 6, CV_8UC1, cv::Scalar(7)),
                                            cv::Mat(4, 6, CV_8UC1, cv::Scalar(9)), "L", "R"));
  ips::imu_sample_t imu{};
  imu.utime = 1000;
  imu.seq = 1;
  imu.specific_force[2] = 9.81;
  writeMessage(dir, imu);
  ips::tilt_sample_t tilt{};
  tilt.utime = 1000;
  writeMessage(dir, tilt);
  ips::tracker_delta_t delta{};
  delta.utime = 2000;
  delta.utime_prev = 1000;
  delta.valid = 1;
  delta.rotation[0] = 1;
  for (int i = 0; i < 6; ++i) delta.covariance[i * 7] = 1e-4;
  delta.far_valid = 1;
  delta.far_rotation[0] = 1;
  for (int i = 0; i < 3; ++i) delta.far_rotation_covariance[i * 4] = 1e-8;
  delta.num_far_matches = delta.num_far_inliers = 20;
  writeMessage(dir, delta);
  writeMessage(dir, ips::test_support::sampleFilterState());
  writeMessage(dir, ips::test_support::sampleDisparityMap());
  writeMessage(dir, ips::test_support::samplePointCloud());
  writeMessage(dir, ips::test_support::sampleHealth());
  ips::ground_truth_t gt{};
  gt.utime = 1000;
  gt.orientation[0] = 1;
  writeMessage(dir, gt);
  ips::integrity_t integrity{};
  integrity.utime = 2000;
  integrity.seq = 2;
  integrity.state = ips::integrity_t::STATE_ALARM;
  integrity.num_probes = 150;
  integrity.num_points = 100;
  integrity.pair_valid = 1;
  integrity.correction[0] = integrity.applied[0] = 2e-3;
  for (int i = 0; i < 4; ++i) integrity.correction_covariance[i * 5] = 1e-10;
  integrity.certain = 1;
  integrity.applied_utime = 1000;
  integrity.alarms = integrity.steps = integrity.corrections = 1;
  writeMessage(dir, integrity);
  ips::keyframe_t keyframe{};
  keyframe.utime = 3000;
  keyframe.seq = 24;
  writeMessage(dir, keyframe);
  writeMessage(dir, ips::stereo_time_t{3000, 24});

#ifdef IPS_FUZZ_PROCMAN
  writeMessage(dir, ips::test_support::sampleOrders(), "fuzz_decode_procman_");
  writeMessage(dir, ips::test_support::sampleDeputyInfo(), "fuzz_decode_procman_");
  writeMessage(dir, ips::test_support::sampleOutput(), "fuzz_decode_procman_");
  writeMessage(dir, ips::test_support::sampleDiscovery(), "fuzz_decode_procman_");
#endif

  // Serial: the first byte selects checksums (bit 0: MMQ-50 sum16, bit 1: Z260 XOR), then the line's bytes.
  std::vector<uint8_t> serial = {1};
  ips::drivers::Mmq50Format imu_format;
  const double rate[3] = {0.01, -0.02, 0.03}, force[3] = {0.1, 0.2, 9.81};
  for (uint32_t c = 0; c < 3; ++c) {
    auto frame = ips::drivers::Mmq50Parser::encode(imu_format, c, rate, force);
    serial.insert(serial.end(), frame.begin(), frame.end());
  }
  writeBytes(dir / "fuzz_serial" / "imu_frames", serial);
  std::vector<uint8_t> lines = {0};
  for (int i = 0; i < 3; ++i) {
    const std::string line = ips::drivers::Z260Parser::format(ips::drivers::Z260Format{}, 0.01 * i, -0.02 * i);
    lines.insert(lines.end(), line.begin(), line.end());
  }
  writeBytes(dir / "fuzz_serial" / "tilt_lines", lines);
  return 0;
}
