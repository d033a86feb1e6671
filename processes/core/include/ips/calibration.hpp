#pragma once
// The project's calibration format for a stereo sensor head: interior orientation of both cameras,
// their relative exterior orientation, and the mounting of the IMU and tilt sensor relative to camera 0.
// The simulator writes it, calib_from_euroc converts to it, every process reads it.
//
// Frames: camera frames are OpenCV's (x right, y down, z forward, origin at the projection centre).
// A transform named T_a_b maps a point from frame b into frame a: X_a = T_a_b * X_b.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace ips {

// Lens distortion models: OpenCV's radial-tangential (k1 k2 p1 p2 k3; Kalibr "radtan", ROS "plumb_bob") and
// the equidistant fisheye model (k1 k2 k3 k4 of theta; OpenCV cv::fisheye, Kalibr "equidistant", ROS
// "equidistant"). A file without `distortion_model` is radial-tangential.
enum class DistortionModel { kRadialTangential, kEquidistant };

struct CameraIntrinsics {
  int width = 0;
  int height = 0;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();  // fx 0 cx; 0 fy cy; 0 0 1 (pixels)
  DistortionModel model = DistortionModel::kRadialTangential;
  // Radial-tangential: k1 k2 p1 p2 k3. Equidistant: k1 k2 k3 k4, the fifth element zero.
  Eigen::Matrix<double, 5, 1> distortion = Eigen::Matrix<double, 5, 1>::Zero();
  std::string serial;  // camera serial number, informational
  // Flat-field gain of the lens (vignetting; key `vignetting_gain`, absent = none): the grey of a raw pixel whose ray
  // makes the angle theta with the optical axis is multiplied by G = 1 + g1 t + g2 t^2 + g3 t^3, t = tan^2 theta, to
  // undo the fall-off of the illumination towards the image corners. A polynomial in tan^2 theta because natural
  // vignetting, cos^4 theta = 1 / (1 + t)^2, is then exactly G = (1 + t)^2 (g = 2, 1, 0), and the mechanical
  // vignetting of a real lens adds a smooth term of its own. calibrate_vignetting estimates it (ips_calib).
  Eigen::Vector3d vignetting_gain = Eigen::Vector3d::Zero();

  cv::Mat cvK() const;
  cv::Mat cvDistortion() const;  // 1x5 (radial-tangential) or 1x4 (equidistant, as cv::fisheye takes it)
  bool hasVignetting() const { return !vignetting_gain.isZero(0); }
  double flatFieldGain(double tan2_theta) const {
    const Eigen::Vector3d& g = vignetting_gain;
    return 1 + tan2_theta * (g[0] + tan2_theta * (g[1] + tan2_theta * g[2]));
  }
};

// tan^2 of the angle between each raw pixel's ray and the optical axis (CV_32FC1 of the camera's size), through
// the camera's distortion model: what a lens's vignetting is a function of.
cv::Mat rayTan2Image(const CameraIntrinsics& cam);
// The largest tan^2 theta of the image (its border's widest ray).
double widestRayTan2(const CameraIntrinsics& cam);
// The smallest flat-field gain of rays up to widest_tan2 (101 samples; the gain is a cubic): it must be positive.
double lowestFlatFieldGain(const CameraIntrinsics& cam, double widest_tan2);

// The head's IMU as its data sheet or its own calibration gives it (Kalibr's and EuRoC's conventions: continuous-time
// densities): what the filter takes for the IMU's noise, its biases' random walk and their prior at a start. Keys
// under `imu` in the calibration file.
struct ImuDescription {
  std::string model;               // informational: "ADIS16448 (EuRoC VI-Sensor)"
  double rate_hz = 0;              // nominal sample rate
  double gyro_noise_density = 0;   // [rad/s/sqrt(Hz)] white rate noise (angle random walk)
  double gyro_random_walk = 0;     // [rad/s^2/sqrt(Hz)] bias diffusion
  double accel_noise_density = 0;  // [m/s^2/sqrt(Hz)] white acceleration noise (velocity random walk)
  double accel_random_walk = 0;    // [m/s^3/sqrt(Hz)] bias diffusion
  double gyro_bias_sigma = 0;      // [rad/s] turn-on bias, 1 sigma per axis (before any estimate)
  double accel_bias_sigma = 0;     // [m/s^2]
};

// The head's tilt sensor (inclinometer), keys under `tilt`. A calibration file with an `imu` block and no `tilt`
// block describes a head without one (EuRoC, KITTI).
struct TiltDescription {
  std::string model;
  double rate_hz = 0;
  double accuracy = 0;    // [rad] 1 sigma per angle: its constant offset (and nonlinearity) at 25 deg C
  double resolution = 0;  // [rad] its white noise at rest
};

struct StereoCalibration {
  CameraIntrinsics cam0;  // left
  CameraIntrinsics cam1;  // right
  Eigen::Matrix3d R_cam1_cam0 = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_cam1_cam0 = Eigen::Vector3d::Zero();  // metres; about (-baseline, 0, 0) for a left/right head
  Eigen::Isometry3d T_imu_cam0 = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d R_tilt_cam0 = Eigen::Matrix3d::Identity();
  // The inertial sensors (absent in a file without `imu`: a head described by its cameras only).
  std::optional<ImuDescription> imu;
  std::optional<TiltDescription> tilt;
  // How it was obtained, so that a run can say what it ran on: "true" (the simulator's own head), "perturbed"
  // (the simulator's head with the errors a good calibration leaves), "estimated" (the calibration tools),
  // "converted" (from another tool's format). Empty when the file does not say.
  std::string source;

