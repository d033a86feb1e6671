// calibrate_camera_imu: the rotation between the IMU and camera 0 and the time offset of their stamps, together,
// from an LCM log (lcm-logger) of the head turned about all axes with the tracker running (IMU and TRACKER_DELTA).
// The library (ips/calib/camera_imu.hpp) does the work; this reads the log, prints the figures and writes the
// calibration with the estimated rotation. The last line is
// `delay_us=... delay_sigma_us=... rotation_sigma_deg=... residual_deg=... intervals=...`.
#include <cstdio>
#include <ips/imu_sample_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <opencv2/core.hpp>

#include "ips/args.hpp"
#include "ips/calib/camera_imu.hpp"
#include "ips/calib/figures.hpp"
#include "ips/calibration.hpp"
#include "ips/rotation.hpp"

namespace {

constexpr double kDeg = M_PI / 180.0;

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv,
                   "Camera-to-IMU rotation and camera-IMU time offset, together, from an LCM log (tracker deltas "
                   "against the gyro)");
    args.repeated("--log", "FILE",
                  "LCM log with the IMU or tracker delta channels (the head turned about all axes); give it twice "
                  "when the head's recording and the tracker's are separate files")
        .option("--calib", "FILE", "the head's calibration: the rotation is reported against its T_imu_cam0")
        .option("--out", "FILE.yaml", "write --calib with the estimated rotation (translation kept) and the figures")
        .option("--imu-channel", "NAME", "channel of ips::imu_sample_t", "IMU")
        .option("--delta-channel", "NAME", "channel of ips::tracker_delta_t", "TRACKER_DELTA")
        .option("--max-delay-ms", "MS", "search range +- of the delay", "200")
        .option("--step-us", "US", "grid step of the coarse delay search", "1000")
        .option("--min-rate", "RAD_S", "the coarse delay search leaves out tracker intervals slower than this", "0.05")
        .epilog("Exit status: 0 estimated, 1 error, 2 bad command line, 3 the recording does not determine it.");
    if (!args.parse()) return 0;
    if (args.has("--out") && !args.has("--calib")) throw std::runtime_error("--out needs --calib (the file to update)");
    const std::vector<std::string> logs = args.getAll("--log");
    if (logs.empty()) throw ips::ArgError("calibrate_camera_imu: --log is required (see --help)");
    std::vector<ips::calib::GyroSample> gyro;
    std::vector<ips::calib::TrackerRotation> deltas;
    long long undecodable = 0, invalid = 0;
    const std::string imu_channel = args.get("--imu-channel"), delta_channel = args.get("--delta-channel");
    for (const std::string& path : logs) {
      lcm::LogFile log(path, "r");
      if (!log.good()) throw std::runtime_error("cannot open log " + path);
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
          deltas.push_back(
              {m.utime_prev, m.utime, Eigen::Quaterniond(m.rotation[0], m.rotation[1], m.rotation[2], m.rotation[3])});
        }
      }
    }
    ips::calib::CameraImuConfig config;
    config.coarse.max_delay_us = static_cast<int64_t>(args.getDouble("--max-delay-ms") * 1000);
    config.coarse.step_us = args.getInt("--step-us");
    config.coarse.min_rate = args.getDouble("--min-rate");
    const ips::calib::CameraImuEstimate est = ips::calib::calibrateCameraImu(gyro, deltas, config);
    std::printf("imu_samples=%zu deltas=%zu invalid_deltas=%lld undecodable=%lld\n", gyro.size(), deltas.size(),
                invalid, undecodable);
    std::printf("coarse delay (rate magnitudes): %.0f us, correlation %.4f\n", est.coarse_delay_us,
                est.coarse_correlation);
    if (!est.ok) {
      std::printf("no estimate: %s\n", est.reason.c_str());
      return 3;
    }
    const Eigen::Vector3d rv = ips::rotationVectorDeg(est.R_imu_cam);
    std::printf("R_imu_cam0 rotation vector [deg]: %.4f %.4f %.4f (sigma %.4f %.4f %.4f)\n", rv.x(), rv.y(), rv.z(),
                est.rotation_sigma_deg.x(), est.rotation_sigma_deg.y(), est.rotation_sigma_deg.z());
    std::printf("gyro bias [deg/s]: %.4f %.4f %.4f\n", est.gyro_bias.x() / kDeg, est.gyro_bias.y() / kDeg,
                est.gyro_bias.z() / kDeg);
    std::printf("intervals used %zu, left out as outliers %zu\n", est.intervals, est.rejected);
    if (args.has("--calib")) {
      ips::StereoCalibration calib = ips::loadCalibration(args.get("--calib"));
      const Eigen::Vector3d change = ips::rotationVectorDeg(calib.T_imu_cam0.linear().transpose() * est.R_imu_cam);
      std::printf("change against %s: %.4f deg (rotation vector in camera 0: %.4f %.4f %.4f)\n",
                  args.get("--calib").c_str(), change.norm(), change.x(), change.y(), change.z());
      if (args.has("--out")) {
        calib.T_imu_cam0.linear() = est.R_imu_cam;
        calib.source = "estimated";
        ips::saveCalibration(args.get("--out"), calib, [&](cv::FileStorage& fs) {
          ips::calib::copyFigureBlocks(fs, args.get("--calib"), "camera_imu_figures");
          fs << "camera_imu_figures"
             << "{"
             << "date" << ips::calib::utcNow() << "log" << logs.front() << "delay_us" << est.delay_us
             << "delay_sigma_us" << est.delay_sigma_us << "rotation_sigma_deg"
             << std::vector<double>{est.rotation_sigma_deg.x(), est.rotation_sigma_deg.y(), est.rotation_sigma_deg.z()}
             << "residual_rms_deg" << est.residual_rms_deg << "intervals" << static_cast<int>(est.intervals)
             << "rejected" << static_cast<int>(est.rejected) << "}";
        });
        std::printf("wrote %s\n", args.get("--out").c_str());
      }
    }
    std::printf("camera stamps are %s IMU stamps by %.2f ms: add %.0f to camera/delay_us (config/camera.yaml)\n",
                est.delay_us >= 0 ? "late against" : "early against", std::abs(est.delay_us) / 1000.0, est.delay_us);
    std::printf("delay_us=%.1f delay_sigma_us=%.1f rotation_sigma_deg=%.4f residual_deg=%.4f intervals=%zu\n",
                est.delay_us, est.delay_sigma_us, est.rotation_sigma_deg.maxCoeff(), est.residual_rms_deg,
                est.intervals);
    return 0;
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "calibrate_camera_imu: %s\n", e.what());
    return 1;
  }
}
