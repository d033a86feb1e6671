#pragma once
// Calibration files of the tools people calibrate with, read into the project's StereoCalibration
// (ips/calibration.hpp; cam0 = left, cam1 = right, T_a_b maps points from b to a), and written where a tool
// reads them back. Every reader throws ips::ConfigError with a one-line message naming the file and the key.
//
//  EuRoC / ASL   one sensor.yaml per camera: T_BS (camera to body = IMU), resolution, intrinsics fu fv cu cv,
//                distortion_model radial-tangential, distortion_coefficients k1 k2 p1 p2.
//  Kalibr        camchain.yaml or imu-camchain.yaml: cam0 and cam1 with camera_model pinhole, intrinsics
//                fu fv cu cv, resolution, distortion_model radtan (k1 k2 p1 p2) or equidistant (k1..k4),
//                distortion_coeffs; cam1's T_cn_cnm1 (cam0 to cam1); T_cam_imu (IMU to camera); the
//                OpenVINS variant's T_imu_cam (camera to IMU) is read too.
//  ROS           camera_info YAML of each camera (camera_calibration's output): image_width, image_height,
//                camera_matrix, distortion_model plumb_bob|equidistant, distortion_coefficients,
//                rectification_matrix, projection_matrix; the stereo geometry follows from the rectification
//                rotations and the right camera's projection matrix (Tx = -fx' * baseline).
//  IMU noise     EuRoC's imu0/sensor.yaml (rate_hz, gyroscope_noise_density, gyroscope_random_walk,
//                accelerometer_noise_density, accelerometer_random_walk) or Kalibr's imu.yaml (the same densities
//                under imu0, update_rate): the ImuDescription of the calibration file's `imu` block.
//  OpenCV        stereo_calib sample output: M1 D1 M2 D2 (intrinsics.yml) and R T (extrinsics.yml), T in
//                the calibration target's unit; the image size is not in these files and must be given.
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "ips/calibration.hpp"

namespace ips::calib {

struct EurocCamera {
  int width = 0, height = 0;
  double fu = 0, fv = 0, cu = 0, cv = 0;
  std::vector<double> distortion;                      // k1 k2 p1 p2
  Eigen::Matrix4d T_BS = Eigen::Matrix4d::Identity();  // camera (sensor) to body = IMU frame
};
EurocCamera readEurocCamera(const std::string& path);
// T_imu_cam0 = T_BS of cam0; R/t_cam1_cam0 = inverse(T_BS1) * T_BS0.
StereoCalibration readEuroc(const std::string& cam0_path, const std::string& cam1_path);

// T_imu_cam0 from cam0's T_cam_imu (or T_imu_cam); the stereo pair from cam1's T_cn_cnm1 or, without it, from
// both cameras' IMU transforms. Without any IMU transform, T_imu_cam0 stays identity.
StereoCalibration readKalibr(const std::string& path);

// Neither EuRoC's nor Kalibr's IMU file gives the turn-on biases; without the data sheet's, a MEMS IMU's: gyros'
// zero-rate offsets of +-3 to +-10 deg/s (0.1 rad/s, 5.7 deg/s) and accelerometers' zero-g offsets of +-40 to
// +-60 mg (0.3 m/s^2). Only the filter's start depends on them: its first deltas estimate the gyro bias, and the
// accelerometer bias shows as the head turns.
constexpr double kMemsGyroBiasSigma = 0.1;   // [rad/s]
constexpr double kMemsAccelBiasSigma = 0.3;  // [m/s^2]
// The IMU's noise from an EuRoC sensor.yaml or a Kalibr imu.yaml (told apart by Kalibr's `imu0:` section), with the
// turn-on biases given.
ImuDescription readImuNoise(const std::string& path, double gyro_bias_sigma = kMemsGyroBiasSigma,
                            double accel_bias_sigma = kMemsAccelBiasSigma);

// ROS files are in metres.
StereoCalibration readRosCameraInfo(const std::string& cam0_path, const std::string& cam1_path);
void writeRosCameraInfo(const std::string& cam0_path, const std::string& cam1_path, const StereoCalibration& calib);

// One file holding all six keys, or two (intrinsics, extrinsics) in either order. T is divided by
// `units_per_metre` (1 when the target's square size was given in metres, 1000 for millimetres).
StereoCalibration readOpenCvStereo(const std::vector<std::string>& paths, cv::Size image_size,
                                   double units_per_metre = 1.0);
void writeOpenCvStereo(const std::string& intrinsics_path, const std::string& extrinsics_path,
                       const StereoCalibration& calib);

}  // namespace ips::calib
