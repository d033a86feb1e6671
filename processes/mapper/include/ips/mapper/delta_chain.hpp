#pragma once
// Poses from the stereo tracker alone: its increments chained, for a head without a navigation filter (no IMU,
// as on KITTI). The world is the body frame at the first image.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "ips/mapper/pose_buffer.hpp"

namespace ips::mapper {

class DeltaChain {
 public:
  explicit DeltaChain(const Eigen::Isometry3d& T_body_cam0) : T_body_cam0_(T_body_cam0) {}

  // One increment: camera 0 at `utime` expressed in camera 0 at `utime_prev` (X_prev = T_prev_now X_now), with
  // its covariance (translation, rotation vector). Returns the body poses it gives: the start pose as well for
  // the first increment. An increment that does not continue the chain (its utime_prev is not the last
  // utime) starts it over. The covariance is summed in the world frame to first order, without the coupling
  // of rotation error into later translation.
  std::vector<Pose> add(int64_t utime_prev, int64_t utime, const Eigen::Isometry3d& T_prev_now,
                        const Eigen::Matrix<double, 6, 6>& covariance);

 private:
  Eigen::Isometry3d T_body_cam0_;
  bool started_ = false;
  int64_t last_utime_ = 0;
  Eigen::Isometry3d T_world_cam0_ = Eigen::Isometry3d::Identity();
  Eigen::Matrix<double, 6, 6> covariance_ = Eigen::Matrix<double, 6, 6>::Zero();
};

}  // namespace ips::mapper
