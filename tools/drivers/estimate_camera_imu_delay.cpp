// estimate_camera_imu_delay: the constant time offset between camera and IMU stamps, from a recorded LCM log
// (lcm-logger) holding the tracker's deltas and the gyro. Record a minute of lively rotation about all axes
// (walk with the head, wave it), with the tracker running. See ips/drivers/delay_estimation.hpp for the method.
// Output: delay_us > 0 means camera stamps are late against IMU stamps: add it to camera/delay_us.
#include <cstdio>
#include <fstream>
#include <ips/imu_sample_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include "ips/args.hpp"
#include "ips/drivers/delay_estimation.hpp"

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "Estimates the camera-IMU time offset from an LCM log (tracker deltas vs gyro)");
    args.required("--log", "FILE", "LCM log file with the IMU and tracker delta channels")
        .option("--imu-channel", "NAME", "channel of ips::imu_sample_t", "IMU")
        .option("--delta-channel", "NAME", "channel of ips::tracker_delta_t", "TRACKER_DELTA")
        .option("--max-delay-ms", "MS", "search range +-", "200")
        .option("--step-us", "US", "grid step before sub-step refinement", "1000")
        .option("--min-rate", "RAD_S", "leave out tracker intervals slower than this", "0.05")
        .option("--curve", "CSV", "write the correlation curve (delay_us,correlation) to this file");
    if (!args.parse()) return 0;
    lcm::LogFile log(args.get("--log"), "r");
    if (!log.good()) throw std::runtime_error("cannot open log " + args.get("--log"));
    std::vector<ips::drivers::GyroSample> gyro;
    std::vector<ips::drivers::TrackerRotation> deltas;
    long long undecodable = 0, invalid = 0;
    const std::string imu_channel = args.get("--imu-channel"), delta_channel = args.get("--delta-channel");
    while (const lcm::LogEvent* e = log.readNextEvent()) {
      if (e->channel == imu_channel) {
        ips::imu_sample_t m;
        if (m.decode(e->data, 0, e->datalen) < 0) {
          ++undecodable;
          continue;
        }
        gyro.push_back({m.utime, Eigen::Vector3d(m.angular_rate[0], m.angular_rate[1], m.angular_rate[2])});
      } else if (e->channel == delta_channel) {
        ips::tracker_delta_t m;
        if (m.decode(e->data, 0, e->datalen) < 0) {
          ++undecodable;
          continue;
        }
        if (!m.valid) {
          ++invalid;
          continue;
        }
        deltas.push_back({m.utime_prev, m.utime,
                          Eigen::Quaterniond(m.rotation[0], m.rotation[1], m.rotation[2], m.rotation[3])});
      }
    }
    ips::drivers::DelayEstimatorConfig config;
    config.max_delay_us = static_cast<int64_t>(args.getDouble("--max-delay-ms") * 1000);
    config.step_us = args.getInt("--step-us");
    config.min_rate = args.getDouble("--min-rate");
    const auto estimate = ips::drivers::estimateCameraImuDelay(gyro, deltas, config);
    if (args.has("--curve")) {
      std::ofstream csv(args.get("--curve"));
      csv << "delay_us,correlation\n";
      for (const auto& [d, c] : estimate.curve) csv << d << "," << c << "\n";
    }
    std::printf("imu_samples=%zu deltas=%zu invalid_deltas=%lld undecodable=%lld intervals_used=%zu\n", gyro.size(),
                deltas.size(), invalid, undecodable, estimate.intervals);
    if (!estimate.ok) {
      std::printf("no estimate: too few usable intervals or the best correlation at the edge of the range\n");
      return 2;
    }
    std::printf("delay_us=%.0f correlation=%.4f\n", estimate.delay_us, estimate.correlation);
    std::printf("camera stamps are %s IMU stamps by %.1f ms%s\n", estimate.delay_us >= 0 ? "late against" : "early against",
                std::abs(estimate.delay_us) / 1000.0,
                estimate.correlation < 0.8 ? " (weak correlation: record livelier rotation)" : "");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "estimate_camera_imu_delay: error: %s\n", e.what());
    return 1;
  }
}
