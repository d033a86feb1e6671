#pragma once
// Readers of public stereo recordings (EuRoC ASL folders, KITTI odometry folders) into plain types: stereo
// frames (image paths and stamps), IMU samples, ground-truth poses of the body, and the head's calibration in
// the project's format. No LCM here: dataset_to_lcm encodes what these readers return.
//
// The IMU's description (ImuDescription: noise densities and rate from EuRoC's imu0/sensor.yaml) is the
// calibration's `imu` block; a recording without IMU has none, and neither has a tilt sensor.
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
#include "ips/kinematic_state.hpp"

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

struct Recording {
  std::string format;  // "euroc" or "kitti"
  StereoCalibration calib;
  std::vector<StereoFrame> frames;
  std::vector<ImuSample> imu;  // empty when the recording has none
  // The body's truth (no acceleration or angular rate): empty when none was found. Velocity and biases are given
  // when ground_truth_has_state (EuRoC's state_groundtruth_estimate0), zero otherwise.
  std::vector<InertialState> ground_truth;
  bool ground_truth_has_state = false;
  std::string ground_truth_source;  // the file it came from
};

struct ReadOptions {
  std::string sequence;  // KITTI: "06"; empty = the only folder under sequences/
  int64_t first = 0;     // first frame (0-based, inclusive)
  int64_t last = -1;     // last frame (inclusive); -1 = to the end
  std::string gt_path;   // EuRoC: a TUM file of the body's pose instead of the folder's ground truth
  bool imu = true;       // false: the recording's IMU is left out (the cameras alone)
  // EuRoC: the IMU and the ground truth of the whole recording, not only of the frames' span (a flight's IMU and
  // truth where only some of its frames are kept, as in the shared V1_01 excerpt).
  bool whole_recording = false;
};

// KITTI's times.txt starts at 0 s; the head's clock never reads 0 (a zero stamp is "no stamp" on the bus), so
// KITTI stamps are this many microseconds plus the file's seconds.
constexpr int64_t kKittiClockOffsetUs = 1'000'000;

// "euroc" (mav0/cam0/data.csv) or "kitti" (sequences/ and calib.txt); throws DatasetError otherwise.
std::string detectFormat(const std::string& dir);

Recording readEuroc(const std::string& dir, const ReadOptions& options);
Recording readKitti(const std::string& dir, const ReadOptions& options);

// A KITTI raw drive (Geiger et al., IJRR 2013): `dir` is the drive's folder (2011_09_26_drive_0001_sync or
// _extract) with image_00 (left grey), image_01 (right grey), oxts/ (data/*.txt, timestamps.txt), and its date's
// three calibration files (calib_cam_to_cam.txt, calib_imu_to_velo.txt, calib_velo_to_cam.txt) in `dir` or its
// parent. Synced-and-rectified drives (images of S_rect_00's size) get the rectified pinhole pair P_rect_00 /
// P_rect_01; raw ones K_0x, D_0x and R_01 / T_01. The OXTS GPS/INS is both the IMU (wx wy wz, ax ay az in its x
// forward, y left, z up frame, at its own rate: 10 Hz synced, 100 Hz raw) and the ground truth (lat, lon, alt by
// the devkit's Mercator projection at the first latitude, z up; roll, pitch, yaw as Rz Ry Rx). The body is the
// OXTS unit; T_imu_cam0 = (R_rect_00 T_cam_velo T_velo_imu)^-1 for the rectified camera 0. The IMU description is
// oxtsInsDescription's.
Recording readKittiRaw(const std::string& dir, const ReadOptions& options);
// The OXTS outputs as an IMU: the INS's bias-compensated samples at `rate_hz`, their noise densities measured from
// the samples themselves (each against the mean of its neighbours: at 10 Hz the car's vibration, not the sensors'
// white noise, is what a snapshot carries), floored at the sensors' own.
ImuDescription oxtsInsDescription(const std::vector<ImuSample>& samples, double rate_hz);
Recording readRecording(const std::string& format, const std::string& dir, const ReadOptions& options);

// A frame's image as 8-bit grey; throws DatasetError naming the file when it does not load or its size differs
// from the calibration's.
cv::Mat loadImage(const std::string& path, int width, int height);

// The pose of camera 0 in the ground truth's world frame.
Eigen::Isometry3d cameraPose(const InertialState& body, const StereoCalibration& calib);

}  // namespace ips::dataset