  double baseline() const { return t_cam1_cam0.norm(); }
};

// Throws ConfigError naming the file and key on any problem.
StereoCalibration loadCalibration(const std::string& path);
// `write_more`, when given, adds keys of its own to the same document after the calibration's (a tool's figures);
// every reader ignores keys it does not know.
void saveCalibration(const std::string& path, const StereoCalibration& calib,
                     const std::function<void(cv::FileStorage&)>& write_more = {});

// The rectified geometry of a head: both rectified cameras share K_rect and differ by a pure
// translation of `baseline` along x, so matching points lie on the same row and x_left - x_right = d,
// depth Z = f * baseline / d.
struct StereoRectification {
  cv::Size size;
  double f = 0, cx = 0, cy = 0;                                // rectified pinhole (both cameras)
  double baseline = 0;                                         // metres
  Eigen::Matrix3d R_rect0_cam0 = Eigen::Matrix3d::Identity();  // rotation of the rectified left frame
  Eigen::Matrix3d R_rect1_cam1 = Eigen::Matrix3d::Identity();
  // For each rectified pixel, where to sample the raw image (CV_32FC1, as cv::remap takes them).
  cv::Mat map0x, map0y, map1x, map1y;
  // For each rectified pixel, the flat-field gain of the raw position it samples (CV_32FC1, the cameras'
  // vignetting_gain); both empty when neither camera has one. rectifyPair and E3D's device rectification multiply
  // the sampled grey by it.
  cv::Mat gain0, gain1;
  bool hasFlatField() const { return !gain0.empty(); }
};

// A correction of the right camera for a head that has changed since calibration (a knock, temperature), as the
// epipolar integrity monitor estimates it from the vertical disparity of matched points.
struct RightCameraCorrection {
  // Rotation vector [rad] in the rectified right frame. Its x and z turn the right camera: R_rect1_cam1 becomes
  // exp([wx 0 wz]) * R_rect1_cam1. Its y, the yaw, moves rows only: the right rectified image is warped vertically
  // by the yaw's row effect, right pixel (x, y) sampling where (x, y - f u v wy) did (u = (x - cx) / f,
  // v = (y - cy) / f), its columns left as they were. Rows see a yaw only through that u v keystone, and a keystone
  // in rows need not come from a yaw (KITTI's rectified pairs carry 0.75 px of it in their corners, while their
  // disparities show nothing of the 6 px a yaw of that size would add); a yaw's column part, nearly a constant
  // disparity, is what the tracker's disparity offset observes from motion.
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero();
  // Relative error of the right camera's focal length: its fx and fy become (1 + focal_scale) times the file's.
  double focal_scale = 0;
  // The disparity offset [px] (the tracker's self-calibration of the right rectified principal point against the
  // left's, StereoTracker): a point the calibration puts at column x of the right rectified image shows at
  // x + disparity_offset_px, so the right image is read that much further right and disparities regain their zero.
  double disparity_offset_px = 0;
  bool isZero() const { return rotation.isZero(0) && focal_scale == 0 && disparity_offset_px == 0; }
  bool operator==(const RightCameraCorrection& o) const {
    return rotation == o.rotation && focal_scale == o.focal_scale && disparity_offset_px == o.disparity_offset_px;
  }
  bool operator!=(const RightCameraCorrection& o) const { return !(*this == o); }
};

// The corrections a consumer of pairs (E3D) has been told of, each with the stamp of the pair that decided it: a
// pair takes the newest one decided before its own stamp, so that which rectification a pair gets depends on stamps.
class RightCorrectionSchedule {
 public:
  // Returns false (and keeps nothing) for a stamp not after the newest one held: repeated or out of order.
  bool add(int64_t decided_utime, const RightCameraCorrection& correction);
  // The correction for a pair with this stamp (none: zero).
  RightCameraCorrection forPair(int64_t utime) const;
  // Forget those no later pair can take (all but the newest decided before this stamp).
  void dropBefore(int64_t utime);
  size_t size() const { return entries_.size(); }

 private:
  std::vector<std::pair<int64_t, RightCameraCorrection>> entries_;  // by stamp, increasing
};

// alpha as in cv::stereoRectify: 0 keeps only valid pixels, 1 keeps all source pixels.
// A right-camera correction changes only the right camera's maps: the left rectification, f, cx, cy and the baseline
// stay those of the calibration, so left pixels and disparities keep their meaning.
StereoRectification computeRectification(const StereoCalibration& calib, double alpha = 0.0,
                                         const RightCameraCorrection& right_correction = {});

// The rectification of computeRectification(calib) at a reduced resolution: `scale` in (0, 1] times its size
// (rounded), rectified pixel (u, v) at the reduced scale sampling where full-scale pixel ((u + 0.5) / scale - 0.5,
// (v + 0.5) / scale - 0.5) samples (so raw images are still sampled once); f, cx, cy scaled alike.
// Throws std::invalid_argument for a scale outside (0, 1].
StereoRectification scaledRectification(const StereoCalibration& calib, double scale,
                                        const RightCameraCorrection& right_correction = {});

// Remaps a raw pair into the rectified geometry on the CPU (the reference for the device stage). With flat-field
// gains each grey is the bilinear sample (in float) times the gain, rounded half up and clamped to 0..255.
void rectifyPair(const StereoRectification& rect, const cv::Mat& raw0, const cv::Mat& raw1, cv::Mat& out0,
                 cv::Mat& out1);

}  // namespace ips
