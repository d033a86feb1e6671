// dataset_to_lcm: a public recording (EuRoC ASL, KITTI odometry or KITTI raw folder) into an LCM log holding what
// the live head would publish (STEREO_TIME and STEREO, IMU when present, GT_POSE) plus FILE.lcmlog.calib.yaml in the
// project's format, with the IMU's description (its `imu` block: EuRoC's imu0/sensor.yaml) where the recording has an
// IMU. The log is written under a temporary name and renamed when complete: a bad folder leaves no output.
#include <filesystem>
#include <ips/ground_truth_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/stereo_pair_t.hpp>

#include "ips/args.hpp"
#include "ips/dataset/dataset.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/log_writer.hpp"
#include "ips/framework/message_arrays.hpp"
#include "ips/framework/message_poses.hpp"
#include "ips/framework/process.hpp"
#include "ips/log.hpp"

namespace {

namespace ch = ips::channels;

// Velocity and biases are zero when the source has none (Recording::ground_truth_has_state), acceleration and
// angular rate always.
void writeGroundTruth(ips::fw::LogWriter& log, const ips::InertialState& g) {
  log.write(ch::kGtPose, g.utime, ips::fw::groundTruthMessage(g));
}

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("dataset_to_lcm", [&]() {
    ips::Args args(argc, argv, "a EuRoC or KITTI recording into an LCM log (STEREO, IMU, GT_POSE) and its calibration");
    args.required("--format", "euroc|kitti|kitti_raw",
                  "layout of the recording (kitti: odometry; kitti_raw: a raw drive)")
        .required("--in", "DIR",
                  "the recording's folder (EuRoC: holds mav0/; KITTI: holds sequences/ and poses/; KITTI raw: the\n"
                  "drive's folder, with image_00/, image_01/, oxts/ and the date's calib_*.txt in it or its parent)")
        .required("--out", "FILE.lcmlog", "the log to write (and FILE.lcmlog.calib.yaml)")
        .option("--sequence", "NN", "KITTI sequence (default: the only one in sequences/)")
        .option("--first", "N", "first frame, 0-based", "0")
        .option("--last", "N", "last frame, inclusive (default: the last)", "-1")
        .option("--gt", "FILE", "EuRoC: ground truth of the body as a TUM file (t tx ty tz qx qy qz qw)")
        .flag("--no-imu", "leave the recording's IMU out: the cameras alone (no filter runs on the log)");
    if (!args.parse()) return 0;
    ips::dataset::ReadOptions opt;
    opt.sequence = args.get("--sequence");
    opt.first = args.getInt("--first");
    opt.last = args.getInt("--last");
    opt.gt_path = args.get("--gt");
    opt.imu = !args.getFlag("--no-imu");
    const ips::dataset::Recording rec = ips::dataset::readRecording(args.get("--format"), args.get("--in"), opt);

    const std::string out = args.get("--out");
    const std::string tmp_log = out + ".partial", calib_path = out + ".calib.yaml",
                      tmp_calib = calib_path + ".partial.yaml";
    struct Cleanup {  // removes the partial files unless the job completed
      std::vector<std::string> paths;
      bool done = false;
      ~Cleanup() {
        if (!done)
          for (const auto& p : paths) std::filesystem::remove(p);
      }
    } cleanup{{tmp_log, tmp_calib}};

    ips::saveCalibration(tmp_calib, rec.calib);
    int64_t pairs = 0, imu = 0, gt = 0;
    {
      ips::fw::LogWriter log(tmp_log);
      // Events in time order; at equal stamps IMU and ground truth go before the image (as the head sends them).
      size_t i_imu = 0, i_gt = 0;
      const int w = rec.calib.cam0.width, h = rec.calib.cam0.height;
      for (const auto& f : rec.frames) {
        for (; i_imu < rec.imu.size() && rec.imu[i_imu].utime <= f.utime; ++i_imu, ++imu) {
          const auto& s = rec.imu[i_imu];
          ips::imu_sample_t m;
          m.utime = s.utime;
          m.seq = static_cast<int64_t>(i_imu);
          ips::fw::vectorToArray(s.angular_rate, m.angular_rate);
          ips::fw::vectorToArray(s.specific_force, m.specific_force);
          log.write(ch::kImu, m.utime, m);
        }
        for (; i_gt < rec.ground_truth.size() && rec.ground_truth[i_gt].utime <= f.utime; ++i_gt, ++gt) {
          writeGroundTruth(log, rec.ground_truth[i_gt]);
        }
        const cv::Mat left = ips::dataset::loadImage(f.left_path, w, h);
        const cv::Mat right = ips::dataset::loadImage(f.right_path, w, h);
        ips::stereo_pair_t m =
            ips::fw::makeStereoPair(f.utime, f.index, left, right, rec.calib.cam0.serial, rec.calib.cam1.serial);
        log.write(ch::kStereoTime, m.utime, ips::fw::stereoTimeOf(m));
        log.write(ch::kStereo, m.utime, m);
        ++pairs;
      }
      // The samples after the last frame that the readers kept (one past the end, for interpolation).
      for (; i_gt < rec.ground_truth.size(); ++i_gt, ++gt) {
        writeGroundTruth(log, rec.ground_truth[i_gt]);
      }
    }
    std::filesystem::rename(tmp_calib, calib_path);
    std::filesystem::rename(tmp_log, out);
    cleanup.done = true;
    std::printf("%s: %s, %lld stereo pairs %dx%d, %lld IMU samples, %lld ground-truth poses (%s); calibration %s\n",
                out.c_str(), rec.format.c_str(), static_cast<long long>(pairs), rec.calib.cam0.width,
                rec.calib.cam0.height, static_cast<long long>(imu), static_cast<long long>(gt),
                rec.ground_truth_source.empty() ? "none" : rec.ground_truth_source.c_str(), calib_path.c_str());
    return 0;
  });
}
