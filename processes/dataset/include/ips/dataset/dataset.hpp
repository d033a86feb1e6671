#pragma once
// Readers of public stereo recordings (EuRoC ASL folders, KITTI odometry folders) into plain types: stereo
// frames (image paths and stamps), IMU samples, ground-truth poses of the body, and the head's calibration in
// the project's format. No LCM here: dataset_to_lcm encodes what these readers return.
//
// Frames (see tools/dataset/README.md): the body is the IMU frame (EuRoC: imu0 = the "B" frame of T_BS; KITTI has
// no IMU, there the body is camera 0 and T_imu_cam0 is the identity). Ground truth is the pose of the body in
// the dataset's world frame; the pose of camera 0 is T_world_body * T_imu_cam0.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "ips/calibration.hpp"

namespace ips::dataset {

// A bad folder: the message names the file (and line where there is one): "path:line: what".
struct DatasetError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct StereoFrame {
  int64_t utime = 0;  // exposure time [us], the dataset's stamp
  int64_t index = 0;  // the frame's number in the recording (KITTI: file number; EuRoC: line in data.csv)
  std::string left_path, right_path;
};

struct ImuSample {
  int64_t utime = 0;
  Eigen::Vector3d angular_rate = Eigen::Vector3d::Zero();    // [rad/s], IMU frame
  Eigen::Vector3d specific_force = Eigen::Vector3d::Zero();  // [m/s^2], IMU frame
};

struct GroundTruthPose {
  int64_t utime = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();               // body in world [m]
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // body to world
  bool has_state = false;  // velocity and biases below are given (EuRoC's state_groundtruth_estimate0)
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
};

struct Recording {
  std::string format;  // "euroc" or "kitti"
  StereoCalibration calib;
  std::vector<StereoFrame> frames;
  std::vector<ImuSample> imu;                 // empty when the recording has none
  std::vector<GroundTruthPose> ground_truth;  // empty when none was found
  std::string ground_truth_source;            // the file it came from
};

struct ReadOptions {
  std::string sequence;  // KITTI: "06"; empty = the only folder under sequences/
  int64_t first = 0;     // first frame (0-based, inclusive)
  int64_t last = -1;     // last frame (inclusive); -1 = to the end
  std::string gt_path;   // EuRoC: a TUM file of the body's pose instead of the folder's ground truth
};

// KITTI's times.txt starts at 0 s; the head's clock never reads 0 (a zero stamp is "no stamp" on the bus), so
// KITTI stamps are this many microseconds plus the file's seconds.
constexpr int64_t kKittiClockOffsetUs = 1'000'000;

// "euroc" (mav0/cam0/data.csv) or "kitti" (sequences/ and calib.txt); throws DatasetError otherwise.
std::string detectFormat(const std::string& dir);

Recording readEuroc(const std::string& dir, const ReadOptions& options);
Recording readKitti(const std::string& dir, const ReadOptions& options);
Recording readRecording(const std::string& format, const std::string& dir, const ReadOptions& options);

// A frame's image as 8-bit grey; throws DatasetError naming the file when it does not load or its size differs
// from the calibration's.
cv::Mat loadImage(const std::string& path, int width, int height);

// The pose of camera 0 in the ground truth's world frame.
Eigen::Isometry3d cameraPose(const GroundTruthPose& body, const StereoCalibration& calib);

}  // namespace ips::dataset
