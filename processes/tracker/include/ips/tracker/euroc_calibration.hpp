#pragma once
// EuRoC / ASL sensor.yaml files (one per camera: T_BS, resolution, intrinsics fu fv cu cv,
// radial-tangential distortion k1 k2 p1 p2) into the project's calibration format. The files start with
// "%YAML:1.0" but hold plain YAML maps and flow sequences that cv::FileStorage does not always accept, so a
// small tolerant reader is used: it understands exactly the keys above, ignores comments and everything else.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "ips/calibration.hpp"

namespace ips::tracker {

struct EurocCamera {
  int width = 0, height = 0;
  double fu = 0, fv = 0, cu = 0, cv = 0;
  std::vector<double> distortion;                      // k1 k2 p1 p2
  Eigen::Matrix4d T_BS = Eigen::Matrix4d::Identity();  // camera (sensor) to body = IMU frame
};

// Throws ConfigError naming the file and the key.
EurocCamera readEurocCamera(const std::string& path);
// cam0 = left, cam1 = right; T_imu_cam0 = T_BS of cam0; R/t_cam1_cam0 = inverse(T_BS1) * T_BS0.
StereoCalibration calibrationFromEuroc(const std::string& cam0_path, const std::string& cam1_path);

}  // namespace ips::tracker
